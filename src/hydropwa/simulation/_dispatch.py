"""The model table of the compiled code: each kind's right-hand side and derivatives.

The functions of each kind are found from its registry row (:data:`hydropwa._layout.MODEL_KINDS`:
``rhs_module``, ``entry_id``, ``exact_jacobian_always``), once, at import: :data:`KIND_FUNCTIONS`.
The overloads here pick a kind's functions from that table while numba types a kernel, so a
kernel whose model kind is a literal holds only its own model's code, and no compiled code
branches over kinds; the point kernels serve the Python side.
"""

from __future__ import annotations

import importlib
from typing import Any, NamedTuple

import numpy as np
from numba import njit
from numba.core.errors import TypingError
from numba.extending import overload

from .. import _jitcache  # noqa: F401  (one cache stamp for all compiled modules)
from ._kcommon import (
    CHAMBER,
    KIND_ROWS,
    PWA,
    REDUCED,
    Y_X,
    _input_rates,
    _inputs,
    literal_kind,
)
from ._rhs_chamber import dfdt_chamber, jac_chamber, rhs_chamber
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

_literal_kind = literal_kind  # (the name the method table's overload imports)
_JIT: dict[str, Any] = {"cache": True, "nogil": True, "error_model": "numpy", **NO_REFCOUNT}


class KindFunctions(NamedTuple):
    """The compiled functions of one model kind (from its registry row)."""

    rhs: Any  # f(y, u, P_S, F_L, p, dy)
    jac: Any  # exact ∂f/∂y into J (returns False where it has none, see exact_always)
    dfdt: Any  # ∂f/∂t from the inputs' rates
    exact_always: bool
    rhs_call: Any  # rhs called through a wrapper, not inlined (finite differences, see _rhs_fd)


def _call_wrapper(rhs, name):
    """``rhs`` behind a compiled call of its own (cached under ``name``)."""

    def call(y, u, ps, fl, p, dy):
        rhs(y, u, ps, fl, p, dy)

    call.__name__ = call.__qualname__ = name
    return njit(**_JIT)(call)


def _kind_functions(row) -> KindFunctions:
    """A registry row's compiled functions: ``rhs_<entry_id>`` etc. of its ``rhs_module``."""
    module = importlib.import_module(row.rhs_module)
    rhs, jac, dfdt = (getattr(module, f"{f}_{row.entry_id}") for f in ("rhs", "jac", "dfdt"))
    call = _call_wrapper(rhs, f"_rhs_{row.entry_id}_call") if row.exact_jacobian_always else rhs
    return KindFunctions(rhs, jac, dfdt, row.exact_jacobian_always, call)


#: Each kind's compiled functions, indexed by its kernel id.
KIND_FUNCTIONS: tuple[KindFunctions, ...] = tuple(_kind_functions(row) for row in KIND_ROWS)


def _functions_of(kind, what):
    """The :class:`KindFunctions` of a literal ``kind`` (a typing error otherwise)."""
    k = literal_kind(kind)
    if k is None:
        raise TypingError(f"{what}: the model kind must be a compile-time constant")
    return KIND_FUNCTIONS[k]


def rhs_at(kind, y, u, ps, fl, p, dy):
    """Right-hand side of model ``kind`` with the inputs u, P_S, F_L already evaluated (Python side)."""
    KIND_FUNCTIONS[int(kind)].rhs(y, u, ps, fl, p, dy)


def _rhs_for(kind, y, u, ps, fl, p, dy):
    """The right-hand side of the literal model ``kind``, chosen while typing; compiled code only.

    Inside the integrator the model kind is a literal (one entry point per model); this
    overload picks the model's own right-hand side from :data:`KIND_FUNCTIONS`, so each kernel
    compiles only its model.
    """


