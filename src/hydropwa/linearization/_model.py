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
from typing import Any, NamedTuple

import numpy as np

from .._errors import ParameterError, PwaError
from ..components import (
    PiecewiseAffine,
    dead_zone,
    end_stop_force,
    load_flow,
    load_pressure_rate,
    piston_acceleration,
    stribeck_friction,
)
from ..params import SystemParams
from ._cells import (
    CQ_INTERVAL,
    CQP_INTERVAL,
    FRICTION_INTERVAL,
    cq_cells,
    cqp_cells,
    dead_zone_cells,
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
]

FORMS = ("consistent", "paper")
KIND_PWA = 2
# Packed layout agreed with hydropwa.simulation._kernel (model kind 2).
I_SCHED, I_PSFIX, I_FORM, I_NG, I_NO, I_NN, I_NW, I_CELLS, N_BASE = 40, 41, 42, 43, 44, 45, 46, 50, 40
DEFAULT_CELLS = {"cq": 5, "cqp": 5, "friction": 7}
#: Default command range [1] of the exported polyhedra (beyond the saturation at 1.1).
INPUT_RANGE = (-1.5, 1.5)
_MODES = ("paper", "tangent", "optimized", "optimized-rms")


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
    """

    A: np.ndarray
    B: np.ndarray
    f: np.ndarray
    cells: CellIndex
    point: dict
    dt: float | None = None

    def to_statespace(self):
        """python-control ``StateSpace`` (outputs = all three states) and the constant term f.

        Returns
        -------
        sys : control.StateSpace
        f : ndarray, shape (3,)
            Add ``f`` as a constant disturbance input (the system itself is linear).
        """
        import control

        C = np.eye(3)
        D = np.zeros((3, 1))
        if self.dt is None:
            sys = control.ss(self.A, self.B, C, D, inputs=["u"], outputs=["p_l", "v", "x"], states=["p_l", "v", "x"])
        else:
            sys = control.ss(self.A, self.B, C, D, self.dt, inputs=["u"], outputs=["p_l", "v", "x"],
                             states=["p_l", "v", "x"])
        return sys, self.f.copy()

    def discretize(self, dt: float) -> AffineDynamics:
        """Zero-order-hold discretisation including the affine term.

        Uses ``scipy.signal.cont2discrete`` on the augmented input [u, 1], i.e. the matrix
        exponential of [[A, B, f], [0, 0, 0], [0, 0, 0]]·dt.
        """
        from scipy.signal import cont2discrete

        if self.dt is not None:
            raise PwaError("these dynamics are already discrete")
        if not (isinstance(dt, int | float) and math.isfinite(dt) and dt > 0):
            raise PwaError(f"sample time {dt!r} s must be a positive number")
        Bf = np.hstack((self.B, self.f[:, None]))
        Ad, Bd, *_ = cont2discrete((self.A, Bf, np.eye(3), np.zeros((3, 2))), float(dt), method="zoh")
        return AffineDynamics(Ad, Bd[:, :1], Bd[:, 1].copy(), self.cells, dict(self.point), float(dt))


@dataclass(frozen=True, eq=False)
class PwaModel:
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
        ``consistent`` or ``paper`` (see module docstring).
    scheduled : bool
        If True the cells follow the supply-pressure input P_S(t); else P_S is fixed.
    supply_pressure : float
        Fixed P_S [Pa] (used when not scheduled, and as the default for exports).
    input_range : tuple of float
        Command range [1] that bounds the exported polyhedra.
    breakpoints : str
        How the cells were chosen (provenance).
    """

    params: SystemParams
    dead_zone: PiecewiseAffine
    cq: PwaFit
    cqp: PwaFit
    friction: PwaFit
    form: str = "consistent"
    scheduled: bool = False
    supply_pressure: float = 100e5
    input_range: tuple[float, float] = INPUT_RANGE
    breakpoints: str = "paper"
    kind = KIND_PWA
    name = "pwa"
    state_names: tuple[str, ...] = field(default=("p_l", "v", "x"), init=False)

    def __post_init__(self) -> None:
        if self.form not in FORMS:
            raise PwaError(f"form {self.form!r} must be one of {', '.join(FORMS)}")
        if not isinstance(self.params, SystemParams):
            raise PwaError(f"PwaModel needs a SystemParams, got {type(self.params).__name__}")
        _check_supply(self.supply_pressure, self.params)

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
        from .._display import html_table

        rows = [
            ("dead zone (16), Table IV", "u [1]", self.dead_zone.slopes.size, "exact"),
            ("C_q (18), (20)", "p̃ = sign(z)P_L/P_S", self.cq.n_cells, f"max error {self.cq.max_error:.3g}"),
            ("C_qp (19), (21)", "p̃", self.cqp.n_cells, f"max error {self.cqp.max_error:.3g}"),
            ("friction (22), Table V", "v [m/s]", self.friction.n_cells, f"max error {self.friction.max_error:.3g} N"),
        ]
        sched = "scheduled on P_S(t)" if self.scheduled else "fixed P_S"
        title = f"PwaModel: form {self.form}, {sched}, P_S = {self.supply_pressure / 1e5:.4g} bar"
        return html_table(title, ("cell set", "variable", "cells", "fit"), rows)

    # --- protocol of hydropwa.models ----------------------------------------------------
    def pack(self, command_amplitude: float = 0.0) -> np.ndarray:
        """Kernel parameter vector (base layout of ``hydropwa.models.pack_params`` + PWA cells)."""
        return pack_pwa(self)

    # The PWA model has the reduced model's states [P_L, v, x]; it shares its conventions.
    def state_scale(self) -> np.ndarray:
        """Typical state magnitudes [Pa, m/s, m] used as absolute tolerances."""
        from ..models import ReducedModel

        return ReducedModel(self.params).state_scale()

    def initial_state(self, x0=None, supply_pressure=None, load_force=0.0) -> np.ndarray:
        """Rest at ``x0`` [m] (default mid-stroke) with Ā·P_L = F_L."""
        from ..models import ReducedModel

        return ReducedModel(self.params).initial_state(x0, supply_pressure, load_force)

    @staticmethod
    def state_from_measurement(x, v, p_a, p_b, p_s=None, spool=0.0) -> np.ndarray:
        """Initial state [P_A − P_B, v, x] from measured quantities (SI)."""
        from ..models import ReducedModel

        return ReducedModel.state_from_measurement(x, v, p_a, p_b, p_s, spool)

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
        _check_supply(ps, self.params)
        K = self.params.flow.K
        root = math.sqrt(0.5 * ps)
        return {
            "dead_zone": self.dead_zone,
            "cq": _scaled(self.cq.pwa, K * root, ps, sign),
            "cqp": _scaled(self.cqp.pwa, K / (4.0 * root), ps, sign),
            "friction": self.friction.pwa,
        }

    def cell_index(self, p_l: float, v: float, u: float, p_s: float | None = None) -> CellIndex:
        """Active cells at state (P_L [Pa], v [m/s]) and command u [1]."""
        ps = self._ps(p_s)
        g = int(self.dead_zone.cell(u))
        z = self.dead_zone.slopes[g] * u + self.dead_zone.offsets[g]
        s = _sign(z)
        pn = s * p_l / ps
        return CellIndex(g, s, int(self.cq.pwa.cell(pn)), int(self.cqp.pwa.cell(pn)), int(self.friction.pwa.cell(v)))

    def load_flow(self, p_l: float, u: float, p_s: float | None = None) -> float:
        """PWA load flow Q_L [m³/s] (consistent or paper form, see module docstring)."""
        ps = self._ps(p_s)
        K = self.params.flow.K
        g = self.dead_zone.cell(u)
        z = self.dead_zone.slopes[g] * u + self.dead_zone.offsets[g]
        s = _sign(z)
        pn = s * p_l / ps
        root = math.sqrt(0.5 * ps)
        q = z * K * root * float(self.cq.pwa(pn))
        if self.form == "paper":
            q -= abs(z) * K / (4.0 * root) * float(self.cqp.pwa(pn)) * p_l
        return float(q)

    # --- dynamics -----------------------------------------------------------------------
    def rhs(self, t: float, y, u: float, p_s: float | None = None, f_l: float | None = None) -> np.ndarray:
        """Right-hand side [Ṗ_L, v̇, ẋ]; see :func:`pwa_rhs`."""
        return pwa_rhs(t, y, u, p_s, f_l, self)

    def matrices(self, p_l: float, v: float, u: float, p_s: float | None = None, f_l: float | None = None):
        """A(x), b(x), f of Eq. (23) for state x = [P_L, ẋ] in the active cells, exact in the cell.

        Returns
        -------
        A : ndarray (2, 2), b : ndarray (2,), f : ndarray (2,)
            ẋ = A(x) x + b(x) u + f reproduces :func:`pwa_rhs` (without end stops).

        Notes
        -----
        A₁₁ = 4E/V_t (d_g k_o − C_L − c·s·d_g (k_n P_L + d_n)), A₁₂ = −4EĀ/V_t,
        A₂₁ = Ā/m, A₂₂ = −k_w/m; b₁ = 4E k_g/V_t (k_o P_L + d_o − c·s (k_n P_L + d_n) P_L);
        f = (4E d_g d_o/V_t, −(d_w + F_L)/m). Printed (25)–(27) have +k_n, +d_n in place of
        −s·k_n, −s·d_n and divide by d_g and P_L (zero in cell III and at P_L = 0).
        """
        c = self._coefficients(p_l, v, u, p_s)
        cf = 1.0 if self.form == "paper" else 0.0
        c4, ab, m, cl = c["c4"], c["abar"], c["m"], c["cl"]
        qp = c["k_n"] * p_l + c["d_n"]
        A = np.array(
            [[c4 * (c["d_g"] * c["k_o"] - cl - cf * c["s"] * c["d_g"] * qp), -c4 * ab], [ab / m, -c["k_w"] / m]]
        )
        b = np.array([c4 * c["k_g"] * (c["k_o"] * p_l + c["d_o"] - cf * c["s"] * qp * p_l), 0.0])
        fl = self.params.load.force if f_l is None else f_l
        f = np.array([c4 * c["d_g"] * c["d_o"], -(c["d_w"] + fl) / m])
        return A, b, f

    def _coefficients(self, p_l, v, u, p_s) -> dict[str, Any]:
        ps = self._ps(p_s)
        idx = self.cell_index(p_l, v, u, ps)
        cells = self.cells_at(ps, idx.s)
        cq, cqp = cells["cq"], cells["cqp"]
        o = int(cq.cell(p_l))
        n = int(cqp.cell(p_l))
        cyl = self.params.cylinder
        return {
            "idx": idx,
            "ps": ps,
            "s": idx.s,
            "k_g": self.dead_zone.slopes[idx.g],
            "d_g": self.dead_zone.offsets[idx.g],
            "k_o": cq.slopes[o],
            "d_o": cq.offsets[o],
            "k_n": cqp.slopes[n],
            "d_n": cqp.offsets[n],
            "k_w": self.friction.pwa.slopes[idx.w],
            "d_w": self.friction.pwa.offsets[idx.w],
            "c4": 4.0 * self.params.oil.bulk_modulus / cyl.total_volume,
            "abar": cyl.mean_area,
            "cl": cyl.leakage,
            "m": self.params.load.mass,
        }

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
            A, B = Jacobians of :func:`pwa_rhs` at the point (exact inside the cell, end
            stops excluded), f = rhs − A y − B u there.
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
            raise PwaError(f"operating point needs p_l [Pa], v [m/s] and u [1]; missing {exc}") from None
        x = float(pt.get("x", 0.5 * self.params.cylinder.stroke))
        c = self._coefficients(p_l, v, u, ps)
        cf = 1.0 if self.form == "paper" else 0.0
        z = c["k_g"] * u + c["d_g"]
        qp = c["k_n"] * p_l + c["d_n"]
        c4, ab, m = c["c4"], c["abar"], c["m"]
        A = np.zeros((3, 3))
        A[0, 0] = c4 * (z * c["k_o"] - c["cl"] - cf * abs(z) * (2.0 * c["k_n"] * p_l + c["d_n"]))
        A[0, 1] = -c4 * ab
        A[1, 0] = ab / m
        A[1, 1] = -c["k_w"] / m
        A[2, 1] = 1.0
        B = np.zeros((3, 1))
        B[0, 0] = c4 * c["k_g"] * (c["k_o"] * p_l + c["d_o"] - cf * c["s"] * qp * p_l)
        y = np.array([p_l, v, x])
        rhs = _pwa_rhs_at(y, u, c["ps"], f_l, self, False)
        f = rhs - A @ y - B[:, 0] * u
        return AffineDynamics(A, B, f, c["idx"], {"p_l": p_l, "v": v, "x": x, "u": u, "p_s": ps})

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
        for name, i, n in (("g", g, self.dead_zone.n_cells), ("o", o, self.cq.n_cells), ("w", w, self.friction.n_cells)):
            if not 0 <= i < n:
                raise PwaError(f"cell index {name} = {i} outside 0..{n - 1}")
        u = float(self._input_cell_point(g, s))
        return {"p_l": float(s * ps * self.cq.working_points[o]), "v": float(self.friction.working_points[w]),
                "x": 0.5 * self.params.cylinder.stroke, "u": u}

    def _input_cell_point(self, g: int, s: int) -> float:
        lo, hi = self._input_bounds(g, s)
        return 0.5 * (lo + hi)

    def _input_bounds(self, g: int, s: int) -> tuple[float, float]:
        """Command interval of dead-zone cell g restricted to sign(z) = s (splits the creep cell)."""
        b = np.concatenate(([self.input_range[0]], self.dead_zone.breakpoints, [self.input_range[1]]))
        lo, hi = float(max(b[g], self.input_range[0])), float(min(b[g + 1], self.input_range[1]))
        k, d = self.dead_zone.slopes[g], self.dead_zone.offsets[g]
        if k != 0.0:
            u0 = -d / k  # where z changes sign
            if lo < u0 < hi:
                lo, hi = (u0, hi) if s > 0 else (lo, u0)
        return lo, hi

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
        pmax = ps * max(abs(self.cq.interval[0]), abs(self.cq.interval[1]))
        vlo, vhi = self.friction.interval
        bw = np.concatenate(([vlo], np.clip(self.friction.pwa.breakpoints, vlo, vhi), [vhi]))
        paper = self.form == "paper"
        for g in range(self.dead_zone.n_cells):
            for s in (1, -1):
                ulo, uhi = self._input_bounds(g, s)
                z_mid = self.dead_zone.slopes[g] * 0.5 * (ulo + uhi) + self.dead_zone.offsets[g]
                if uhi <= ulo or _sign(z_mid) != s:
                    continue
                bo = _pressure_edges(self.cq.pwa, ps, s, pmax)
                bn = _pressure_edges(self.cqp.pwa, ps, s, pmax) if paper else None
                for o in range(self.cq.n_cells):
                    ns = range(self.cqp.n_cells) if paper else (int(self.cqp.pwa.cell(s * _mid(bo, o, s) / ps)),)
                    for n in ns:
                        plo, phi = bo[o]
                        if paper:
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
        from ._export import model_to_dict

        return model_to_dict(self)

    def to_json(self, **kwargs) -> str:
        """JSON document of the model (schema ``hydropwa.pwa/1``); see :func:`from_json`."""
        return json.dumps(self.to_dict(), **kwargs)

    @classmethod
    def from_json(cls, text: str) -> PwaModel:
        """Model from :meth:`to_json` or :func:`export_pwa` output; PwaError on schema mismatch."""
        from ._export import model_from_dict

        try:
            data = json.loads(text)
        except json.JSONDecodeError as exc:
            raise PwaError(f"PWA document is not valid JSON: {exc.msg} at line {exc.lineno}") from None
        return model_from_dict(data)


