"""Discrete position controllers as frozen, validated objects that pack for the compiled loop.

Every controller runs at a fixed sample time with a zero-order hold, an optional
one-sample computation delay, valve-command saturation and anti-windup, and an
optional dead-zone inverse; :meth:`pack` gives the float vector that
:func:`hydropwa.simulation._controller.controller_sample` evaluates inside the
integrator, so ``simulate(model, controller=..., reference=...)`` calls no Python
per sample.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .._errors import HydropwaError
from ..simulation import _controller as C

__all__ = [
    "ControlError",
    "DeadZoneInverse",
    "FlowFeedForward",
    "SpoolModel",
    "PIController",
    "GainRow",
    "StateFeedbackController",
    "ANTI_WINDUP",
    "MACHINE_KEYS",
    "position_observer_gains",
    "spool_filter_gain",
    "SPOOL_COMMAND_NOISE",
    "machine_of",
    "DEFAULT_SAMPLE_TIME",
]

#: 2 kHz, the rig's real-time target (Sec. V of the paper).
DEFAULT_SAMPLE_TIME = 5e-4
ANTI_WINDUP = {"none": C.AW_NONE, "clamp": C.AW_CLAMP, "back-calculation": C.AW_BACK}
#: the controlled output (``output``): the reference and the error are in its unit
OUTPUTS = {"position": C.OUT_POSITION, "force": C.OUT_FORCE, "pressure": C.OUT_PRESSURE}
#: SI unit of each output's reference
OUTPUT_UNITS = {"position": "m", "force": "N", "pressure": "Pa"}
#: scales [Pa, m/s, m, 1] of the distance to a gain row's box (1 bar, 1 mm/s, 1 mm, 1 %)
BOX_SCALES = (1e5, 1e-3, 1e-3, 1e-2)
#: the machine a controller was designed for (SI): piston areas, stroke, design supply pressure
MACHINE_KEYS = ("area_a", "area_b", "stroke", "supply_pressure")


def machine_of(params, supply_pressure: float | None = None) -> dict[str, float]:
    """The :data:`MACHINE_KEYS` of a parameter set (SI)."""
    cyl = params.cylinder
    ps = params.supply.pressure if supply_pressure is None else supply_pressure
    return {
        "area_a": float(cyl.area_a),
        "area_b": float(cyl.area_b),
        "stroke": float(cyl.stroke),
        "supply_pressure": float(ps),
    }


class ControlError(HydropwaError, ValueError):
    """A controller, reference or design request that cannot be used as given."""


def position_observer_gains(
    sample_time: float, position_noise: float, acceleration_noise: float
) -> tuple[float, float]:
    """Steady-state Kalman gains (L_x [1], L_v [1/s]) of the position observer.

    Model: x⁺ = x + T v + T²/2 (r̈ + w), v⁺ = v + T (r̈ + w), measured x + n, with the
    acceleration deviation w ~ N(0, ``acceleration_noise``² [m²/s⁴]) and the position noise
    n ~ N(0, ``position_noise``² [m²]). The filter (measurement-update) gain
    L = P Cᵀ (C P Cᵀ + R)⁻¹, P the a-priori covariance of the discrete Riccati equation.
    """
    if not (position_noise > 0 and acceleration_noise > 0 and sample_time > 0):
        raise ControlError(
            "position_observer_gains needs a positive sample time [s], position noise [m] and "
            "acceleration noise [m/s²]"
        )
    T = float(sample_time)
    A = np.array([[1.0, T], [0.0, 1.0]])
    G = np.array([[0.5 * T * T], [T]])
    Cm = np.array([[1.0, 0.0]])
    Q = G @ G.T * acceleration_noise**2
    R = np.array([[position_noise**2]])
    L, _ = kalman_gain(A, Cm, Q, R)
    return float(L[0, 0]), float(L[1, 0])


def kalman_gain(phi, h, q, r):
    """Steady-state filter gain L = P Hᵀ(H P Hᵀ + R)⁻¹ and the a-priori covariance P.

    P solves the discrete Riccati equation P = Φ P Φᵀ − Φ P Hᵀ(H P Hᵀ + R)⁻¹ H P Φᵀ + Q.
    """
    from scipy.linalg import solve_discrete_are  # deferred: scipy.linalg costs 0.1-0.5 s

    P = solve_discrete_are(phi.T, h.T, q, r)
    L = P @ h.T @ np.linalg.inv(h @ P @ h.T + r)
    return L, P


def _finite(
    obj, name: str, unit: str, *, gt: float | None = None, ge: float | None = None
) -> float:
    v = getattr(obj, name)
    if isinstance(v, bool) or not isinstance(v, int | float | np.floating | np.integer):
        raise ControlError(f"{type(obj).__name__}.{name} = {v!r} must be a number in {unit}")
    v = float(v)
    if not math.isfinite(v):
        raise ControlError(f"{type(obj).__name__}.{name} = {v} {unit} is not finite")
    if gt is not None and not v > gt:
        raise ControlError(f"{type(obj).__name__}.{name} = {v:g} {unit} must be > {gt:g}")
    if ge is not None and not v >= ge:
        raise ControlError(f"{type(obj).__name__}.{name} = {v:g} {unit} must be >= {ge:g}")
    object.__setattr__(obj, name, v)
    return v


#: the schema-2 elements of :class:`DeadZoneInverse` (fields beyond offset and width): written
#: to a file only where set, read as 0 where absent (the law without them)
DEAD_ZONE_V2 = (
    "hysteresis",
    "quiet_band",
    "integral_leak",
    "integral_band",
    "quiet_at_rest",
    "pre_open",
    "pressure_vent",
    "quiet_open",
)


@dataclass(frozen=True)
class DeadZoneInverse:
    """Inverse of the valve dead zone, Eq. (2) / Table IV, placed after the controller.

    Attributes
    ----------
    offset : float
        Outer-cell offset [1] of the dead zone (β, or β(1 − creep) if continuous).
    width : float
        Blend width z_w [1]: for |c| < z_w the inverse is the line through zero that
        meets u = c + offset·sign(c) at |c| = z_w (no ±offset switching near zero).
    hysteresis : float
        Band h [1] of the side of the dead zone (0: none; schema 2): the inverse keeps
        the side of the last command until c crosses the other side's −h, and a command on
        the other side within the band gives u = 0 (the middle of the dead zone, closed)
        (``dead_zone_hysteresis`` of the compiled law). Sized from the
        command noise, it keeps sensor noise from throwing the spool across the dead zone.
    quiet_band : float
        Quiet band q [1] of the command (0: none; schema 2): the opening asked for is 0 for
        |c| < q, sign(c)·2(|c| − q) for q ≤ |c| < 2q and c beyond (``quiet_band`` of the
        compiled law), before the inverse. Sized from the command's noise at a hold
        (:func:`~hydropwa.control.quiet_band_for`), it keeps the spool in the middle of the
        dead zone (closed) while the sensor noise alone moves the command.
    integral_leak : float
        Time constant T_l [s] of the integral's leak (0: none; schema 2): wherever the quiet
        band parks the valve (opening 0) the integral decays, I ← exp(−T_s/T_l)·I, instead of
        holding, so a hold ends with the valve parked and no standing offset k_i·I/k_x.
    integral_band : float
        Position-error band e_I [m] of the integral (0: none; schema 2): the integral runs only
        while |r − x| ≤ e_I, so the approach to a step's target (errors of millimetres) does
        not wind it into an undershoot that Stribeck friction then holds.
    quiet_at_rest : float
        1: the quiet band acts only while the reference is at rest (ṙ, the look-ahead ṙ_ff
        and r̈ all 0); 0 (schema 1 and earlier schema-2 files): always (schema 2). While the
        reference moves, a band only delays the breakaway from static friction at a
        profile's start (paper rig trapezoid: peak error 0.071 → 0.062 mm, docs/control.md).
    pre_open : float
        Look-ahead τ_o [s] of the pre-opening (0: none; schema 2): while the reference is at
        rest now (ṙ(t_k) = 0) but moves τ_o ahead (ṙ(t_k + τ_o) ≠ 0), the opening asked for
        is at least z_w toward the coming move (``pre_open`` of the compiled law), so the
        spool has crossed the dead zone (no flow yet) when the reference starts.
    pressure_vent : float
        Time constant T_p [s] of the pressure vent at rest (0: none; schema 2): where the
        quiet band parks the valve, the command's load-pressure share −k_pl·p_dev, low-passed
        with T_p, still opens it beyond 0.8 q (``pressure_vent`` of the compiled law), and the
        integral leaks wherever |c| < 2q. The pressure feedback so vents the load pressure a
        stop leaves in the closed chambers, which would otherwise relax through the friction
        law's creep and move the rod tens of µm (paper rig).
    quiet_open : float
        Opening delay n [samples] of the quiet band (0: none; schema 2; a whole number): where
        the band acts it opens the valve only on the n-th consecutive sample beyond q on one
        side, or at once where |e| > ``integral_band``, and reads c limited to ±q before
        (``quiet_open`` of the compiled law); with the pressure vent, the vent's share is 0
        where it points away from the target while |k_x e| > q (``vent_toward_target``);
        n ≤ 1 is the band without it. Sized from the command noise's correlation
        (:func:`~hydropwa.control.quiet_open_for`), it keeps the observer's correlated noise
        and the spool terms' alternating swings from opening the valve at a hold, while a
        real position error still opens it n − 1 samples later.
    """

    offset: float = 0.1
    width: float = 0.0
    hysteresis: float = 0.0
    quiet_band: float = 0.0
    integral_leak: float = 0.0
    integral_band: float = 0.0
    quiet_at_rest: float = 0.0
    pre_open: float = 0.0
    pressure_vent: float = 0.0
    quiet_open: float = 0.0

    def __post_init__(self) -> None:
        _finite(self, "offset", "1", ge=0.0)
        _finite(self, "width", "1", ge=0.0)
        _finite(self, "hysteresis", "1", ge=0.0)
        _finite(self, "quiet_band", "1", ge=0.0)
        _finite(self, "integral_leak", "s", ge=0.0)
        _finite(self, "integral_band", "m", ge=0.0)
        _finite(self, "pre_open", "s", ge=0.0)
        _finite(self, "pressure_vent", "s", ge=0.0)
        _finite(self, "quiet_open", "samples", ge=0.0)
        if self.quiet_open != math.floor(self.quiet_open):
            raise ControlError(
                f"DeadZoneInverse.quiet_open = {self.quiet_open:g} samples must be a whole number"
            )
        if self.quiet_at_rest not in (0.0, 1.0):
            raise ControlError(
                f"DeadZoneInverse.quiet_at_rest = {self.quiet_at_rest:g} must be 0 or 1 "
                "(1: the quiet band only while the reference is at rest)"
            )
        if self.offset >= 1.0:
            raise ControlError(
                f"DeadZoneInverse.offset = {self.offset:g} must be below 1 (a fraction of the stroke)"
            )

    @classmethod
    def from_params(cls, dead_zone, width: float | None = None) -> DeadZoneInverse:
        """Inverse of an identified :class:`~hydropwa.params.DeadZone` (Table IV cells).

        The default width makes the small-signal gain through the creep band one:
        creep·(z_w + β)/z_w = 1, i.e. z_w = creep·β/(1 − creep) (4.2e-3 for Table IV);
        without creep z_w = 0.01·β.
        """
        creep, beta = float(dead_zone.creep_slope), float(dead_zone.beta)
        if width is None:
            width = creep * beta / (1.0 - creep) if creep > 0.0 else 0.01 * beta
        return cls(offset=float(dead_zone.outer_offset), width=float(width))

    def __call__(self, c: float) -> float:
        """Valve command u [1] for the desired opening c [1]."""
        return float(C.dead_zone_inverse(float(c), self.offset, self.width))


@dataclass(frozen=True, kw_only=True)
class FlowFeedForward:
    """Velocity (flow) feed-forward per flow direction with its load-pressure correction.

    The opening that passes the reference's flow through the metering edges, Eqs. (5)/(6)
    inverted in quasi-steady flow at the measured load pressure:
    c_ff = A_A ṙ(t + τ)/(K √Δp(sign ṙ, P_L, P_S)), Δp the edge drop of
    :func:`~hydropwa.components._physics.load_flow_drop` (at least ``min_drop``). With
    ``reference_state`` the controller's velocity and load-pressure gains act on the
    deviation from the reference state [P_ref, ṙ]: c += k_v ṙ + k_pl P_ref, P_ref =
    (m r̈ + b ṙ)/A_A the pressure that accelerates the mass and drives the viscous
    friction (washed out like P_L): the acceleration/pressure feed-forward along the
    reference.

    Attributes
    ----------
    flow_coefficient : float
        K [m³/(s·√Pa)] per metering edge (Eq. (5)).
    transition_pressure : float
        Pressure [Pa] below which the root is linearised (``flow.transition_pressure``).
    area_a : float
        Piston area A_A [m²].
    area_ratio : float
        α = A_B/A_A [1].
    supply_pressure, tank_pressure : float
        P_S, P_T [Pa] the feed-forward inverts the flow at.
    min_drop : float
        Smallest edge drop [Pa] used in the inversion (default 2 % of P_S).
    lead : float
        Look-ahead τ [s] of ṙ: the sample's zero-order hold (T_s/2), the computation
        delay (T_s) and the servo valve's lag 2ζ/ω0 (Eq. (1)).
    reference_state : bool
        Whether the gains act on the deviation from the reference state.
    mass : float
        Moving mass m [kg] of P_ref.
    viscous : float
        Viscous friction slope b [N·s/m] of P_ref.
    """

    flow_coefficient: float
    transition_pressure: float
    area_a: float
    area_ratio: float
    supply_pressure: float
    tank_pressure: float = 0.0
    min_drop: float = 0.0
    lead: float = 0.0
    reference_state: bool = True
    mass: float = 0.0
    viscous: float = 0.0

    def __post_init__(self) -> None:
        _finite(self, "flow_coefficient", "m^3/(s*Pa^0.5)", gt=0.0)
        _finite(self, "transition_pressure", "Pa", ge=0.0)
        _finite(self, "area_a", "m^2", gt=0.0)
        _finite(self, "area_ratio", "1", gt=0.0)
        ps = _finite(self, "supply_pressure", "Pa", gt=0.0)
        _finite(self, "tank_pressure", "Pa")
        if self.min_drop == 0.0:
            object.__setattr__(self, "min_drop", 0.02 * ps)
        _finite(self, "min_drop", "Pa", gt=0.0)
        _finite(self, "lead", "s", ge=0.0)
        _finite(self, "mass", "kg", ge=0.0)
        _finite(self, "viscous", "N*s/m", ge=0.0)
        object.__setattr__(self, "reference_state", bool(self.reference_state))

    @classmethod
    def from_params(
        cls,
        params,
        *,
        sample_time: float = DEFAULT_SAMPLE_TIME,
        delay: bool = False,
        supply_pressure: float | None = None,
        reference_state: bool = True,
    ) -> FlowFeedForward:
        """The feed-forward of a parameter set; the look-ahead τ = T_s(½ + delay) + 2ζ/ω0."""
        v = params.valve
        return cls(
            flow_coefficient=float(params.flow.K),
            transition_pressure=float(params.flow.transition_pressure),
            area_a=float(params.cylinder.area_a),
            area_ratio=float(params.cylinder.area_b / params.cylinder.area_a),
            supply_pressure=float(
                params.supply.pressure if supply_pressure is None else supply_pressure
            ),
            tank_pressure=float(params.supply.tank_pressure),
            lead=float(sample_time * (0.5 + (1.0 if delay else 0.0)) + 2.0 * v.zeta / v.omega0),
            reference_state=reference_state,
            mass=float(params.load.mass),
            viscous=float(params.friction.viscous + params.load.damping),
        )

    def __call__(self, v_ff: float, p_l: float) -> float:
        """Opening c_ff [1] for the reference velocity v_ff [m/s] at load pressure p_l [Pa]."""
        ext = np.zeros(C.N_EXT)
        self._pack(ext)
        return float(C.flow_feedforward(ext, 0, float(v_ff), float(p_l), 0.0, 1.0, 1.0))

    def _pack(self, ext: np.ndarray) -> None:
        ext[C.X_FF] = 1.0
        ext[C.X_K] = self.flow_coefficient
        ext[C.X_PTR] = self.transition_pressure
        ext[C.X_AA] = self.area_a
        ext[C.X_ALPHA] = self.area_ratio
        ext[C.X_PS] = self.supply_pressure
        ext[C.X_PT] = self.tank_pressure
        ext[C.X_DPMIN] = self.min_drop
        ext[C.X_REFST] = 1.0 if self.reference_state else 0.0
        ext[C.X_MASS] = self.mass
        ext[C.X_BV] = self.viscous
        ext[C.X_LEAD] = self.lead

    def describe(self) -> dict[str, Any]:
        """Plain dict of every setting (SI)."""
        return {
            "flow_coefficient": self.flow_coefficient,
            "transition_pressure": self.transition_pressure,
            "area_a": self.area_a,
            "area_ratio": self.area_ratio,
            "supply_pressure": self.supply_pressure,
            "tank_pressure": self.tank_pressure,
            "min_drop": self.min_drop,
            "lead": self.lead,
            "reference_state": self.reference_state,
            "mass": self.mass,
            "viscous": self.viscous,
        }


#: process noise of the spool filter [1]: white noise on the opening the valve holds over a
#: sample, standing for what the linear valve model leaves out (ω0 that varies with the
#: amplitude and ±10 % between valves, the dead zone's blend). Paper rig, 0.2 % spool noise:
#: L = [0.25, 72/s] at 0.005, [0.61, 571/s] at 0.02, [0.91, 2007/s] at 0.1; on the full model's
#: trapezoid (20 µm / 0.1 bar, seeds 1-3) peak error 0.042-0.045 mm with each, hold p-p
#: 0.019-0.031 / 0.019-0.037 / 0.027-0.040 mm: a weak optimum, the middle kept
SPOOL_COMMAND_NOISE = 0.02


@dataclass(frozen=True)
class SpoolModel:
    """Discrete servo-valve model of the controller's spool estimate, Eq. (1) with ZOH at T_s.

    [ν̂, ν̂̇]_{k+1} = Φ [ν̂, ν̂̇]_k + Γ c_k, c_k the (saturated) opening command the
    valve holds over the sample; ν̂ in units of the opening c [1], ν̂̇ [1/s].

    Attributes
    ----------
    phi : tuple of 4 floats
        Φ row-major [1, s, 1/s, 1].
    gamma : tuple of 2 floats
        Γ [1, 1/s].
    measured : bool
        Feed back the valve's reported spool position (the full model's spool state)
        instead of the estimate (the estimate still runs; models without a spool state
        use it).
    gain : tuple of 2 floats
        With ``measured``: the steady-state Kalman gain (L_ν [1], L_ν̇ [1/s]) that corrects
        the model's prediction by the measured spool, ν̂ = ν̂⁻ + L_ν (ν_m − ν̂⁻) and
        ν̂̇ = ν̂̇⁻ + L_ν̇ (ν_m − ν̂⁻) (:func:`spool_filter_gain`, schema 2). (0, 0), the
        default, with ``measured``: an exact sensor, packed as that filter's limit σ_ν → 0,
        :attr:`exact_gain` = (1, Γ₂/Γ₁) (ν̂ = ν_m; ν̂̇ from the model, corrected).
    noise : dict
        The filter's design: ``{"spool": σ_ν [1], "command": σ_c [1]}`` (provenance).
    """

    phi: tuple[float, ...]
    gamma: tuple[float, ...]
    measured: bool = False
    gain: tuple[float, ...] = (0.0, 0.0)
    noise: dict = field(default_factory=dict, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "measured", bool(self.measured))
        gain = np.asarray(self.gain, dtype=float).ravel()
        if gain.size != 2 or not np.all(np.isfinite(gain)) or not 0.0 <= gain[0] <= 1.0:
            raise ControlError(
                "SpoolModel.gain must be (L_nu in [0, 1], L_dnu [1/s]), finite; (0, 0) for none"
            )
        if gain[0] > 0.0 and not self.measured:
            raise ControlError("SpoolModel.gain corrects a measured spool: set measured=True")
        object.__setattr__(self, "gain", (float(gain[0]), float(gain[1])))
        if not isinstance(self.noise, dict):
            raise ControlError("SpoolModel.noise must be a dict")
        phi = np.asarray(self.phi, dtype=float).ravel()
        gam = np.asarray(self.gamma, dtype=float).ravel()
        if (
            phi.size != 4
            or gam.size != 2
            or not (np.all(np.isfinite(phi)) and np.all(np.isfinite(gam)))
        ):
            raise ControlError("SpoolModel needs a finite 2x2 phi and a 2-vector gamma")
        object.__setattr__(self, "phi", tuple(float(v) for v in phi))
        object.__setattr__(self, "gamma", tuple(float(v) for v in gam))

    @classmethod
    def from_valve(cls, omega0: float, zeta: float, sample_time: float) -> SpoolModel:
        """ZOH discretisation of ν̈ = ω0² (c − ν) − 2ζω0 ν̇ (Eq. (1)) at the sample time [s]."""
        from scipy.linalg import expm  # deferred: scipy submodules cost 0.1-0.5 s at import

        M = np.zeros((3, 3))
        M[0, 1] = 1.0
        M[1, 0] = -(omega0**2)
        M[1, 1] = -2.0 * zeta * omega0
        M[1, 2] = omega0**2
        E = expm(M * sample_time)
        return cls(tuple(E[:2, :2].ravel()), tuple(E[:2, 2]))

    @property
    def exact_gain(self) -> tuple[float, float]:
        """The spool filter's gain for an exact sensor, the limit σ_ν → 0 of
        :func:`spool_filter_gain`: (1, Γ₂/Γ₁) [1, 1/s].

        With L_ν = 1 the error dynamics (I − L H) Φ have the eigenvalues 0 and
        Φ₂₂ − L_ν̇ Φ₁₂, and the cheap-sensor Kalman filter puts the second at the zero of the
        valve model's transfer H (zI − Φ)⁻¹ Γ, z₀ = Φ₂₂ − Φ₁₂ Γ₂/Γ₁ (tested against the
        Riccati solution): L_ν̇ = Γ₂/Γ₁. A target computes it from ``gamma`` in the file.
        """
        return 1.0, self.gamma[1] / self.gamma[0]

    @property
    def packed_gain(self) -> tuple[float, float]:
        """The gain the law runs: :attr:`gain`, or :attr:`exact_gain` for a measured spool
        without one (an exact sensor); (0, 0) for the estimate."""
        if self.measured and self.gain[0] <= 0.0:
            return self.exact_gain
        return self.gain[0], self.gain[1]

    @property
    def filtered(self) -> bool:
        """Whether the measured spool corrects the model through a filter gain (schema 2)."""
        return self.gain[0] > 0.0

    def with_filter(self, spool_noise: float, command_noise: float = SPOOL_COMMAND_NOISE):
        """This model fed by the measured spool: the steady-state Kalman filter of
        :func:`spool_filter_gain`; for ``spool_noise`` 0 (an exact sensor) no gain, which packs
        as its limit :attr:`exact_gain`."""
        if not (spool_noise >= 0.0 and math.isfinite(spool_noise)):
            raise ControlError(f"spool noise {spool_noise!r} must be a standard deviation >= 0")
        if spool_noise == 0.0:
            return dataclasses.replace(self, measured=True, gain=(0.0, 0.0), noise={})
        gain = spool_filter_gain(self.phi, self.gamma, spool_noise, command_noise)
        noise = {"spool": float(spool_noise), "command": float(command_noise)}
        return dataclasses.replace(self, measured=True, gain=gain, noise=noise)


def spool_filter_gain(
    phi, gamma, spool_noise: float, command_noise: float = SPOOL_COMMAND_NOISE
) -> tuple[float, float]:
    """Steady-state Kalman gain (L_ν [1], L_ν̇ [1/s]) of the spool estimate with the measured spool.

    Model: the discrete valve of Eq. (1) with ZOH at T_s, [ν, ν̇]⁺ = Φ [ν, ν̇] + Γ (c + w),
    w ~ N(0, ``command_noise``²) on the opening the valve holds; measured ν_m = ν + n,
    n ~ N(0, ``spool_noise``²) (in units of the opening). The filter (measurement-update)
    gain L = P Hᵀ (H P Hᵀ + R)⁻¹, H = [1, 0], P the a-priori covariance of the discrete
    Riccati equation (python-control's ``dlqe`` gives the predictor gain Φ L; tested).
    """
    if not (spool_noise > 0 and command_noise > 0):
        raise ControlError(
            "spool_filter_gain needs a positive spool noise and command noise (standard deviations [1])"
        )
    F = np.asarray(phi, dtype=float).reshape(2, 2)
    G = np.asarray(gamma, dtype=float).reshape(2, 1)
    # ν̇ in 1/ms so that the Riccati equation is well scaled
    T, Ti = np.diag([1.0, 1e3]), np.diag([1.0, 1e-3])
    H = np.array([[1.0, 0.0]])
    Q = (Ti @ G) @ (Ti @ G).T * command_noise**2
    Ls, _P = kalman_gain(Ti @ F @ T, H @ T, Q, np.array([[spool_noise**2]]))
    L = T @ Ls
    return float(L[0, 0]), float(L[1, 0])


@dataclass(frozen=True, kw_only=True)
class _Discrete:
    """Settings shared by every controller: sampling, limits, anti-windup, dead-zone inverse.

    ``pressure_washout`` T_w [s] (0: off): the load-pressure gains act on P_L − P̄_L, P̄_L
    its first-order low-pass, so they damp the pressure dynamics without fighting a static
    load (which the integral then carries, whichever gain row is active).
    ``load_pressure``: the definition of P_L the gains were designed for, ``asymmetric``
    (P_A − α P_B, the default models) or ``mean-area`` (the paper's form); on the full model
    the controller measures that quantity from the chamber pressures.
    ``output``: what the reference is for, ``position`` (x [m]), ``force`` (the cylinder force
    A_A·P_A − A_B·P_B [N], from the pressure sensors) or ``pressure`` (the load pressure P_L
    [Pa]); the gains then act on that output's error (k_p in 1/N or 1/Pa, k_i in 1/(N·s)).
    ``feedforward_compliance`` [m per output unit]: with a force or pressure output the flow
    feed-forward passes the velocity ``feedforward_compliance`` times the reference's rate
    (1/k_s + 1/k_h for a force, k_s the specimen's, k_h the oil columns' stiffness).
    ``transfer`` (integral, command, opening) or None: the run starts from another law's last
    command without a bump (the integral in this law's output unit times s; a run-time state,
    not written to files; :func:`~hydropwa.control.press_cycle`).
    """

    sample_time: float = DEFAULT_SAMPLE_TIME
    delay: bool = False
    u_min: float = -1.0
    u_max: float = 1.0
    anti_windup: str = "clamp"
    tracking_gain: float = 0.0
    dead_zone_inverse: DeadZoneInverse | None = None
    pressure_washout: float = 0.0
    load_pressure: str = "asymmetric"
    feedforward: FlowFeedForward | None = None
    velocity_filter: float = 0.0
    position_observer: tuple[float, float] | None = None
    spool_model: SpoolModel | None = None
    output: str = "position"
    feedforward_compliance: float = 0.0
    transfer: tuple[float, float, float] | None = field(default=None, compare=False)
    machine: dict = field(default_factory=dict, compare=False)
    verification: dict = field(default_factory=dict, compare=False)

    kind = "controller"

    def __post_init__(self) -> None:
        ts = _finite(self, "sample_time", "s", gt=0.0)
        if ts > 0.1:
            raise ControlError(
                f"{type(self).__name__}.sample_time = {ts:g} s is longer than 0.1 s; did you give a rate in Hz? "
                "(2 kHz is 0.0005 s)"
            )
        _finite(self, "u_min", "1")
        _finite(self, "u_max", "1")
        if not self.u_min < self.u_max:
            raise ControlError(
                f"{type(self).__name__}: u_min = {self.u_min:g} must be below u_max = {self.u_max:g}"
            )
        if not isinstance(self.delay, bool | np.bool_):
            raise ControlError(
                f"{type(self).__name__}.delay = {self.delay!r} must be true or false"
            )
        object.__setattr__(self, "delay", bool(self.delay))
        if self.anti_windup not in ANTI_WINDUP:
            raise ControlError(
                f"{type(self).__name__}.anti_windup = {self.anti_windup!r}; choose one of {', '.join(ANTI_WINDUP)}"
            )
        _finite(self, "tracking_gain", "1/s", ge=0.0)
        _finite(self, "pressure_washout", "s", ge=0.0)
        if self.load_pressure not in ("asymmetric", "mean-area"):
            raise ControlError(
                f"{type(self).__name__}.load_pressure = {self.load_pressure!r}; choose asymmetric or mean-area"
            )
        if self.anti_windup == "back-calculation" and self.tracking_gain == 0.0:
            raise ControlError(
                f"{type(self).__name__}: back-calculation anti-windup needs tracking_gain > 0 1/s "
                "(about the integral's corner frequency)"
            )
        if self.dead_zone_inverse is not None and not isinstance(
            self.dead_zone_inverse, DeadZoneInverse
        ):
            raise ControlError(
                f"{type(self).__name__}.dead_zone_inverse must be a DeadZoneInverse or None"
            )
        if self.feedforward is not None and not isinstance(self.feedforward, FlowFeedForward):
            raise ControlError(
                f"{type(self).__name__}.feedforward must be a FlowFeedForward or None"
            )
        if self.spool_model is not None and not isinstance(self.spool_model, SpoolModel):
            raise ControlError(f"{type(self).__name__}.spool_model must be a SpoolModel or None")
        _finite(self, "velocity_filter", "s", ge=0.0)
        self._check_output()
        if self.position_observer is not None:
            gains = tuple(float(g) for g in self.position_observer)
            if len(gains) != 2 or not all(math.isfinite(g) for g in gains) or not 0 < gains[0] <= 1:
                raise ControlError(
                    f"{type(self).__name__}.position_observer = {self.position_observer!r} must be the "
                    "Kalman gains (L_x in (0, 1], L_v [1/s]); see position_observer_gains"
                )
            object.__setattr__(self, "position_observer", gains)
        if not isinstance(self.machine, dict) or not isinstance(self.verification, dict):
            raise ControlError(f"{type(self).__name__}.machine and .verification must be dicts")
        unknown = set(self.machine) - set(MACHINE_KEYS)
        if unknown:
            raise ControlError(
                f"{type(self).__name__}.machine has unknown keys {sorted(unknown)}; known: {', '.join(MACHINE_KEYS)}"
            )

    def _check_output(self) -> None:
        """``output``, ``feedforward_compliance`` and ``transfer`` (issue 52)."""
        if self.output not in OUTPUTS:
            raise ControlError(
                f"{type(self).__name__}.output = {self.output!r}; choose one of {', '.join(OUTPUTS)}"
            )
        _finite(self, "feedforward_compliance", "m per output unit", ge=0.0)
        if self.transfer is not None:
            tr = tuple(float(v) for v in self.transfer)
            if len(tr) != 3 or not all(math.isfinite(v) for v in tr):
                raise ControlError(
                    f"{type(self).__name__}.transfer = {self.transfer!r} must be (integral, "
                    "command, opening), three finite numbers; see transfer_integral"
                )
            object.__setattr__(self, "transfer", tr)

    @property
    def verdict(self) -> str:
        """The verification verdict the controller carries: ``"pass"``, ``"fail"`` or
        ``"unverified"`` (no ``[verification]`` record, e.g. ``control design --no-verify`` or a
        controller built by hand). It travels into the controller file, the exported C (the
        ``HYDROPWA_CTRL_VERIFIED`` define), its README and the FMU's description."""
        v = self.verification.get("verdict")
        return v if v in ("pass", "fail") else "unverified"

    @property
    def extended(self) -> bool:
        """Whether the controller uses a schema-2 element (feed-forward, velocity filter, spool model)."""
        return (
            self.feedforward is not None
            or self.velocity_filter > 0.0
            or self.position_observer is not None
            or self.spool_model is not None
            or self.output != "position"
            or self.transfer is not None
            or (
                self.dead_zone_inverse is not None
                and (
                    self.dead_zone_inverse.hysteresis > 0.0
                    or self.dead_zone_inverse.quiet_band > 0.0
                    or self.dead_zone_inverse.integral_leak > 0.0
                    or self.dead_zone_inverse.integral_band > 0.0
                    or self.dead_zone_inverse.quiet_at_rest > 0.0
                    or self.dead_zone_inverse.pre_open > 0.0
                    or self.dead_zone_inverse.pressure_vent > 0.0
                    or self.dead_zone_inverse.quiet_open > 0.0
                )
            )
            or self._estimator() is not None
        )

    def _estimator(self):
        """The per-cell Kalman filter (state feedback only), or None."""
        return None

    def _ext_rows(self) -> np.ndarray:
        """Per-row extension gains [k_nu, k_dnu, k_up] (zero unless the spool is fed back)."""
        return np.zeros((self._rows().shape[0], C.XROW))

    @property
    def sample_rate(self) -> float:
        """Sample rate [Hz]."""
        return 1.0 / self.sample_time

    def _rows(self) -> np.ndarray:  # pragma: no cover - overridden
        raise NotImplementedError

    def _pressure_filter(self) -> float:
        return 0.0

    def pack(self) -> np.ndarray:
        """Float vector of the compiled controller (layout in :mod:`hydropwa.simulation._controller`)."""
        rows = self._rows()
        v = np.zeros(C.C_ROWS + C.ROW * rows.shape[0])
        v[C.C_TS] = self.sample_time
        v[C.C_DELAY] = 1.0 if self.delay else 0.0
        v[C.C_UMIN], v[C.C_UMAX] = self.u_min, self.u_max
        v[C.C_AW] = ANTI_WINDUP[self.anti_windup]
        v[C.C_KT] = self.tracking_gain
        if self.dead_zone_inverse is not None:
            v[C.C_DZINV] = 1.0
            v[C.C_DZOFF] = self.dead_zone_inverse.offset
            v[C.C_DZW] = self.dead_zone_inverse.width
        tf = self._pressure_filter()
        v[C.C_FILT] = math.exp(-self.sample_time / tf) if tf > 0.0 else 0.0
        v[C.C_NROWS] = rows.shape[0]
        tw = self.pressure_washout
        v[C.C_WASH] = math.exp(-self.sample_time / tw) if tw > 0.0 else 0.0
        v[C.C_PLMEAN] = 1.0 if self.load_pressure == "mean-area" else 0.0
        v[C.C_SCALE : C.C_SCALE + 4] = BOX_SCALES
        v[C.C_ROWS :] = rows.ravel()
        if not self.extended:  # schema 1: the vector ends after the rows
            return v
        ext = np.zeros(C.N_EXT)
        if self.feedforward is not None:
            self.feedforward._pack(ext)
        if self.velocity_filter > 0.0:
            ext[C.X_VEST] = math.exp(-self.sample_time / self.velocity_filter)
        if self.position_observer is not None:
            ext[C.X_KF] = 1.0
            ext[C.X_KFX], ext[C.X_KFV] = self.position_observer
        if self.spool_model is not None:
            ext[C.X_SPOOL] = C.SPOOL_MEASURED if self.spool_model.measured else C.SPOOL_ESTIMATED
            ext[C.X_PHI : C.X_PHI + 4] = self.spool_model.phi
            ext[C.X_GAM : C.X_GAM + 2] = self.spool_model.gamma
            ext[C.X_SPLN], ext[C.X_SPLD] = self.spool_model.packed_gain
        ext[C.X_OUT] = OUTPUTS[self.output]
        ext[C.X_FCOMP] = self.feedforward_compliance
        if self.transfer is not None:  # a run that takes over from another law (no bump)
            ext[C.X_XFER] = 1.0
            ext[C.X_INTZ], ext[C.X_UZ], ext[C.X_CZ] = self.transfer
        if self.dead_zone_inverse is not None:
            ext[C.X_DZH] = self.dead_zone_inverse.hysteresis
            ext[C.X_DZQ] = self.dead_zone_inverse.quiet_band
            tl = self.dead_zone_inverse.integral_leak
            ext[C.X_ILEAK] = math.exp(-self.sample_time / tl) if tl > 0.0 else 0.0
            ext[C.X_IBAND] = self.dead_zone_inverse.integral_band
            ext[C.X_DZQR] = self.dead_zone_inverse.quiet_at_rest
            ext[C.X_DZPO] = self.dead_zone_inverse.pre_open
            tp = self.dead_zone_inverse.pressure_vent
            ext[C.X_DZPV] = math.exp(-self.sample_time / tp) if tp > 0.0 else 0.0
            ext[C.X_DZQO] = self.dead_zone_inverse.quiet_open
        est = self._estimator()
        if est is None:
            return np.concatenate([v, ext, self._ext_rows().ravel()])
        ext[C.X_EST] = 1.0
        ext[C.X_ESTNU] = 1.0 if est.measures_spool else 0.0
        parts = [v, ext, self._ext_rows().ravel(), est.packed_rows().ravel()]
        return np.concatenate([*parts, est.spool_columns().ravel()])

    def _dead_zone_dict(self) -> dict[str, float]:
        dz = self.dead_zone_inverse
        assert dz is not None
        out = {"offset": dz.offset, "width": dz.width}
        for key in DEAD_ZONE_V2:
            if getattr(dz, key) > 0.0:  # schema 2 only; files without them read as 0
                out[key] = getattr(dz, key)
        return out

    def _common(self) -> dict[str, Any]:
        out = (
            {}
            if self.output == "position"  # a position controller's file is as before
            else {"output": self.output, "feedforward_compliance": self.feedforward_compliance}
        )
        return out | {
            "kind": self.kind,
            "sample_time": self.sample_time,
            "delay": self.delay,
            "u_min": self.u_min,
            "u_max": self.u_max,
            "anti_windup": self.anti_windup,
            "tracking_gain": self.tracking_gain,
            "pressure_washout": self.pressure_washout,
            "load_pressure": self.load_pressure,
            "dead_zone_inverse": None if self.dead_zone_inverse is None else self._dead_zone_dict(),
            "feedforward": None if self.feedforward is None else self.feedforward.describe(),
            "velocity_filter": self.velocity_filter,
            "position_observer": None
            if self.position_observer is None
            else list(self.position_observer),
            "spool_model": None
            if self.spool_model is None
            else {
                "phi": list(self.spool_model.phi),
                "gamma": list(self.spool_model.gamma),
                "measured": self.spool_model.measured,
            }
            | (
                {"gain": list(self.spool_model.gain), "noise": dict(self.spool_model.noise)}
                if self.spool_model.filtered
                else {}
            ),
        }


def _row(lo, hi, kp=0.0, ki=0.0, kff=0.0, kv=0.0, kpl=0.0, kdpl=0.0, uff=0.0) -> np.ndarray:
    r = np.zeros(C.ROW)
    r[C.R_LO : C.R_LO + 4] = lo
    r[C.R_HI : C.R_HI + 4] = hi
    r[C.R_KP], r[C.R_KI], r[C.R_KFF], r[C.R_KV] = kp, ki, kff, kv
    r[C.R_KPL], r[C.R_KDPL], r[C.R_UFF] = kpl, kdpl, uff
    return r


_EVERYWHERE = (np.full(4, -np.inf), np.full(4, np.inf))


@dataclass(frozen=True, kw_only=True)
class PIController(_Discrete):
    """P / PI position controller with velocity feed-forward and pressure feedback.

    c = k_p e + k_i ∫e dt + k_ff ṙ − k_v ẋ − k_pl P_L − k_dpl Ṗ_L,  e = r − x,
    u = sat(DZ⁻¹(c)), evaluated every ``sample_time`` (Ṗ_L a backward difference,
    low-pass filtered with ``pressure_filter``).

    Attributes
    ----------
    kp : float
        Position gain [1/m] (valve fraction per metre of error).
    ki : float
        Integral gain [1/(m·s)].
    kff : float
        Velocity feed-forward [s/m]: 1/K_v, K_v the velocity gain [m/s per unit command].
    kv : float
        Velocity feedback [s/m].
    kpl : float
        Load-pressure feedback [1/Pa] (active damping; a high-pass of P_L is the usual
        rig form, here the plain P_L with k_pl small, or its rate via ``kdpl``).
    kdpl : float
        Load-pressure rate feedback [s/Pa].
    pressure_filter : float
        Time constant T_f [s] of the first-order filter on Ṗ_L (0: unfiltered).
    sample_time, delay, u_min, u_max, anti_windup, tracking_gain, dead_zone_inverse
        See the module docstring: sample time [s] (default 0.5 ms, 2 kHz), one-sample
        computation delay, command limits [1], ``"clamp"`` | ``"back-calculation"`` |
        ``"none"``, back-calculation gain [1/s], :class:`DeadZoneInverse` or None.
    pressure_washout
        T_w [s] of the high-pass on P_L for ``kpl`` (0: the plain P_L).
    """

    kp: float = 0.0
    ki: float = 0.0
    kff: float = 0.0
    kv: float = 0.0
    kpl: float = 0.0
    kdpl: float = 0.0
    pressure_filter: float = 0.0

    kind = "pi"

    def __post_init__(self) -> None:
        super().__post_init__()
        for name, unit in (
            ("kp", "1/m"),
            ("ki", "1/(m*s)"),
            ("kff", "s/m"),
            ("kv", "s/m"),
            ("kpl", "1/Pa"),
            ("kdpl", "s/Pa"),
        ):
            _finite(self, name, unit)
        _finite(self, "pressure_filter", "s", ge=0.0)

    def _rows(self) -> np.ndarray:
        return _row(*_EVERYWHERE, self.kp, self.ki, self.kff, self.kv, self.kpl, self.kdpl)[None, :]

    def _pressure_filter(self) -> float:
        return self.pressure_filter

    def describe(self) -> dict[str, Any]:
        """Plain dict of every setting (SI), as written to controller files."""
        d = self._common()
        d.update(
            kp=self.kp,
            ki=self.ki,
            kff=self.kff,
            kv=self.kv,
            kpl=self.kpl,
            kdpl=self.kdpl,
            pressure_filter=self.pressure_filter,
        )
        return d


@dataclass(frozen=True)
class GainRow:
    """State-feedback gains of one PWA cell and the box over [P_L, ẋ, x, c] where they apply.

    u = u_ff − k_pl P_L − k_v ẋ + k_x (r − x) + k_i ∫(r − x) dt.

    Attributes
    ----------
    lower, upper : tuple of 4 floats
        Box bounds [Pa, m/s, m, 1] over load pressure, velocity, position and the last
        command c (its sign is the flow direction s of the cell); ±inf allowed.
    k_pl : float
        [1/Pa]. k_v : [s/m]. k_x : [1/m]. k_i : [1/(m·s)]. u_ff : [1].
    label : str
        The cell, e.g. ``"s=+1 o=2 w=3"``.
    """

    lower: tuple[float, ...]
    upper: tuple[float, ...]
    k_pl: float
    k_v: float
    k_x: float
    k_i: float = 0.0
    u_ff: float = 0.0
    label: str = ""
    k_nu: float = 0.0
    k_dnu: float = 0.0
    k_up: float = 0.0

    def __post_init__(self) -> None:
        lo = np.asarray(self.lower, dtype=float).ravel()
        hi = np.asarray(self.upper, dtype=float).ravel()
        if (
            lo.size != 4
            or hi.size != 4
            or np.any(np.isnan(lo))
            or np.any(np.isnan(hi))
            or np.any(hi < lo)
        ):
            raise ControlError(
                f"gain row {self.label!r}: lower/upper must be 4 bounds [Pa, m/s, m, 1] with lower <= upper"
            )
        object.__setattr__(self, "lower", tuple(float(v) for v in lo))
        object.__setattr__(self, "upper", tuple(float(v) for v in hi))
        for name, unit in (
            ("k_pl", "1/Pa"),
            ("k_v", "s/m"),
            ("k_x", "1/m"),
            ("k_i", "1/(m*s)"),
            ("u_ff", "1"),
            ("k_nu", "1"),
            ("k_dnu", "s"),
            ("k_up", "1"),
        ):
            _finite(self, name, unit)


@dataclass(frozen=True, kw_only=True)
class StateFeedbackController(_Discrete):
    """Gain-scheduled state feedback with integral action: one gain row per PWA cell.

    At each sample the row whose box holds [P_L, ẋ, x, c_{k−1}] is used (the nearest
    box outside all of them); the integral of r − x is shared by all rows, so a cell
    change is bumpless. Designed by :func:`hydropwa.control.design_state_feedback`.

    Attributes
    ----------
    rows : tuple of GainRow
    design : dict
        Provenance (method, weights, model) written to controller files; not used in
        the loop.
    """

    rows: tuple[GainRow, ...] = ()
    design: dict = field(default_factory=dict, compare=False)
    estimator: Any = None

    kind = "state_feedback"

    def __post_init__(self) -> None:
        super().__post_init__()
        rows = tuple(self.rows)
        if not rows or not all(isinstance(r, GainRow) for r in rows):
            raise ControlError("StateFeedbackController needs at least one GainRow")
        object.__setattr__(self, "rows", rows)
        if self.estimator is not None:
            self._check_estimator(len(rows))

    def _check_estimator(self, n_rows: int) -> None:
        from ._estimator import CellEstimator  # deferred: it imports this module

        est = self.estimator
        if not isinstance(est, CellEstimator) or est.rows != n_rows:
            raise ControlError(
                f"StateFeedbackController.estimator must be a CellEstimator with one filter per "
                f"gain row ({n_rows}); see design_cell_estimator"
            )
        if (
            self.spool_model is None
            or self.position_observer is not None
            or self.velocity_filter > 0
        ):
            raise ControlError(
                "the per-cell Kalman filter replaces the position observer and the velocity "
                "filter and needs the spool model (the valve-aware design)"
            )

    def _estimator(self):
        return self.estimator

    def _rows(self) -> np.ndarray:
        return np.stack(
            [
                _row(r.lower, r.upper, r.k_x, r.k_i, 0.0, r.k_v, r.k_pl, 0.0, r.u_ff)
                for r in self.rows
            ]
        )

    def _ext_rows(self) -> np.ndarray:
        return np.array([[r.k_nu, r.k_dnu, r.k_up] for r in self.rows], dtype=float)

    def describe(self) -> dict[str, Any]:
        d = self._common()
        d["cells"] = [
            {
                "label": r.label,
                "lower": list(r.lower),
                "upper": list(r.upper),
                "k_pl": r.k_pl,
                "k_v": r.k_v,
                "k_x": r.k_x,
                "k_i": r.k_i,
                "u_ff": r.u_ff,
                "k_nu": r.k_nu,
                "k_dnu": r.k_dnu,
                "k_up": r.k_up,
            }
            for r in self.rows
        ]
        d["design"] = dict(self.design)
        if self.estimator is not None:  # schema 2 only; files without it load as before
            d["estimator"] = self.estimator.describe()
        return d
