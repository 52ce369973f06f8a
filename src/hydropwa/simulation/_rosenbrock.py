"""The Rosenbrock methods: LU, tableaus, Jacobian refresh and one step of each method.

A method is one row of :data:`METHODS` (:class:`Method`: γ, error order, W-method, FSAL, its
stage coefficients); the step loop reads a method's constants through per-method tables
indexed by the literal method id, and a kind's linear-solve block structure comes from its
registry row (:attr:`hydropwa._layout.ModelKind.lu_blocks`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numba import njit
from numba.core.errors import TypingError
from numba.extending import overload

from .. import _jitcache  # noqa: F401  (one cache stamp for all compiled modules)
from ._dispatch import _exact_derivatives, _rhs_fd, _rhs_for
from ._kcommon import (
    INLINE_NRT_JIT,
    KIND_ROWS,
    S_KIND_FL,
    S_KIND_PS,
    S_KIND_U,
    SOLVER_JIT,
    _inputs,
    inert_state,
    literal_kind,
    n_solve,
    n_states,
    per_kind,
)
from ._signals import NO_REFCOUNT


@njit(**INLINE_NRT_JIT)
def _lu(a, piv, n):
    """In-place LU factorisation with partial pivoting of the leading n×n block of ``a``."""
    for k in range(n):
        m = k
        big = abs(a[k, k])
        for i in range(k + 1, n):
            if abs(a[i, k]) > big:
                big = abs(a[i, k])
                m = i
        piv[k] = m
        if m != k:
            for j in range(n):
                tmp = a[k, j]
                a[k, j] = a[m, j]
                a[m, j] = tmp
        if a[k, k] == 0.0:
            a[k, k] = 1e-300
        inv = 1.0 / a[k, k]
        a[k, k] = inv  # the diagonal of U is stored inverted: _solve multiplies
        for i in range(k + 1, n):
            a[i, k] *= inv
            f = a[i, k]
            if f != 0.0:
                for j in range(k + 1, n):
                    a[i, j] -= f * a[k, j]


@njit(**INLINE_NRT_JIT)
def _solve(a, piv, B, r, n):
    """Solve LU x = B[r] in place (row r of B overwritten with x; no array views in the hot loop)."""
    for k in range(n):
        m = piv[k]
        if m != k:
            tmp = B[r, k]
            B[r, k] = B[r, m]
            B[r, m] = tmp
    for i in range(1, n):
        s = B[r, i]
        for j in range(i):
            s -= a[i, j] * B[r, j]
        B[r, i] = s
    for i in range(n - 1, -1, -1):
        s = B[r, i]
        for j in range(i + 1, n):
            s -= a[i, j] * B[r, j]
        B[r, i] = s * a[i, i]


@njit(**INLINE_NRT_JIT)
def _lu_rows(a, piv, lo, hi):
    """:func:`_lu` of the diagonal block a[lo:hi, lo:hi]; a pivot swaps whole rows (0 … hi − 1)."""
    for k in range(lo, hi):
        m = k
        big = abs(a[k, k])
        for i in range(k + 1, hi):
            if abs(a[i, k]) > big:
                big = abs(a[i, k])
                m = i
        piv[k] = m
        if m != k:
            for j in range(hi):
                tmp = a[k, j]
                a[k, j] = a[m, j]
                a[m, j] = tmp
        if a[k, k] == 0.0:
            a[k, k] = 1e-300
        inv = 1.0 / a[k, k]
        a[k, k] = inv
        for i in range(k + 1, hi):
            a[i, k] *= inv
            f = a[i, k]
            if f != 0.0:
                for j in range(k + 1, hi):
                    a[i, j] -= f * a[k, j]


@njit(**INLINE_NRT_JIT)
def _solve_rows(a, piv, B, r, lo, hi):
    """Solve the factors of :func:`_lu_rows` for B[r, lo:hi] in place (its pivots applied first)."""
    for k in range(lo, hi):
        m = piv[k]
        if m != k:
            tmp = B[r, k]
            B[r, k] = B[r, m]
            B[r, m] = tmp
    for i in range(lo, hi):
        s = B[r, i]
        for j in range(i):  # the columns before lo: the coupling block, already solved
            s -= a[i, j] * B[r, j]
        B[r, i] = s
    for i in range(hi - 1, lo - 1, -1):
        s = B[r, i]
        for j in range(i + 1, hi):
            s -= a[i, j] * B[r, j]
        B[r, i] = s * a[i, i]


_BLOCK_JIT: dict[str, Any] = {"cache": True, "nogil": True, "error_model": "numpy", **NO_REFCOUNT}


def _block_lu(blocks: tuple[int, ...], name: str):
    """Block LU and solve of a W = I − hγJ that is block lower triangular, [[A, 0], [C, D]].

    ``blocks`` = (end of A, end of D) (:attr:`~hydropwa._layout.ModelKind.lu_blocks`). The full
    model's spool rows of J vanish outside the spool columns (the servo valve (3) is linear in
    ν, ν̇ and u alone), so A (2×2) and D (4×4: P_A, P_B, x, ẋ) are factorised apart, each with
    partial pivoting inside its block (D's row swaps carry C's rows along), and C is kept as it
    is: the same solution as the dense LU (up to rounding) at about a third of its operations.
    Compiled once each (called, not inlined at each use: inlined, the unrolled code added ~4
    CPU-s to the first compilation).
    """
    if len(blocks) != 2:
        raise ValueError(f"lu_blocks {blocks} of {name}: the block LU takes two diagonal blocks")
    b0, b1 = blocks

    def lu(a, piv):
        _lu_rows(a, piv, 0, b0)
        _lu_rows(a, piv, b0, b1)

    def solve(a, piv, B, r):
        _solve_rows(a, piv, B, r, 0, b0)
        _solve_rows(a, piv, B, r, b0, b1)

    lu.__name__ = lu.__qualname__ = f"_lu_{name}"
    solve.__name__ = solve.__qualname__ = f"_solve_{name}"
    return njit(**_BLOCK_JIT)(lu), njit(**_BLOCK_JIT)(solve)


#: Each kind's (block size, block LU, block solve), or None for a dense LU (registry ``lu_blocks``).
_BLOCK_LU = tuple(
    (row.lu_blocks[-1], *_block_lu(row.lu_blocks, row.entry_id)) if row.lu_blocks else None
    for row in KIND_ROWS
)


def _lu_block(kind, a, piv, n):
    """:func:`_lu` of the leading n×n block; the kind's block LU where n is its block size.

    With a constant size LLVM unrolls the loops and keeps the block in registers, where a
    runtime size leaves loops of 1–7 iterations; the block form skips the zero block of the
    spool's rows (docs/architecture_performance.md). The chamber model keeps the runtime size
    (no ``lu_blocks``): its trajectory moved at the tolerance level with the unrolled code.
    Compiled code only; the kind's structure is chosen while typing.
    """


def _solve_block(kind, a, piv, B, r, n):
    """:func:`_solve` on the leading n×n block, with the kind's block solve (as :func:`_lu_block`)."""


