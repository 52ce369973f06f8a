"""The chamber-level piecewise-affine model (``pwa-chamber``): spool, P_A, P_B, x, ẋ in cells.

The load-pressure forms of :mod:`._model` make the chamber pressures quasi-steady; this form
keeps the full model's states (Eqs. (1)–(11)) and replaces each nonlinearity by cells:

=====================  ========================================  ==============================
nonlinearity           cells over                                fit
=====================  ========================================  ==============================
dead zone, Eq. (2)     spool position ν [1]                      exact (Eq. (16), Table IV)
metering flow (5)–(6)  q = ΔP/P_S of each edge [1]               chord interpolation of
                                                                 signed_sqrt(q, p_tr/P_S),
                                                                 refined to a bound
capacitance, Eq. (9)   rod position x [m]                        V_A, V_B at the cell centre,
                                                                 refined to a bound
friction, Eq. (11)     ẋ [m/s]                                   as the other forms (Eq. (22))
=====================  ========================================  ==============================

Kernel formula (kind 3, :func:`hydropwa.simulation._kernel.rhs_chamber`)::

    z   = k_g ν + d_g                                    (cell g over ν)
    Q_A = z K √P_S (k_a q_a + d_a),  Q_B = z K √P_S (k_b q_b + d_b)
          z ≥ 0: q_a = (P_S − P_A)/P_S, q_b = (P_B − P_T)/P_S
          z < 0: q_a = (P_A − P_T)/P_S, q_b = (P_S − P_B)/P_S
    Ṗ_A = E/V_A(x_j) (Q_A − A_A ẋ + C_L (P_B − P_A))        (x_j: centre of x cell j)
    Ṗ_B = E/V_B(x_j) (−Q_B + A_B ẋ + C_L (P_A − P_B))
    ν̈ = ω0² (u − ν) − 2ζω0 ν̇,   ẍ = (P_A A_A − P_B A_B − (k_w ẋ + d_w) − F_L + F_stop)/m

Inside one cell the right-hand side is affine in the state apart from the bilinear z·P terms
(z = k_g ν + d_g times the drop), as in the load-pressure forms. The flow cells are fitted once
in the normalised drop q (signed_sqrt(ΔP, p_tr)/√P_S = signed_sqrt(q, p_tr/P_S)), so scheduling
on P_S(t) costs one square root per right-hand side.

Error bounds: the flow cells interpolate the root at their breakpoints; the root is concave for
q > 0 and convex for q < 0, so the largest deviation of each cell lies where the root's slope
equals the chord's and is found to rounding (no sampling). The capacitance cells bound the
relative error |V(x_j)/V(x) − 1| of both chambers by its value at the cell's ends.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from functools import partial
from typing import Any, ClassVar, NamedTuple

import numpy as np

from .._errors import PwaError
from .._layout import CHAMBER_KIND, FULL_STATES, I_CELLS, N_BASE, PWA_SLOT
from ..components import PiecewiseAffine, orifice_flows, signed_sqrt, signed_sqrt_slope
from ..components import dead_zone as _dz
from ..components._pwa import read_only
from ..models import FullOrderModel, pack_params
from ..models._models import SmoothModelStates
from ..params import SystemParams
from ..simulation import _kernel as K
from ._cells import dead_zone_cells, dead_zone_interval, friction_cells
from ._fit import PwaFit

__all__ = [
    "ChamberPwaModel",
    "ChamberCellIndex",
    "FlowCells",
    "CapacitanceCells",
    "flow_cells",
    "capacitance_cells",
    "linearize_chamber",
    "FLOW_TOLERANCE",
    "CAPACITANCE_TOLERANCE",
    "DROP_INTERVAL",
]

#: Default bound on the normalised metering-flow error, |Q_PWA − Q|/(|z| K √P_S) [1] (0.5 % of the
#: flow at the full drop P_S).
FLOW_TOLERANCE = 0.005
#: Default bound on the relative chamber-capacitance error |V(x_j)/V(x) − 1| [1].
CAPACITANCE_TOLERANCE = 0.01
#: Range of the normalised edge drop q = ΔP/P_S the flow cells cover: a supply edge from a
#: chamber at 2.5 P_S (braking an overrunning load) to one at the vapour pressure; a tank edge
#: up to 2.5 P_S (the rod side of a single-rod cylinder intensifies the pressure by A_A/A_B).
DROP_INTERVAL = (-1.5, 2.5)
_STATE_NAMES = tuple(name for name, _u, _s in FULL_STATES)
I_SCHED, I_PSFIX, I_FORM = PWA_SLOT["sched"], PWA_SLOT["psfix"], PWA_SLOT["form"]
I_NG, I_NC, I_NX, I_NW = PWA_SLOT["ng"], PWA_SLOT["no"], PWA_SLOT["nn"], PWA_SLOT["nw"]


class ChamberCellIndex(NamedTuple):
    """Active cells: g (dead zone), s (sign of z), a, b (flow cells of edges A, B), j (x), w."""

    g: int
    s: int
    a: int
    b: int
    j: int
    w: int


def _root(q, eps: float):
    """signed_sqrt(q, ε): the orifice root of Eqs. (5)–(6) in the normalised drop q (floats)."""
    return signed_sqrt(float(q), eps)


def _chord_error(lo: float, hi: float, eps: float) -> float:
    """Largest |root − chord| over [lo, hi] (one side of q = 0), exact to rounding.

    The root is concave for q ≥ 0 and convex for q ≤ 0 (its slope is monotone on each side),
    so the error of the chord is extreme where the root's slope equals the chord's slope s;
    that point is found by bisection on the slope (``signed_sqrt_slope``).
    """
    fa, fb = _root(lo, eps), _root(hi, eps)
    s = (fb - fa) / (hi - lo)
    side = 1.0 if lo + hi > 0.0 else -1.0  # slope decreasing in q for q > 0, increasing for q < 0
    a, b = lo, hi
    for _ in range(200):
        m = 0.5 * (a + b)
        g = signed_sqrt_slope(m, eps) - s
        if (g > 0.0) == (side > 0.0):
            a = m
        else:
            b = m
        if b - a <= 1e-15 * max(1.0, abs(m)):
            break
    qs = 0.5 * (a + b)
    return abs(_root(qs, eps) - (fa + s * (qs - lo)))


@dataclass(frozen=True, eq=False)
class FlowCells:
    """Metering-flow cells: r(q) ≈ k_c q + d_c ≈ signed_sqrt(q, ε) over the normalised drop q.

    Attributes
    ----------
    pwa : PiecewiseAffine
        Cells over q = ΔP/P_S [1]; values in units of √P_S (Q = z K √P_S r).
    bounds : ndarray, shape (n,)
        Guaranteed max |r − signed_sqrt(q, ε)| over each cell's interval within ``interval``.
    interval : (float, float)
        Drop range the cells cover [1]; the outer cells extend their chord beyond it.
    eps : float
        Laminar transition p_tr/P_S of the fit [1] (the root's regularisation, docs/errata.md E3).
    tolerance : float
        The bound the refinement met [1].
    """

    pwa: PiecewiseAffine
    bounds: np.ndarray
    interval: tuple[float, float]
    eps: float
    tolerance: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "bounds", read_only(self.bounds))

    @property
    def n_cells(self) -> int:
        """Number of cells."""
        return self.pwa.n_cells

    @property
    def max_error(self) -> float:
        """Largest per-cell bound [1]."""
        return float(np.max(self.bounds))

    def edges(self) -> np.ndarray:
        """Cell boundaries clipped to ``interval``, shape (n + 1,)."""
        return np.concatenate(([self.interval[0]], self.pwa.breakpoints, [self.interval[1]]))


def _halve_until(
    error: Callable[[float, float], float],
    work: list[tuple[float, float]],
    tolerance: float,
    max_cells: int,
    what: str,
) -> list[tuple[float, float, float]]:
    """Halve the intervals ``work`` until ``error(a, b)`` ≤ ``tolerance`` on each.

    Returns the cells (a, b, error) in order; more than ``max_cells`` raises a PwaError that
    names ``what`` cells. The refinement of the flow and the capacitance cells.
    """
    work = list(work)
    done: list[tuple[float, float, float]] = []
    while work:
        a, b = work.pop()
        e = error(a, b)
        if e <= tolerance:
            done.append((a, b, e))
        else:
            m = 0.5 * (a + b)
            work += [(a, m), (m, b)]
        if len(done) + len(work) > max_cells:
            raise PwaError(
                f"{what} cells need more than {max_cells} cells for tolerance {tolerance:g}; "
                "raise the tolerance"
            )
    return sorted(done)


def flow_cells(
    eps: float, tolerance: float = FLOW_TOLERANCE, interval=DROP_INTERVAL, max_cells: int = 400
) -> FlowCells:
    """Chord cells of the orifice root signed_sqrt(q, ε), refined until each cell's bound ≤ tolerance.

    Parameters
    ----------
    eps : float
        p_tr/P_S [1] (laminar transition of the root, docs/errata.md E3), > 0.
    tolerance : float
        Bound on |r − root| per cell [1] (in units of √P_S; the root is 1 at the full drop).
    interval : (float, float)
        Drop range q = ΔP/P_S [1], lo < 0 < hi.
    max_cells : int
        Refinement stops with a PwaError beyond this many cells.

    Returns
    -------
    FlowCells
        Continuous cells (they interpolate the root at every breakpoint, 0 at q = 0), split in
        halves until the bound of :func:`_chord_error` meets ``tolerance``.
    """
    if not (math.isfinite(tolerance) and tolerance > 0.0):
        raise PwaError(f"flow-cell tolerance {tolerance!r} must be a positive number")
    lo, hi = (float(v) for v in interval)
    if not lo < 0.0 < hi:
        raise PwaError(f"drop interval ({lo:g}, {hi:g}) must contain 0")
    error = partial(_chord_error, eps=eps)
    done = _halve_until(error, [(lo, 0.0), (0.0, hi)], tolerance, max_cells, "flow")
    k, d = [], []
    for a, b, _e in done:
        fa, fb = _root(a, eps), _root(b, eps)
        s = (fb - fa) / (b - a)
        k.append(s)
        d.append(fa - s * a)
    pwa = PiecewiseAffine(np.array([a for a, _b, _e in done[1:]]), np.array(k), np.array(d))
    return FlowCells(pwa, np.array([e for _a, _b, e in done]), (lo, hi), float(eps), tolerance)


@dataclass(frozen=True, eq=False)
class CapacitanceCells:
    """Position cells of the chamber capacitances: V_A, V_B evaluated at each cell's centre.

    Attributes
    ----------
    breakpoints : ndarray, shape (n − 1,)
        Cell boundaries [m] inside the stroke (outer cells unbounded).
    centres : ndarray, shape (n,)
        Rod position x_j [m] at which each cell evaluates V_A(x) = V_A0 + A_A x and
        V_B(x) = V_B0 + A_B (l − x).
    bounds : ndarray, shape (n,)
        Guaranteed max relative error |V(x_j)/V(x) − 1| of either chamber over the cell [1].
    tolerance : float
    """

    breakpoints: np.ndarray
    centres: np.ndarray
    bounds: np.ndarray
    tolerance: float

    def __post_init__(self) -> None:
        for name in ("breakpoints", "centres", "bounds"):
            object.__setattr__(self, name, read_only(getattr(self, name)))

    @property
    def n_cells(self) -> int:
        """Number of cells."""
        return int(self.centres.size)

    def cell(self, x):
        """Index of the cell of rod position x [m]."""
        return np.searchsorted(self.breakpoints, x, side="right")


def _capacitance_error(a: float, b: float, params: SystemParams) -> float:
    c = params.cylinder
    h = 0.5 * (b - a)
    va = c.dead_volume_a + c.area_a * a  # smallest V_A in the cell
    vb = c.dead_volume_b + c.area_b * (c.stroke - b)  # smallest V_B in the cell
    return max(c.area_a * h / va, c.area_b * h / vb)


def capacitance_cells(
    params: SystemParams, tolerance: float = CAPACITANCE_TOLERANCE, max_cells: int = 400
) -> CapacitanceCells:
    """Cells over the stroke, halved until |V(x_j)/V(x) − 1| ≤ ``tolerance`` in both chambers.

    With x_j the centre of [a, b], the relative error of V_A is A_A |x_j − x|/V_A(x), largest
    at x = a (A_A (b − a)/2 / V_A(a)); that of V_B at x = b. Both are exact bounds.
    """
    if not (math.isfinite(tolerance) and tolerance > 0.0):
        raise PwaError(f"capacitance tolerance {tolerance!r} must be a positive number")
    error = partial(_capacitance_error, params=params)
    stroke = [(0.0, float(params.cylinder.stroke))]
    done = _halve_until(error, stroke, tolerance, max_cells, "capacitance")
    return CapacitanceCells(
        np.array([a for a, _b, _e in done[1:]]),
        np.array([0.5 * (a + b) for a, b, _e in done]),
        np.array([e for _a, _b, e in done]),
        float(tolerance),
    )


@dataclass(frozen=True, eq=False)
class ChamberPwaModel(SmoothModelStates):
    """Chamber-level piecewise-affine model (model name ``pwa-chamber``; module docstring).

    Attributes
    ----------
    params : SystemParams
    dead_zone : PiecewiseAffine
        z = k_g ν + d_g over the spool position ν [1] (Eq. (16), Table IV; exact).
    flow : FlowCells
        Metering-flow cells over the normalised drop of each edge.
    capacitance : CapacitanceCells
        Position cells of the chamber volumes.
    friction : PwaFit
        Friction cells over ẋ [m/s] → N (Eq. (22)).
    scheduled : bool
        Follow the P_S(t) input (True) or keep P_S at ``supply_pressure``.
    supply_pressure : float
        Fixed (and nominal) P_S [Pa].
    """

    params: SystemParams
    dead_zone: PiecewiseAffine
    flow: FlowCells
    capacitance: CapacitanceCells
    friction: PwaFit
    scheduled: bool = False
    supply_pressure: float = 100e5
    kind: ClassVar[int] = K.CHAMBER
    name: ClassVar[str] = CHAMBER_KIND.name
    form: ClassVar[str] = "chamber"
    state_names: ClassVar[tuple[str, ...]] = _STATE_NAMES

    def __post_init__(self) -> None:
        if not isinstance(self.params, SystemParams):
            raise PwaError(
                f"ChamberPwaModel needs a SystemParams, got {type(self.params).__name__}"
            )
        ps = self.supply_pressure
        if not (math.isfinite(ps) and ps > max(0.0, self.params.supply.tank_pressure)):
            raise PwaError(
                f"supply pressure {ps / 1e5:g} bar must be finite and above the tank pressure"
            )

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, ChamberPwaModel):
            return NotImplemented
        return self.to_json() == other.to_json()

    __hash__ = None  # type: ignore[assignment]

    def __repr__(self) -> str:
        sched = "scheduled" if self.scheduled else f"P_S={self.supply_pressure / 1e5:.4g} bar"
        n = (
            f"{self.dead_zone.n_cells}/{self.flow.n_cells}/{self.capacitance.n_cells}/"
            f"{self.friction.n_cells}"
        )
        return f"ChamberPwaModel({sched}, cells g/flow/x/w={n})"

    # --- protocol of hydropwa.models ----------------------------------------------------
    @property
    def full(self) -> FullOrderModel:
        """The full-order model this model linearizes."""
        return FullOrderModel(self.params)

    @property
    def smooth(self) -> FullOrderModel:
        """The full-order model: its states, scales and rest (balanced forces)."""
        return self.full

    def pack(self, command_amplitude: float = 0.0) -> np.ndarray:
        """Kernel parameter vector (kind 3): base block, flags, then the four cell sections.

        ω0 follows the valve's amplitude schedule as in the full model. Sections (n − 1
        breakpoints, n slopes, n offsets each): dead zone over ν, flow over q, capacitance
        position over x (slopes 0, offsets x_j), friction over ẋ.
        """
        base = pack_params(self.params, self.params.valve.omega0_at(command_amplitude))
        base[K.I_PUMP] = 0.0  # P_S is the model's (scheduled) input, not a state
        head = np.zeros(I_CELLS - N_BASE)
        head[I_SCHED - N_BASE] = 1.0 if self.scheduled else 0.0
        head[I_PSFIX - N_BASE] = self.supply_pressure
        cap = self.capacitance
        sets = (
            (self.dead_zone.breakpoints, self.dead_zone.slopes, self.dead_zone.offsets),
            (self.flow.pwa.breakpoints, self.flow.pwa.slopes, self.flow.pwa.offsets),
            (cap.breakpoints, np.zeros(cap.n_cells), cap.centres),
            (self.friction.pwa.breakpoints, self.friction.pwa.slopes, self.friction.pwa.offsets),
        )
        head[I_NG - N_BASE : I_NW - N_BASE + 1] = [k.size for _b, k, _d in sets]
        body = [np.concatenate(s) for s in sets]
        return np.concatenate([base, head] + body)

    def state_from_measurement(
        self, measured: Mapping[str, float], /, *positional: float
    ) -> np.ndarray:
        """Initial state from measured channels (name → value [SI]), as the full model's; ``p_s``
        [Pa] defaults to the model's supply pressure."""
        if isinstance(measured, Mapping) and "p_s" not in measured:
            measured = {**measured, "p_s": self.supply_pressure}
        return self.full.state_from_measurement(measured, *positional)

    # --- cells and dynamics --------------------------------------------------------------
    def _ps(self, p_s: float | None) -> float:
        if p_s is None or not self.scheduled:
            return self.supply_pressure if p_s is None else float(p_s)
        return float(p_s)

    def _packed_scheduled(self) -> np.ndarray:
        """Packed vector with the cells following the P_S argument (memoised).

        Point evaluations pass P_S explicitly (``_ps`` holds it at the fixed value for an
        unscheduled model), so ∂f/∂P_S of :meth:`point` is the cells' true dependence on P_S.
        """
        p = self.__dict__.get("_packed_sched")
        if p is None:
            p = self.pack().copy()
            p[I_SCHED] = 1.0
            self.__dict__["_packed_sched"] = p
        return p

    def point(self, y, u: float, p_s: float | None = None, f_l: float | None = None):
        """(f, ∂f/∂y, ∂f/∂(u, P_S, F_L)) of the model at one point, from the compiled kernel."""
        ps = self._ps(p_s)
        fl = self.params.load.force if f_l is None else float(f_l)
        y = np.asarray(y, dtype=float)
        if y.shape != (len(_STATE_NAMES),):
            raise PwaError(f"state needs {len(_STATE_NAMES)} values ({', '.join(_STATE_NAMES)})")
        return K.point_derivatives(K.CHAMBER, y, float(u), ps, fl, self._packed_scheduled())

    def rhs(self, t: float, y, u: float, p_s: float | None = None, f_l: float | None = None):
        """Right-hand side (the state rates, ``state_names`` order) at one point."""
        return self.point(y, u, p_s, f_l)[0]

    def flows(self, y, p_s: float | None = None) -> tuple[float, float]:
        """PWA metering flows (Q_A into A, Q_B out of B) [m³/s] at state y (kernel's cells)."""
        ps = self._ps(p_s)
        t = K.chamber_terms(np.asarray(y, dtype=float), ps, self._packed_scheduled())
        return float(t[3]), float(t[4])

    def cell_index(self, y, p_s: float | None = None) -> ChamberCellIndex:
        """Active cells at state y (``state_names`` order)."""
        ps = self._ps(p_s)
        t = K.chamber_terms(np.asarray(y, dtype=float), ps, self._packed_scheduled())
        z = t[0]
        return ChamberCellIndex(
            int(t[14]), 1 if z >= 0.0 else -1, int(t[15]), int(t[16]), int(t[17]), int(t[18])
        )

    def flow_error_bound(self, cells: ChamberCellIndex, z: float, p_s: float | None = None):
        """Guaranteed bounds (on Q_A, on Q_B) [m³/s] of |Q_PWA − Q| inside the cells at opening z.

        |z| K √P_S times the flow cells' bounds (drops within the cells' covered interval).
        """
        ps = self._ps(p_s)
        scale = abs(z) * self.params.flow.K * math.sqrt(ps)
        return scale * self.flow.bounds[cells.a], scale * self.flow.bounds[cells.b]

    def working_point(self, cells, p_s: float | None = None) -> dict[str, float]:
        """Working point (state by name, and u) at the centre of a cell combination (g, s, a, b, j, w).

        The spool rests at u = ν in the middle of dead-zone cell g (on the side of sign s), the
        chamber pressures sit at the centres of their flow cells (clipped to the covered drops),
        x at the capacitance cell's centre, ẋ at the friction cell's working point.
        """
        ps = self.supply_pressure if p_s is None else float(p_s)
        try:
            g, s, a, b, j, w = (int(i) for i in cells)
        except (TypeError, ValueError):
            raise PwaError(f"cell combination {cells!r} must be (g, s, a, b, j, w)") from None
        for name, i, n in (
            ("g", g, self.dead_zone.n_cells),
            ("a", a, self.flow.n_cells),
            ("b", b, self.flow.n_cells),
            ("j", j, self.capacitance.n_cells),
            ("w", w, self.friction.n_cells),
        ):
            if not 0 <= i < n:
                raise PwaError(f"cell index {name} = {i} outside 0..{n - 1}")
        lo, hi = self._spool_bounds(g, s)
        nu = 0.5 * (lo + hi)
        e = self.flow.edges()
        qa, qb = 0.5 * (e[a] + e[a + 1]), 0.5 * (e[b] + e[b + 1])
        pt = self.params.supply.tank_pressure
        if s > 0:
            pa, pb = ps * (1.0 - qa), pt + ps * qb
        else:
            pa, pb = pt + ps * qa, ps * (1.0 - qb)
        return {
            "spool": nu,
            "spool_rate": 0.0,
            "p_a": pa,
            "p_b": pb,
            "x": float(self.capacitance.centres[j]),
            "v": float(self.friction.working_points[w]),
            "p_s": ps,
            "p_acc": pa,
            "u": nu,
        }

    def _spool_bounds(self, g: int, s: int) -> tuple[float, float]:
        """Spool interval of dead-zone cell g restricted to sign(z) = s (±1.5 beyond saturation)."""
        return dead_zone_interval(self.dead_zone, g, s, -1.5, 1.5)

    def state_space(self, point=None, *, cells=None, p_s: float | None = None, f_l=None):
        """Affine dynamics ẏ = A y + B u + f at an operating point (or a cell's working point).

        Parameters
        ----------
        point : mapping, optional
            State by name (missing states at their working-point value of the active cells is
            not attempted: give every state of ``state_names`` and ``u``).
        cells : (g, s, a, b, j, w), optional
            Instead of a point: the cell combination's :meth:`working_point`.

        Returns
        -------
        AffineDynamics
            A = ∂f/∂y, B = ∂f/∂u from the compiled kernel (exact inside the cells, the
            bilinear z·ΔP terms linearized at the point), f = rhs − A y − B u.
        """
        from ._model import AffineDynamics  # deferred: _model imports this module

        ps = self.supply_pressure if p_s is None else float(p_s)
        if (point is None) == (cells is None):
            raise PwaError("give exactly one of point or cells")
        pt = dict(self.working_point(cells, ps) if cells is not None else point)
        try:
            y = np.array([float(pt[n]) if n != "p_s" else ps for n in _STATE_NAMES])
            u = float(pt["u"])
        except KeyError as exc:
            raise PwaError(f"operating point needs every state and u; missing {exc}") from None
        c = self.params.cylinder
        y[4] = min(max(y[4], 1e-9 * c.stroke), c.stroke * (1 - 1e-9))  # no end stops
        f, J, G = self.point(y, u, ps, f_l)
        A = J.copy()
        B = G[:, :1].copy()
        fa = f - A @ y - B[:, 0] * u
        idx = self.cell_index(y, ps)
        wp = {n: float(v) for n, v in zip(_STATE_NAMES, y, strict=True)}
        wp.update(u=u, p_s=ps)
        return AffineDynamics(A, B, fa, idx, wp, states=_STATE_NAMES)  # type: ignore[arg-type]

    def reference_flows(self, y, p_s: float | None = None) -> tuple[float, float]:
        """The full model's metering flows (Eqs. (5)–(6)) at state y [m³/s], for comparisons."""
        ps = self._ps(p_s)
        dz = self.params.dead_zone
        z = float(_dz(float(y[0]), dz.alpha, dz.beta, dz.creep_slope, dz.outer_offset))
        f = self.params.flow
        qa, qb = orifice_flows(
            z,
            float(y[2]),
            float(y[3]),
            ps,
            self.params.supply.tank_pressure,
            f.K,
            f.transition_pressure,
        )
        return float(qa), float(qb)

    def visited_cells(self, result) -> list[ChamberCellIndex]:
        """The cell combinations a simulation of this model visits (sorted, each once).

        ``result``: a :class:`~hydropwa.SimulationResult` of a ``pwa-chamber`` model (its
        channels cell_g, cell_qa, cell_qb, cell_x, cell_w and z); pass the list to
        :func:`~._export.export_pwa` as ``cells``.
        """
        try:
            ch = result.channels
            rows = np.column_stack(
                [
                    ch["cell_g"],
                    np.where(ch["z"] >= 0.0, 1, -1),
                    ch["cell_qa"],
                    ch["cell_qb"],
                    ch["cell_x"],
                    ch["cell_w"],
                ]
            ).astype(int)
        except (AttributeError, KeyError):
            raise PwaError(
                "visited_cells needs a simulation result of a pwa-chamber model"
            ) from None
        return [ChamberCellIndex(*(int(v) for v in r)) for r in np.unique(rows, axis=0)]

    # --- export -------------------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        """The model as a JSON-ready dict (schema ``hydropwa.pwa-chamber/1``)."""
        from ._export import chamber_to_dict  # deferred: _export builds model objects

        return chamber_to_dict(self)

    def to_json(self, **kwargs) -> str:
        """JSON document of the model (cell sets; see :func:`~._export.export_pwa` for cells)."""
        return json.dumps(self.to_dict(), **kwargs)


