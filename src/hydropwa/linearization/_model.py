"""The piecewise-affine model of Sec. IV: cells, right-hand side, state-space form (23)–(28).

Load flow, two forms (docs/errata.md E7; docs/architecture_pwa.md):

``consistent`` (default)
    Q_L = z·C_q(P_L). C_q is the PWA of Ĉ_q = K√(½(P_S − sign(z)P_L)), so z·C_q already
    carries the pressure dependence of Eq. (12); its Jacobian is that of the reduced
    model at each tangent point.
``paper``
    Q_L = z·C_q(P_L) − C_qp(P_L, z)·P_L, Eq. (17) with (20), (21) as printed, where
    C_qp = |z|(k_n P_L + d_n) ≥ 0 is the PWA of Eq. (19). The pressure dependence is
    counted twice (about −50 % flow at P_L = P_S/2).

Kernel formula (both forms, c = 0 or 1)::

    z  = k_g u + d_g                        (cell g over u)
    s  = +1 if z >= 0 else −1
    p̃  = s·P_L/P_S
    C_q  = K√(P_S/2)·(k̂_o p̃ + d̂_o)          (cell o over p̃)
    C_qp = |z|·K/(4√(P_S/2))·(k̂_n p̃ + d̂_n)  (cell n over p̃)
    Q_L  = z·C_q − c·C_qp·P_L                (no factor s: ∂Q_L/∂P_L = −C_qp for both signs)
    Ṗ_L = 4E/V_t (Q_L − Ā v − C_L P_L)
    v̇   = (Ā P_L − (k_w v + d_w) − F_L + F_stop(x, v))/m   (cell w over v)
    ẋ   = v
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, ClassVar, NamedTuple

import numpy as np

from .._display import html_table
from .._errors import ParameterError, PwaError
from .._layout import I_CELLS, N_BASE, PWA_KIND, PWA_SLOT
from ..components import PiecewiseAffine
from ..components import dead_zone as _dz
from ..models import ReducedModel, pack_params
from ..models._models import SmoothModelStates
from ..params import SystemParams
from ..simulation import _kernel as K
from ._cells import (
    CQ_INTERVAL,
    CQP_INTERVAL,
    FRICTION_INTERVAL,
    cq_cells,
    cqp_cells,
    dead_zone_cells,
    dead_zone_interval,
    friction_cells,
)
from ._fit import PwaFit

__all__ = [
    "PwaModel",
    "CellIndex",
    "AffineDynamics",
    "linearize",
    "pack_pwa",
    "pwa_rhs",
    "reduced_rhs",
    "FORMS",
    "machine_velocity_range",
]

#: Load-flow forms: ``asymmetric`` (default, built on the single-rod reduced model), and the two
#: forms built on the paper's mean-area reduced model, ``consistent`` (Q_L = z·C_q) and ``paper``
#: (Eq. (17) with C_qp).
FORMS = ("asymmetric", "consistent", "paper")
KIND_PWA = K.PWA
I_SCHED, I_PSFIX, I_FORM = PWA_SLOT["sched"], PWA_SLOT["psfix"], PWA_SLOT["form"]
I_NG, I_NO, I_NN, I_NW = PWA_SLOT["ng"], PWA_SLOT["no"], PWA_SLOT["nn"], PWA_SLOT["nw"]
DEFAULT_CELLS = {"cq": 5, "cqp": 5, "friction": 7}
#: Default command range [1] of the exported polyhedra (beyond the saturation at 1.1).
INPUT_RANGE = (-1.5, 1.5)
_MODES = ("machine", "paper", "tangent", "optimized", "optimized-rms")


class CellIndex(NamedTuple):
    """Active cells: g (dead zone), s (sign of z, ±1), o (C_q), n (C_qp), w (friction)."""

    g: int
    s: int
    o: int
    n: int
    w: int


def _sign(z: float) -> int:
    return 1 if z >= 0.0 else -1


def _scaled(fit: PiecewiseAffine, scale: float, p_s: float, sign: int) -> PiecewiseAffine:
    """Normalised cells over p̃ → physical cells over P_L for one flow direction."""
    b, k, d = fit.breakpoints, fit.slopes, fit.offsets
    if sign > 0:
        return PiecewiseAffine(p_s * b, scale * k / p_s, scale * d)
    return PiecewiseAffine(-p_s * b[::-1], -scale * k[::-1] / p_s, scale * d[::-1])


@dataclass(frozen=True)
class AffineDynamics:
    """Affine dynamics ẏ = A y + B u + f of one cell (or y⁺ = A y + B u + f if ``dt``).

    Attributes
    ----------
    A : ndarray, shape (3, 3)
        State matrix for y = [P_L (Pa), v (m/s), x (m)] (units: 1/s and the ratios of the
        state units).
    B : ndarray, shape (3, 1)
        Input matrix for u [1].
    f : ndarray, shape (3,)
        Affine term [Pa/s, m/s², m/s] (or [Pa, m/s, m] per sample if discrete).
    cells : CellIndex
        Cell combination the dynamics belong to.
    point : dict
        Working point {p_l, v, x, u, p_s} (SI) at which the bilinear u·P_L term was
        linearized.
    dt : float or None
        Sample time [s] of a discretised system; None for continuous time.
    states : tuple of str
        State names in the order of A's rows: [p_l, v, x] for the load-pressure forms, the
        full model's eight states for the chamber form (``pwa-chamber``).
    """

    A: np.ndarray
    B: np.ndarray
    f: np.ndarray
    cells: CellIndex
    point: dict
    dt: float | None = None
    states: tuple[str, ...] = ("p_l", "v", "x")

    def to_statespace(self):
        """python-control ``StateSpace`` (outputs = all three states) and the constant term f.

        Returns
        -------
        sys : control.StateSpace
        f : ndarray, shape (3,)
            Add ``f`` as a constant disturbance input (the system itself is linear).
        """
        import control  # deferred: python-control loads scipy.signal and matplotlib

        n = len(self.states)
        C = np.eye(n)
        D = np.zeros((n, 1))
        names = list(self.states)
        if self.dt is None:
            sys = control.ss(self.A, self.B, C, D, inputs=["u"], outputs=names, states=names)
        else:
            sys = control.ss(
                self.A, self.B, C, D, self.dt, inputs=["u"], outputs=names, states=names
            )
        return sys, self.f.copy()

    def discretize(self, dt: float) -> AffineDynamics:
        """Zero-order-hold discretisation including the affine term.

        Uses ``scipy.signal.cont2discrete`` on the augmented input [u, 1], i.e. the matrix
        exponential of [[A, B, f], [0, 0, 0], [0, 0, 0]]·dt.
        """
        from scipy.signal import cont2discrete  # deferred: scipy.signal costs ~0.3 s

        if self.dt is not None:
            raise PwaError("these dynamics are already discrete")
        if not (isinstance(dt, int | float) and math.isfinite(dt) and dt > 0):
            raise PwaError(f"sample time {dt!r} s must be a positive number")
        Bf = np.hstack((self.B, self.f[:, None]))
        n = self.A.shape[0]
        Ad, Bd, *_ = cont2discrete(
            (self.A, Bf, np.eye(n), np.zeros((n, 2))), float(dt), method="zoh"
        )
        return AffineDynamics(
            Ad, Bd[:, :1], Bd[:, 1].copy(), self.cells, dict(self.point), float(dt), self.states
        )


@dataclass(frozen=True, eq=False)
class PwaModel(SmoothModelStates):
    """Piecewise-affine model of Sec. IV, Eqs. (16)–(28).

    Attributes
    ----------
    params : SystemParams
        Parameters it was built from (K, E, V_t, Ā, C_L, m, F_L, end stops).
    dead_zone : PiecewiseAffine
        z = k_g u + d_g over u [1], Eq. (16), Table IV.
    cq : PwaFit
        Normalised C_q cells over p̃ = sign(z)P_L/P_S approximating √(1 − p̃), Eqs. (18), (20).
    cqp : PwaFit
        Normalised C_qp cells over p̃ approximating 1/√(1 − p̃), Eqs. (19), (21).
    friction : PwaFit
        Friction cells over v [m/s] → N, Eq. (22), Table V.
    form : str
        ``asymmetric`` (default), ``consistent`` or ``paper`` (see module docstring).
    scheduled : bool
        If True the cells follow the supply-pressure input P_S(t); else P_S is fixed.
    supply_pressure : float
        Fixed P_S [Pa] (used when not scheduled, and as the default for exports).
    input_range : tuple of float
        Command range [1] that bounds the exported polyhedra.
    breakpoints : str
        How the cells were chosen (provenance).
    capacitance_position : float or None
        Rod position [m] at which the asymmetric form freezes its chamber capacitances
        (so the cells stay affine in the state); None: mid-stroke.
    """

    params: SystemParams
    dead_zone: PiecewiseAffine
    cq: PwaFit
    cqp: PwaFit
    friction: PwaFit
    form: str = "asymmetric"
    scheduled: bool = False
    supply_pressure: float = 100e5
    input_range: tuple[float, float] = INPUT_RANGE
    breakpoints: str = "paper"
    capacitance_position: float | None = None
    kind = KIND_PWA
    name: ClassVar[str] = PWA_KIND.name
    state_names: tuple[str, ...] = field(default=("p_l", "v", "x"), init=False)

    def __post_init__(self) -> None:
        if self.form not in FORMS:
            raise PwaError(f"form {self.form!r} must be one of {', '.join(FORMS)}")
        if not isinstance(self.params, SystemParams):
            raise PwaError(f"PwaModel needs a SystemParams, got {type(self.params).__name__}")
        _check_supply(self.supply_pressure, self.params, self.form)
        xc = self.capacitance_position
        if xc is not None and not (
            isinstance(xc, int | float) and 0.0 <= xc <= self.params.cylinder.stroke
        ):
            raise PwaError(
                f"capacitance position {xc!r} m must lie within the stroke 0 … {self.params.cylinder.stroke:g} m"
            )

    # --- equality (arrays inside) -------------------------------------------------------
    def __eq__(self, other: object) -> bool:
        if not isinstance(other, PwaModel):
            return NotImplemented
        return self.to_json() == other.to_json()

    __hash__ = None  # type: ignore[assignment]

    def __repr__(self) -> str:
        sched = "scheduled" if self.scheduled else f"P_S={self.supply_pressure / 1e5:.4g} bar"
        cells = f"{self.dead_zone.slopes.size}/{self.cq.n_cells}/{self.cqp.n_cells}/{self.friction.n_cells}"
        return f"PwaModel(form={self.form!r}, {sched}, cells g/o/n/w={cells})"

    def _repr_html_(self) -> str:
        rows = [
            ("dead zone (16), Table IV", "u [1]", self.dead_zone.slopes.size, "exact"),
            (
                "C_q (18), (20)",
                "p̃ = sign(z)P_L/P_S",
                self.cq.n_cells,
                f"max error {self.cq.max_error:.3g}",
            ),
            ("C_qp (19), (21)", "p̃", self.cqp.n_cells, f"max error {self.cqp.max_error:.3g}"),
            (
                "friction (22), Table V",
                "v [m/s]",
                self.friction.n_cells,
                f"max error {self.friction.max_error:.3g} N",
            ),
        ]
        sched = "scheduled on P_S(t)" if self.scheduled else "fixed P_S"
        title = f"PwaModel: form {self.form}, {sched}, P_S = {self.supply_pressure / 1e5:.4g} bar"
        return html_table(title, ("cell set", "variable", "cells", "fit"), rows)

    # --- protocol of hydropwa.models ----------------------------------------------------
    @property
    def reduced(self) -> ReducedModel:
        """The reduced model this PWA model linearizes (its form: asymmetric or paper)."""
        return ReducedModel(self.params, "asymmetric" if self.form == "asymmetric" else "paper")

    @property
    def smooth(self) -> ReducedModel:
        """The reduced model: its states [P_L, v, x], scales and rest (A·P_L = F_L)."""
        return self.reduced

    @property
    def area_ratio(self) -> float:
        """α [1] of the state P_L = P_A − α P_B."""
        return self.reduced.area_ratio

    @property
    def force_area(self) -> float:
        """Area [m²] that turns P_L into force (A_A, or Ā for the mean-area forms)."""
        return self.reduced.force_area

    @property
    def x_capacitance(self) -> float:
        """Rod position [m] of the frozen chamber capacitances (asymmetric form)."""
        c = self.params.cylinder
        return (
            0.5 * c.stroke
            if self.capacitance_position is None
            else float(self.capacitance_position)
        )

    def pack(self, command_amplitude: float = 0.0) -> np.ndarray:
        """Kernel parameter vector (base layout of ``hydropwa.models.pack_params`` + PWA cells)."""
        return pack_pwa(self)

    def state_from_measurement(
        self, measured: Mapping[str, float], /, *positional: float
    ) -> np.ndarray:
        """Initial state [P_A − α P_B, v, x] from measured channels (name → value [SI]), as
        the reduced model's."""
        return self.reduced.state_from_measurement(measured, *positional)

    def edge_pressure(self, p_s: float, sign: int) -> tuple[float, float]:
        """(P_e [Pa], flow scale √(P_e/(1 + α³)) [√Pa]) of flow direction ``sign`` at P_S.

        p̃ = sign·P_L/P_e normalises the C_q cells; P_e = P_S − α P_T (extension) or
        α P_S − P_T (retraction) in the asymmetric form, P_S in the mean-area forms.
        """
        if self.form != "asymmetric":
            return float(p_s), math.sqrt(0.5 * p_s)
        al = self.area_ratio
        pt = self.params.supply.tank_pressure
        pe = p_s - al * pt if sign > 0 else al * p_s - pt
        return float(pe), math.sqrt(pe / (1.0 + al**3))

    # --- cells --------------------------------------------------------------------------
    def _ps(self, p_s: float | None) -> float:
        if p_s is None or not self.scheduled:
            return self.supply_pressure if p_s is None else float(p_s)
        return float(p_s)

    def cells_at(self, p_s: float | None = None, sign: int = 1) -> dict[str, PiecewiseAffine]:
        """Physical cells at supply pressure ``p_s`` [Pa] for flow direction ``sign``.

        Returns
        -------
        dict
            ``dead_zone`` (u → z [1]), ``cq`` (P_L [Pa] → C_q [m³/s], k_o [m³/(s·Pa)],
            d_o [m³/s]; Tables VI–VII for sign +1), ``cqp`` (P_L → C_qp/|z| [m³/(s·Pa)],
            k_n [m³/(s·Pa²)], d_n [m³/(s·Pa)]; Tables VIII–IX), ``friction`` (v [m/s] → N).
        """
        ps = self.supply_pressure if p_s is None else float(p_s)
        _check_supply(ps, self.params, self.form)
        Kv = self.params.flow.K
        pe, root = self.edge_pressure(ps, sign)
        return {
            "dead_zone": self.dead_zone,
            "cq": _scaled(self.cq.pwa, Kv * root, pe, sign),
            "cqp": _scaled(self.cqp.pwa, Kv / (4.0 * root), pe, sign),
            "friction": self.friction.pwa,
        }

    def cell_index(self, p_l: float, v: float, u: float, p_s: float | None = None) -> CellIndex:
        """Active cells at state (P_L [Pa], v [m/s]) and command u [1]."""
        ps = self._ps(p_s)
        g = int(self.dead_zone.cell(u))
        z = self.dead_zone.slopes[g] * u + self.dead_zone.offsets[g]
        s = _sign(z)
        pn = s * p_l / self.edge_pressure(ps, s)[0]
        return CellIndex(
            g,
            s,
            int(self.cq.pwa.cell(pn)),
            int(self.cqp.pwa.cell(pn)),
            int(self.friction.pwa.cell(v)),
        )

    def _kernel_point(self, y, u: float, ps: float, fl: float):
        """(f, ∂f/∂y, ∂f/∂(u, P_S, F_L)) from the compiled kernel, the one assembly."""
        return K.point_derivatives(
            K.PWA, np.asarray(y, dtype=float), u, ps, fl, self._packed_fixed(ps)
        )

    def _packed_fixed(self, ps: float) -> np.ndarray:
        """Packed vector with the cells fixed at P_S = ``ps`` (not scheduled); memoised per P_S."""
        cache = self.__dict__.setdefault("_packed_cache", {})
        p = cache.get(ps)
        if p is None:
            p = pack_pwa(self).copy()
            p[I_SCHED] = 0.0
            p[I_PSFIX] = ps
            if len(cache) > 64:
                cache.clear()
            cache[ps] = p
        return p

    def load_flow(self, p_l: float, u: float, p_s: float | None = None) -> float:
        """PWA load flow Q_L [m³/s] (see module docstring), evaluated by the kernel."""
        ps = self._ps(p_s)
        return float(K.pwa_load_flow_at(float(p_l), float(u), ps, self._packed_fixed(ps)))

    # --- dynamics -----------------------------------------------------------------------
    def rhs(
        self, t: float, y, u: float, p_s: float | None = None, f_l: float | None = None
    ) -> np.ndarray:
        """Right-hand side [Ṗ_L, v̇, ẋ]; see :func:`pwa_rhs`."""
        return pwa_rhs(t, y, u, p_s, f_l, self)

    def cell_box(self, cells: CellIndex, p_s: float | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Bounds [P_L, v, x, u] (SI) of the region of cell combination ``cells`` (see :meth:`regions`)."""
        ps = self.supply_pressure if p_s is None else float(p_s)
        want = tuple(cells)
        for idx, lo, hi in self.regions(ps):
            if idx == want or (
                self.form != "paper"
                and (idx.g, idx.s, idx.o, idx.w) == (want[0], want[1], want[2], want[4])
            ):
                return lo, hi
        raise PwaError(f"cell combination {want} is empty at P_S = {ps / 1e5:g} bar")

    def _row0_polynomial(
        self, cells: CellIndex, ps: float, fl: float, box=None
    ) -> tuple[np.ndarray, float]:
        """Exact polynomial of Ṗ_L inside a cell: Σ a_ij P_L^i u^j (i ≤ 2, j ≤ 1) + a_v·v.

        Inside one cell the PWA right-hand side is bilinear in (P_L, u) (quadratic in P_L in
        the paper form, Eq. (17)) and linear in v; the six coefficients are read off the
        kernel at six points of the cell (an exact fit up to rounding). Returns the 3×2
        array a[i, j] and a_v.
        """
        lo, hi = self.cell_box(cells, ps) if box is None else box
        x = self.x_capacitance
        quad = self.form == "paper"
        fps = (0.2, 0.5, 0.8) if quad else (0.25, 0.75)
        pc, ph = 0.5 * (lo[0] + hi[0]), max(0.5 * (hi[0] - lo[0]), 1.0)
        v = 0.5 * (lo[1] + hi[1])
        M, r = [], []
        a_v = 0.0
        for fp in fps:
            for fu in (0.25, 0.75):
                P, u = lo[0] + fp * (hi[0] - lo[0]), lo[3] + fu * (hi[3] - lo[3])
                f, J, _G = self._kernel_point((P, v, x), u, ps, fl)
                t = (P - pc) / ph  # scaled pressure: a well-conditioned fit
                M.append([1.0, t, u, u * t] + ([t * t, u * t * t] if quad else []))
                r.append(f[0] - J[0, 1] * v)
                a_v = J[0, 1]
        c = np.linalg.solve(np.array(M), np.array(r))
        b2 = (c[4], c[5]) if quad else (0.0, 0.0)
        a = np.zeros((3, 2))
        for j, (b0, b1, bq) in enumerate(((c[0], c[1], b2[0]), (c[2], c[3], b2[1]))):
            a[2, j] = bq / ph**2
            a[1, j] = b1 / ph - 2.0 * bq * pc / ph**2
            a[0, j] = b0 - b1 * pc / ph + bq * pc**2 / ph**2
        return a, float(a_v)

    def matrices(
        self, p_l: float, v: float, u: float, p_s: float | None = None, f_l: float | None = None
    ):
        """A(x), b(x), f of Eq. (23) for state x = [P_L, ẋ] in the active cells, exact in the cell.

        Returns
        -------
        A : ndarray (2, 2), b : ndarray (2,), f : ndarray (2,)
            ẋ = A(x) x + b(x) u + f reproduces :func:`pwa_rhs` (without end stops); f is
            constant in the cell, A(x) and b(x) carry the bilinear u·P_L (and, in the paper
            form, the P_L² of Eq. (17)) terms. Derived from the kernel (docs/reduced_asymmetric.md gives
            the closed forms; the printed (25)–(27) differ as documented in docs/errata.md).
        """
        ps = self._ps(p_s)
        fl = self.params.load.force if f_l is None else float(f_l)
        idx = self.cell_index(p_l, v, u, ps)
        a, a_v = self._row0_polynomial(idx, ps, fl)
        y = np.array([p_l, v, self.x_capacitance])
        f_k, J, _G = self._kernel_point(y, u, ps, fl)
        A = np.array([[a[1, 0] + a[2, 0] * p_l, a_v], [J[1, 0], J[1, 1]]])
        b = np.array([a[0, 1] + a[1, 1] * p_l + a[2, 1] * p_l * p_l, 0.0])
        f = np.array([a[0, 0], f_k[1] - J[1, 0] * p_l - J[1, 1] * v])
        return A, b, f

    def state_space(
        self,
        point: Mapping[str, float] | None = None,
        *,
        cells: CellIndex | tuple | None = None,
        p_s: float | None = None,
        f_l: float | None = None,
    ) -> AffineDynamics:
        """Affine dynamics of the cell at an operating point, linearized in the bilinear u·P_L term.

        Parameters
        ----------
        point : mapping, optional
            Operating point {"p_l": Pa, "v": m/s, "u": 1, "x": m (optional)}.
        cells : CellIndex or (g, s, o, w), optional
            Instead of a point: the cell combination; its working point is the cell
            working points (tangent points, or centres clipped to the fit ranges).
        p_s : float, optional
            Supply pressure [Pa]; default the model's fixed P_S.
        f_l : float, optional
            Load force [N]; default ``params.load.force``.

        Returns
        -------
        AffineDynamics
            A = ∂f/∂y, B = ∂f/∂u from the compiled kernel at the point (exact inside the
            cell, end stops excluded), f = rhs − A y − B u there.
        """
        ps = self.supply_pressure if p_s is None else float(p_s)
        if (point is None) == (cells is None):
            raise PwaError("give exactly one of point or cells")
        if cells is not None:
            point = self.working_point(cells, ps)
        pt = dict(point)  # type: ignore[arg-type]
        try:
            p_l, v, u = float(pt["p_l"]), float(pt["v"]), float(pt["u"])
        except KeyError as exc:
            raise PwaError(
                f"operating point needs p_l [Pa], v [m/s] and u [1]; missing {exc}"
            ) from None
        x = float(pt.get("x", self.x_capacitance))
        c = self.params.cylinder
        x_in = min(
            max(x, 1e-9 * c.stroke), c.stroke * (1 - 1e-9)
        )  # end stops are not part of the export
        fl = self.params.load.force if f_l is None else float(f_l)
        y = np.array([p_l, v, x_in])
        f_k, J, G = self._kernel_point(y, u, ps, fl)
        A = J.copy()
        B = G[:, :1].copy()
        f = f_k - A @ y - B[:, 0] * u
        idx = self.cell_index(p_l, v, u, ps)
        return AffineDynamics(A, B, f, idx, {"p_l": p_l, "v": v, "x": x_in, "u": u, "p_s": ps})

    def error_bound(
        self,
        cells: CellIndex,
        dyn: AffineDynamics,
        lower=None,
        upper=None,
        f_l: float | None = None,
        polynomial=None,
    ) -> float:
        """Guaranteed bound [Pa/s] of |Ṗ_L(PWA) − (A y + B u + f)₀| over a cell's box.

        The other rows are affine inside a cell and exact. In Ṗ_L the error of the tangent
        plane is e(P_L, u) = poly − tangent, linear in u for fixed P_L and at most
        quadratic in P_L for fixed u, so its extremes over the box lie at the u-edges, at
        the P_L-edges or at the vertex of the parabola: all of them are evaluated (no
        sampling). ``lower``/``upper`` [P_L, v, x, u] restrict the box (default the cell's);
        ``polynomial`` is the cell's ``_row0_polynomial`` if already known.
        """
        ps = float(dyn.point["p_s"])
        fl = self.params.load.force if f_l is None else float(f_l)
        lo, hi = self.cell_box(cells, ps)
        if lower is not None:
            lo, hi = np.asarray(lower, float), np.asarray(upper, float)
        a, a_v = self._row0_polynomial(cells, ps, fl) if polynomial is None else polynomial
        A0, B0, f0 = dyn.A[0], float(dyn.B[0, 0]), float(dyn.f[0])

        def err(P, u, v, x):  # PWA Ṗ_L minus the exported affine row, exact inside the cell
            poly = (
                a[0, 0]
                + a[1, 0] * P
                + a[2, 0] * P * P
                + u * (a[0, 1] + a[1, 1] * P + a[2, 1] * P * P)
            )
            return poly + a_v * v - (A0[0] * P + A0[1] * v + A0[2] * x + B0 * u + f0)

        worst = 0.0
        # e is linear in u, v and x and at most quadratic in P_L: extremes at the edges in u, v,
        # x, and in P_L at the edges or the vertex of the parabola
        for u in (lo[3], hi[3]):
            cands = [lo[0], hi[0]]
            q2 = a[2, 0] + u * a[2, 1]
            if q2 != 0.0:
                pv = -(a[1, 0] + u * a[1, 1] - A0[0]) / (2.0 * q2)
                if lo[0] < pv < hi[0]:
                    cands.append(pv)
            for P in cands:
                for v in (lo[1], hi[1]):
                    for x in (lo[2], hi[2]):
                        worst = max(worst, abs(err(P, u, v, x)))
        scale = max(
            abs(f0),
            abs(A0[0]) * max(abs(lo[0]), abs(hi[0])),
            abs(B0) * max(abs(lo[3]), abs(hi[3])),
            abs(a_v) * max(abs(lo[1]), abs(hi[1])),
        )
        return float(worst + 1e-9 * scale)  # rounding margin of the coefficient fit

    def working_point(self, cells, p_s: float | None = None) -> dict[str, float]:
        """Working point {p_l, v, x, u} [SI] of a cell combination (g, s, o, [n,] w)."""
        ps = self.supply_pressure if p_s is None else float(p_s)
        cells = tuple(int(i) for i in cells)
        if len(cells) == 4:
            g, s, o, w = cells
        elif len(cells) == 5:
            g, s, o, _n, w = cells
        else:
            raise PwaError(f"cell combination {cells} must be (g, s, o, w) or (g, s, o, n, w)")
        for name, i, n in (
            ("g", g, self.dead_zone.n_cells),
            ("o", o, self.cq.n_cells),
            ("w", w, self.friction.n_cells),
        ):
            if not 0 <= i < n:
                raise PwaError(f"cell index {name} = {i} outside 0..{n - 1}")
        u = float(self._input_cell_point(g, s))
        pe = self.edge_pressure(ps, s)[0]
        return {
            "p_l": float(s * pe * self.cq.working_points[o]),
            "v": float(self.friction.working_points[w]),
            "x": self.x_capacitance,
            "u": u,
        }

    def _input_cell_point(self, g: int, s: int) -> float:
        lo, hi = self._input_bounds(g, s)
        return 0.5 * (lo + hi)

    def _input_bounds(self, g: int, s: int) -> tuple[float, float]:
        """Command interval of dead-zone cell g restricted to sign(z) = s (splits the creep cell)."""
        return dead_zone_interval(self.dead_zone, g, s, *self.input_range)

    def regions(self, p_s: float | None = None) -> list[tuple[CellIndex, np.ndarray, np.ndarray]]:
        """All non-empty cell combinations as boxes over [P_L, v, x, u].

        Returns
        -------
        list of (CellIndex, lower, upper)
            Bounds [Pa, m/s, m, 1]; the outer cells are clipped to the fit ranges
            (|P_L| <= P_S·max|p̃|, v in the friction interval, 0 <= x <= l, u in input_range).
        """
        ps = self.supply_pressure if p_s is None else float(p_s)
        out = []
        span = max(abs(self.cq.interval[0]), abs(self.cq.interval[1]))
        vlo, vhi = self.friction.interval
        bw = np.concatenate(([vlo], np.clip(self.friction.pwa.breakpoints, vlo, vhi), [vhi]))
        paper = self.form == "paper"
        for g in range(self.dead_zone.n_cells):
            for s in (1, -1):
                ulo, uhi = self._input_bounds(g, s)
                z_mid = self.dead_zone.slopes[g] * 0.5 * (ulo + uhi) + self.dead_zone.offsets[g]
                if uhi <= ulo or _sign(z_mid) != s:
                    continue
                pe = self.edge_pressure(ps, s)[0]
                bo = _pressure_edges(self.cq.pwa, pe, s, pe * span)
                bn = _pressure_edges(self.cqp.pwa, pe, s, pe * span) if paper else None
                for o in range(self.cq.n_cells):
                    ns = (
                        range(self.cqp.n_cells)
                        if paper
                        else (int(self.cqp.pwa.cell(s * _mid(bo, o, s) / pe)),)
                    )
                    for n in ns:
                        plo, phi = bo[o]
                        if bn is not None:  # the paper form: C_qp cells of their own
                            plo, phi = max(plo, bn[n][0]), min(phi, bn[n][1])
                        if phi <= plo:
                            continue
                        for w in range(self.friction.n_cells):
                            if bw[w + 1] <= bw[w]:
                                continue
                            lower = np.array([plo, bw[w], 0.0, ulo])
                            upper = np.array([phi, bw[w + 1], self.params.cylinder.stroke, uhi])
                            out.append((CellIndex(g, s, o, n, w), lower, upper))
        return out

    # --- export -------------------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        """The model as a JSON-ready dict (parameters, cell sets, flags); see :mod:`._export`."""
        # deferred: import cycle, _export builds PwaModel objects (the file format lives there)
        from ._export import model_to_dict

        return model_to_dict(self)

    def to_json(self, **kwargs) -> str:
        """JSON document of the model (schema ``hydropwa.pwa/1``); see :func:`from_json`."""
        return json.dumps(self.to_dict(), **kwargs)

    @classmethod
    def from_json(cls, text: str) -> PwaModel:
        """Model from :meth:`to_json` or :func:`export_pwa` output; PwaError on schema mismatch."""
        try:
            data = json.loads(text)
        except json.JSONDecodeError as exc:
            raise PwaError(
                f"PWA document is not valid JSON: {exc.msg} at line {exc.lineno}"
            ) from None
        # deferred: import cycle, _export builds PwaModel objects (the file format lives there)
        from ._export import model_from_dict

        return model_from_dict(data)


def _mid(edges, o, s):
    lo, hi = edges[o]
    return 0.5 * (lo + hi)


def _pressure_edges(
    pwa: PiecewiseAffine, ps: float, s: int, pmax: float
) -> list[tuple[float, float]]:
    """P_L interval [Pa] of each normalised cell for flow direction s, clipped to ±pmax."""
    b = np.concatenate(([-np.inf], pwa.breakpoints, [np.inf]))
    out = []
    for i in range(pwa.n_cells):
        lo, hi = (ps * b[i], ps * b[i + 1]) if s > 0 else (-ps * b[i + 1], -ps * b[i])
        out.append((float(max(lo, -pmax)), float(min(hi, pmax))))
    return out


def _check_supply(p_s, params: SystemParams, form: str = "asymmetric") -> float:
    try:
        ps = float(p_s)
    except (TypeError, ValueError):
        raise PwaError(f"supply pressure {p_s!r} is not a number in Pa") from None
    if not math.isfinite(ps) or ps <= max(0.0, params.supply.tank_pressure):
        raise PwaError(
            f"supply pressure {ps / 1e5:g} bar must be finite and above the tank pressure"
        )
    area = params.cylinder.area_a if form == "asymmetric" else params.cylinder.mean_area
    p_load = abs(params.load.force) / area
    if p_load >= ps:
        raise PwaError(
            f"supply pressure {ps / 1e5:g} bar is below the load pressure F_L/A = {p_load / 1e5:g} bar "
            "needed to hold the load; raise the supply pressure"
        )
    return ps


def _parse_cells(cells) -> dict[str, int]:
    out = dict(DEFAULT_CELLS)
    if cells is None:
        return out
    if not isinstance(cells, Mapping):
        raise PwaError(
            f"cells {cells!r} must be a mapping like {{'cq': 5, 'cqp': 5, 'friction': 7}}"
        )
    for key, n in cells.items():
        if key not in DEFAULT_CELLS:
            raise PwaError(f"unknown cell set {key!r}; choose from {', '.join(DEFAULT_CELLS)}")
        if isinstance(n, bool) or not isinstance(n, int | np.integer) or n < 1:
            raise PwaError(f"number of {key} cells {n!r} must be a positive integer")
        out[key] = int(n)
    return out


def _spec(breakpoints, key: str):
    """(mode, explicit breakpoints or None) for one cell set."""
    if isinstance(breakpoints, str):
        if breakpoints not in _MODES:
            raise PwaError(
                f"breakpoints {breakpoints!r} must be one of {', '.join(_MODES)} or a mapping"
            )
        if breakpoints == "machine":  # cells over the machine's own operating range
            # C_q/C_qp cells live in p̃ = P_L/P_e, already scaled to the machine's pressures:
            # the tangent cells of Tables VI–IX serve every machine
            return ("machine" if key == "friction" else "paper"), None
        return breakpoints, None
    if isinstance(breakpoints, Mapping):
        unknown = set(breakpoints) - set(DEFAULT_CELLS)
        if unknown:
            raise PwaError(
                f"unknown cell set(s) {sorted(unknown)} in breakpoints; choose from {', '.join(DEFAULT_CELLS)}"
            )
        v = breakpoints.get(key, "paper")
        if isinstance(v, str):
            return _spec(v, key)
        return "given", np.asarray(v, dtype=float)
    raise PwaError(
        f"breakpoints {breakpoints!r} must be a mode name or a mapping of cell set to breakpoints"
    )


def linearize(
    params: SystemParams,
    *,
    supply_pressure: float | None = None,
    cells: Mapping[str, int] | None = None,
    breakpoints: str | Mapping[str, Any] = "machine",
    form: str = "asymmetric",
    scheduled: bool = False,
    working_points: Mapping[str, Any] | None = None,
    load_pressure_range: tuple[float, float] | None = None,
    friction_range: tuple[float, float] | None = None,
    capacitance_position: float | None = None,
    tolerances: Mapping[str, float] | None = None,
) -> Any:
    """Build the piecewise-affine model of Sec. IV from a parameter set.

    Parameters
    ----------
    params : SystemParams
        Parameters (dead zone, K, cylinder, oil, friction, load, supply).
    supply_pressure : float, optional
        Fixed P_S [Pa] (the paper's average); default ``params.supply.pressure``.
    cells : mapping, optional
        Cell counts {"cq": 5, "cqp": 5, "friction": 7}; the dead zone has 5 cells.
    breakpoints : str or mapping
        ``machine`` (default: minimax-optimal cells, the friction cells over the machine's
        own velocity range, see :func:`machine_velocity_range`), ``paper`` (tangents at the
        recovered working points for C_q/C_qp, Table V's breakpoints for friction over
        ±0.2 m/s), ``tangent`` (tangents at ``working_points``),
        ``optimized`` (minimax-optimal breakpoints), ``optimized-rms``, or a mapping
        {cell set: mode or breakpoints}; C_q/C_qp breakpoints are in p̃ = P_L/P_S [1],
        friction breakpoints in m/s.
    form : {"asymmetric", "consistent", "paper", "chamber"}
        Load-flow form (see the module docstring): the single-rod model (default) or the
        paper's mean-area model with Q_L = z·C_q or Eq. (17) as printed; ``chamber``: the
        chamber-level model (:class:`~._chamber.ChamberPwaModel`, model name ``pwa-chamber``:
        spool, P_A, P_B, x, ẋ; cells refined until their error bounds meet ``tolerances``).
    scheduled : bool
        Follow the P_S(t) input (cells rescaled online at no cost) instead of a fixed P_S.
    working_points : mapping, optional
        Tangent points for ``tangent`` mode: {"cq": p̃ [1], "cqp": p̃ [1], "friction": m/s}.
    load_pressure_range : (float, float), optional
        P_L range [Pa] the cells must cover; must lie within ±P_S. Default ±P_S.
    friction_range : (float, float), optional
        Velocity range [m/s] of the friction fit; default the machine's range
        (:func:`machine_velocity_range`) widened to the next step of a 5 % grid, so that
        linearizations at nearby supply pressures share their (cached) friction cells; or
        ±0.2 m/s (Table V) with ``breakpoints="paper"``.
    capacitance_position : float, optional
        Rod position [m] at which the asymmetric form freezes the chamber capacitances;
        default mid-stroke.
    tolerances : mapping, optional
        Chamber form only: {"flow": bound [1] on the normalised metering-flow error,
        "capacitance": bound [1] on the relative chamber-volume error}; defaults
        :data:`~._chamber.FLOW_TOLERANCE`, :data:`~._chamber.CAPACITANCE_TOLERANCE`.

    Returns
    -------
    PwaModel or ChamberPwaModel

    Raises
    ------
    PwaError
        Bad cell counts, breakpoints, supply pressure below the load-pressure range, form.
    """
    if form == CHAMBER_FORM:
        return _linearize_chamber_form(
            params,
            supply_pressure=supply_pressure,
            cells=cells,
            breakpoints=breakpoints,
            scheduled=scheduled,
            working_points=working_points,
            load_pressure_range=load_pressure_range,
            friction_range=friction_range,
            capacitance_position=capacitance_position,
            tolerances=tolerances,
        )
    if tolerances is not None:
        raise PwaError("tolerances belong to the chamber form; pass form='chamber'")
    if not isinstance(params, SystemParams):
        raise PwaError(f"linearize needs a SystemParams, got {type(params).__name__}")
    if form not in FORMS:
        raise PwaError(f"form {form!r} must be one of {', '.join(FORMS + (CHAMBER_FORM,))}")
    ps = _check_supply(
        params.supply.pressure if supply_pressure is None else supply_pressure, params, form
    )
    n = _parse_cells(cells)
    _check_capacitance_position(capacitance_position, params)
    if friction_range is None:
        friction_range = _default_friction_range(breakpoints, params, ps, form)
    wp = dict(working_points or {})
    cq_int, cqp_int = _pressure_intervals(load_pressure_range, ps)
    mode, b = _spec(breakpoints, "cq")
    cq = cq_cells(n["cq"], mode, interval=cq_int, breakpoints=b, working_points=wp.get("cq"))
    mode, b = _spec(breakpoints, "cqp")
    cqp = cqp_cells(n["cqp"], mode, interval=cqp_int, breakpoints=b, working_points=wp.get("cqp"))
    mode, b = _spec(breakpoints, "friction")
    fr = friction_cells(
        params.friction,
        n["friction"],
        mode,
        interval=friction_range,
        breakpoints=b,
        working_points=wp.get("friction"),
    )
    return PwaModel(
        params,
        dead_zone_cells(params.dead_zone),
        cq,
        cqp,
        fr,
        form,
        bool(scheduled),
        ps,
        INPUT_RANGE,
        _breakpoints_label(breakpoints),
        capacitance_position,
    )


def _check_capacitance_position(capacitance_position: float | None, params: SystemParams) -> None:
    """PwaError unless the position is None or lies within the stroke."""
    if capacitance_position is not None:
        xc = float(capacitance_position)
        if not (math.isfinite(xc) and 0.0 <= xc <= params.cylinder.stroke):
            raise PwaError(
                f"capacitance position {xc:g} m must lie within the stroke 0 … {params.cylinder.stroke:g} m"
            )


def _default_friction_range(
    breakpoints, params: SystemParams, ps: float, form: str
) -> tuple[float, float]:
    """The friction fit's velocity range [m/s] when none is given: Table V's ±0.2 m/s for
    paper friction cells, else the machine's range widened to the 5 % grid."""
    fr_mode = (
        breakpoints
        if isinstance(breakpoints, str)
        else breakpoints.get("friction", "paper")
        if isinstance(breakpoints, Mapping)
        else None
    )
    return (
        FRICTION_INTERVAL
        if fr_mode == "paper"
        else _widened(machine_velocity_range(params, ps, form))
    )


def _pressure_intervals(
    load_pressure_range, ps: float
) -> tuple[tuple[float, float], tuple[float, float]]:
    """The C_q and C_qp fit intervals in p̃ = P_L/P_S [1] that cover ``load_pressure_range``
    [Pa] (checked: two numbers, lo < hi, within ±P_S); the defaults when it is None."""
    if load_pressure_range is None:
        return CQ_INTERVAL, CQP_INTERVAL
    try:
        lo, hi = (float(v) for v in load_pressure_range)
    except (TypeError, ValueError):
        raise PwaError(
            f"load pressure range {load_pressure_range!r} must be two numbers in Pa"
        ) from None
    if not lo < hi:
        raise PwaError(f"load pressure range ({lo:g}, {hi:g}) Pa must have lo < hi")
    m = max(abs(lo), abs(hi))
    if m > ps:
        raise PwaError(
            f"supply pressure {ps / 1e5:g} bar is below the load-pressure range up to {m / 1e5:g} bar; "
            "raise the supply pressure or narrow the range"
        )
    r = m / ps
    return (-r, r), (-r, min(r, CQP_INTERVAL[1]))


def _breakpoints_label(breakpoints) -> str:
    """The model's label of its breakpoints: the mode name, or the mapping as JSON."""
    return (
        breakpoints
        if isinstance(breakpoints, str)
        else json.dumps(
            {
                k: (v if isinstance(v, str) else np.asarray(v, float).tolist())
                for k, v in breakpoints.items()
            }
        )
    )


#: The ``form`` of :func:`linearize` that builds the chamber-level model (``pwa-chamber``).
CHAMBER_FORM = "chamber"


def _linearize_chamber_form(
    params,
    *,
    supply_pressure,
    cells,
    breakpoints,
    scheduled,
    working_points,
    load_pressure_range,
    friction_range,
    capacitance_position,
    tolerances,
):
    """:func:`linearize` with ``form="chamber"``: the arguments that apply, checked."""
    from ._chamber import linearize_chamber  # deferred: _chamber imports this module

    for name, value in (
        ("working_points", working_points),
        ("load_pressure_range", load_pressure_range),
        ("capacitance_position", capacitance_position),
    ):
        if value is not None:
            raise PwaError(
                f"{name} does not apply to the chamber form (its cells follow error bounds)"
            )
    if breakpoints != "machine":
        raise PwaError("the chamber form's cells follow error bounds; leave breakpoints='machine'")
    n_w = 7
    if cells is not None:
        if not isinstance(cells, Mapping) or set(cells) - {"friction"}:
            raise PwaError(
                "the chamber form takes only {'friction': n} as cells; its flow and "
                "capacitance cells follow tolerances={'flow': ..., 'capacitance': ...}"
            )
        n_w = _parse_cells(cells)["friction"]
    tol = dict(tolerances or {})
    unknown = set(tol) - {"flow", "capacitance"}
    if unknown:
        raise PwaError(f"unknown tolerance(s) {sorted(unknown)}; choose flow, capacitance")
    kw = {f"{k}_tolerance": float(v) for k, v in tol.items()}
    return linearize_chamber(
        params,
        supply_pressure=supply_pressure,
        scheduled=scheduled,
        friction_cells_n=n_w,
        friction_range=friction_range,
        **kw,
    )


#: Steps per decade of the grid the default friction range is widened to (10^(1/48) ≈ 1.049).
_RANGE_STEPS = 48


def _widened(interval: tuple[float, float]) -> tuple[float, float]:
    """``interval`` (lo < 0 < hi) with each end moved outward to the next 5 % grid point."""

    def out(v: float) -> float:
        if v == 0.0 or not math.isfinite(v):
            return v
        k = math.ceil(round(math.log10(abs(v)) * _RANGE_STEPS, 9))
        return math.copysign(10.0 ** (k / _RANGE_STEPS), v)

    return (out(interval[0]), out(interval[1]))


def machine_velocity_range(
    params: SystemParams, supply_pressure: float | None = None, form: str = "asymmetric"
) -> tuple[float, float]:
    """Rod velocity range [m/s] the machine reaches: no-load speeds at full opening.

    v = z_max K √Δp / A with the edge drop Δp of the reduced model at P_L = 0 (the valve's
    flow at P_S): extension P_e/(1 + α³) with P_e = P_S − α P_T over A_A, retraction
    (α P_S − P_T)/(1 + α³) over A_A (mean-area forms: ½ P_S over Ā). z_max is the saturated
    opening of the dead zone. The friction cells are fitted over this range by default.
    """
    ps = params.supply.pressure if supply_pressure is None else float(supply_pressure)
    dz = params.dead_zone
    zmax = float(_dz(INPUT_RANGE[1], dz.alpha, dz.beta, dz.creep_slope, dz.outer_offset))
    c = params.cylinder
    Kv = params.flow.K
    if form == "asymmetric":
        al, pt = c.area_b / c.area_a, params.supply.tank_pressure
        a3 = 1.0 + al**3
        v_ext = zmax * Kv * math.sqrt(max(ps - al * pt, 0.0) / a3) / c.area_a
        v_ret = zmax * Kv * math.sqrt(max(al * ps - pt, 0.0) / a3) / c.area_a
    else:
        v_ext = v_ret = zmax * Kv * math.sqrt(0.5 * ps) / c.mean_area
    return (-float(v_ret), float(v_ext))


def pack_pwa(model: PwaModel) -> np.ndarray:
    """Packed float64 parameter vector of the PWA model for the compiled kernel (kind 2).

    Layout, by the names of the one table ``hydropwa._layout`` (its numbers move when a slot
    is added, so none is written here): ``p[:N_BASE]`` = ``hydropwa.models.pack_params``;
    ``p[PWA_SLOT["sched"]]`` the scheduled flag; ``p[PWA_SLOT["psfix"]]`` the fixed P_S [Pa];
    ``p[PWA_SLOT["form"]]`` the paper-form flag c; ``p[PWA_SLOT["ng"] … PWA_SLOT["nw"]]`` the
    cell counts n_g, n_o, n_n, n_w; zeros up to ``I_CELLS``; from ``p[I_CELLS]``, for the dead
    zone (over u), C_q (over p̃), C_qp (over p̃) and friction (over v) in turn: n−1
    breakpoints, n slopes, n offsets (normalised k̂, d̂ for C_q and C_qp).
    """
    asym = model.form == "asymmetric"
    base = pack_params(
        model.params,
        form="asymmetric" if asym else "paper",
        capacitance_position=model.x_capacitance if asym else None,
    )
    if base.size != N_BASE:
        raise PwaError(
            f"base parameter vector has {base.size} entries, the PWA layout expects {N_BASE}"
        )
    sets = (model.dead_zone, model.cq.pwa, model.cqp.pwa, model.friction.pwa)
    head = np.zeros(I_CELLS - N_BASE)
    head[I_SCHED - N_BASE] = 1.0 if model.scheduled else 0.0
    head[I_PSFIX - N_BASE] = model.supply_pressure
    head[I_FORM - N_BASE] = 1.0 if model.form == "paper" else 0.0
    head[I_NG - N_BASE : I_NW - N_BASE + 1] = [s.n_cells for s in sets]
    body = [np.concatenate((s.breakpoints, s.slopes, s.offsets)) for s in sets]
    return np.concatenate([base, head] + body)


def pwa_rhs(
    t: float,
    y,
    u: float,
    p_s: float | None,
    f_l: float | None,
    model: PwaModel,
    *,
    end_stops: bool = True,
) -> np.ndarray:
    """Right-hand side of the PWA model at one point, evaluated by the compiled kernel.

    Parameters
    ----------
    t : float
        Time [s] (unused; the model is autonomous apart from the inputs).
    y : array_like, shape (3,)
        State [P_L (Pa), v (m/s), x (m)].
    u : float
        Valve command [1].
    p_s : float or None
        Supply pressure input [Pa]; used only if ``model.scheduled`` (None: fixed P_S).
    f_l : float or None
        Load force [N]; None: ``params.load.force``.
    model : PwaModel
    end_stops : bool
        Include the end-stop contact force (as the simulation does); False clips x into
        the stroke, where the contact force is zero.

    Returns
    -------
    ndarray, shape (3,)
        [Ṗ_L (Pa/s), v̇ (m/s²), ẋ (m/s)]; formula in the module docstring.
    """
    ps = model.supply_pressure if (p_s is None or not model.scheduled) else float(p_s)
    fl = model.params.load.force if f_l is None else float(f_l)
    return model._kernel_point(_no_stop(y, model.params, end_stops), u, ps, fl)[0]


def _no_stop(y, params: SystemParams, end_stops: bool) -> np.ndarray:
    y = np.array(y, dtype=float)
    if not end_stops:
        y[2] = min(max(y[2], 0.0), params.cylinder.stroke)
    return y


def reduced_rhs(
    t: float,
    y,
    u: float,
    p_s: float,
    f_l: float | None,
    params: SystemParams,
    *,
    end_stops: bool = True,
    form: str = "asymmetric",
) -> np.ndarray:
    """Right-hand side of the reduced model at one point, evaluated by the compiled kernel.

    Parameters
    ----------
    y : array_like, shape (3,)
        [P_L (Pa), v (m/s), x (m)]; u [1]; p_s [Pa]; f_l [N] (None: params.load.force).
    form : {"asymmetric", "paper"}
        Load-pressure form (see :class:`hydropwa.models.ReducedModel`).

    Returns
    -------
    ndarray, shape (3,)
        [Ṗ_L, v̇, ẋ]; the valve dynamics are dropped (ν = u), Sec. III.
    """
    if not isinstance(params, SystemParams):
        raise ParameterError("reduced_rhs needs a SystemParams")
    fl = params.load.force if f_l is None else float(f_l)
    p = ReducedModel(params, form).pack()
    return K.point_derivatives(
        K.REDUCED, _no_stop(y, params, end_stops), float(u), float(p_s), fl, p
    )[0]