def _kind_blocks(kind, what):
    k = literal_kind(kind)
    if k is None:
        raise TypingError(f"{what}: the model kind must be a compile-time constant")
    return _BLOCK_LU[k]


@overload(_lu_block, prefer_literal=True, inline="always")
def _ol_lu_block(kind, a, piv, n):
    blocks = _kind_blocks(kind, "_lu_block")
    if blocks is None:
        return lambda kind, a, piv, n: _lu(a, piv, n)
    size, lu, _solve_b = blocks

    def impl(kind, a, piv, n):
        if n == size:
            lu(a, piv)
        else:
            _lu(a, piv, n)

    return impl


@overload(_solve_block, prefer_literal=True, inline="always")
def _ol_solve_block(kind, a, piv, B, r, n):
    blocks = _kind_blocks(kind, "_solve_block")
    if blocks is None:
        return lambda kind, a, piv, B, r, n: _solve(a, piv, B, r, n)
    size, _lu_b, solve = blocks

    def impl(kind, a, piv, B, r, n):
        if n == size:
            solve(a, piv, B, r)
        else:
            _solve(a, piv, B, r, n)

    return impl


#: Size of the leading block of W = I − hγJ that the LU and the solves work on
#: (:func:`~._kcommon.n_solve`): the kind's trailing inert states (registry ``inert_states``;
#: the full model's P_S without the pump model and P_acc without an accumulator) have zero rows
#: and columns of J and zero rates, so W is the identity there, partial pivoting never picks
#: those rows, and the solution there is the right-hand side itself, which the stages leave at
#: 0. Solving the leading block alone is the same arithmetic (bit for bit) at (6/8)³ of the
#: LU's and (6/8)² of the solves' cost.
_n_solve = n_solve


