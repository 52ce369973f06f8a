"""The Rosenbrock methods: LU, tableaus, Jacobian refresh and one step of each method."""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numba.extending import overload

from .. import _jitcache  # noqa: F401  (one cache stamp for all compiled modules)
from ._dispatch import _exact_derivatives, _literal_kind, _rhs_fd, _rhs_for
from ._kcommon import (
    CHAMBER,
    FULL,
    INLINE_NRT_JIT,
    N_STATES,
    S_KIND_FL,
    S_KIND_PS,
    S_KIND_U,
    SOLVER_JIT,
    Y_PACC,
    Y_PS,
    _inputs,
    n_states,
)
from ._rhs_full import _inert_column
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


#: The full model's block size without pump model and accumulator (the common case), which its
#: LU and solves get as a compile-time constant (see :func:`_lu_block`).
_FULL_BLOCK = 6
#: ... of which the leading two states (spool position and rate) form a closed block: the servo
#: valve (3) is linear in ν, ν̇ and u alone, so their rows of J are zero in every other column.
_SPOOL = 2


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


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def _lu6(a, piv):
    """Block LU of the full model's leading 6×6 block of W = I − hγJ, compiled once (called, not
    inlined at each use: inlined, the unrolled code added ~4 CPU-s to the first compilation).

    The spool's rows of J vanish outside the spool columns (:data:`_SPOOL`), so W is block
    lower triangular, [[A, 0], [C, D]]: A (2×2) and D (4×4: P_A, P_B, x, ẋ) are factorised
    apart, each with partial pivoting inside its block (D's row swaps carry C's rows along),
    and C is kept as it is. The same solution as the dense 6×6 LU (up to rounding) at about
    a third of its operations: pivoting over all six rows only moved the spool columns'
    pivots onto the chambers' rows.
    """
    _lu_rows(a, piv, 0, _SPOOL)
    _lu_rows(a, piv, _SPOOL, _FULL_BLOCK)


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def _solve6(a, piv, B, r):
    """Solve :func:`_lu6`'s block factors for row r of B: the spool block, then D with C's part."""
    _solve_rows(a, piv, B, r, 0, _SPOOL)
    _solve_rows(a, piv, B, r, _SPOOL, _FULL_BLOCK)


@njit(**INLINE_NRT_JIT)
def _lu_block(kind, a, piv, n):
    """:func:`_lu` of the leading n×n block; for the full model's n = 6 the block LU :func:`_lu6`.

    With a constant size LLVM unrolls the loops and keeps the block in registers, where a
    runtime size leaves loops of 1–7 iterations; the block form skips the zero block of the
    spool's rows (docs/architecture_performance.md). The chamber model keeps the runtime size:
    its trajectory moved at the tolerance level with the unrolled code.
    """
    if kind == FULL and n == _FULL_BLOCK:
        _lu6(a, piv)
    else:
        _lu(a, piv, n)


@njit(**INLINE_NRT_JIT)
def _solve_block(kind, a, piv, B, r, n):
    """:func:`_solve` on the leading n×n block, for the full model's n = 6 :func:`_solve6` (as :func:`_lu_block`)."""
    if kind == FULL and n == _FULL_BLOCK:
        _solve6(a, piv, B, r)
    else:
        _solve(a, piv, B, r, n)


@njit(cache=True, nogil=True, error_model="numpy", inline="always", **NO_REFCOUNT)
def _n_solve(kind, p):
    """Size of the leading block of W = I − hγJ that the LU and the solves work on.

    The full and chamber models' trailing states P_S (without the pump model; always in the
    chamber model) and P_acc (without an accumulator) are constant: their rows and columns of
    J vanish (:func:`~._rhs_full._inert_column`, and their rates are 0), so W is the identity
    there, partial pivoting never picks those rows, and the solution there is the right-hand
    side itself, which the stages leave at 0. Solving the leading block alone is therefore
    the same arithmetic (bit for bit) at (6/8)³ of the LU's and (6/8)² of the solves' cost.
    """
    n = n_states(kind)
    if kind == FULL or kind == CHAMBER:
        if _inert_column(kind, Y_PACC, p):
            n -= 1
            if _inert_column(kind, Y_PS, p):
                n -= 1
    return n


# (checked on the Python table: calling the compiled n_states here cost ~0.2 s per import)
if not (Y_PACC == N_STATES[FULL] - 1 and Y_PS == N_STATES[FULL] - 2):  # pragma: no cover
    raise ImportError("_n_solve needs P_S and P_acc as the full state's last two entries")


