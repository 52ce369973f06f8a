"""Fitting a scalar function on an interval by a continuous piecewise-affine function.

Three ways to choose the cells, Eqs. (16)–(22) of the paper:

``tangent``
    The paper's construction, Eqs. (17)–(19): one tangent line per working point;
    neighbouring lines meet at the breakpoints.
``fixed breakpoints``
    Breakpoints given; the values at the breakpoints (and at the interval ends)
    are chosen to minimise the max error (a linear programme) or the RMS error
    (weighted least squares). Continuity holds by construction.
``optimised breakpoints``
    As above, with the breakpoints themselves chosen by Nelder–Mead on the
    outer problem (``scipy.optimize.minimize``).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.optimize import linprog, minimize

from .._errors import PwaError
from ..components import PiecewiseAffine
from ..components._pwa import read_only

__all__ = ["PwaFit", "fit_pwa", "tangent_pwa", "approximation_errors"]

_METHODS = ("minimax", "rms")


@dataclass(frozen=True, eq=False)
class PwaFit:
    """A fitted cell set: the PWA function, where it was fitted and how well.

    Attributes
    ----------
    pwa : PiecewiseAffine
        The cells (breakpoints, slopes k, offsets d) in the units of the fitted function.
    interval : tuple of float
        Fit interval (lo, hi) in the unit of the argument.
    working_points : ndarray, shape (n,)
        Working point of each cell: the tangent point in ``tangent`` mode, otherwise the
        centre of the cell clipped to ``interval``.
    max_error : float
        Largest absolute error on a fine grid over ``interval`` (unit of the function).
    rms_error : float
        Root-mean-square error over ``interval`` (unit of the function).
    method : str
        ``tangent``, ``minimax``, ``rms``, ``minimax-optimized``, ``rms-optimized`` or ``given``.
    """

    pwa: PiecewiseAffine
    interval: tuple[float, float]
    working_points: np.ndarray
    max_error: float
    rms_error: float
    method: str

    def __post_init__(self) -> None:
        object.__setattr__(self, "working_points", read_only(self.working_points))

    @property
    def n_cells(self) -> int:
        """Number of cells."""
        return self.pwa.n_cells

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, PwaFit):
            return NotImplemented
        a, b = self.pwa, other.pwa
        return (
            np.array_equal(a.breakpoints, b.breakpoints)
            and np.array_equal(a.slopes, b.slopes)
            and np.array_equal(a.offsets, b.offsets)
            and tuple(self.interval) == tuple(other.interval)
            and np.array_equal(self.working_points, other.working_points)
            and self.method == other.method
        )

    __hash__ = None  # type: ignore[assignment]


def _check_interval(interval) -> tuple[float, float]:
    try:
        lo, hi = (float(v) for v in interval)
    except (TypeError, ValueError):
        raise PwaError(f"fit interval {interval!r} must be two numbers (lo, hi)") from None
    if not (np.isfinite(lo) and np.isfinite(hi) and lo < hi):
        raise PwaError(f"fit interval ({lo:g}, {hi:g}) must be finite with lo < hi")
    return lo, hi


def _check_breakpoints(breakpoints, lo: float, hi: float, what: str = "breakpoints") -> np.ndarray:
    b = np.atleast_1d(np.asarray(breakpoints, dtype=float))
    if b.ndim != 1 or not np.all(np.isfinite(b)):
        raise PwaError(f"{what} {b.tolist()} must be a 1-D list of finite numbers")
    if np.any(np.diff(b) <= 0):
        raise PwaError(f"{what} {b.tolist()} must be strictly increasing")
    if b.size and (b[0] <= lo or b[-1] >= hi):
        raise PwaError(f"{what} {b.tolist()} must lie inside the fit interval ({lo:g}, {hi:g})")
    return b


def _grid(lo: float, hi: float, n: int, extra=()) -> np.ndarray:
    """Uniform points plus Chebyshev points (dense at the ends, where roots steepen)."""
    t = np.linspace(0.0, 1.0, n)
    cheb = lo + (hi - lo) * 0.5 * (1.0 - np.cos(np.pi * t))
    return np.unique(np.concatenate((np.linspace(lo, hi, n), cheb, np.asarray(extra, float))))


def _eval(func: Callable, x: np.ndarray) -> np.ndarray:
    y = np.asarray(func(x), dtype=float)
    if y.shape != x.shape:
        y = np.broadcast_to(y, x.shape).copy()
    if not np.all(np.isfinite(y)):
        raise PwaError("the function to fit is not finite on the whole fit interval")
    return y


def _hat_basis(x: np.ndarray, nodes: np.ndarray) -> np.ndarray:
    """Matrix Φ with Φ @ y = linear interpolation of node values y at x."""
    j = np.clip(np.searchsorted(nodes, x, side="right") - 1, 0, nodes.size - 2)
    w = (x - nodes[j]) / (nodes[j + 1] - nodes[j])
    phi = np.zeros((x.size, nodes.size))
    rows = np.arange(x.size)
    phi[rows, j] = 1.0 - w
    phi[rows, j + 1] += w
    return phi


def _trapz_weights(x: np.ndarray) -> np.ndarray:
    dx = np.diff(x)
    w = np.zeros_like(x)
    w[:-1] += 0.5 * dx
    w[1:] += 0.5 * dx
    return w / w.sum()


def _node_values(x, fx, nodes, method):
    """Optimal node values for fixed nodes; returns (values, achieved error on x)."""
    phi = _hat_basis(x, nodes)
    if method == "rms":
        sw = np.sqrt(_trapz_weights(x))
        y, *_ = np.linalg.lstsq(phi * sw[:, None], fx * sw, rcond=None)
        r = phi @ y - fx
        return y, float(np.sqrt(np.sum(_trapz_weights(x) * r**2)))
    m = nodes.size
    a_ub = np.block([[phi, -np.ones((x.size, 1))], [-phi, -np.ones((x.size, 1))]])
    b_ub = np.concatenate((fx, -fx))
    c = np.zeros(m + 1)
    c[-1] = 1.0
    res = linprog(c, A_ub=a_ub, b_ub=b_ub, bounds=[(None, None)] * (m + 1), method="highs")
    if res.status != 0:  # pragma: no cover - LP is always feasible and bounded
        raise PwaError(f"minimax fit failed: {res.message}")
    return res.x[:m], float(res.x[-1])


def _from_nodes(nodes: np.ndarray, values: np.ndarray) -> PiecewiseAffine:
    k = np.diff(values) / np.diff(nodes)
    d = values[:-1] - k * nodes[:-1]
    return PiecewiseAffine(nodes[1:-1], k, d)


def approximation_errors(
    func: Callable, pwa: PiecewiseAffine, interval, n: int = 20001
) -> tuple[float, float]:
    """Max and RMS error of ``pwa`` against ``func`` on a fine grid over ``interval``.

    Returns
    -------
    max_error, rms_error : float
        In the unit of ``func``; the RMS is the trapezoidal mean over the interval.
    """
    lo, hi = _check_interval(interval)
    x = _grid(lo, hi, n, pwa.breakpoints[(pwa.breakpoints > lo) & (pwa.breakpoints < hi)])
    r = pwa(x) - _eval(func, x)
    return float(np.max(np.abs(r))), float(np.sqrt(np.sum(_trapz_weights(x) * r**2)))


def _centres(pwa: PiecewiseAffine, lo: float, hi: float) -> np.ndarray:
    edges = np.concatenate(([lo], np.clip(pwa.breakpoints, lo, hi), [hi]))
    return 0.5 * (edges[:-1] + edges[1:])


def _finish(func, pwa, lo, hi, method, working_points=None) -> PwaFit:
    emax, erms = approximation_errors(func, pwa, (lo, hi))
    wp = _centres(pwa, lo, hi) if working_points is None else np.asarray(working_points, float)
    return PwaFit(pwa, (lo, hi), wp, emax, erms, method)


def tangent_pwa(
    func: Callable, working_points, interval, derivative: Callable | None = None
) -> PwaFit:
    """Tangent lines at the working points, Eqs. (17)–(19); breakpoints where neighbours meet.

    Parameters
    ----------
    func : callable
        Vectorised scalar function f(x).
    working_points : array_like, shape (n,)
        Strictly increasing working points x̂_i inside ``interval`` (unit of x).
    interval : (float, float)
        Interval over which the errors are reported.
    derivative : callable, optional
        f'(x); central differences when omitted.

    Returns
    -------
    PwaFit
        k_i = f'(x̂_i), d_i = f(x̂_i) − k_i x̂_i.
    """
    lo, hi = _check_interval(interval)
    xw = np.atleast_1d(np.asarray(working_points, dtype=float))
    if xw.size == 0:
        raise PwaError("tangent construction needs at least one working point")
    if np.any(np.diff(xw) <= 0) or xw[0] < lo or xw[-1] > hi:
        raise PwaError(
            f"working points {xw.tolist()} must increase strictly and lie in [{lo:g}, {hi:g}]"
        )
    fx = _eval(func, xw)
    if derivative is not None:
        k = np.asarray(derivative(xw), dtype=float)
    else:
        h = 1e-6 * np.maximum(1.0, np.abs(xw))
        k = (_eval(func, xw + h) - _eval(func, xw - h)) / (2 * h)
    d = fx - k * xw
    if xw.size == 1:
        pwa = PiecewiseAffine(np.empty(0), k, d)
    else:
        try:
            pwa = PiecewiseAffine.from_lines(k, d)
        except PwaError as exc:
            raise PwaError(
                f"tangent lines at {xw.tolist()} do not meet in order ({exc}); "
                "choose working points on a convex or concave stretch"
            ) from None
    return _finish(func, pwa, lo, hi, "tangent", xw)


def _density_breakpoints(x, fx, n_cells) -> np.ndarray:
    """Breakpoints equidistributing √|f''| (optimal density for interpolation)."""
    d2 = np.abs(np.gradient(np.gradient(fx, x), x))
    dens = np.sqrt(d2 + 1e-12 * (np.max(d2) + 1e-300)) + 0.05 * np.mean(np.sqrt(d2))
    cum = np.concatenate(([0.0], np.cumsum(0.5 * (dens[1:] + dens[:-1]) * np.diff(x))))
    if cum[-1] <= 0:
        return np.linspace(x[0], x[-1], n_cells + 1)[1:-1]
    return np.interp(np.linspace(0, cum[-1], n_cells + 1)[1:-1], cum, x)


def _optimise_breakpoints(x, fx, lo, hi, n_cells, method, maxiter) -> np.ndarray:
    """Nelder–Mead over log-widths of the cells (keeps breakpoints ordered and inside)."""
    b0 = _density_breakpoints(x, fx, n_cells)
    widths0 = np.diff(np.concatenate(([lo], b0, [hi])))
    theta0 = np.log(np.maximum(widths0, 1e-9 * (hi - lo)) / widths0[0])[1:]

    def nodes_of(theta):
        w = np.exp(np.concatenate(([0.0], np.clip(theta, -30, 30))))
        return lo + (hi - lo) * np.concatenate(([0.0], np.cumsum(w) / w.sum()))

    def objective(theta):
        nodes = nodes_of(theta)
        if np.any(np.diff(nodes) <= 0):
            return np.inf
        return _node_values(x, fx, nodes, method)[1]

    best = theta0
    for _ in range(2):  # a restart escapes the occasional collapsed simplex
        res = minimize(
            objective,
            best,
            method="Nelder-Mead",
            options={"maxiter": maxiter, "xatol": 1e-5, "fatol": 1e-12, "adaptive": True},
        )
        best = res.x
    return nodes_of(best)


def fit_pwa(
    func: Callable,
    interval,
    *,
    n_cells: int | None = None,
    breakpoints=None,
    working_points=None,
    derivative: Callable | None = None,
    method: str = "minimax",
    n_grid: int = 600,
    maxiter: int = 300,
) -> PwaFit:
    """Approximate ``func`` on ``interval`` by a continuous piecewise-affine function.

    Exactly one of ``n_cells`` (optimised breakpoints), ``breakpoints`` (given) or
    ``working_points`` (tangent construction of Eqs. (17)–(19)) selects the mode.

    Parameters
    ----------
    func : callable
        Vectorised scalar function f(x) [unit of y].
    interval : (float, float)
        Fit interval (lo, hi) [unit of x]; the outer cells extend beyond it.
    n_cells : int, optional
        Number of cells; the n−1 breakpoints are chosen to minimise the error.
    breakpoints : array_like, optional
        Strictly increasing breakpoints inside ``interval``.
    working_points : array_like, optional
        Tangent points (see :func:`tangent_pwa`).
    derivative : callable, optional
        f'(x), used in tangent mode.
    method : {"minimax", "rms"}
        Error to minimise in the fixed and optimised modes.
    n_grid : int
        Points of the fitting grid (uniform plus Chebyshev points).
    maxiter : int
        Nelder–Mead iterations per restart in the optimised mode.

    Returns
    -------
    PwaFit
        Cells and the achieved max and RMS errors (on a 20001-point grid).

    Raises
    ------
    PwaError
        Bad interval, zero cells, breakpoints out of order or outside the interval,
        or more than one mode selected.
    """
    lo, hi = _check_interval(interval)
    given = [
        m
        for m, v in (
            ("n_cells", n_cells),
            ("breakpoints", breakpoints),
            ("working_points", working_points),
        )
        if v is not None
    ]
    if len(given) != 1:
        raise PwaError(
            f"give exactly one of n_cells, breakpoints or working_points (got {given or 'none'})"
        )
    if working_points is not None:
        return tangent_pwa(func, working_points, (lo, hi), derivative)
    if method not in _METHODS:
        raise PwaError(f"method {method!r} must be one of {', '.join(_METHODS)}")
    if breakpoints is not None:
        b = _check_breakpoints(breakpoints, lo, hi)
        nodes = np.concatenate(([lo], b, [hi]))
        x = _grid(lo, hi, n_grid, b)
        y, _ = _node_values(x, _eval(func, x), nodes, method)
        return _finish(func, _from_nodes(nodes, y), lo, hi, method)
    if isinstance(n_cells, bool) or not isinstance(n_cells, int | np.integer) or n_cells < 1:
        raise PwaError(f"number of cells {n_cells!r} must be a positive integer")
    x = _grid(lo, hi, max(100, n_grid // 3))  # coarse grid for the outer search
    fx = _eval(func, x)
    if n_cells == 1:
        nodes = np.array([lo, hi])
    else:
        nodes = _optimise_breakpoints(x, fx, lo, hi, int(n_cells), method, maxiter)
    xf = _grid(lo, hi, n_grid, nodes[1:-1])
    y, _ = _node_values(xf, _eval(func, xf), nodes, method)
    return _finish(func, _from_nodes(nodes, y), lo, hi, f"{method}-optimized")