def _mid(edges, o, s):
    lo, hi = edges[o]
    return 0.5 * (lo + hi)


def _pressure_edges(pwa: PiecewiseAffine, ps: float, s: int, pmax: float) -> list[tuple[float, float]]:
    """P_L interval [Pa] of each normalised cell for flow direction s, clipped to ±pmax."""
    b = np.concatenate(([-np.inf], pwa.breakpoints, [np.inf]))
    out = []
    for i in range(pwa.n_cells):
        lo, hi = (ps * b[i], ps * b[i + 1]) if s > 0 else (-ps * b[i + 1], -ps * b[i])
        out.append((float(max(lo, -pmax)), float(min(hi, pmax))))
    return out


def _check_supply(p_s, params: SystemParams) -> float:
    try:
        ps = float(p_s)
    except (TypeError, ValueError):
        raise PwaError(f"supply pressure {p_s!r} is not a number in Pa") from None
    if not math.isfinite(ps) or ps <= max(0.0, params.supply.tank_pressure):
        raise PwaError(f"supply pressure {ps / 1e5:g} bar must be finite and above the tank pressure")
    p_load = abs(params.load.force) / params.cylinder.mean_area
    if p_load >= ps:
        raise PwaError(
            f"supply pressure {ps / 1e5:g} bar is below the load pressure F_L/Ā = {p_load / 1e5:g} bar "
            "needed to hold the load; raise the supply pressure"
        )
    return ps


