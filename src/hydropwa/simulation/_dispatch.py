"""The model table of the compiled code: each kind's right-hand side and derivatives.

The overloads here are resolved while numba types a kernel, so a kernel whose model kind
is a literal holds only its own model's code; the point kernels serve the Python side.
"""

from __future__ import annotations

import numpy as np
from numba import njit, types
from numba.extending import overload

from .. import _jitcache  # noqa: F401  (one cache stamp for all compiled modules)
from ._kcommon import (
    CHAMBER,
    FULL,
    PWA,
    REDUCED,
    Y_X,
    _input_rates,
    _inputs,
)
from ._rhs_chamber import dfdt_chamber, jac_chamber, rhs_chamber
from ._rhs_full import dfdt_full, jac_full, rhs_full
from ._rhs_load import (
    _pwa_load_flow,
    dfdt_pwa,
    dfdt_reduced,
    jac_pwa,
    jac_reduced,
    pwa_cells,
    rhs_pwa,
    rhs_reduced,
)
from ._signals import NO_REFCOUNT


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def rhs_at(kind, y, u, ps, fl, p, dy):
    """Right-hand side of model ``kind`` with the inputs u, P_S, F_L already evaluated."""
    if kind == FULL:
        rhs_full(y, u, ps, fl, p, dy)
    elif kind == REDUCED:
        rhs_reduced(y, u, ps, fl, p, dy)
    elif kind == PWA:
        rhs_pwa(y, u, ps, fl, p, dy)
    else:
        rhs_chamber(y, u, ps, fl, p, dy)


def _literal_kind(kind):
    """The value of a literal integer type (a model kind or a method), or None if not literal."""
    return kind.literal_value if isinstance(kind, types.IntegerLiteral) else None


def _rhs_for(kind, y, u, ps, fl, p, dy):
    """:func:`rhs_at` resolved at compile time; callable from compiled code only.

    Inside the integrator the model kind is a literal (one entry point per model). numba
    inlines ``inline="always"`` functions before it types them, so the branches of an
    inlined :func:`rhs_at` on ``kind`` survive and all three right-hand sides (with their
    Jacobians) would be typed and compiled into every model's kernel. This overload picks
    the model's own right-hand side while typing, so each kernel compiles only its model.
    """


# The reduced and PWA right-hand sides are inlined into their kernels through the _rhs_for
# overload. Called through the two wrappers below instead, they compile faster (PWA 16.8 against
# 24.7 CPU-s, reduced 13.7 against 14.6 s, measured on the mean-area models) but the asymmetric
# models then run at 3.2 / 4.3 ms per 10 s of the paper rig instead of 3.0 / 3.3 ms (3300x and
# 3000x real time, the speed the asymmetric model had to keep): the warm speed won. The
# wrappers stay for a build that prefers a fast first run: return them from _ol_rhs_for.
@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def _rhs_reduced_call(y, u, ps, fl, p, dy):
    rhs_reduced(y, u, ps, fl, p, dy)


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def _rhs_pwa_call(y, u, ps, fl, p, dy):
    rhs_pwa(y, u, ps, fl, p, dy)


@overload(_rhs_for, prefer_literal=True)
def _ol_rhs_for(kind, y, u, ps, fl, p, dy):
    k = _literal_kind(kind)
    if k == FULL:
        return lambda kind, y, u, ps, fl, p, dy: rhs_full(y, u, ps, fl, p, dy)
    if k == REDUCED:
        return lambda kind, y, u, ps, fl, p, dy: rhs_reduced(y, u, ps, fl, p, dy)
    if k == PWA:
        return lambda kind, y, u, ps, fl, p, dy: rhs_pwa(y, u, ps, fl, p, dy)
    if k == CHAMBER:
        return lambda kind, y, u, ps, fl, p, dy: rhs_chamber(y, u, ps, fl, p, dy)
    return lambda kind, y, u, ps, fl, p, dy: rhs_at(kind, y, u, ps, fl, p, dy)