def linearize_chamber(
    params: SystemParams,
    *,
    supply_pressure: float | None = None,
    scheduled: bool = False,
    flow_tolerance: float = FLOW_TOLERANCE,
    capacitance_tolerance: float = CAPACITANCE_TOLERANCE,
    friction_cells_n: int = 7,
    friction_range: tuple[float, float] | None = None,
) -> ChamberPwaModel:
    """Build the chamber-level PWA model (``linearize(params, form="chamber")``).

    Parameters
    ----------
    params : SystemParams
    supply_pressure : float, optional
        Fixed (nominal) P_S [Pa]; default ``params.supply.pressure``. The flow cells are
        normalised by it (their laminar band p_tr/P_S).
    scheduled : bool
        Follow the P_S(t) input online.
    flow_tolerance : float
        Bound per flow cell on |r − √q| [1] in units of √P_S (:func:`flow_cells`).
    capacitance_tolerance : float
        Bound per position cell on the relative volume error [1] (:func:`capacitance_cells`).
    friction_cells_n : int
        Friction cells (as the other forms: minimax over the machine's velocity range).
    friction_range : (float, float), optional
        Velocity range [m/s] of the friction cells; default the machine's
        (:func:`~._model.machine_velocity_range`).
    """
    from ._model import _widened, machine_velocity_range  # deferred: _model imports this module

    if not isinstance(params, SystemParams):
        raise PwaError(f"linearize needs a SystemParams, got {type(params).__name__}")
    try:
        ps = float(params.supply.pressure if supply_pressure is None else supply_pressure)
    except (TypeError, ValueError):
        raise PwaError(f"supply pressure {supply_pressure!r} is not a number in Pa") from None
    if not (math.isfinite(ps) and ps > max(0.0, params.supply.tank_pressure)):
        raise PwaError(
            f"supply pressure {ps / 1e5:g} bar must be finite and above the tank pressure"
        )
    eps = params.flow.transition_pressure / ps
    fc = flow_cells(eps, flow_tolerance)
    cap = capacitance_cells(params, capacitance_tolerance)
    if friction_range is None:
        friction_range = _widened(machine_velocity_range(params, ps, "asymmetric"))
    fr = friction_cells(params.friction, friction_cells_n, "machine", interval=friction_range)
    return ChamberPwaModel(
        params, dead_zone_cells(params.dead_zone), fc, cap, fr, bool(scheduled), ps
    )