# --- Rosenbrock tableaus -----------------------------------------------------
# Solvers of integrate(): ROS23 is Shampine & Reichelt's ROS2(3) (MATLAB's ode23s);
# ROS34PW2 is the L-stable, stiffly accurate Rosenbrock-W method of order 3 with
# an embedded order-2 estimate (Rang & Angermann 2005). Being a W-method it keeps
# its order with an approximate Jacobian, which is why a Jacobian may be reused.
# ROS4LS is the L-stable member of the ROS4 family of order 4 with an embedded order-3
# estimate (Hairer & Wanner): 4 stages, 3 right-hand sides (a_4j = a_3j); not a W-method, so
# it takes a fresh Jacobian at every step.


def _transformed_tableau(alpha, gamma, b, b_hat):
    """Coefficients of the form (I − hγJ) U_i = hγ (f(t + α_i h, y + Σ A_ij U_j) + Σ C_ij U_j / h + γ_i h f_t).

    With U = Γ K (Hairer & Wanner, Sect. IV.7): A = αΓ⁻¹, C = −Γ⁻¹ (strictly lower
    part), m = bΓ⁻¹ for the solution and e = (b − b̂)Γ⁻¹ for the error estimate.
    """
    g_inv = np.linalg.inv(gamma)
    a_t = alpha @ g_inv
    c_t = -np.tril(g_inv, -1)
    return (
        tuple(float(v) for v in a_t.ravel()),
        tuple(float(v) for v in c_t.ravel()),
        tuple(float(v) for v in alpha.sum(axis=1)),
        tuple(float(v) for v in gamma.sum(axis=1)),
        tuple(float(v) for v in b @ g_inv),
        tuple(float(v) for v in (b - b_hat) @ g_inv),
    )


_G = 4.3586652150845900e-01
_PW2 = _transformed_tableau(
    np.array(
        [
            [0.0, 0.0, 0.0, 0.0],
            [8.7173304301691801e-01, 0.0, 0.0, 0.0],
            [8.4457060015369423e-01, -1.1299064236484185e-01, 0.0, 0.0],
            [0.0, 0.0, 1.0, 0.0],
        ]
    ),
    np.array(
        [
            [_G, 0.0, 0.0, 0.0],
            [-8.7173304301691801e-01, _G, 0.0, 0.0],
            [-9.0338057013044082e-01, 5.4180672388095326e-02, _G, 0.0],
            [2.4212380706095346e-01, -1.2232505839045147e00, 5.4526025533510214e-01, _G],
        ]
    ),
    np.array([2.4212380706095346e-01, -1.2232505839045147e00, 1.5452602553351020e00, _G]),
    np.array([3.7810903145819369e-01, -9.6042292212423178e-02, 0.5, 2.1793326075422950e-01]),
)
PW2_A, PW2_C, PW2_ALPHA, PW2_GSUM, PW2_M, PW2_E = (np.array(v) for v in _PW2)
PW2_GAMMA = _G

