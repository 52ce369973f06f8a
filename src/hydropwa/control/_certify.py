"""A certificate for a state-feedback loop at a hold: an ultimate bound ē and a region of attraction.

:func:`certify` writes the file's law at a hold (the reference at rest) as a switched linear
loop with bounded disturbances, one linear loop per gain row, and searches a common quadratic
Lyapunov function V(ξ) = ξᵀPξ for it with cvxpy and Clarabel. The verdict is not the
solver's: :func:`~hydropwa.control._certcheck.check_certificate`, which shares no code with
this module, rebuilds every matrix from the raw data and re-checks every inequality in float64.

The certified loop (per gain row j, state ξ = [P_L, ẋ, x, ν, ν̇, c_pend…, I, P̄_L, x̂, v̂] as
deviations from the hold, x the position error):

* the row's PWA cell (the Ṗ_L row of :meth:`~hydropwa.linearization.PwaModel.state_space`),
  the servo valve of Eq. (1) in series, a zero-order hold, ``delay_samples`` samples of delay;
* the friction as its viscous slope b plus a bounded force: |F_f(ẋ) − b ẋ| ≤ F_s (the
  Stribeck drop and Coulomb's force as a disturbance, not as the unstable falling branch);
* the law's linear part: washout, position observer, the row's gains, the integral (two
  modes, integrate and leak, as vertices; the hold of the integral band as a disturbance
  proportional to |x̂|);
* bounded disturbances per row: the cell's affine residual at the hold and its guaranteed
  error bound (:meth:`~hydropwa.linearization.PwaModel.error_bound`), the sensor noise within
  ``noise_sigmas`` standard deviations, the quiet band with its vent (|c_o − c| ≤ 2q) and the
  dead-zone inverse's blend (≤ z_w + creep).

With ρ_j the largest ‖P^½ w‖ of row j and ρ₁√V the integral hold's share,
√V⁺ ≤ (√λ + ρ₁)√V + ρ_j; every sublevel set above c_j = (ρ_j / (1 − √λ − ρ₁))² then shrinks.
A row whose box lies at V ≥ c_j everywhere (a lower bound from the box's faces) cannot hold
the state above 𝒰 = {V ≤ c_U}; the others set c_U. ē = √(c_U·(P⁻¹)ₓₓ). The region
𝓡 = {V ≤ c_R} keeps every row's command out of saturation and the velocity inside the
friction fit; its largest box of (x, ẋ, P_L) with the controller's start values (x̂ = x,
v̂ = 0, P̄_L = P_L, I = 0) is reported with the reach time from 𝓡 to 𝒰.

Not in the certified model (the certificate lists them): the opening delay ``quiet_open``
(the band opens only on the n-th sample beyond q), the feed-forward (zero at rest), the
supply-pressure and parameter draws of the verification.
"""

from __future__ import annotations

import enum
import hashlib
import json
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ._controllers import ControlError, StateFeedbackController

__all__ = [
    "CertificateStatus",
    "Certificate",
    "LoopData",
    "certify",
    "loop_data",
    "NOISE_SIGMAS",
    "REGION_SHAPE",
]

#: sensor noise bound in standard deviations: the certificate holds for |n| ≤ 4σ (a Gaussian
#: sample leaves it with probability 6e-5)
NOISE_SIGMAS = 4.0
#: the box the region is reported as, scaled: position error 20 mm, velocity 100 mm/s, 30 bar
REGION_SHAPE = (20e-3, 0.1, 30e5)
#: contraction rates tried for λ (per sample), slowest last
_LAMBDAS = (0.999, 0.9995, 0.9999)
#: the certified loop's state names and their engineering scales (bar, mm/s, mm, %, …)
_NAMES = ("p_l", "v", "x", "nu", "nu_rate")
_SCALES = {"p_l": 1e5, "v": 1e-3, "x": 1e-3, "nu": 1e-2, "nu_rate": 1.0}


class CertificateStatus(enum.Enum):
    """Outcome of :func:`certify`; each member carries ``success`` and a fix-it ``message``."""

    CERTIFIED = (True, "certified: the checker re-verified every inequality")
    NO_LYAPUNOV = (
        False,
        "no common quadratic Lyapunov function of the rows' loops: a row's loop is unstable "
        "alone or the rows cannot share one (see failing_rows)",
    )
    NO_BOUND = (
        False,
        "the disturbances are too large for the contraction: no sublevel set shrinks (a "
        "softer integral or a stiffer position loop may help)",
    )
    EMPTY_REGION = (
        False,
        "the ultimate set is not inside the region kept out of saturation: the region is empty",
    )
    CHECK_FAILED = (False, "the solver's certificate failed the independent check")

    @property
    def success(self) -> bool:
        return bool(self.value[0])

    @property
    def message(self) -> str:
        return str(self.value[1])