# The reduced and PWA right-hand sides (exact Jacobians) are inlined into their kernels through
# the _rhs_for overload. Called through their call wrappers instead (KindFunctions.rhs_call),
# they compile faster (PWA 16.8 against 24.7 CPU-s, reduced 13.7 against 14.6 s, measured on the
# mean-area models) but the asymmetric models then run at 3.2 / 4.3 ms per 10 s of the paper rig
# instead of 3.0 / 3.3 ms (3300x and 3000x real time, the speed the asymmetric model had to
# keep): the warm speed won. Return rhs_call from _ol_rhs_for for a build that prefers a fast
# first run.
@overload(_rhs_for, prefer_literal=True)
def _ol_rhs_for(kind, y, u, ps, fl, p, dy):
    rhs = _functions_of(kind, "_rhs_for").rhs
    return lambda kind, y, u, ps, fl, p, dy: rhs(y, u, ps, fl, p, dy)


def _rhs_fd(kind, y, u, ps, fl, p, dy):
    """The right-hand side for the finite-difference Jacobian; compiled code only.

    A kind whose Jacobian may be by differences (the full and chamber models) calls its
    right-hand side as in :func:`_rhs_for`. Kinds with an exact Jacobian always use differences
    only with ``exact_jac=False`` (comparisons): there the right-hand side is called through a
    wrapper instead of inlined, which keeps two more copies of it out of their kernels
    (compile time) without costing the default path anything.
    """


@overload(_rhs_fd, prefer_literal=True)
def _ol_rhs_fd(kind, y, u, ps, fl, p, dy):
    call = _functions_of(kind, "_rhs_fd").rhs_call
    return lambda kind, y, u, ps, fl, p, dy: call(y, u, ps, fl, p, dy)


def _exact_derivatives(kind, t, y, u, ps, fl, p, sg, J, dfdt):
    """Exact ∂f/∂y into J and ∂f/∂t into dfdt where model ``kind`` has them; True if filled.

    Compiled code only; resolved at compile time like :func:`_rhs_for`, so the full
    model's kernel holds no reduced or PWA Jacobian.
    """


def _exact_impl(fns: KindFunctions):
    """:func:`_exact_derivatives` of one kind's functions."""
    jac, rates = fns.jac, fns.dfdt
    if fns.exact_always:

        def always(kind, t, y, u, ps, fl, p, sg, J, dfdt):
            jac(y, u, ps, fl, p, J)
            du, dps, dfl = _input_rates(t, sg)
            rates(y, u, ps, fl, du, dps, dfl, p, dfdt)
            return True

        return always

    def where_available(kind, t, y, u, ps, fl, p, sg, J, dfdt):
        if not jac(y, u, ps, fl, p, J):
            return False
        du, dps, dfl = _input_rates(t, sg)
        rates(y, u, ps, fl, du, dps, dfl, p, dfdt)
        return True

    return where_available


@overload(_exact_derivatives, prefer_literal=True)
def _ol_exact_derivatives(kind, t, y, u, ps, fl, p, sg, J, dfdt):
    return _exact_impl(_functions_of(kind, "_exact_derivatives"))


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


def _rhs_entry(fns: KindFunctions, name: str):
    """``rhs(t, y, p, sg, dy)`` of one kind, the inputs evaluated from the packed signals."""
    f = fns.rhs

    def entry(t, y, p, sg, dy):
        u, ps, fl = _inputs(t, sg)
        f(y, u, ps, fl, p, dy)

    entry.__name__ = entry.__qualname__ = name
    return njit(cache=True, nogil=True, error_model="numpy")(entry)


_RHS_ENTRIES = tuple(
    _rhs_entry(fns, f"_rhs_{row.entry_id}_at_t")
    for fns, row in zip(KIND_FUNCTIONS, KIND_ROWS, strict=True)
)


def rhs(kind, t, y, p, sg, dy):
    """Right-hand side of model ``kind`` at time t (inputs evaluated from the packed signals)."""
    _RHS_ENTRIES[int(kind)](t, y, p, sg, dy)