def _rhs_fd(kind, y, u, ps, fl, p, dy):
    """The right-hand side for the finite-difference Jacobian; compiled code only.

    Every model has an exact Jacobian; differences serve ``exact_jac=False`` (comparisons)
    and a full model whose exact Jacobian declines (with a gas accumulator): the full and
    chamber models' right-hand side is called as in :func:`_rhs_for`, the reduced and PWA
    models' through a wrapper instead of inlined, which keeps two more copies of it out of
    their kernels (compile time) without costing the default path anything.
    """


@overload(_rhs_fd, prefer_literal=True)
def _ol_rhs_fd(kind, y, u, ps, fl, p, dy):
    k = _literal_kind(kind)
    if k == REDUCED:
        return lambda kind, y, u, ps, fl, p, dy: _rhs_reduced_call(y, u, ps, fl, p, dy)
    if k == PWA:
        return lambda kind, y, u, ps, fl, p, dy: _rhs_pwa_call(y, u, ps, fl, p, dy)
    return lambda kind, y, u, ps, fl, p, dy: _rhs_for(kind, y, u, ps, fl, p, dy)


def _exact_derivatives(kind, t, y, u, ps, fl, p, sg, J, dfdt):
    """Exact ∂f/∂y into J and ∂f/∂t into dfdt where model ``kind`` has them; True if filled.

    Compiled code only; resolved at compile time like :func:`_rhs_for`, so the full
    model's kernel holds no reduced or PWA Jacobian.
    """


def _exact_reduced(kind, t, y, u, ps, fl, p, sg, J, dfdt):
    jac_reduced(y, u, ps, fl, p, J)
    du, dps, dfl = _input_rates(t, sg)
    dfdt_reduced(y, u, ps, fl, du, dps, dfl, p, dfdt)
    return True


def _exact_pwa(kind, t, y, u, ps, fl, p, sg, J, dfdt):
    jac_pwa(y, u, ps, fl, p, J)
    du, dps, dfl = _input_rates(t, sg)
    dfdt_pwa(y, u, ps, fl, du, dps, dfl, p, dfdt)
    return True


def _exact_full(kind, t, y, u, ps, fl, p, sg, J, dfdt):
    if not jac_full(y, u, ps, fl, p, J):
        return False
    du, dps, dfl = _input_rates(t, sg)
    dfdt_full(y, u, ps, fl, du, dps, dfl, p, dfdt)
    return True


def _exact_chamber(kind, t, y, u, ps, fl, p, sg, J, dfdt):
    if not jac_chamber(y, u, ps, fl, p, J):
        return False
    du, dps, dfl = _input_rates(t, sg)
    dfdt_chamber(y, u, ps, fl, du, dps, dfl, p, dfdt)
    return True


def _exact_any(kind, t, y, u, ps, fl, p, sg, J, dfdt):
    if kind == FULL:
        if not jac_full(y, u, ps, fl, p, J):
            return False
        du, dps, dfl = _input_rates(t, sg)
        dfdt_full(y, u, ps, fl, du, dps, dfl, p, dfdt)
        return True
    if kind == REDUCED:
        jac_reduced(y, u, ps, fl, p, J)
        du, dps, dfl = _input_rates(t, sg)
        dfdt_reduced(y, u, ps, fl, du, dps, dfl, p, dfdt)
        return True
    if kind == PWA:
        jac_pwa(y, u, ps, fl, p, J)
        du, dps, dfl = _input_rates(t, sg)
        dfdt_pwa(y, u, ps, fl, du, dps, dfl, p, dfdt)
        return True
    if kind == CHAMBER:
        if not jac_chamber(y, u, ps, fl, p, J):
            return False
        du, dps, dfl = _input_rates(t, sg)
        dfdt_chamber(y, u, ps, fl, du, dps, dfl, p, dfdt)
        return True
    return False


@overload(_exact_derivatives, prefer_literal=True)
def _ol_exact_derivatives(kind, t, y, u, ps, fl, p, sg, J, dfdt):
    k = _literal_kind(kind)
    if k == FULL:
        return _exact_full
    if k == REDUCED:
        return _exact_reduced
    if k == PWA:
        return _exact_pwa
    if k == CHAMBER:
        return _exact_chamber
    return _exact_any