@dataclass(frozen=True, eq=False)
class LoopData:
    """The raw data of the certified loop, SI: what the checker rebuilds the matrices from.

    Attributes
    ----------
    cells : tuple of dict
        Per gain row: ``label``, continuous ``A`` (3 × 3) and ``B`` (3,) of the cell with the
        opening as input and the viscous friction slope, the affine residual ``f0`` (3,) at the
        hold [Pa/s, m/s², m/s], ``error_bound`` [Pa/s], the row's ``gains`` and box
        ``lower``/``upper`` over [P_L, ẋ, x, c].
    sample_time : float
        T_s [s].
    omega0, zeta : float
        The servo valve of Eq. (1) [rad/s], [1].
    delay_samples : int
        Samples between the computation and the valve.
    observer : tuple of float
        Position observer gains (L_x [1], L_v [1/s]).
    washout : float
        a_w = exp(−T_s/T_w) [1] (0: no washout).
    leak : float
        a_l = exp(−T_s/T_l) [1] of the integral leak (1: no leak).
    mass : float
        Moving mass [kg].
    bounds : dict
        Disturbance magnitudes (SI): ``friction`` [N], ``x_noise`` [m], ``p_noise`` [Pa],
        ``command`` [1].
    hold_pressure : float
        P_L at the hold [Pa].
    velocity_limit, command_limit : float
        |ẋ| [m/s] of the friction fit and |c| [1] before saturation, inside the region.
    """

    cells: tuple[dict, ...]
    sample_time: float
    omega0: float
    zeta: float
    delay_samples: int
    observer: tuple[float, float]
    washout: float
    leak: float
    mass: float
    bounds: dict
    hold_pressure: float
    velocity_limit: float
    command_limit: float

    @property
    def n_states(self) -> int:
        """States of the certified loop: 5 plant, the delay line, I, P̄_L, x̂, v̂."""
        return 5 + self.delay_samples + 4


@dataclass(frozen=True, eq=False)
class Certificate:
    """The result of :func:`certify` (frozen).

    Attributes
    ----------
    status : CertificateStatus
    success : bool
        The independent checker's verdict (not the solver's status).
    message : str
    e_bar : float
        Ultimate bound ē on |x − r| [m] (inf when not certified).
    box : tuple of float
        Half-widths of the largest box of (position error [m], velocity [m/s], load pressure
        deviation [Pa]) of :data:`REGION_SHAPE`'s aspect inside the region (zeros when none).
    reach_time : float
        Time [s] from the region's boundary into 𝒰.
    P : ndarray
        Lyapunov matrix in the scaled states (engineering units, see :attr:`scales`).
    scales : ndarray
        State scales [SI per unit] (ξ_SI = scales·ξ).
    lam : float
        Contraction rate λ [1] per sample of V.
    level_ultimate, level_region : float
        c_U and c_R of V.
    rho : ndarray
        ρ_j per row [√V units]; ``rho_hold`` ρ₁.
    rho_hold : float
    disturbance : dict
        The disturbance terms (SI magnitudes).
    failing_rows : tuple of str
        Rows whose conditions fail (empty when certified).
    not_modelled : tuple of str
        Law elements outside the certified model.
    model_hash, law_hash : str
        sha256 of the machine's parameters and of the law (the file without its verdicts).
    check : Any
        The checker's :class:`~hydropwa.control._certcheck.CheckResult`.
    data : LoopData
    """

    status: CertificateStatus
    success: bool
    message: str
    e_bar: float
    box: tuple[float, float, float]
    reach_time: float
    P: np.ndarray
    scales: np.ndarray
    lam: float
    level_ultimate: float
    level_region: float
    rho: np.ndarray
    rho_hold: float
    disturbance: dict
    failing_rows: tuple[str, ...]
    not_modelled: tuple[str, ...]
    model_hash: str
    law_hash: str
    check: Any = None
    data: LoopData | None = field(default=None, repr=False)

    def summary(self) -> str:
        """One paragraph: verdict, ē, the region's box and the reach time."""
        head = f"certificate: {'certified' if self.success else 'NOT certified'} ({self.message})"
        if not self.success:
            rows = ", ".join(self.failing_rows[:8]) + (" …" if len(self.failing_rows) > 8 else "")
            return head + (f"\n  failing rows: {rows}" if rows else "")
        e, v, p = self.box
        return (
            f"{head}\n  ultimate bound ē = {self.e_bar * 1e3:.3f} mm; region box |e| ≤ "
            f"{e * 1e3:.2f} mm, |ẋ| ≤ {v * 1e3:.1f} mm/s, |ΔP_L| ≤ {p / 1e5:.2f} bar; reach "
            f"time {self.reach_time:.3f} s\n  not modelled: {', '.join(self.not_modelled)}"
        )

    def to_dict(self) -> dict[str, Any]:
        """The controller file's ``[certificate]`` table (units in the strings)."""
        d: dict[str, Any] = {
            "verdict": "certified" if self.success else "not certified",
            "status": self.status.name.lower(),
            "message": self.message,
            "checker": "pass" if self.check is not None and self.check.passed else "fail",
            "model_hash": self.model_hash,
            "law_hash": self.law_hash,
            "not_modelled": list(self.not_modelled),
            "disturbance": {k: float(v) for k, v in self.disturbance.items()},
        }
        if self.success:
            d |= {
                "e_bar": f"{self.e_bar * 1e3:.6g} mm",
                "region_box": {
                    "position_error": f"{self.box[0] * 1e3:.6g} mm",
                    "velocity": f"{self.box[1] * 1e3:.6g} mm/s",
                    "load_pressure": f"{self.box[2] / 1e5:.6g} bar",
                },
                "reach_time": f"{self.reach_time:.6g} s",
                "sublevel": {
                    "lambda": self.lam,
                    "level_ultimate": self.level_ultimate,
                    "level_region": self.level_region,
                    "scales": self.scales.tolist(),
                    "P": self.P.tolist(),
                },
            }
        else:
            d["failing_rows"] = list(self.failing_rows)
        return d


