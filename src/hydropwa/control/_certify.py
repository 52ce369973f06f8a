"""A certificate for a state-feedback loop at a hold: an ultimate bound ē and a region of attraction.

:func:`certify` writes the file's law at a hold (the reference at rest) as a switched linear
loop with bounded disturbances, one linear loop per gain row, and searches a common quadratic
Lyapunov function V(ξ) = ξᵀPξ for it with cvxpy and Clarabel. The verdict is not the
solver's: :func:`~hydropwa.control._certcheck.check_certificate`, which shares no code with
this module, rebuilds every matrix from the raw data and re-checks every inequality in float64.

The certified loop (per gain row j, state ξ = [P_L, ẋ, x, ν, ν̇, c_pend…, I, P̄_L, x̂, v̂] as
deviations from the hold, x the position error):

* the row's PWA plant (:meth:`~hydropwa.linearization.PwaModel.state_space` at a small
  opening) at both ends of the region's load-pressure range (the flow gain ∝ √Δp is monotone
  in P_L: two vertices), the servo valve of Eq. (1) in series, a zero-order hold and
  ``delay_samples`` samples of delay;
* the friction as its viscous slope b plus a bounded force, |F_f(ẋ) − b ẋ| ≤ F_s (the
  Stribeck drop and Coulomb's force as a disturbance, not the unstable falling branch), which
  is also passive: it opposes ẋ (an S-procedure term τ·F·ẋ, :data:`SECTOR_FRICTION`, off:
  not sound in the sampled loop near ẋ = 0);
* the law's linear part: washout, position observer, the row's gains, the integral in its
  two modes (integrate, and the leak where the valve is parked) as vertices;
* bounded disturbances: the plant's residual at the hold, the sensor noise within
  :data:`NOISE_SIGMAS` standard deviations, the quiet band as a dead zone (|δ| ≤ q and
  δ(δ + c) ≤ 0, sector [0, 1]: a term σ·(qd² + dc), :data:`SECTOR_BAND`), its vent's second
  q, the dead-zone inverse's blend (≤ z_w + creep) and its offset's error against the
  machine's dead band.

An invariant ellipsoid: P and multipliers μ ≥ 0 with [M W]ᵀP[M W] ≼ diag(λP, diag μ),
Σμ ≤ 1 − λ for every row, pressure vertex and integral mode (W the disturbance columns times
their bounds) give V⁺ − 1 ≤ λ(V − 1) for every disturbance in its box (the S-procedure).
𝒰 = {V ≤ (1 + m)²}, ē = (1 + m)·√((P⁻¹)ₓₓ); the region 𝓡 = {V ≤ c_R} keeps every row's
command out of saturation, the velocity inside the friction fit and P_L inside the hold's
pressure cells; it is reported as its largest box of (e, ẋ, ΔP_L) of :data:`REGION_SHAPE`'s
aspect with the controller's start values (x̂ = x, v̂ = 0, P̄_L = P_L, I = 0), with the
reach time log((c_U − 1)/(c_R − 1))/log λ samples.

The integral band's hold (I frozen while |e| > e_I and the valve is open) is not certified:
it leaves a line of rest points on which no quadratic function decreases
(:attr:`CertificateStatus.INTEGRAL_HOLD`).

Not in the certified model (:data:`NOT_MODELLED`, listed in every certificate): the opening
delay ``quiet_open``, the feed-forward (zero at rest), the verification's parameter and
supply-pressure draws, the Ṗ_L row's error between the pressure vertices and to the full
model (no one-step soundness check on the full model yet).
"""

from __future__ import annotations

import dataclasses
import enum
import hashlib
import json
import math
import tomllib
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import tomli_w

from .._io import atomic_write_text, read_text
from ._controllers import ControlError, StateFeedbackController

__all__ = [
    "CertificateStatus",
    "Certificate",
    "LoopData",
    "certify",
    "certify_data",
    "loop_data",
    "NOISE_SIGMAS",
    "REGION_SHAPE",
]