# ROS4LS: the L-stable coefficient set of the ROS4 family of order 4(3) (E. Hairer, G. Wanner,
# Solving Ordinary Differential Equations II, 2nd ed., Springer 1996, Sect. IV.7, and their
# code ROS4; the family is Kaps & Rentrop's, Numer. Math. 33 (1979) 55-68), in the transformed
# form above: stage arguments y + Σ A_ij U_j (row 4 = row 3, so stage 4 reuses stage 3's
# right-hand side), U_i from (I − hγJ) U_i = hγ (f_i + Σ C_ij U_j / h + d_i h f_t),
# y_new = y + Σ m_i U_i, error Σ e_i U_i (order 3: the step factor is err^(−1/4)).
# tests/performance/test_perf_convergence.py checks its order 4.
R4_GAMMA = 0.57282
R4_A = np.array(
    [
        0.0, 0.0, 0.0, 0.0,
        2.0, 0.0, 0.0, 0.0,
        1.867943637803922, 0.2344449711399156, 0.0, 0.0,
        1.867943637803922, 0.2344449711399156, 0.0, 0.0,
    ]
)  # fmt: skip
R4_C = np.array(
    [
        0.0, 0.0, 0.0, 0.0,
        -7.137615036412310, 0.0, 0.0, 0.0,
        2.580708087951457, 0.6515950076447975, 0.0, 0.0,
        -2.137148994382534, -0.3214669691237626, -0.6949742501781779, 0.0,
    ]
)  # fmt: skip
R4_ALPHA = np.array([0.0, 1.14564, 0.65521686381559, 0.65521686381559])
R4_GSUM = np.array([0.57282, -1.769193891319233, 0.7592633437920482, -0.1049021087100450])
R4_M = np.array([2.255570073418735, 0.2870493262186792, 0.4353179431840180, 1.093502252409163])
R4_E = np.array(
    [-0.2815431932141155, -0.07276199124938920, -0.1082196201495311, -1.093502252409163]
)
_D23 = 1.0 / (2.0 + math.sqrt(2.0))
_E32 = 6.0 + math.sqrt(2.0)


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def _jacobian(kind, t, y, f0, u, ps, fl, p, sg, scale, J, dfdt, yt, ft, exact):
    """Jacobian ∂f/∂y and time derivative ∂f/∂t at (t, y); returns rhs calls.

    Both are exact for every model when ``exact`` (:func:`jac_full`, :func:`jac_reduced`,
    :func:`jac_pwa`, :func:`jac_chamber`; the ``dfdt_*`` with the inputs' rates), so a
    refresh costs no right-hand side. Otherwise (``exact`` off, or an exact Jacobian that
    declines: the full model with a gas accumulator) ∂f/∂y is by forward differences with
    the inputs evaluated once for the n state columns (columns known to vanish, P_S of
    the full model without the pump, are skipped) and ∂f/∂t a forward difference,
    skipped when every input is constant.
    """
    n = n_states(kind)
    sqrt_eps = 1.4901161193847656e-08
    nfev = 0
    if exact and _exact_derivatives(kind, t, y, u, ps, fl, p, sg, J, dfdt):
        return 0
    for j in range(n):
        if inert_state(kind, j, p):
            for i in range(n):
                J[i, j] = 0.0
            continue
        nfev += 1
        for i in range(n):
            yt[i] = y[i]
        dj = sqrt_eps * max(abs(y[j]), scale[j])
        yt[j] = y[j] + dj
        _rhs_fd(kind, yt, u, ps, fl, p, ft)
        for i in range(n):
            J[i, j] = (ft[i] - f0[i]) / dj
    if sg[S_KIND_U] == 0.0 and sg[S_KIND_PS] == 0.0 and sg[S_KIND_FL] == 0.0:  # all constant
        for i in range(n):
            dfdt[i] = 0.0
    else:
        dt = sqrt_eps * max(abs(t), 1e-3)
        u2, ps2, fl2 = _inputs(t + dt, sg)
        _rhs_fd(kind, y, u2, ps2, fl2, p, ft)
        for i in range(n):
            dfdt[i] = (ft[i] - f0[i]) / dt
        nfev += 1
    return nfev


@njit(**INLINE_NRT_JIT)
def _factor(kind, J, W, piv, hg, p):
    """W = I − hγ J, LU-factorised in place (its leading :func:`_n_solve` block; the rest is I)."""
    n = _n_solve(kind, p)
    for i in range(n):
        for j in range(n):
            W[i, j] = -hg * J[i, j]
        W[i, i] += 1.0
    _lu_block(kind, W, piv, n)