def _hash(obj: Any) -> str:
    return hashlib.sha256(json.dumps(obj, sort_keys=True, default=str).encode()).hexdigest()


def law_hash(controller) -> str:
    """sha256 of the controller's law (its file form without verdicts)."""
    from ._io import controller_to_dict  # deferred: the file form is needed only here

    d = controller_to_dict(controller)
    for k in ("verification", "certificate", "design"):
        d.pop(k, None)
    return _hash(d)


def _row_cell(model, row, prm, hold_pressure: float) -> dict:
    """The certified data of one gain row: its cell with viscous friction, residual, bound."""
    lo, hi = np.array(row.lower, float), np.array(row.upper, float)
    s = 1.0 if hi[3] > 0 else -1.0
    v_mid = 0.5 * (max(lo[1], model.friction.interval[0]) + min(hi[1], model.friction.interval[1]))
    p_mid = 0.5 * (lo[0] + hi[0])
    dyn = model.state_space({"p_l": p_mid, "v": v_mid, "u": 0.5 * s})
    k_g = float(model.dead_zone.slopes[dyn.cells.g])
    A = dyn.A.copy()
    B = dyn.B[:, 0] / k_g
    A[1, 1] = -prm.friction.viscous / prm.load.mass  # the rest of the friction is bounded
    # residual at the hold (P_L*, ẋ = 0, c = 0) in the cell's affine form; the mechanics row
    # is balanced by the choice of P_L* and its friction is in the bounded force
    y = np.array([hold_pressure, 0.0, 0.0])
    # c = k_g·u + o_g on the open dead-zone cell: c = 0 is u = −o_g/k_g
    o_g = float(model.dead_zone.offsets[dyn.cells.g])
    f0 = np.array([dyn.A[0] @ y + dyn.f[0] - dyn.B[0, 0] * o_g / k_g, 0.0, 0.0])
    ebound = float(model.error_bound(dyn.cells, dyn))
    gains = {
        k: float(getattr(row, k)) for k in ("k_pl", "k_v", "k_x", "k_i", "k_nu", "k_dnu", "k_up")
    }
    return {
        "label": row.label,
        "A": A,
        "B": B,
        "f0": f0,
        "error_bound": ebound,
        "gains": gains,
        "lower": lo,
        "upper": hi,
    }