# --- Rosenbrock tableaus -----------------------------------------------------
# Solvers of integrate(): ROS23 is Shampine & Reichelt's ROS2(3) (MATLAB's ode23s);
# ROS34PW2 is the L-stable, stiffly accurate Rosenbrock-W method of order 3 with
# an embedded order-2 estimate (Rang & Angermann 2005). Being a W-method it keeps
# its order with an approximate Jacobian, which is why a Jacobian may be reused.
# ROS4LS is the L-stable member of the ROS4 family of order 4 with an embedded order-3
# estimate (Hairer & Wanner): 4 stages, 3 right-hand sides (a_4j = a_3j); not a W-method, so
# it takes a fresh Jacobian at every step.
ROS23, ROS34PW2, ROS4LS = 0, 1, 2
SOLVERS = {"ros23": ROS23, "ros34pw2": ROS34PW2, "ros4ls": ROS4LS}


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
        if (kind == FULL or kind == CHAMBER) and _inert_column(kind, j, p):
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


_PW2_TAB = (PW2_A, PW2_C, PW2_ALPHA, PW2_GSUM, PW2_M, PW2_E)
_R4_TAB = (R4_A, R4_C, R4_ALPHA, R4_GSUM, R4_M, R4_E)


@njit(**SOLVER_JIT, **NO_REFCOUNT)
def _step_ros34pw2(kind, t, h, y, f0, dfdt, W, piv, U, yt, ft, ynew, fnew, yerr, p, sg):
    """One ROS34PW2 step from (t, y): fills ynew and the error yerr (:func:`_four_stages`).

    Returns (rhs calls, u, P_S, F_L at t + h): α_4 = 1, so the last stage's inputs are those
    at t + h. f(t + h, ynew) is left to the caller, which evaluates it only for an accepted
    step (``fnew`` is untouched here).
    """
    u, ps, fl = _four_stages(
        kind, t, h, y, f0, dfdt, W, piv, U, yt, ft, ynew, yerr, p, sg, _PW2_TAB, PW2_GAMMA, 4
    )
    return 3, u, ps, fl


@njit(**SOLVER_JIT, **NO_REFCOUNT)
def _step_ros4ls(kind, t, h, y, f0, dfdt, W, piv, U, yt, ft, ynew, fnew, yerr, p, sg):
    """One ROS4LS step from (t, y) (W must hold I − h·R4_GAMMA·J with the exact J at (t, y)).

    Like :func:`_step_ros34pw2`: fills ynew and yerr, returns (rhs calls, u, P_S, F_L at t + h);
    f(t + h, ynew) is left to the caller. Stage 4 reuses stage 3's right-hand side.
    """
    _four_stages(
        kind, t, h, y, f0, dfdt, W, piv, U, yt, ft, ynew, yerr, p, sg, _R4_TAB, R4_GAMMA, 3
    )
    u, ps, fl = _inputs(t + h, sg)
    return 2, u, ps, fl


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


def _step_for(method, kind, t, h, y, f0, dfdt, W, piv, U, yt, ft, ynew, fnew, yerr, p, sg):
    """One step of ``method`` (:func:`_step_ros34pw2`, :func:`_step_ros4ls` or :func:`_step_ros23`), chosen while typing.

    Compiled code only. With a literal ``method`` (one entry point per model and method)
    the kernel holds only the stepper it uses; otherwise all three, chosen at run time.
    """


def _step_with_ros34pw2(
    method, kind, t, h, y, f0, dfdt, W, piv, U, yt, ft, ynew, fnew, yerr, p, sg
):
    return _step_ros34pw2(kind, t, h, y, f0, dfdt, W, piv, U, yt, ft, ynew, fnew, yerr, p, sg)


def _step_with_ros23(method, kind, t, h, y, f0, dfdt, W, piv, U, yt, ft, ynew, fnew, yerr, p, sg):
    return _step_ros23(kind, t, h, y, f0, dfdt, W, piv, U, yt, ft, ynew, fnew, yerr, p, sg)


def _step_with_ros4ls(method, kind, t, h, y, f0, dfdt, W, piv, U, yt, ft, ynew, fnew, yerr, p, sg):
    return _step_ros4ls(kind, t, h, y, f0, dfdt, W, piv, U, yt, ft, ynew, fnew, yerr, p, sg)


def _step_with_either(method, kind, t, h, y, f0, dfdt, W, piv, U, yt, ft, ynew, fnew, yerr, p, sg):
    if method == ROS34PW2:
        return _step_ros34pw2(kind, t, h, y, f0, dfdt, W, piv, U, yt, ft, ynew, fnew, yerr, p, sg)
    if method == ROS4LS:
        return _step_ros4ls(kind, t, h, y, f0, dfdt, W, piv, U, yt, ft, ynew, fnew, yerr, p, sg)
    return _step_ros23(kind, t, h, y, f0, dfdt, W, piv, U, yt, ft, ynew, fnew, yerr, p, sg)


@overload(_step_for, prefer_literal=True)
def _ol_step_for(method, kind, t, h, y, f0, dfdt, W, piv, U, yt, ft, ynew, fnew, yerr, p, sg):
    m = _literal_kind(method)
    if m == ROS34PW2:
        return _step_with_ros34pw2
    if m == ROS23:
        return _step_with_ros23
    if m == ROS4LS:
        return _step_with_ros4ls
    return _step_with_either
