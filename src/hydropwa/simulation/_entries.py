"""The compiled entry points, generated from one table: model kinds × methods × open/closed loop.

Each entry point is a numba function in which the model kind and the Rosenbrock method are
compile-time constants (closure constants of :func:`_open_entry` / :func:`_closed_entry`), so its
machine code holds only its own model's right-hand side, Jacobian and stepper (see
:func:`~._dispatch._rhs_for`, :func:`~._dispatch._exact_derivatives`,
:func:`~._rosenbrock._step_for`), and a command compiles only the one it runs. The table is
:data:`hydropwa._layout.MODEL_KINDS` × :data:`~._rosenbrock.SOLVERS`; each entry is named
``_integrate_<model>[_ros23]`` and ``_closed_<model>[_ros23]`` (its on-disk cache file is keyed by
that name, numba's index by the closure constants).

The argument builders give the entries exactly the types they are compiled for.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .. import _jitcache  # noqa: F401  (one cache stamp for all compiled modules)
from .._layout import MODEL_KINDS
from ._march import _integrate, _integrate_closed
from ._rosenbrock import ROS23, ROS34PW2

#: Identifier of each model kind in the entry points' names (``pwa-chamber`` → ``chamber``).
KERNEL_IDS: dict[int, str] = {
    kind: name.split("-")[-1] for name, (kind, _s, _w) in MODEL_KINDS.items()
}
_METHOD_SUFFIX = {ROS34PW2: "", ROS23: "_ros23"}


def _compiled(fn, name):
    """``fn`` under its own name (and so its own cache file), compiled on first use and cached."""
    fn.__name__ = fn.__qualname__ = name
    return njit(cache=True, nogil=True, error_model="numpy")(fn)


def _open_entry(kind, method):
    """The open-loop entry of model ``kind`` and ``method`` (:func:`~._march._integrate`)."""

    def entry(y0, t_out, p, sg, rtol, scale, h0, hmax, max_steps, jac_reuse, gustafsson, exact_jac):
        return _integrate(
            kind,
            y0,
            t_out,
            p,
            sg,
            rtol,
            scale,
            h0,
            hmax,
            max_steps,
            method,
            jac_reuse,
            gustafsson,
            exact_jac,
        )

    return _compiled(entry, f"_integrate_{KERNEL_IDS[kind]}{_METHOD_SUFFIX[method]}")


def _closed_entry(kind, method):
    """The closed-loop entry of model ``kind`` and ``method`` (:func:`~._march._integrate_closed`)."""

    def entry(y0, t_out, p, sg, rtol, scale, h0, hmax, max_steps, ctl, ref, dref):
        return _integrate_closed(
            kind, y0, t_out, p, sg, rtol, scale, h0, hmax, max_steps, method, ctl, ref, dref
        )

    return _compiled(entry, f"_closed_{KERNEL_IDS[kind]}{_METHOD_SUFFIX[method]}")


#: Open-loop entry points: ``_ENTRY[kind]`` (ROS34PW2) and ``_ENTRY_ROS23[kind]``.
_ENTRY = {kind: _open_entry(kind, ROS34PW2) for kind in KERNEL_IDS}
_ENTRY_ROS23 = {kind: _open_entry(kind, ROS23) for kind in KERNEL_IDS}
#: Closed-loop entry points, likewise.
_CLOSED = {kind: _closed_entry(kind, ROS34PW2) for kind in KERNEL_IDS}
_CLOSED_ROS23 = {kind: _closed_entry(kind, ROS23) for kind in KERNEL_IDS}
# every entry under its name in this module (``_integrate_full``, ``_closed_pwa_ros23``, …)
globals().update(
    {d.__name__: d for t in (_ENTRY, _ENTRY_ROS23, _CLOSED, _CLOSED_ROS23) for d in t.values()}
)


def _owned(a):
    """``a`` as a writable, C-contiguous float64 array (a copy only where it is not one).

    The kernels are compiled for exactly these arrays; a read-only array (a frozen
    parameter vector, a slice of a stored run) would otherwise be a new signature and
    compile the whole solver a second time.
    """
    a = np.ascontiguousarray(a, dtype=np.float64)
    return a if a.flags.writeable else a.copy()


def _open_args(
    y0, t_out, p, sg, rtol, scale, h0, hmax, max_steps, jac_reuse, gustafsson, exact_jac
):
    """The open-loop entry points' arguments, of exactly the types they are compiled for."""
    return (
        _owned(y0),
        _owned(t_out),
        _owned(p),
        _owned(sg),
        float(rtol),
        _owned(scale),
        float(h0),
        float(hmax),
        int(max_steps),
        bool(jac_reuse),
        bool(gustafsson),
        bool(exact_jac),
    )


def _closed_args(y0, t_out, p, sg, rtol, scale, h0, hmax, max_steps, ctl, ref, dref):
    """The closed-loop entry points' arguments, of exactly the types they are compiled for."""
    return (
        _owned(y0),
        _owned(t_out),
        _owned(p),
        _owned(sg),
        float(rtol),
        _owned(scale),
        float(h0),
        float(hmax),
        int(max_steps),
        _owned(ctl),
        _owned(ref),
        _owned(dref),
    )


def _output_args(t_out, Y, n_done, p, sg):
    """The output passes' arguments, of exactly the types they are compiled for."""
    return (_owned(t_out), _owned(Y), int(n_done), _owned(p), _owned(sg))


def _point_args(y, u, ps, fl, p):
    """The point-derivative kernels' arguments and result arrays f, J, G (G column-major)."""
    n = len(y)
    f, J, G = np.zeros(n), np.zeros((n, n)), np.asfortranarray(np.zeros((n, 3)))
    return (_owned(y), float(u), float(ps), float(fl), _owned(p), f, J, G)