def loop_data(
    controller, model, *, delay_samples: int | None = None, sensor_noise: dict | None = None
) -> LoopData:
    """The raw data of the certified loop of ``controller`` on the PWA ``model`` (SI).

    Parameters
    ----------
    controller : StateFeedbackController
    model : PwaModel
        The machine's PWA model (its cells give the rows' plants and error bounds).
    delay_samples : int, optional
        Samples of delay between computation and valve (default: 1 with the file's delay,
        else 0); a test of a slower target.
    sensor_noise : mapping, optional
        Standard deviations {"x" [m], "p_a", "p_b" [Pa]} (default those of the default design).
    """
    from ._defaults import DEFAULT_DESIGN  # deferred: the defaults record imports the law

    if not isinstance(controller, StateFeedbackController):
        raise ControlError(
            "certify needs a state-feedback controller (control design --method lqr)"
        )
    dz = controller.dead_zone_inverse
    if controller.position_observer is None:
        raise ControlError(
            "certify needs the position observer (the default design's --quiet-band)"
        )
    prm = model.params
    nd = (1 if controller.delay else 0) if delay_samples is None else int(delay_samples)
    if not 0 <= nd <= 10:
        raise ControlError(f"delay_samples {nd} must be between 0 and 10")
    noise = dict(DEFAULT_DESIGN.sensor_noise if sensor_noise is None else sensor_noise)
    alpha = prm.cylinder.area_b / prm.cylinder.area_a
    p_noise = math.hypot(noise.get("p_a", 0.0), alpha * noise.get("p_b", 0.0))
    hold_p = float(prm.load.force / prm.cylinder.area_a)
    ts = controller.sample_time
    q = dz.quiet_band if dz is not None else 0.0
    z_w = dz.width if dz is not None else 0.0
    beta = dz.offset if dz is not None else 0.0
    command = 2.0 * q + z_w + prm.dead_zone.creep_slope * (z_w + beta)
    bounds = {
        "friction": float(max(prm.friction.static, prm.friction.coulomb)),
        "x_noise": NOISE_SIGMAS * float(noise.get("x", 0.0)),
        "p_noise": NOISE_SIGMAS * p_noise,
        "command": float(command),
    }
    # the rows whose pressure range holds the hold's P_L: the region keeps P_L inside the
    # intersection of their ranges, so no other row is ever active in it
    rows = [r for r in controller.rows if r.lower[0] <= hold_p <= r.upper[0]]
    if not rows:
        raise ControlError(
            f"no gain row's load-pressure range holds the hold's P_L {hold_p / 1e5:.4g} bar"
        )
    cells = tuple(_row_cell(model, r, prm, hold_p) for r in rows)
    washout = (
        math.exp(-ts / controller.pressure_washout) if controller.pressure_washout > 0 else 0.0
    )
    leak = math.exp(-ts / dz.integral_leak) if dz is not None and dz.integral_leak > 0 else 1.0
    return LoopData(
        cells=cells,
        sample_time=ts,
        omega0=float(prm.valve.omega0),
        zeta=float(prm.valve.zeta),
        delay_samples=nd,
        observer=(float(controller.position_observer[0]), float(controller.position_observer[1])),
        washout=washout,
        leak=leak,
        mass=float(prm.load.mass),
        bounds=bounds,
        hold_pressure=hold_p,
        velocity_limit=float(min(-model.friction.interval[0], model.friction.interval[1])),
        command_limit=float(controller.u_max - beta - command),
    )


#: disturbance components d of the loop, in the columns of E: friction force [N], position
#: noise [m], load-pressure noise [Pa], command perturbation [1], Ṗ_L model error [Pa/s]
_DIST = ("friction", "x_noise", "p_noise", "command", "error_bound")
#: the ultimate set's margin m: 𝒰 = {√V ≤ (1 + m)·√c_U0}; a row is separated from 𝒰 where
#: its box lies at V ≥ (1 + m)²·c_j
MARGIN = 0.1


def _zoh(A: np.ndarray, G: np.ndarray, ts: float) -> tuple[np.ndarray, np.ndarray]:
    """(Φ, ∫₀^T e^{As} ds · G): the zero-order-hold sampling of ż = A z + G d."""
    from scipy.linalg import expm  # deferred: scipy.linalg costs 0.1-0.5 s at import

    n, m = A.shape[0], G.shape[1]
    M = np.zeros((n + m, n + m))
    M[:n, :n] = A
    M[:n, n:] = G
    E = expm(M * ts)
    return E[:n, :n], E[:n, n:]


