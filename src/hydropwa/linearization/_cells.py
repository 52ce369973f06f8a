"""The paper's cell sets: dead-zone (16), C_q (18), (20), C_qp (19), (21), friction (22).

C_q and C_qp are fitted once, independent of the supply pressure, as functions of the
normalised load pressure p̃ = sign(z)·P_L/P_S (docs/errata.md E5, E10)::

    Ĉ_q(P_L)  = K √(½(P_S − sign(z) P_L))        = K √(P_S/2) · √(1 − p̃)
    Ĉ_qp(P_L) = |z| K / (4 √(½(P_S − sign(z) P_L))) = |z| K / (4 √(P_S/2)) · 1/√(1 − p̃)

so a cell set in p̃ serves every supply pressure: slopes scale with √P_S/P_S,
offsets with √P_S, breakpoints with P_S, and both flow directions use the same cells.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from .._errors import PwaError
from ..components import PiecewiseAffine, stribeck_friction, stribeck_friction_slope
from ..params import DeadZone, Friction, table_v_pwa
from ._fit import PwaFit, approximation_errors, fit_pwa, tangent_pwa

__all__ = [
    "PAPER_WORKING_POINTS",
    "CQ_INTERVAL",
    "CQP_INTERVAL",
    "FRICTION_INTERVAL",
    "dead_zone_cells",
    "cq_shape",
    "cqp_shape",
    "cq_cells",
    "cqp_cells",
    "friction_cells",
    "machine_friction_cells",
    "friction_function",
    "friction_slope",
]

#: Normalised working points p̂ = P̂_L/P_S of the paper's five C_q and C_qp cells,
#: recovered from Tables VI–IX (see :func:`recover_paper_columns`): tangents at
#: 1 − p̂ = 0.7, 0.3, 0.1, 0.005 and 0.001.
PAPER_WORKING_POINTS = (0.3, 0.7, 0.9, 0.995, 0.999)

#: Default fit interval of C_q in p̃: |P_L| <= P_S (both chambers between tank and supply).
CQ_INTERVAL = (-1.0, 1.0)
#: Default fit interval of C_qp in p̃; 1/√(1 − p̃) is unbounded at p̃ = 1, the paper's last
#: working point is 0.999.
CQP_INTERVAL = (-1.0, 0.999)
#: Default velocity interval [m/s] of the friction cells (fastest Stribeck run ≈ 0.2 m/s).
FRICTION_INTERVAL = (-0.2, 0.2)


def cq_shape(p):
    """√(1 − p̃) [1]: Ĉ_q of Eq. (18) divided by K√(P_S/2); zero beyond p̃ = 1."""
    return np.sqrt(np.maximum(1.0 - np.asarray(p, dtype=float), 0.0))


def _cq_shape_slope(p):
    return -0.5 / np.sqrt(1.0 - np.asarray(p, dtype=float))


def cqp_shape(p):
    """1/√(1 − p̃) [1]: Ĉ_qp of Eq. (19) at |z| = 1 divided by K/(4√(P_S/2))."""
    return 1.0 / np.sqrt(1.0 - np.asarray(p, dtype=float))


def _cqp_shape_slope(p):
    return 0.5 * (1.0 - np.asarray(p, dtype=float)) ** -1.5


def dead_zone_cells(dz: DeadZone) -> PiecewiseAffine:
    """Dead-zone and saturation cells z = k_g u + d_g, Eq. (16) and Table IV.

    Parameters
    ----------
    dz : DeadZone
        α, β, creep slope and the continuity choice (docs/errata.md E4).

    Returns
    -------
    PiecewiseAffine
        Five cells over u [1] with breakpoints −(α+o), −β, β, α+o (o the outer offset):
        saturation −α, the negative linear cell, the creep cell, the positive linear
        cell and saturation +α. With β = 0 the creep cell vanishes (three cells).
        Reproduces :data:`hydropwa.params.TABLE_IV` exactly for the paper's preset; the
        jump of creep·β at |u| = β is kept unless ``dz.continuous``.
    """
    a, b, c, o = dz.alpha, dz.beta, dz.creep_slope, dz.outer_offset
    us = a + o
    if b == 0.0:
        return PiecewiseAffine(
            np.array([-us, us]), np.array([0.0, 1.0, 0.0]), np.array([-a, 0.0, a])
        )
    return PiecewiseAffine(
        np.array([-us, -b, b, us]),
        np.array([0.0, 1.0, c, 1.0, 0.0]),
        np.array([-a, o, 0.0, -o, a]),
    )


def dead_zone_interval(
    dead_zone: PiecewiseAffine, g: int, s: int, lo: float, hi: float
) -> tuple[float, float]:
    """Input interval of dead-zone cell ``g`` within [lo, hi] where sign(z) = ``s`` (±1).

    The cell spans its breakpoints (the outer cells end at ``lo``/``hi``); where z = k_g u + d_g
    changes sign inside it (the creep cell, Eq. (16)), at u₀ = −d_g/k_g, the half of sign ``s``
    is kept. One rule for the command cells of :class:`PwaModel` and the spool cells of the
    chamber-level model.
    """
    b = np.concatenate(([lo], dead_zone.breakpoints, [hi]))
    lo, hi = float(max(b[g], lo)), float(min(b[g + 1], hi))
    k, d = dead_zone.slopes[g], dead_zone.offsets[g]
    if k != 0.0:
        u0 = -d / k  # where z changes sign
        if lo < u0 < hi:
            lo, hi = (u0, hi) if s > 0 else (lo, u0)
    return lo, hi


def _check_cells(n, what: str) -> int:
    if isinstance(n, bool) or not isinstance(n, int | np.integer) or n < 1:
        raise PwaError(f"number of {what} cells {n!r} must be a positive integer")
    return int(n)


def _shape_cells(func, slope, interval, mode, n, breakpoints, working_points, what) -> PwaFit:
    n = _check_cells(n, what)
    if mode == "paper":
        if n != len(PAPER_WORKING_POINTS):
            raise PwaError(
                f"the paper's {what} cells are {len(PAPER_WORKING_POINTS)}; for {n} cells use "
                "breakpoints='optimized'"
            )
        return tangent_pwa(func, PAPER_WORKING_POINTS, interval, slope)
    if mode == "tangent":
        wp = PAPER_WORKING_POINTS if working_points is None else working_points
        return tangent_pwa(func, wp, interval, slope)
    if mode in ("optimized", "optimized-rms"):
        return _optimized(
            func.__name__, tuple(interval), n, "rms" if mode.endswith("rms") else "minimax"
        )
    if mode == "given":
        fit = fit_pwa(func, interval, breakpoints=breakpoints)
        if fit.n_cells != n:
            raise PwaError(
                f"{len(np.atleast_1d(breakpoints))} {what} breakpoints make {fit.n_cells} cells, not {n}"
            )
        return fit
    raise PwaError(f"unknown breakpoint mode {mode!r} for {what}")


_SHAPES = {"cq_shape": cq_shape, "cqp_shape": cqp_shape}


@lru_cache(maxsize=64)
def _optimized(name: str, interval: tuple[float, float], n: int, method: str) -> PwaFit:
    return fit_pwa(_SHAPES[name], interval, n_cells=n, method=method)


def cq_cells(
    n: int = 5, mode: str = "paper", *, interval=CQ_INTERVAL, breakpoints=None, working_points=None
) -> PwaFit:
    """Normalised C_q cells k̂_o p̃ + d̂_o ≈ √(1 − p̃), Eqs. (18), (20).

    Parameters
    ----------
    n : int
        Number of cells.
    mode : {"paper", "tangent", "optimized", "optimized-rms", "given"}
        ``paper``: tangents at :data:`PAPER_WORKING_POINTS` (Tables VI–VII);
        ``tangent``: tangents at ``working_points`` [1]; ``optimized``: minimax-optimal
        breakpoints; ``given``: minimax fit on ``breakpoints`` [1].
    interval : (float, float)
        Fit/report interval in p̃ [1].

    Returns
    -------
    PwaFit
        Cells in p̃; physical k_o = K√(P_S/2)·k̂_o·sign(z)/P_S [m³/(s·Pa)],
        d_o = K√(P_S/2)·d̂_o [m³/s], breakpoints sign(z)·P_S·p̃ [Pa].
    """
    return _shape_cells(
        cq_shape, _cq_shape_slope, interval, mode, n, breakpoints, working_points, "C_q"
    )


def cqp_cells(
    n: int = 5, mode: str = "paper", *, interval=CQP_INTERVAL, breakpoints=None, working_points=None
) -> PwaFit:
    """Normalised C_qp cells k̂_n p̃ + d̂_n ≈ 1/√(1 − p̃), Eqs. (19), (21).

    Parameters are those of :func:`cq_cells`. Physical k_n = K/(4√(P_S/2))·k̂_n·sign(z)/P_S
    [m³/(s·Pa²)], d_n = K/(4√(P_S/2))·d̂_n [m³/(s·Pa)]; C_qp = |z|(k_n P_L + d_n).
    """
    return _shape_cells(
        cqp_shape, _cqp_shape_slope, interval, mode, n, breakpoints, working_points, "C_qp"
    )


def friction_function(friction: Friction):
    """Eq. (11) with the given parameters as a vectorised function of ẋ [m/s] → f [N]."""
    fr = friction

    def f(v):
        return stribeck_friction(
            np.asarray(v, dtype=float),
            fr.coulomb,
            fr.static,
            fr.viscous,
            fr.stribeck_velocity,
            fr.shape,
            fr.smoothness,
        )

    return f


def friction_slope(friction: Friction):
    """df/dẋ [N·s/m] of Eq. (11) as a function of velocity (arrays too); at ẋ = 0 the limit γF_s + σ.

    Evaluates :func:`hydropwa.components.stribeck_friction_slope` element-wise.
    """
    fr = friction
    args = (fr.coulomb, fr.static, fr.viscous, fr.stribeck_velocity, fr.shape, fr.smoothness)

    def df(v):
        v = np.asarray(v, dtype=float)
        out = np.array([stribeck_friction_slope(float(x), *args) for x in v.ravel()])
        return out.reshape(v.shape)

    return df


def _paper_friction_breakpoints() -> np.ndarray:
    return table_v_pwa().breakpoints


def friction_cells(
    friction: Friction,
    n: int = 7,
    mode: str = "paper",
    *,
    interval=FRICTION_INTERVAL,
    breakpoints=None,
    working_points=None,
) -> PwaFit:
    """Stribeck friction cells f(ẋ) ≈ k_w ẋ + d_w, Eq. (22) and Table V.

    Parameters
    ----------
    friction : Friction
        Stribeck parameters of Eq. (11).
    n : int
        Number of cells (7 in the paper).
    mode : {"paper", "machine", "optimized", "optimized-rms", "given", "tangent"}
        ``machine``: :func:`machine_friction_cells` (breakpoints from the machine's own
        Stribeck velocity, optimised over ``interval``);
        ``paper``: least-squares fit on Table V's breakpoints (±0.79, ±14.5, ±54.4 mm/s);
        ``optimized``: minimax-optimal breakpoints; ``given``: minimax fit on
        ``breakpoints`` [m/s]; ``tangent``: tangents at ``working_points`` [m/s].
    interval : (float, float)
        Velocity interval [m/s].

    Returns
    -------
    PwaFit
        Cells over ẋ [m/s] with slopes k_w [N·s/m] and offsets d_w [N].
    """
    n = _check_cells(n, "friction")
    func = friction_function(friction)
    if mode == "paper":
        if n != 7:
            raise PwaError(
                f"the paper's friction cells are 7; for {n} cells use breakpoints='optimized'"
            )
        return fit_pwa(func, interval, breakpoints=_paper_friction_breakpoints(), method="rms")
    if mode == "tangent":
        if working_points is None:
            raise PwaError("tangent friction cells need working_points [m/s]")
        return tangent_pwa(func, working_points, interval, friction_slope(friction))
    if mode == "machine":
        return machine_friction_cells(friction, n, tuple(float(v) for v in interval))
    if mode in ("optimized", "optimized-rms"):
        return _optimized_friction(
            friction, tuple(interval), n, "rms" if mode.endswith("rms") else "minimax"
        )
    if mode == "given":
        fit = fit_pwa(func, interval, breakpoints=breakpoints)
        if fit.n_cells != n:
            raise PwaError(
                f"{len(np.atleast_1d(breakpoints))} friction breakpoints make {fit.n_cells} cells, not {n}"
            )
        return fit
    raise PwaError(f"unknown breakpoint mode {mode!r} for friction")


#: Table V's breakpoints (±0.79, ±14.5, ±54.4 mm/s) in units of the paper's Stribeck velocity
#: χ = 15.7 mm/s: where a 7-cell fit of a Stribeck curve wants its breakpoints.
_STRIBECK_BREAKPOINTS = (0.05, 0.92, 3.47)


@lru_cache(maxsize=32)
def machine_friction_cells(friction: Friction, n: int, interval: tuple[float, float]) -> PwaFit:
    """Friction cells for the machine's own velocity range, Eq. (22).

    Symmetric breakpoints start from Table V's pattern scaled by the machine's Stribeck
    velocity χ (0.05χ, 0.92χ, 3.5χ for 7 cells; a geometric spread from 1/γ to a third of
    the range for other counts) and are then optimised (Nelder–Mead on their logarithms,
    minimax error of the least-squares-continuous fit over ``interval``). A range too narrow
    for that pattern (its breakpoints clipped onto one another, e.g. at a supply pressure of
    a few pascal) gets the plain n-cell minimax fit instead. Cached per (friction, n, interval).
    """
    from scipy.optimize import minimize  # deferred: scipy.optimize is slow to import

    n = _check_cells(n, "friction")
    func = friction_function(friction)
    lo, hi = interval
    vmax = min(abs(lo), abs(hi))
    if n < 3 or n % 2 == 0 or vmax <= 0.0:
        return _optimized_friction(friction, interval, n, "minimax")
    k = (n - 1) // 2
    chi = friction.stribeck_velocity
    if k == 3:
        b0 = np.array(_STRIBECK_BREAKPOINTS) * chi
    else:
        b0 = np.geomspace(
            min(1.0 / max(friction.smoothness, 1e-9), 0.05 * chi), max(3.5 * chi, vmax / 3), k
        )
    b0 = np.clip(b0, 1e-6 * vmax, 0.95 * vmax)

    def fit(logb):
        b = np.sort(np.exp(logb))
        if b[-1] >= 0.98 * vmax or np.any(np.diff(b) <= 1e-9 * vmax):
            return None
        return fit_pwa(func, interval, breakpoints=np.concatenate((-b[::-1], b)), method="minimax")

    start = fit(np.log(b0))
    if start is None:  # a range narrower than the pattern (e.g. a low supply): it collapses
        return _optimized_friction(friction, interval, n, "minimax")

    def cost(logb):
        f = fit(logb)
        return np.inf if f is None else f.max_error

    res = minimize(
        cost,
        np.log(b0),
        method="Nelder-Mead",
        options={"maxiter": 20 * k, "xatol": 1e-3, "fatol": 1e-2},
    )
    return fit(res.x) if np.isfinite(res.fun) and res.fun <= start.max_error else start


@lru_cache(maxsize=32)
def _optimized_friction(friction: Friction, interval, n: int, method: str) -> PwaFit:
    return fit_pwa(friction_function(friction), interval, n_cells=n, method=method, n_grid=900)


def table_v_residual(
    friction: Friction, fit: PwaFit | None = None, interval=FRICTION_INTERVAL
) -> float:
    """RMS difference [N] between friction cells built from ``friction`` and Table V's curve."""
    fit = friction_cells(friction) if fit is None else fit
    return approximation_errors(table_v_pwa(), fit.pwa, interval)[1]