def _parse_cells(cells) -> dict[str, int]:
    out = dict(DEFAULT_CELLS)
    if cells is None:
        return out
    if not isinstance(cells, Mapping):
        raise PwaError(f"cells {cells!r} must be a mapping like {{'cq': 5, 'cqp': 5, 'friction': 7}}")
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
            raise PwaError(f"breakpoints {breakpoints!r} must be one of {', '.join(_MODES)} or a mapping")
        return breakpoints, None
    if isinstance(breakpoints, Mapping):
        unknown = set(breakpoints) - set(DEFAULT_CELLS)
        if unknown:
            raise PwaError(f"unknown cell set(s) {sorted(unknown)} in breakpoints; choose from {', '.join(DEFAULT_CELLS)}")
        v = breakpoints.get(key, "paper")
        if isinstance(v, str):
            return _spec(v, key)
        return "given", np.asarray(v, dtype=float)
    raise PwaError(f"breakpoints {breakpoints!r} must be a mode name or a mapping of cell set to breakpoints")


def linearize(
    params: SystemParams,
    *,
    supply_pressure: float | None = None,
    cells: Mapping[str, int] | None = None,
    breakpoints: str | Mapping[str, Any] = "paper",
    form: str = "consistent",
    scheduled: bool = False,
    working_points: Mapping[str, Any] | None = None,
    load_pressure_range: tuple[float, float] | None = None,
    friction_range: tuple[float, float] = FRICTION_INTERVAL,
) -> PwaModel:
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
        ``paper`` (tangents at the recovered working points for C_q/C_qp, Table V's
        breakpoints for friction), ``tangent`` (tangents at ``working_points``),
        ``optimized`` (minimax-optimal breakpoints), ``optimized-rms``, or a mapping
        {cell set: mode or breakpoints}; C_q/C_qp breakpoints are in p̃ = P_L/P_S [1],
        friction breakpoints in m/s.
    form : {"consistent", "paper"}
        Load-flow form (see the module docstring).
    scheduled : bool
        Follow the P_S(t) input (cells rescaled online at no cost) instead of a fixed P_S.
    working_points : mapping, optional
        Tangent points for ``tangent`` mode: {"cq": p̃ [1], "cqp": p̃ [1], "friction": m/s}.
    load_pressure_range : (float, float), optional
        P_L range [Pa] the cells must cover; must lie within ±P_S. Default ±P_S.
    friction_range : (float, float)
        Velocity range [m/s] of the friction fit.

    Returns
    -------
    PwaModel

    Raises
    ------
    PwaError
        Bad cell counts, breakpoints, supply pressure below the load-pressure range, form.
    """
    if not isinstance(params, SystemParams):
        raise PwaError(f"linearize needs a SystemParams, got {type(params).__name__}")
    if form not in FORMS:
        raise PwaError(f"form {form!r} must be one of {', '.join(FORMS)}")
    ps = _check_supply(params.supply.pressure if supply_pressure is None else supply_pressure, params)
    n = _parse_cells(cells)
    wp = dict(working_points or {})
    cq_int, cqp_int = CQ_INTERVAL, CQP_INTERVAL
    if load_pressure_range is not None:
        try:
            lo, hi = (float(v) for v in load_pressure_range)
        except (TypeError, ValueError):
            raise PwaError(f"load pressure range {load_pressure_range!r} must be two numbers in Pa") from None
        if not lo < hi:
            raise PwaError(f"load pressure range ({lo:g}, {hi:g}) Pa must have lo < hi")
        m = max(abs(lo), abs(hi))
        if m > ps:
            raise PwaError(
                f"supply pressure {ps / 1e5:g} bar is below the load-pressure range up to {m / 1e5:g} bar; "
                "raise the supply pressure or narrow the range"
            )
        r = m / ps
        cq_int, cqp_int = (-r, r), (-r, min(r, CQP_INTERVAL[1]))
    mode, b = _spec(breakpoints, "cq")
    cq = cq_cells(n["cq"], mode, interval=cq_int, breakpoints=b, working_points=wp.get("cq"))
    mode, b = _spec(breakpoints, "cqp")
    cqp = cqp_cells(n["cqp"], mode, interval=cqp_int, breakpoints=b, working_points=wp.get("cqp"))
    mode, b = _spec(breakpoints, "friction")
    fr = friction_cells(params.friction, n["friction"], mode, interval=friction_range, breakpoints=b,
                        working_points=wp.get("friction"))
    label = breakpoints if isinstance(breakpoints, str) else json.dumps(
        {k: (v if isinstance(v, str) else np.asarray(v, float).tolist()) for k, v in breakpoints.items()})
    return PwaModel(params, dead_zone_cells(params.dead_zone), cq, cqp, fr, form, bool(scheduled), ps,
                    INPUT_RANGE, label)


def pack_pwa(model: PwaModel) -> np.ndarray:
    """Packed float64 parameter vector of the PWA model for the compiled kernel (kind 2).

    Layout: p[0:40] = ``hydropwa.models.pack_params(model.params)``; p[40] scheduled flag;
    p[41] fixed P_S [Pa]; p[42] paper-form flag c; p[43:47] n_g, n_o, n_n, n_w; p[47:50] 0;
    from p[50]: for dead zone (over u), C_q (over p̃), C_qp (over p̃), friction (over v) in
    turn: n−1 breakpoints, n slopes, n offsets (normalised k̂, d̂ for C_q and C_qp).
    """
    try:
        from ..models import pack_params

        base = pack_params(model.params)
    except ImportError:  # pragma: no cover - the models layer is part of the package
        raise PwaError("hydropwa.models.pack_params is not available") from None
    if base.size != N_BASE:
        raise PwaError(f"base parameter vector has {base.size} entries, the PWA layout expects {N_BASE}")
    sets = (model.dead_zone, model.cq.pwa, model.cqp.pwa, model.friction.pwa)
    head = np.zeros(I_CELLS - N_BASE)
    head[I_SCHED - N_BASE] = 1.0 if model.scheduled else 0.0
    head[I_PSFIX - N_BASE] = model.supply_pressure
    head[I_FORM - N_BASE] = 1.0 if model.form == "paper" else 0.0
    head[I_NG - N_BASE : I_NW - N_BASE + 1] = [s.n_cells for s in sets]
    body = [np.concatenate((s.breakpoints, s.slopes, s.offsets)) for s in sets]
    return np.concatenate([base, head] + body)


def pwa_rhs(t: float, y, u: float, p_s: float | None, f_l: float | None, model: PwaModel, *,
            end_stops: bool = True) -> np.ndarray:
    """Reference right-hand side of the PWA model (pure numpy; the kernel must match it).

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
        Include the end-stop contact force (as the kernel does).

    Returns
    -------
    ndarray, shape (3,)
        [Ṗ_L (Pa/s), v̇ (m/s²), ẋ (m/s)], Eqs. (14)–(17), (20)–(22); formula in the module
        docstring.
    """
    ps = model.supply_pressure if (p_s is None or not model.scheduled) else float(p_s)
    return _pwa_rhs_at(y, u, ps, f_l, model, end_stops)


def _pwa_rhs_at(y, u: float, ps: float, f_l: float | None, model: PwaModel, end_stops: bool) -> np.ndarray:
    """:func:`pwa_rhs` with the supply pressure [Pa] already resolved."""
    prm = model.params
    cyl = prm.cylinder
    fl = prm.load.force if f_l is None else float(f_l)
    p_l, v, x = (float(c) for c in y)
    ql = model.load_flow(p_l, u, ps)
    ff = float(model.friction.pwa(v))
    stop = end_stop_force(x, v, cyl.stroke, cyl.end_stop_stiffness, cyl.end_stop_damping) if end_stops else 0.0
    dp = load_pressure_rate(ql, v, p_l, cyl.mean_area, cyl.total_volume, cyl.leakage, prm.oil.bulk_modulus)
    dv = piston_acceleration(cyl.mean_area * p_l, ff, fl, stop, prm.load.mass)
    return np.array([dp, dv, v])


def reduced_rhs(t: float, y, u: float, p_s: float, f_l: float | None, params: SystemParams, *,
                end_stops: bool = True) -> np.ndarray:
    """Right-hand side of the reduced model, Eqs. (12), (14), (15), from the components.

    Parameters
    ----------
    y : array_like, shape (3,)
        [P_L (Pa), v (m/s), x (m)]; u [1]; p_s [Pa]; f_l [N] (None: params.load.force).

    Returns
    -------
    ndarray, shape (3,)
        [Ṗ_L, v̇, ẋ]; the valve dynamics are dropped (ν = u), Sec. III.
    """
    if not isinstance(params, SystemParams):
        raise ParameterError("reduced_rhs needs a SystemParams")
    dz, cyl, fr = params.dead_zone, params.cylinder, params.friction
    fl = params.load.force if f_l is None else float(f_l)
    p_l, v, x = (float(c) for c in y)
    z = dead_zone(float(u), dz.alpha, dz.beta, dz.creep_slope, dz.outer_offset)
    ql = load_flow(z, p_l, float(p_s), params.flow.K, params.flow.transition_pressure)
    ff = float(stribeck_friction(v, fr.coulomb, fr.static, fr.viscous, fr.stribeck_velocity, fr.shape, fr.smoothness))
    stop = end_stop_force(x, v, cyl.stroke, cyl.end_stop_stiffness, cyl.end_stop_damping) if end_stops else 0.0
    dp = load_pressure_rate(ql, v, p_l, cyl.mean_area, cyl.total_volume, cyl.leakage, params.oil.bulk_modulus)
    dv = piston_acceleration(cyl.mean_area * p_l, ff, fl, stop, params.load.mass)
    return np.array([dp, dv, v])