def _row_loop(data: LoopData, cell: dict):
    """(M_integrate, M_leak, E, a, k, h): ξ⁺ = M ξ + E d + a, the command c = k·[ξ; d] and
    the observer's x̂⁺ = h·[ξ; d] of one row (SI states)."""
    n, nd = data.n_states, data.delay_samples
    iI, iP, iX, iV = 5 + nd, 6 + nd, 7 + nd, 8 + nd
    om, ze, ts = data.omega0, data.zeta, data.sample_time
    Av = np.zeros((5, 5))
    Av[:3, :3] = cell["A"]
    Av[:3, 3] = cell["B"]
    Av[3, 4] = 1.0
    Av[4, 3] = -(om**2)
    Av[4, 4] = -2.0 * ze * om
    G = np.zeros((5, 4))  # columns: c, force/m, Ṗ_L error, residual
    G[4, 0] = om**2
    G[1, 1] = 1.0 / data.mass
    G[0, 2] = 1.0
    G[0, 3] = cell["f0"][0]
    Phi, Gam = _zoh(Av, G, ts)
    nz = n + len(_DIST)  # linear forms over [ξ; d]
    row = lambda: np.zeros(nz)  # noqa: E731
    lx, lv = data.observer
    x_pred = row()
    x_pred[iX], x_pred[iV] = 1.0, ts
    meas = row()
    meas[2], meas[n + 1] = 1.0, 1.0
    xh = x_pred + lx * (meas - x_pred)
    vh = row()
    vh[iV] = 1.0
    vh += lv * (meas - x_pred)
    pm = row()
    pm[0], pm[n + 2] = 1.0, 1.0
    pbar = row()
    if data.washout > 0:
        pbar[iP] = data.washout
        pbar += (1.0 - data.washout) * pm
        pfb = pm - pbar
    else:
        pfb = pm
    g = cell["gains"]
    k = -g["k_x"] * xh - g["k_v"] * vh - g["k_pl"] * pfb
    k[iI] += g["k_i"]
    k[3] -= g["k_nu"]
    k[4] -= g["k_dnu"]
    if nd > 0:
        k[5] -= g["k_up"]
    cmd = k.copy()
    cmd[n + 3] += 1.0  # the band, the vent and the inverse's blend
    applied = cmd if nd == 0 else _unit(nz, 5)
    T = np.zeros((n, nz))
    T[:5, :5] = Phi
    T[:5, :] += np.outer(Gam[:, 0], applied)
    T[:5, n + 0] += Gam[:, 1]
    T[:5, n + 4] += Gam[:, 2]
    for i in range(nd - 1):
        T[5 + i, 6 + i] = 1.0
    if nd > 0:
        T[4 + nd, :] = cmd
    T[iI, iI] = 1.0
    T[iI, :] -= ts * xh
    T[iP, :] = pbar
    T[iX, :] = xh
    T[iV, :] = vh
    a = np.zeros(n)
    a[:5] = Gam[:, 3]
    M_int, E = T[:, :n], T[:, n:]
    M_leak = M_int.copy()
    M_leak[iI, :] = 0.0
    M_leak[iI, iI] = data.leak
    return M_int, M_leak, E, a, k, xh


def _unit(n: int, i: int) -> np.ndarray:
    u = np.zeros(n)
    u[i] = 1.0
    return u


def _scales(data: LoopData) -> np.ndarray:
    """Engineering scales of the states (bar, mm/s, mm, %, 1/s, % per delay, integral mm·s…)."""
    s = [_SCALES[k] for k in _NAMES] + [1e-2] * data.delay_samples
    return np.array(s + [1e-6, 1e5, 1e-3, 1e-3])


def _bounds(data: LoopData, cell: dict) -> np.ndarray:
    b = data.bounds
    return np.array([b["friction"], b["x_noise"], b["p_noise"], b["command"], cell["error_bound"]])


@dataclass(frozen=True, eq=False)
class _Scaled:
    """The rows' loops in the scaled states."""

    modes: list  # per row: (M_int, M_leak)
    W: list  # per row: E·diag(bounds) (scaled) and the residual a as the last column
    k: list  # per row: command form over [ξ; d] (ξ scaled)
    h: np.ndarray  # x̂⁺ over [ξ; d] (ξ scaled)


def _scaled(data: LoopData) -> _Scaled:
    S = _scales(data)
    n = data.n_states
    modes, W, ks = [], [], []
    h = None
    for cell in data.cells:
        Mi, Ml, E, a, k, xh = _row_loop(data, cell)
        modes.append(((Mi * S) / S[:, None], (Ml * S) / S[:, None]))
        W.append(np.column_stack([(E * _bounds(data, cell)) / S[:, None], a / S]))
        kk = k.copy()
        kk[:n] *= S
        ks.append(kk)
        h = xh.copy()
        h[:n] *= S
    assert h is not None
    return _Scaled(modes, W, ks, h)