#: sensor noise bound in standard deviations: the certificate holds for |n| ≤ 4σ (a Gaussian
#: sample leaves it with probability 6e-5)
NOISE_SIGMAS = 4.0
#: the box the region is reported as, scaled: position error 20 mm, velocity 100 mm/s, 30 bar
REGION_SHAPE = (20e-3, 0.1, 30e5)
#: contraction rates of V tried (per sample; the rows' slowest loop mode is ≈ 0.995, so
#: λ ≥ 0.990); one rate keeps a certificate within a minute on two cores
_LAMBDAS = (0.995,)
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
    INTEGRAL_HOLD = (
        False,
        "the integral band holds I while |e| > e_I with the valve open: the loop then has a "
        "line of rest points (x̂ = k_i·I/k_x) on which no quadratic function decreases; it is "
        "left only through the quiet band's leak, which this certificate does not model. "
        "Certify the law without the band (integral_band = 0)",
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
        Per gain row and pressure vertex (two per row): ``label``, continuous ``A`` (3 × 3)
        and ``B`` (3,) of the cell at a small opening with the opening as input and the
        viscous friction slope, the affine residual ``f0`` (3,) at the hold [Pa/s, m/s², m/s],
        ``error_bound`` [Pa/s] (a bound on the Ṗ_L row's error; 0, see the module's list of
        what is not modelled), the row's ``gains`` and box ``lower``/``upper`` over
        [P_L, ẋ, x, c].
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
    integral_band : float
        e_I [m] of the integral's band (0: none).
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
    integral_band: float
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
    mu : tuple of ndarray
        The S-procedure multipliers per row and mode (the acting disturbance columns).
    tau : tuple of float
        The friction sector's multiplier per row and mode (τ·F·ẋ, F·ẋ ≤ 0; empty without it).
    sigma : tuple of float
        The quiet band's sector multiplier per row and mode (σ·(δ² + δc)/q, δ(δ + c) ≤ 0).
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
    mu: tuple
    disturbance: dict
    failing_rows: tuple[str, ...]
    not_modelled: tuple[str, ...]
    model_hash: str
    law_hash: str
    check: Any = None
    data: LoopData | None = field(default=None, repr=False)
    tau: tuple = ()
    sigma: tuple = ()

    def summary(self) -> str:
        """One paragraph: verdict, ē, the region's box and the reach time."""
        head = f"certificate: {'certified' if self.success else 'NOT certified'} ({self.message})"
        if not self.success:
            rows = ", ".join(self.failing_rows[:8]) + (" …" if len(self.failing_rows) > 8 else "")
            bound = (
                f"\n  ultimate bound ē = {self.e_bar * 1e3:.3f} mm (not certified)"
                if np.isfinite(self.e_bar)
                else ""
            )
            return head + bound + (f"\n  failing rows: {rows}" if rows else "")
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
                    "tau": [float(t) for t in self.tau],
                    "sigma": [float(t) for t in self.sigma],
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


#: the opening [1] at which a row's flow gain is taken (the hold's neighbourhood: the
#: pressure-flow coefficient ∝ opening is then nearly 0, as it is at the hold)
SMALL_OPENING = 0.01


def _row_cells(model, row, prm, hold_pressure: float, p_range) -> list[dict]:
    """The certified plants of one gain row: its cell with viscous friction at both ends of
    the region's load-pressure range (the flow gain ∝ √Δp is monotone in P_L, so the two ends
    bound it), and the affine residual at the hold."""
    lo, hi = np.array(row.lower, float), np.array(row.upper, float)
    s = 1.0 if hi[3] > 0 else -1.0
    v_mid = 0.5 * (max(lo[1], model.friction.interval[0]) + min(hi[1], model.friction.interval[1]))
    gains = {
        k: float(getattr(row, k)) for k in ("k_pl", "k_v", "k_x", "k_i", "k_nu", "k_dnu", "k_up")
    }
    out = []
    for end, p_l in (("low", p_range[0]), ("high", p_range[1])):
        g = int(model.dead_zone.cell(0.5 * s))
        k_g, o_g = float(model.dead_zone.slopes[g]), float(model.dead_zone.offsets[g])
        u = (s * SMALL_OPENING - o_g) / k_g  # the valve command of a small opening
        dyn = model.state_space({"p_l": p_l, "v": v_mid, "u": u})
        A = dyn.A.copy()
        A[1, 1] = -prm.friction.viscous / prm.load.mass  # the rest of the friction is bounded
        at_hold = model.state_space({"p_l": hold_pressure, "v": 0.0, "u": u})
        # residual of Ṗ_L at the hold with the valve closed (c = 0: u = −o_g/k_g)
        y = np.array([hold_pressure, 0.0, at_hold.point["x"]])
        f0 = at_hold.A[0] @ y + at_hold.f[0] - at_hold.B[0, 0] * o_g / k_g
        out.append(
            {
                "label": f"{row.label} P_L {end}",
                "A": A,
                "B": dyn.B[:, 0] / k_g,
                "f0": np.array([f0, 0.0, 0.0]),
                # the Ṗ_L row is the kernel's Jacobian at the vertex, exact there; the cell's
                # guaranteed bound holds over its whole box (c up to 1: 2500 bar/s on the
                # paper rig) and is not what a hold sees, so no bound is claimed here
                "error_bound": 0.0,
                "gains": gains,
                "lower": lo,
                "upper": hi,
            }
        )
    return out


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
    # the band's dead zone (sector [0, 1], |δ| ≤ q) apart from the rest: the vent's second q,
    # the inverse's blend z_w and the creep
    # and the inverse's offset against the machine's dead band (a wrong offset opens or
    # closes the valve by the difference at every command)
    command = q + z_w + prm.dead_zone.creep_slope * (z_w + beta) + abs(beta - _machine_offset(prm))
    bounds = {
        "friction": float(max(prm.friction.static, prm.friction.coulomb)),
        "x_noise": NOISE_SIGMAS * float(noise.get("x", 0.0)),
        "p_noise": NOISE_SIGMAS * p_noise,
        "command": float(command),
        "band": float(q),
    }
    # the rows whose pressure range holds the hold's P_L: the region keeps P_L inside the
    # intersection of their ranges, so no other row is ever active in it
    rows = [r for r in controller.rows if r.lower[0] <= hold_p <= r.upper[0]]
    if not rows:
        raise ControlError(
            f"no gain row's load-pressure range holds the hold's P_L {hold_p / 1e5:.4g} bar"
        )
    p_range = (max(r.lower[0] for r in rows), min(r.upper[0] for r in rows))
    cells = tuple(c for r in rows for c in _row_cells(model, r, prm, hold_p, p_range))
    washout = (
        math.exp(-ts / controller.pressure_washout) if controller.pressure_washout > 0 else 0.0
    )
    leak = math.exp(-ts / dz.integral_leak) if dz is not None and dz.integral_leak > 0 else 1.0
    return LoopData(
        cells=cells,
        sample_time=ts,
        omega0=float(prm.valve.omega0_at(0.0)),  # the hold's small amplitude (Table II)
        zeta=float(prm.valve.zeta),
        delay_samples=nd,
        observer=(float(controller.position_observer[0]), float(controller.position_observer[1])),
        washout=washout,
        leak=leak,
        mass=float(prm.load.mass),
        bounds=bounds,
        hold_pressure=hold_p,
        integral_band=float(dz.integral_band if dz is not None else 0.0),
        velocity_limit=float(min(-model.friction.interval[0], model.friction.interval[1])),
        command_limit=float(controller.u_max - beta - command - q),
    )


def _machine_offset(prm) -> float:
    """The machine's outer-cell offset [1]: β, or β(1 − creep) with a continuous dead zone
    (what the inverse's ``offset`` is designed to be)."""
    dz = prm.dead_zone
    return float(dz.beta * (1.0 - dz.creep_slope) if dz.continuous else dz.beta)


#: disturbance components d of the loop, in the columns of E: friction force [N], position
#: noise [m], load-pressure noise [Pa], command perturbation [1], Ṗ_L model error [Pa/s]
_DIST = ("friction", "x_noise", "p_noise", "command", "error_bound", "band")
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
    cmd[n + 3] += 1.0  # the vent and the inverse's blend
    cmd[n + 5] += 1.0  # the quiet band's dead zone
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
    return np.array(
        [b["friction"], b["x_noise"], b["p_noise"], b["command"], cell["error_bound"], b["band"]]
    )


@dataclass(frozen=True, eq=False)
class _Scaled:
    """The rows' loops in the scaled states."""

    modes: list  # per row: (M_int, M_leak)
    W: list  # per row: E·diag(bounds) (scaled) and the residual a as the last column
    k: list  # per row: command form over [ξ; d] (ξ scaled)
    h: np.ndarray  # x̂⁺ over [ξ; d] (ξ scaled)
    bounds: list = field(default_factory=list)  # per row: the disturbances' magnitudes


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
    return _Scaled(modes, W, ks, h, [_bounds(data, c) for c in data.cells])


def _solve_lyapunov(sc: _Scaled, data: LoopData, lam: float, sectors: bool = True):
    """(P, μ) of the invariant ellipsoid {V ≤ 1} (scaled states): for every row and mode and
    every disturbance in its box, V⁺ − 1 ≤ λ(V − 1), i.e. [M W]ᵀP[M W] ≼ diag(λP, diag μ)
    with Σμ ≤ 1 − λ (the S-procedure of the bounded components); the ellipsoid's extent in
    x minimised. None where infeasible."""
    import cvxpy as cp  # deferred: cvxpy loads its solvers (~1 s)

    n = data.n_states
    P = cp.Variable((n, n), symmetric=True)
    t = cp.Variable()
    ex = np.zeros((n, 1))
    ex[2, 0] = 1.0
    cons = [
        P >> 1e-9 * np.eye(n),
        cp.bmat([[cp.reshape(t, (1, 1), order="C"), ex.T], [ex, P]]) >> 0,
    ]
    mus, taus, sigmas = [], [], []
    for modes, W, k_all, bounds in zip(sc.modes, sc.W, sc.k, sc.bounds, strict=True):
        kept = _kept(W)
        Wn = W[:, kept] / _OMEGA
        m = Wn.shape[1]
        for M in modes:
            mu = cp.Variable(m, nonneg=True)
            tau = cp.Variable(nonneg=True)
            blk = cp.bmat(
                [
                    [lam * P, np.zeros((n, m)), M.T @ P],
                    [np.zeros((m, n)), cp.diag(mu), Wn.T @ P],
                    [P @ M, P @ Wn, P],
                ]
            )
            if sectors and SECTOR_FRICTION and kept[0]:
                blk = blk + tau * _sector_form(n, m, 2 * n + m)
            sigma = cp.Variable(nonneg=True)
            if sectors and SECTOR_BAND and kept[5]:
                blk = blk + sigma * _band_form(n, kept, k_all, bounds, 2 * n + m)
            cons += [0.5 * (blk + blk.T) >> 0, cp.sum(mu) <= 1.0 - lam]
            mus.append(mu)
            taus.append(tau)
            sigmas.append(sigma)
    prob = cp.Problem(cp.Minimize(t), cons)
    try:
        with warnings.catch_warnings():  # "may be inaccurate": the checker decides, not the solver
            warnings.simplefilter("ignore", UserWarning)
            prob.solve(solver=cp.CLARABEL, max_iter=300)
    except cp.error.SolverError:
        return None
    if prob.status not in ("optimal", "optimal_inaccurate") or P.value is None:
        return None
    Pv = 0.5 * (P.value + P.value.T) / _OMEGA**2  # the LMI with W/ω holds for P/ω² with W
    mu_v = [np.maximum(np.asarray(mu.value, float), 0.0) for mu in mus]
    # the sector term τ·d_F·v of the problem in ξ/ω is τ/ω in ξ
    tau_v = [max(float(tau.value or 0.0), 0.0) / _OMEGA for tau in taus]
    # the band's term σ·(q d² + d·c) is written in c itself: the same σ in ξ
    sig_v = [max(float(sg.value or 0.0), 0.0) for sg in sigmas]
    return Pv, mu_v, tau_v, sig_v


#: friction as a passive term (issue 51): the whole force beyond the viscous slope opposes
#: the velocity, F·ẋ ≤ 0 (Coulomb and Stribeck alike), an S-procedure term τ·F·ẋ on top of
#: its bound |F| ≤ F_s. **Off**: in the sampled loop F is the force held over a sample and
#: ẋ the velocity at its start, and the one-step check on the full model finds F·ẋ > 0 in
#: half its samples near ẋ = 0 (the rod reverses within the sample), so the sector is not
#: sound there; it also bought only 0.3 % of ē on the paper rig
SECTOR_FRICTION = False


#: the quiet band as a dead zone (issue 51): its output is c − δ with δ of c's sign and
#: |δ| ≤ min(|c|, q), i.e. δ(δ + c) ≤ 0 for the disturbance δ = q·d added to c, an
#: S-procedure term σ·(q d² + d·c) on top of its bound
SECTOR_BAND = True


def _band_form(n: int, kept: np.ndarray, k_all: np.ndarray, bounds: np.ndarray, size: int):
    """The quadratic form of q·d_b² + d_b·c over [ξ/ω; d_kept; ·] (c the law's command before
    the band, k_all over [ξ scaled; d SI]; d_b the band's scaled disturbance, q its bound)."""
    nd = len(kept) - 1  # the residual column a is the last of W, not a disturbance of c
    idx = np.cumsum(kept) - 1
    ell = np.zeros(size)
    ell[:n] = _OMEGA * k_all[:n]
    for i in range(nd):
        if kept[i]:
            ell[n + idx[i]] += k_all[n + i] * bounds[i]
    b = n + idx[5]
    S = np.zeros((size, size))
    S[b, :] += 0.5 * ell
    S[:, b] += 0.5 * ell
    S[b, b] += bounds[5]
    return S


def _sector_form(n: int, m: int, size: int) -> np.ndarray:
    """The quadratic form of d_F·ẋ over [ξ; d; ·] (ẋ the state 1, d_F the first disturbance),
    symmetric: the S-procedure adds τ times it to diag(λP, μ) (d_F·ẋ ≤ 0 where it holds)."""
    S = np.zeros((size, size))
    S[1, n] = S[n, 1] = 0.5
    return S


#: disturbances are scaled by 1/ω in the SDP: its ellipsoid is then of order 1 (Clarabel fails
#: on the unscaled problem, whose P is ~1e-4)
_OMEGA = 100.0


def _kept(W: np.ndarray) -> np.ndarray:
    """The disturbance columns that act (a zero column makes its multiplier degenerate)."""
    return np.abs(W).max(axis=0) > 1e-12


def _levels(P: np.ndarray, mus, sc: _Scaled, data: LoopData, lam: float) -> dict[str, Any]:
    """ē, the region's level c_R, its box and the reach time of an invariant ellipsoid."""
    S = _scales(data)
    Pinv = np.linalg.inv(P)
    c_u = (1.0 + MARGIN) ** 2
    c_r = _region_level(Pinv, sc, data, S)
    e_bar = math.sqrt(c_u * Pinv[2, 2]) * S[2]
    out: dict[str, Any] = {"level_ultimate": c_u, "level_region": c_r, "e_bar": e_bar, "mu": mus}
    if not c_r > c_u:
        return out | {"status": CertificateStatus.EMPTY_REGION}
    steps = math.ceil(math.log((c_u - 1.0) / (c_r - 1.0)) / math.log(lam))
    return out | {
        "status": CertificateStatus.CERTIFIED,
        "reach_time": max(steps, 0) * data.sample_time,
        "box": _inscribed_box(P, S, data, c_r),
    }


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
    "the flow's curvature between the two pressure vertices and the PWA's error to the full "
    "model (error_bound 0 unless soundness_samples > 0: the one-step check on the full "
    "model, _certsound, measures it and grows the set from its samples, not exhaustively)",
    "the valve's omega0 schedule (Table II): the hold's small-amplitude omega0 is certified",
    "the chamber capacitance's change with the rod position (the PWA's capacitance position)",
    "the spool estimate's error (the valve model of Eq. (1) taken as exact: ν̂ = ν)",
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
    soundness_samples: int = 0,
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
    soundness_samples : int
        When > 0, the disturbance set is first checked one sample at a time on the full model
        over as many (state, command) pairs (:func:`~hydropwa.control._certsound.one_step_soundness`)
        and the Ṗ_L row's bound grown to what they need (0: the bound 0, not checked).

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
    data = loop_data(controller, model, delay_samples=delay_samples, sensor_noise=sensor_noise)
    if soundness_samples > 0:
        from ._certsound import grow, one_step_soundness  # deferred: it imports this module

        checked = one_step_soundness(controller, model, samples=soundness_samples, data=data)
        data = grow(data, checked)
    hashes = {"model_hash": _hash(model.params.to_dict()), "law_hash": law_hash(controller)}
    return certify_data(data, **hashes)


def certify_data(data: LoopData, **hashes: str) -> Certificate:
    """:func:`certify` on prepared loop data (its rows, bounds and modes as given: the
    negative controls and the tests' reduced loops); ``hashes`` model_hash, law_hash."""
    from ._certcheck import check_certificate  # deferred: the independent checker

    hashes = {"model_hash": "", "law_hash": ""} | hashes
    sc = _scaled(data)
    failing = _failing_rows(sc, data)
    if failing:
        return _failed(CertificateStatus.NO_LYAPUNOV, data, failing, hashes, {}, math.nan)
    if data.integral_band > 0:
        return _failed(CertificateStatus.INTEGRAL_HOLD, data, (), hashes, {}, math.nan)
    best = None
    for lam in _LAMBDAS:
        # the sector terms only widen the feasible set; where Clarabel fails on them (the
        # heavy axis: their multipliers are ~1e-5 of P's scale) the plain problem is tried
        sol = _solve_lyapunov(sc, data, lam) or _solve_lyapunov(sc, data, lam, sectors=False)
        if sol is None:
            continue
        lv = _levels(sol[0], sol[1], sc, data, lam) | {"tau": sol[2], "sigma": sol[3]}
        if best is None or lv["e_bar"] < best[1]["e_bar"]:
            best = (lam, lv, sol[0])
    if best is None:
        return _failed(
            CertificateStatus.NO_LYAPUNOV,
            data,
            ("all rows (no common P)",),
            hashes,
            {},
            math.nan,
        )
    if not best[1]["status"].success:
        return _failed(best[1]["status"], data, (), hashes, best[1], best[0])
    lam, lv, P = best
    cert = _unchecked(data, P, lam, lv, not_modelled=NOT_MODELLED, **hashes)
    check = check_certificate(cert, data)
    st = CertificateStatus.CERTIFIED if check.passed else CertificateStatus.CHECK_FAILED
    msg = st.message if check.passed else f"{st.message}: {'; '.join(check.failures[:3])}"
    return _replace(cert, status=st, success=check.passed, message=msg, check=check)


def _unchecked(data, P, lam: float, lv: dict, **given: Any) -> Certificate:
    """The certificate the levels ``lv`` of P at rate ``lam`` give, before the checker ran
    (status from the levels, ``success`` False until :func:`check_certificate` says so)."""
    fields: dict[str, Any] = {
        "not_modelled": (),
        "model_hash": "",
        "law_hash": "",
        **given,
    }
    return Certificate(
        status=lv["status"],
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
        mu=tuple(lv["mu"]),
        tau=tuple(lv.get("tau", ())),
        sigma=tuple(lv.get("sigma", ())),
        disturbance=_disturbance(data),
        failing_rows=(),
        data=data,
        **fields,
    )


def _disturbance(data: LoopData) -> dict:
    """The disturbance terms of the table (SI): the bounds and the cells' largest Ṗ_L bound."""
    return dict(data.bounds) | {"p_l_rate": max(float(c["error_bound"]) for c in data.cells)}


def _replace(cert: Certificate, **kw) -> Certificate:
    return dataclasses.replace(cert, **kw)


def _failed(status, data, failing, hashes, lv, lam: float) -> Certificate:
    n = data.n_states
    msg = status.message
    return Certificate(
        status=status,
        success=False,
        message=msg,
        # the ellipsoid's bound where one was found (its region empty), else inf
        e_bar=float(lv.get("e_bar", math.inf)),
        box=(0.0, 0.0, 0.0),
        reach_time=math.inf,
        P=np.zeros((n, n)),
        scales=_scales(data),
        lam=lam,
        level_ultimate=float(lv.get("level_ultimate", math.inf)),
        level_region=float(lv.get("level_region", 0.0)),
        mu=(),
        disturbance=_disturbance(data),
        failing_rows=tuple(failing),
        not_modelled=NOT_MODELLED,
        data=data,
        **hashes,
    )


def write_certificate(path, cert: Certificate, *, overwrite: bool = False):
    """Write ``cert`` as the ``[certificate]`` table into the controller file ``path``
    (atomically); a file that has one already is refused without ``overwrite``."""
    path = Path(path)
    text = read_text(path, "controller file", ControlError)
    doc = json.loads(text) if path.suffix.lower() == ".json" else tomllib.loads(text)
    if "certificate" in doc and not overwrite:
        raise ControlError(f"{path} holds a [certificate] already; give --force to replace it")
    doc["certificate"] = cert.to_dict()
    out = json.dumps(doc, indent=2) + "\n" if path.suffix.lower() == ".json" else tomli_w.dumps(doc)
    return atomic_write_text(path, out)
