"""The full-order model's small-signal form at a working point: steady state and exact Jacobian.

The compiled kernel's ``rhs_full``, ``jac_full`` and ``dfdt_full`` are the one assembly of
Eqs. (1)–(11); this module only calls them at one point (through ``prepare``, so a first call
compiles with the same notice as ``simulate``), finds the steady state of the valve and the
chambers at a fixed position, and returns the linear system a frequency response needs.
Nothing here re-derives physics.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .._errors import HydropwaError
from .._layout import FULL_STATES
from . import _kernel as K

__all__ = ["FullSmallSignal", "full_point_derivatives", "full_small_signal"]

_NAMES = tuple(s[0] for s in FULL_STATES)
_I = {n: i for i, n in enumerate(_NAMES)}


class SmallSignalError(HydropwaError, ValueError):
    """No steady state of the full model at the asked working point."""


def full_point_derivatives(model, y, u: float, p_s: float, f_l: float):
    """Right-hand side, ∂f/∂y and ∂f/∂u of the full-order model at one point (compiled kernel).

    Parameters
    ----------
    model : FullOrderModel
        Its ``pack()`` gives the packed parameters.
    y : array_like, shape (8,)
        Full state (``hydropwa._layout.FULL_STATES``) [1, 1/s, Pa, Pa, m, m/s, Pa, Pa].
    u, p_s, f_l : float
        Valve command [1], supply pressure [Pa] (used when the supply is ideal), load force [N].

    Returns
    -------
    f : ndarray (8,), J : ndarray (8, 8), B : ndarray (8,)
        Exact where ``jac_full`` is exact (no gas accumulator); with an accumulator J is by
        central differences of ``rhs_full``.
    """
    p = np.ascontiguousarray(model.pack(), dtype=np.float64)
    y = np.array(y, dtype=np.float64)
    n = y.size
    f, J, B = np.zeros(n), np.zeros((n, n)), np.zeros(n)
    u, ps, fl = float(u), float(p_s), float(f_l)
    calls = (
        (K.rhs_full, (y, u, ps, fl, p, f)),
        (K.jac_full, (y, u, ps, fl, p, J)),
        (K.dfdt_full, (y, u, ps, fl, 1.0, 0.0, 0.0, p, B)),  # ∂f/∂u: a unit command rate
    )
    for fn, args in calls:
        K.prepare(fn, args, "small-signal")
    K.rhs_full(*calls[0][1])
    if not K.jac_full(*calls[1][1]):  # a gas accumulator: central differences
        J = _central_jacobian((y, u, ps, fl, p))
    K.dfdt_full(*calls[2][1])
    return f, J, B


def _central_jacobian(args) -> np.ndarray:
    y, u, ps, fl, p = args
    n = y.size
    J = np.zeros((n, n))
    fp, fm = np.zeros(n), np.zeros(n)
    for j in range(n):
        d = 1e-6 * max(abs(y[j]), 1e-3 if j == _I["x"] else 1.0)
        yp, ym = y.copy(), y.copy()
        yp[j] += d
        ym[j] -= d
        K.rhs_full(yp, u, ps, fl, p, fp)
        K.rhs_full(ym, u, ps, fl, p, fm)
        J[:, j] = (fp - fm) / (2.0 * d)
    return J


@dataclasses.dataclass(frozen=True)
class FullSmallSignal:
    """The full-order model linearized about a steady motion at a fixed position.

    Attributes
    ----------
    A : ndarray (6, 6)
        ∂f/∂y over [ν, ν̇, P_A, P_B, x, ẋ] (P_S an input, no accumulator state).
    B : ndarray (6, 1)
        ∂f/∂u.
    state : ndarray (8,)
        The working point (steady spool, pressures and velocity at position x).
    command, supply_pressure, load_force : float
        u [1], P_S [Pa], F_L [N] of the working point.
    states : tuple of str
        Names of A's states.
    """

    A: np.ndarray
    B: np.ndarray
    state: np.ndarray
    command: float
    supply_pressure: float
    load_force: float
    states: tuple[str, ...] = _NAMES[:6]


def full_small_signal(
    model, command: float, x: float, p_s: float, f_l: float | None = None
) -> FullSmallSignal:
    """Steady motion of the full model at command ``u`` and position ``x``, and its Jacobian.

    The spool rests at the command (ν = u, ν̇ = 0, Eq. (1)); P_A, P_B and ẋ solve
    Ṗ_A = Ṗ_B = ẍ = 0 (Eqs. (9)–(10)) with x held (a frozen-position linearization: the
    volumes change with x far slower than the pressures settle).

    Parameters
    ----------
    model : FullOrderModel
        With ``supply.model = "ideal"`` (P_S is the input ``p_s``) and no gas accumulator.
    command : float
        u [1].
    x : float
        Rod position [m].
    p_s : float
        Supply pressure [Pa].
    f_l : float, optional
        Load force [N] (default ``params.load.force``).

    Returns
    -------
    FullSmallSignal

    Raises
    ------
    SmallSignalError
        No steady state (the command cannot hold the load, or the solver did not converge).
    """
    from scipy.optimize import root  # deferred: scipy submodules cost 0.1-0.5 s at import

    prm = model.params
    fl = float(prm.load.force if f_l is None else f_l)
    y = np.array(model.initial_state(), dtype=np.float64)
    y[_I["spool"]], y[_I["spool_rate"]], y[_I["x"]] = command, 0.0, x
    y[_I["p_s"]] = p_s
    free = [_I["p_a"], _I["p_b"], _I["v"]]
    rows = [_I["p_a"], _I["p_b"], _I["v"]]
    scale = np.array([p_s, p_s, 1.0])

    def resid(z):
        yy = y.copy()
        yy[free] = z * scale
        f, _, _ = full_point_derivatives(model, yy, command, p_s, fl)
        return f[rows] / np.array([p_s * 1e3, p_s * 1e3, 1e3])

    best = None
    for guess in ((0.6, 0.4, 0.0), (0.5, 0.5, 0.0), (0.9, 0.1, 0.05), (0.1, 0.9, -0.05)):
        sol = root(resid, np.array(guess), method="hybr", options={"xtol": 1e-12})
        if sol.success and float(np.max(np.abs(sol.fun))) < 1e-9:
            best = sol.x
            break
    if best is None:
        raise SmallSignalError(
            f"no steady motion of the full model at u = {command:g}, x = {x * 1e3:g} mm, "
            f"P_S = {p_s / 1e5:g} bar, F_L = {fl:g} N; choose a command that moves the load"
        )
    y[free] = best * scale
    _, J, Bv = full_point_derivatives(model, y, command, p_s, fl)
    return FullSmallSignal(
        A=J[:6, :6].copy(),
        B=Bv[:6, None].copy(),
        state=y,
        command=float(command),
        supply_pressure=float(p_s),
        load_force=fl,
    )