def _solve_lyapunov(sc: _Scaled, data: LoopData, lam: float):
    """P of the common quadratic V (scaled states) with MᵀPM ≼ λP for all rows and modes,
    the disturbance energy of the rows at the hold minimised; None where infeasible."""
    import cvxpy as cp  # deferred: cvxpy loads its solvers (~1 s)

    n = data.n_states
    P = cp.Variable((n, n), symmetric=True)
    ex = np.zeros((n, 1))
    ex[2, 0] = 1.0
    cons = [P >> 1e-6 * np.eye(n), cp.bmat([[P, ex], [ex.T, np.ones((1, 1))]]) >> 0]
    seen = set()
    for Mi, Ml in sc.modes:
        for M in (Mi, Ml):
            key = M.round(12).tobytes()
            if key in seen:
                continue
            seen.add(key)
            blk = cp.bmat([[lam * P, M.T @ P], [P @ M, P]])
            cons.append(0.5 * (blk + blk.T) >> 0)
    near = [j for j, c in enumerate(data.cells) if _holds_rest(c, data)]
    obj = sum(cp.trace(sc.W[j].T @ P @ sc.W[j]) for j in near)
    prob = cp.Problem(cp.Minimize(obj), cons)
    try:
        prob.solve(solver=cp.CLARABEL)
    except cp.error.SolverError:
        return None
    if prob.status not in ("optimal", "optimal_inaccurate") or P.value is None:
        return None
    Pv = 0.5 * (P.value + P.value.T)
    return Pv


def _holds_rest(cell: dict, data: LoopData) -> bool:
    lo, hi = cell["lower"], cell["upper"]
    return bool(lo[0] <= data.hold_pressure <= hi[0] and lo[1] <= 0.0 <= hi[1])


def _levels(P: np.ndarray, sc: _Scaled, data: LoopData, lam: float) -> dict[str, Any]:
    """ρ_j, ρ₁, c_U, c_R, ē, the box and the reach time of a Lyapunov matrix (scaled states)."""
    n = data.n_states
    S = _scales(data)
    Pinv = np.linalg.inv(P)
    iI = 5 + data.delay_samples

    def pnorm(w):
        return float(np.sqrt(max(w @ P @ w, 0.0)))

    h_x = sc.h[:n]
    eI = _unit(n, iI) * data.sample_time / S[iI]  # the hold's I-increment per unit x̂⁺ [SI]
    rho1 = pnorm(eI) * float(np.sqrt(h_x @ Pinv @ h_x))
    rho = np.empty(len(data.cells))
    for j, Wj in enumerate(sc.W):
        hold_noise = pnorm(eI) * abs(sc.h[n + 1]) * data.bounds["x_noise"]
        rho[j] = sum(pnorm(Wj[:, i]) for i in range(Wj.shape[1])) + hold_noise
    kappa = 1.0 - math.sqrt(lam) - rho1
    out: dict[str, Any] = {"rho": rho, "rho_hold": rho1, "kappa": kappa}
    if kappa <= 0:
        return out | {"status": CertificateStatus.NO_BOUND}
    cj = (rho / kappa) ** 2
    min_v = np.array([_min_level(c, Pinv, S, data) for c in data.cells])
    contributing = min_v < (1 + MARGIN) ** 2 * cj
    c_u0 = float(cj[contributing].max()) if contributing.any() else 0.0
    c_u = (1 + MARGIN) ** 2 * c_u0
    c_r = _region_level(Pinv, sc, data, S)
    e_bar = math.sqrt(c_u * Pinv[2, 2]) * S[2]
    out |= {
        "level_ultimate": c_u,
        "level_region": c_r,
        "e_bar": e_bar,
        "contributing": contributing,
    }
    if not c_r > c_u:
        return out | {"status": CertificateStatus.EMPTY_REGION}
    gamma = 1.0 - kappa * MARGIN / (1 + MARGIN)
    steps = math.ceil(math.log(math.sqrt(c_u / c_r)) / math.log(gamma))
    box = _inscribed_box(P, S, data, c_r)
    return out | {
        "status": CertificateStatus.CERTIFIED,
        "reach_time": steps * data.sample_time,
        "box": box,
    }