@njit(cache=True, nogil=True, error_model="numpy")
def pwa_load_flow_at(pl, u, ps_in, p):
    """PWA load flow Q_L [m³/s] at P_L [Pa], command u [1] and P_S [Pa] (:func:`_pwa_load_flow`)."""
    g, o, n, w, z, ps, pn = pwa_cells(pl, 0.0, u, ps_in, p)
    return _pwa_load_flow(pl, z, ps, pn, o, n, p)[0]


@njit(cache=True, nogil=True, error_model="numpy")
def _point_reduced(y, u, ps, fl, p, f, J, G):
    """f, ∂f/∂y and ∂f/∂(u, P_S, F_L) of the reduced model at one point (into f, J, G)."""
    rhs_reduced(y, u, ps, fl, p, f)
    jac_reduced(y, u, ps, fl, p, J)
    dfdt_reduced(y, u, ps, fl, 1.0, 0.0, 0.0, p, G[:, 0])
    dfdt_reduced(y, u, ps, fl, 0.0, 1.0, 0.0, p, G[:, 1])
    dfdt_reduced(y, u, ps, fl, 0.0, 0.0, 1.0, p, G[:, 2])


@njit(cache=True, nogil=True, error_model="numpy")
def _point_pwa(y, u, ps, fl, p, f, J, G):
    """f, ∂f/∂y and ∂f/∂(u, P_S, F_L) of the PWA model at one point (into f, J, G)."""
    rhs_pwa(y, u, ps, fl, p, f)
    jac_pwa(y, u, ps, fl, p, J)
    dfdt_pwa(y, u, ps, fl, 1.0, 0.0, 0.0, p, G[:, 0])
    dfdt_pwa(y, u, ps, fl, 0.0, 1.0, 0.0, p, G[:, 1])
    dfdt_pwa(y, u, ps, fl, 0.0, 0.0, 1.0, p, G[:, 2])


@njit(cache=True, nogil=True, error_model="numpy")
def _point_chamber(y, u, ps, fl, p, f, J, G):
    """f, ∂f/∂y and ∂f/∂(u, P_S, F_L) of the chamber PWA model at one point (into f, J, G).

    Without an exact Jacobian (a gas accumulator) J is by central differences.
    """
    rhs_chamber(y, u, ps, fl, p, f)
    if not jac_chamber(y, u, ps, fl, p, J):
        n = y.shape[0]
        yp, ym, fp, fm = y.copy(), y.copy(), np.empty(n), np.empty(n)
        for j in range(n):
            d = 1e-6 * max(abs(y[j]), 1e-3 if j == Y_X else 1.0)
            yp[j] = y[j] + d
            ym[j] = y[j] - d
            rhs_chamber(yp, u, ps, fl, p, fp)
            rhs_chamber(ym, u, ps, fl, p, fm)
            for i in range(n):
                J[i, j] = (fp[i] - fm[i]) / (2.0 * d)
            yp[j] = y[j]
            ym[j] = y[j]
    dfdt_chamber(y, u, ps, fl, 1.0, 0.0, 0.0, p, G[:, 0])
    dfdt_chamber(y, u, ps, fl, 0.0, 1.0, 0.0, p, G[:, 1])
    dfdt_chamber(y, u, ps, fl, 0.0, 0.0, 1.0, p, G[:, 2])


#: One point-derivative kernel per model: a command compiles only the one it uses.
_POINT = {REDUCED: _point_reduced, PWA: _point_pwa, CHAMBER: _point_chamber}


@njit(cache=True, nogil=True, error_model="numpy")
def rhs(kind, t, y, p, sg, dy):
    """Right-hand side of model ``kind`` at time t (inputs evaluated from the packed signals)."""
    u, ps, fl = _inputs(t, sg)
    rhs_at(kind, y, u, ps, fl, p, dy)