@njit(**INLINE_NRT_JIT)
def _four_stages(kind, t, h, y, f0, dfdt, W, piv, U, yt, ft, ynew, yerr, p, sg, tab, gamma, fresh):
    """The four stages of a Rosenbrock method in the transformed form (Hairer & Wanner IV.7)
    and its solution and error combinations: fills U, ynew and yerr.

    ``tab`` = (A, C, α, γ_i sums, m, e), the flattened 4 × 4 tableau of
    :func:`_transformed_tableau`; stages 1 … ``fresh`` − 1 evaluate the right-hand side at
    t + α_i h (a later stage reuses the last one's, as ROS4LS's a_4j = a_3j allows). Inlined
    into each stepper with its tableau as constants. Returns (u, P_S, F_L) of the last
    right-hand side's inputs.
    """
    A, C, ALPHA, GSUM, M, E = tab
    n = n_states(kind)
    n_lu = _n_solve(kind, p)
    hg = h * gamma
    # defined before the loop: a variable numba sees as possibly undefined cannot be
    # inlined through an overload (_step_for)
    u = ps = fl = 0.0
    for i in range(4):
        if i == 0:
            for k in range(n):
                ft[k] = f0[k]
        elif i < fresh:
            for k in range(n):
                s = y[k]
                for j in range(i):
                    s += A[4 * i + j] * U[j, k]
                yt[k] = s
            u, ps, fl = _inputs(t + ALPHA[i] * h, sg)
            _rhs_for(kind, yt, u, ps, fl, p, ft)
        for k in range(n):
            s = ft[k] + GSUM[i] * h * dfdt[k]
            for j in range(i):
                s += C[4 * i + j] / h * U[j, k]
            U[i, k] = hg * s
        _solve_block(kind, W, piv, U, i, n_lu)
    for k in range(n):
        s = y[k]
        e = 0.0
        for j in range(4):
            s += M[j] * U[j, k]
            e += E[j] * U[j, k]
        ynew[k] = s
        yerr[k] = e
    return u, ps, fl


def _four_stage_stepper(name, tab, gamma, fresh, last_at_end):
    """One step of a four-stage method in the transformed form (:func:`_four_stages`), compiled.

    Fills ynew and the error yerr; returns (rhs calls, u, P_S, F_L at t + h): the last stage's
    inputs where it is evaluated at t + h (``last_at_end``: α_4 = 1 and a fresh right-hand side,
    ROS34PW2), else the inputs at t + h evaluated anew. f(t + h, ynew) is left to the caller,
    which evaluates it only for an accepted step (``fnew`` is untouched here).
    """
    n_rhs = fresh - 1

    def step(kind, t, h, y, f0, dfdt, W, piv, U, yt, ft, ynew, fnew, yerr, p, sg):
        u, ps, fl = _four_stages(
            kind, t, h, y, f0, dfdt, W, piv, U, yt, ft, ynew, yerr, p, sg, tab, gamma, fresh
        )
        if not last_at_end:
            u, ps, fl = _inputs(t + h, sg)
        return n_rhs, u, ps, fl

    step.__name__ = step.__qualname__ = f"_step_{name}"
    return njit(**SOLVER_JIT, **NO_REFCOUNT)(step)


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def _step_ros23(kind, t, h, y, f0, dfdt, W, piv, U, yt, ft, ynew, fnew, yerr, p, sg):
    """One ROS2(3) step (ode23s) from (t, y); W must hold I − h d J with d = 1/(2 + √2).

    Fills ynew, fnew = f(t + h, ynew) (its error estimate needs it) and yerr; returns
    (rhs calls, u, P_S, F_L at t + h) like :func:`_step_ros34pw2`.
    """
    n = n_states(kind)
    n_lu = _n_solve(kind, p)
    hd = h * _D23
    for i in range(n):
        U[0, i] = f0[i] + hd * dfdt[i]
    _solve_block(kind, W, piv, U, 0, n_lu)
    for i in range(n):
        yt[i] = y[i] + 0.5 * h * U[0, i]
    u, ps, fl = _inputs(t + 0.5 * h, sg)
    _rhs_for(kind, yt, u, ps, fl, p, ft)
    for i in range(n):
        U[1, i] = ft[i] - U[0, i]
    _solve_block(kind, W, piv, U, 1, n_lu)
    for i in range(n):
        U[1, i] += U[0, i]
        ynew[i] = y[i] + h * U[1, i]
    u, ps, fl = _inputs(t + h, sg)
    _rhs_for(kind, ynew, u, ps, fl, p, fnew)
    for i in range(n):
        U[2, i] = fnew[i] - _E32 * (U[1, i] - ft[i]) - 2.0 * (U[0, i] - f0[i]) + hd * dfdt[i]
    _solve_block(kind, W, piv, U, 2, n_lu)
    for i in range(n):
        yerr[i] = h / 6.0 * (U[0, i] - 2.0 * U[1, i] + U[2, i])
    return 2, u, ps, fl