def _min_level(cell: dict, Pinv: np.ndarray, S: np.ndarray, data: LoopData) -> float:
    """A lower bound of V over the row's box: its faces in P_L and ẋ that exclude the hold."""
    best = 0.0
    for i, ref in ((0, data.hold_pressure), (1, 0.0)):
        lo, hi = cell["lower"][i] - ref, cell["upper"][i] - ref
        if lo > 0 or hi < 0:
            dist = min(abs(lo), abs(hi)) / S[i]
            best = max(best, dist**2 / Pinv[i, i])
    return best


def _region_level(Pinv, sc: _Scaled, data: LoopData, S) -> float:
    """The largest c with every row's command inside its saturation-free range, the velocity
    inside the friction fit and P_L inside the cells, for all states with V ≤ c."""
    n = data.n_states
    b = data.bounds
    levels = []
    for k in sc.k:
        noise = abs(k[n + 1]) * b["x_noise"] + abs(k[n + 2]) * b["p_noise"]
        room = data.command_limit - noise
        levels.append(max(room, 0.0) ** 2 / float(k[:n] @ Pinv @ k[:n]))
    levels.append((data.velocity_limit / S[1]) ** 2 / Pinv[1, 1])
    p_lo = max(c["lower"][0] for c in data.cells) - data.hold_pressure
    p_hi = min(c["upper"][0] for c in data.cells) - data.hold_pressure
    levels.append((min(-p_lo, p_hi) / S[0]) ** 2 / Pinv[0, 0])
    return float(min(levels))


def start_map(data: LoopData) -> np.ndarray:
    """T (n × 3, SI): the loop's start state ξ₀ = T·[e, ẋ, ΔP_L] (x̂ = x, v̂ = 0, P̄_L = P_L,
    I = 0, the valve closed and nothing pending), e the position error x − r."""
    n = data.n_states
    nd = data.delay_samples
    T = np.zeros((n, 3))
    T[2, 0] = 1.0
    T[7 + nd, 0] = 1.0
    T[1, 1] = 1.0
    T[0, 2] = 1.0
    if data.washout > 0:
        T[6 + nd, 2] = 1.0
    return T


def _inscribed_box(P, S, data: LoopData, c_r: float) -> tuple[float, float, float]:
    """The largest box of :data:`REGION_SHAPE`'s aspect whose start states have V ≤ c_r."""
    T = start_map(data) / S[:, None]
    D = T * np.array(REGION_SHAPE)
    Q = D.T @ P @ D
    worst = max(float(s @ Q @ s) for s in _corners())
    scale = math.sqrt(c_r / worst)
    return tuple(float(scale * r) for r in REGION_SHAPE)  # type: ignore[return-value]


def _corners() -> list[np.ndarray]:
    return [np.array([a, b, c], float) for a in (-1, 1) for b in (-1, 1) for c in (-1, 1)]


#: the law's elements outside the certified model (listed in every certificate)
NOT_MODELLED = (
    "quiet_open (the band's opening delay)",
    "feed-forward (zero at rest; the certificate is for a hold)",
    "parameter and supply-pressure draws (nominal machine)",
    "sensor noise beyond 4 sigma",
    "the rows outside the hold's pressure cells (the region keeps P_L inside them)",
)


def _failing_rows(sc: _Scaled, data: LoopData) -> tuple[str, ...]:
    """Rows whose loop is unstable alone (spectral radius ≥ 1 in a mode), else all rows."""
    bad = tuple(
        c["label"] or f"row {j}"
        for j, (c, (Mi, Ml)) in enumerate(zip(data.cells, sc.modes, strict=True))
        if max(np.abs(np.linalg.eigvals(Mi)).max(), np.abs(np.linalg.eigvals(Ml)).max()) >= 1.0
    )
    return bad