@dataclass(frozen=True)
class Method:
    """One Rosenbrock method: a row of :data:`METHODS`, all the step loop asks of it.

    Attributes
    ----------
    name : str
        ``simulate(..., solver=name)``.
    id : int
        Its index in the per-method constant tables (its position in :data:`METHODS`).
    gamma : float
        The diagonal γ of W = I − hγJ.
    error_order : int
        Order q of its error estimate: the step factor is err^(−1/(q + 1)).
    w_method : bool
        It keeps its order with an old Jacobian (a W-method), so a Jacobian may be reused.
    fsal : bool
        Its error estimate needs f(t + h, y_new), which its stepper fills: the step loop does not
        evaluate it again (the others get it from the step loop, for accepted steps only).
    stages : tuple of 6 arrays or None
        The transformed 4 × 4 tableau (A, C, α, γ_i sums, m, e) of :func:`_transformed_tableau`
        for :func:`_four_stage_stepper`; None: ``stepper`` names its own compiled stepper.
    fresh : int
        Four-stage methods: stages 1 … fresh − 1 evaluate the right-hand side (a later stage
        reuses the last one's).
    stepper : str
        The compiled stepper in this module, where ``stages`` is None.
    entry_suffix : str
        Its part of the compiled entry points' names (``_integrate_full_ros23``).
    """

    name: str
    id: int
    gamma: float
    error_order: int
    w_method: bool
    fsal: bool
    stages: tuple[np.ndarray, ...] | None
    fresh: int
    stepper: str
    entry_suffix: str


#: The methods, one row each, in id order. ROS34PW2's α_4 = 1: its last stage is at t + h.
METHODS: tuple[Method, ...] = (
    Method("ros23", 0, _D23, 2, False, True, None, 0, "_step_ros23", "_ros23"),
    Method("ros34pw2", 1, PW2_GAMMA, 2, True, False, _PW2, 4, "", ""),
    Method("ros4ls", 2, R4_GAMMA, 3, False, False, (R4_A, R4_C, R4_ALPHA, R4_GSUM, R4_M, R4_E), 3, "", "_ros4ls"),
)  # fmt: skip
assert [m.id for m in METHODS] == list(range(len(METHODS)))
#: The method ids by name (``simulate``'s ``solver``).
SOLVERS: dict[str, int] = {m.name: m.id for m in METHODS}
ROS23, ROS34PW2, ROS4LS = (SOLVERS[name] for name in ("ros23", "ros34pw2", "ros4ls"))
#: Per-method constants of the step loop, read by the literal method id.
method_gamma = per_kind(tuple(m.gamma for m in METHODS), "method_gamma")
method_error_order = per_kind(tuple(m.error_order for m in METHODS), "method_error_order")
method_w = per_kind(tuple(m.w_method for m in METHODS), "method_w")
method_fsal = per_kind(tuple(m.fsal for m in METHODS), "method_fsal")


def _stepper(m: Method):
    if m.stages is None:
        return globals()[m.stepper]
    tab = tuple(np.array(v) for v in m.stages)
    last_at_end = m.fresh == 4 and float(tab[2][3]) == 1.0
    return _four_stage_stepper(m.name, tab, m.gamma, m.fresh, last_at_end)


#: Each method's compiled stepper, by id.
STEPPERS = tuple(_stepper(m) for m in METHODS)


def _step_for(method, kind, t, h, y, f0, dfdt, W, piv, U, yt, ft, ynew, fnew, yerr, p, sg):
    """One step of the literal ``method`` (its :data:`STEPPERS` entry), chosen while typing.

    Compiled code only: each entry point (one per model and method) holds only its stepper.
    """


@overload(_step_for, prefer_literal=True)
def _ol_step_for(method, kind, t, h, y, f0, dfdt, W, piv, U, yt, ft, ynew, fnew, yerr, p, sg):
    m = literal_kind(method)
    if m is None:
        raise TypingError("_step_for: the method must be a compile-time constant")
    step = STEPPERS[m]

    def impl(method, kind, t, h, y, f0, dfdt, W, piv, U, yt, ft, ynew, fnew, yerr, p, sg):
        return step(kind, t, h, y, f0, dfdt, W, piv, U, yt, ft, ynew, fnew, yerr, p, sg)

    return impl