def certify(
    controller,
    model,
    *,
    delay_samples: int | None = None,
    sensor_noise: dict | None = None,
) -> Certificate:
    """Certify a state-feedback loop at a hold: an ultimate bound ē and a region of attraction.

    Parameters
    ----------
    controller : StateFeedbackController
        The law (a ``control design`` file, :func:`load_controller`).
    model : PwaModel
        The machine's PWA model (:func:`~hydropwa.linearization.linearize` of its parameters).
    delay_samples : int, optional
        Samples of delay between computation and valve (default: the file's, 0 or 1).
    sensor_noise : mapping, optional
        Standard deviations {"x" [m], "p_a", "p_b" [Pa]} (default: the default design's).

    Returns
    -------
    Certificate
        ``success`` is the independent checker's verdict.

    Notes
    -----
    The conditions (module docstring): MᵀPM ≼ λP for every row's integrate and leak modes;
    √V⁺ ≤ (√λ + ρ₁)√V + ρ_j; c_U = (1 + m)²·max c_j over the rows not separated from the
    hold; ē = √(c_U (P⁻¹)ₓₓ) [m]; c_R the largest level free of saturation.
    """
    from ._certcheck import check_certificate  # deferred: the independent checker

    data = loop_data(controller, model, delay_samples=delay_samples, sensor_noise=sensor_noise)
    sc = _scaled(data)
    hashes = {"model_hash": _hash(model.params.to_dict()), "law_hash": law_hash(controller)}
    best = None
    failing = _failing_rows(sc, data)
    status = CertificateStatus.NO_LYAPUNOV
    for lam in () if failing else _LAMBDAS:
        P = _solve_lyapunov(sc, data, lam)
        if P is None:
            continue
        lv = _levels(P, sc, data, lam)
        if best is None or (lv["status"].success and lv["e_bar"] < best[1].get("e_bar", math.inf)):
            best = (lam, lv, P)
        status = lv["status"] if not (best and best[1]["status"].success) else best[1]["status"]
    if best is None or not best[1]["status"].success:
        lv = best[1] if best is not None else {}
        if best is None:
            failing = failing or ("all rows (no common P)",)
        return _failed(status, data, failing, hashes, lv, lam=best[0] if best else math.nan)
    lam, lv, P = best
    cert = Certificate(
        status=CertificateStatus.CERTIFIED,
        success=False,
        message="",
        e_bar=lv["e_bar"],
        box=lv["box"],
        reach_time=lv["reach_time"],
        P=P,
        scales=_scales(data),
        lam=lam,
        level_ultimate=lv["level_ultimate"],
        level_region=lv["level_region"],
        rho=lv["rho"],
        rho_hold=lv["rho_hold"],
        disturbance=dict(data.bounds),
        failing_rows=(),
        not_modelled=NOT_MODELLED,
        data=data,
        **hashes,
    )
    check = check_certificate(cert, data)
    st = CertificateStatus.CERTIFIED if check.passed else CertificateStatus.CHECK_FAILED
    msg = st.message if check.passed else f"{st.message}: {'; '.join(check.failures[:3])}"
    return _replace(cert, status=st, success=check.passed, message=msg, check=check)


def _replace(cert: Certificate, **kw) -> Certificate:
    import dataclasses

    return dataclasses.replace(cert, **kw)


def _failed(status, data, failing, hashes, lv, lam: float) -> Certificate:
    n = data.n_states
    msg = status.message
    if status is CertificateStatus.NO_BOUND:
        msg += (
            f"; the integral hold's share ρ₁ = {lv['rho_hold']:.3g} exceeds the contraction "
            f"1 − √λ = {1 - math.sqrt(lam):.3g} (λ = {lam})"
        )
    return Certificate(
        status=status,
        success=False,
        message=msg,
        e_bar=math.inf,
        box=(0.0, 0.0, 0.0),
        reach_time=math.inf,
        P=np.zeros((n, n)),
        scales=_scales(data),
        lam=lam,
        level_ultimate=float(lv.get("level_ultimate", math.inf)),
        level_region=float(lv.get("level_region", 0.0)),
        rho=np.asarray(lv.get("rho", np.zeros(len(data.cells)))),
        rho_hold=float(lv.get("rho_hold", math.nan)),
        disturbance=dict(data.bounds),
        failing_rows=tuple(failing),
        not_modelled=NOT_MODELLED,
        data=data,
        **hashes,
    )


def write_certificate(path, cert: Certificate, *, overwrite: bool = False):
    """Write ``cert`` as the ``[certificate]`` table into the controller file ``path``
    (atomically); a file that has one already is refused without ``overwrite``."""
    import tomllib  # deferred: the file is read only here
    from pathlib import Path

    import tomli_w

    from .._io import atomic_write_text, read_text

    path = Path(path)
    text = read_text(path, "controller file", ControlError)
    doc = json.loads(text) if path.suffix.lower() == ".json" else tomllib.loads(text)
    if "certificate" in doc and not overwrite:
        raise ControlError(f"{path} holds a [certificate] already; give --force to replace it")
    doc["certificate"] = cert.to_dict()
    out = json.dumps(doc, indent=2) + "\n" if path.suffix.lower() == ".json" else tomli_w.dumps(doc)
    return atomic_write_text(path, out)
