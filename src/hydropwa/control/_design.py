"""Controller design on the PWA model with python-control.

The plant of every cell is the PWA model's affine dynamics (Eqs. (23)–(28),
:meth:`~hydropwa.linearization.PwaModel.state_space`) for y = [P_L, ẋ, x], with the
valve command replaced by the orifice opening c the dead-zone inverse asks for
(B/k_g: the inverse cancels the outer cells' slope and offset). The design is
discrete at the controller's sample time (ZOH, ``control.sample_system``), on states
scaled to engineering units (bar, mm/s, mm), so the Riccati equation and the pole
placement see numbers of order one.

* :func:`design_state_feedback`: LQR (``control.dlqr``) or pole placement
  (``control.place``) per cell (s, o, w) with an integral state; one
  :class:`GainRow` per cell, the cell's polyhedron as its box.
* :func:`design_pi`: P/PI with velocity feed-forward at one working point, the
  crossover chosen as high as the gain and phase margins allow.

Both return the controller and a per-cell table (closed-loop poles, damping,
bandwidth, margins) with warnings for cells that are not controllable or not
stabilised, also with the servo valve's own dynamics (Eq. (1)) in the loop.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .._layout import PWA_KIND
from ._controllers import (
    DEFAULT_SAMPLE_TIME,
    ControlError,
    DeadZoneInverse,
    FlowFeedForward,
    GainRow,
    PIController,
    SpoolModel,
    StateFeedbackController,
    machine_of,
    position_observer_gains,
)
from ._defaults import DEFAULT_DESIGN
from ._design_result import DesignResult

__all__ = [
    "ControlDesign",
    "cell_plant",
    "design_pi",
    "design_state_feedback",
    "design_textbook_pi",
    "DEFAULT_WEIGHTS",
    "clip_friction_slope",
    "friction_slope_limit",
    "valve_augment",
    "valve_series",
]

#: Bryson maxima of the LQR: P_L [Pa], ẋ [m/s], x [m], ∫e [m·s], command [1].
DEFAULT_WEIGHTS = {"p_l": 100e5, "v": 1.0, "x": 2e-3, "integral": 1e-4, "u": 1.0}
_SCALE = np.array([1e5, 1e-3, 1e-3, 1e-5])  # bar, mm/s, mm, mm·10 ms: states of order one


@dataclass
class ControlDesign(DesignResult):
    """A designed controller and what the design knows about it.

    Attributes
    ----------
    controller : PIController or StateFeedbackController
    table : pandas.DataFrame
        One row per cell (or the one working point): gains, closed-loop poles (as
        continuous-time equivalents ln(z)/T_s), smallest damping, dominant natural
        frequency [Hz], closed-loop bandwidth r → x [Hz], spectral radius without and
        with the valve dynamics, controllable/stable flags.
    warnings : list of str
        Cells where the design is not controllable or not stable.
    info : dict
        Method, weights or poles, sample time, model description.
    verification : Verification or None
        The full-model verification (:func:`hydropwa.control.design_controller`).
    """

    controller: Any
    table: Any
    warnings: list[str] = field(default_factory=list)
    info: dict[str, Any] = field(default_factory=dict)
    verification: Any = None

    def summary(self) -> str:
        """Text summary: the method, the worst cell and the warnings."""
        t = self.table
        lines = [
            f"{self.info.get('method', '?')} design, {len(t)} cell(s), T_s = {self.info.get('sample_time', 0) * 1e3:g} ms"
        ]
        if len(t):
            lines.append(
                f"closed loop: damping >= {t['damping_min'].min():.3f}, bandwidth {t['bandwidth_hz'].min():.1f}"
                f"..{t['bandwidth_hz'].max():.1f} Hz, spectral radius <= {t['radius'].max():.4f} "
                f"(with valve dynamics {t['radius_valve'].max():.4f})"
            )
            light = _light_damping_line(t)
            if light:
                lines.append(light)
        if self.verification is not None:
            lines.append(self.verification.summary())
        lines += [f"warning: {w}" for w in self.warnings]
        lines.append(self._status_line())  # the result protocol's status (issue 33)
        return "\n".join(lines)


def cell_plant(
    model, *, cells=None, point=None, f_l: float | None = None, opening_input: bool = True
):
    """Continuous (A, B) of the PWA model in one cell, y = [P_L, ẋ, x], input c or u.

    Parameters
    ----------
    model : PwaModel
    cells : tuple, optional
        (g, s, o, w) cell combination (its working point is used).
    point : mapping, optional
        {"p_l": Pa, "v": m/s, "u": 1} instead of ``cells``.
    f_l : float, optional
        Load force [N].
    opening_input : bool
        Input is the opening c demanded through the dead-zone inverse (B/k_g) instead
        of the valve command u.

    Returns
    -------
    A : ndarray (3, 3), B : ndarray (3, 1), dyn : AffineDynamics
    """
    dyn = model.state_space(point, cells=cells, f_l=f_l)
    B = dyn.B.copy()
    if opening_input:
        k_g = float(model.dead_zone.slopes[dyn.cells.g])
        if k_g == 0.0:
            raise ControlError(
                f"cell {tuple(dyn.cells)} is saturated (k_g = 0): no input to design with"
            )
        B = B / k_g
    return dyn.A.copy(), B, dyn


def _discrete(A, B, ts):
    """Zero-order-hold discretisation: expm([[A, B], [0, 0]]·T_s) (what ``control.sample_system`` does)."""
    from scipy.linalg import expm  # deferred: scipy submodules cost 0.1-0.5 s at import

    n, m = A.shape[0], B.shape[1]
    M = np.zeros((n + m, n + m))
    M[:n, :n] = A
    M[:n, n:] = B
    E = expm(M * ts)
    return E[:n, :n], E[:n, n:]


def _augment(Ad, Bd, ts):
    """Discrete plant with the controller's integral I_{k+1} = I_k + T_s (r − x_k), at r = 0."""
    Aa = np.zeros((4, 4))
    Aa[:3, :3] = Ad
    Aa[3, 2] = -ts
    Aa[3, 3] = 1.0
    Ba = np.zeros((4, 1))
    Ba[:3] = Bd
    return Aa, Ba


#: scales of the valve-aware design's extra states: ν [1] in %, ν̇ [1/s], pending command in %
_VALVE_SCALE = np.array([1e5, 1e-3, 1e-3, 1e-2, 1.0, 1e-5, 1e-2])
#: Bryson maxima of the spool position [1] and rate [1/s] (the opening it mirrors, a 1 % move per ms)
_VALVE_MAXIMA = np.array([1.0, 1e3])


def valve_series(A, B, omega0: float, zeta: float):
    """A cell plant with the servo valve of Eq. (1) before it, in continuous time.

    Parameters
    ----------
    A, B : ndarray
        The cell's state matrix (n × n) and its input column (n × 1), input the spool position ν.
    omega0, zeta : float
        The valve's natural frequency [rad/s] and damping [1] (Eq. (1)).

    Returns
    -------
    Av, Bv : ndarray
        States [cell states, ν, ν̇], input the opening command c: ν̈ = ω0²(c − ν) − 2ζω0 ν̇.
    """
    n = A.shape[0]
    Av = np.zeros((n + 2, n + 2))
    Av[:n, :n] = A
    Av[:n, n] = B[:, 0]
    Av[n, n + 1] = 1.0
    Av[n + 1, n] = -(omega0**2)
    Av[n + 1, n + 1] = -2.0 * zeta * omega0
    Bv = np.zeros((n + 2, 1))
    Bv[n + 1, 0] = omega0**2
    return Av, Bv


def valve_augment(A, B, ts, omega0, zeta, delay):
    """Discrete cell plant with the servo valve, the integral and the computation delay.

    States [P_L, ẋ, x, ν, ν̇, I] (and the pending command c_{k−1} with ``delay``), input
    the opening command c: the cell's input matrix acts on the spool position ν, which
    follows c through Eq. (1), ν̈ = ω0²(c − ν) − 2ζω0 ν̇, held over the sample (ZOH);
    I_{k+1} = I_k + T_s (r − x_k) at r = 0. With the delay the plant receives the command
    computed one sample earlier.
    """
    n = A.shape[0]
    Av, Bv = valve_series(A, B, omega0, zeta)
    Ad, Bd = _discrete(Av, Bv, ts)
    m = n + 3 + (1 if delay else 0)
    Aa = np.zeros((m, m))
    Aa[: n + 2, : n + 2] = Ad
    Aa[n + 2, 2] = -ts
    Aa[n + 2, n + 2] = 1.0
    Ba = np.zeros((m, 1))
    if delay:
        Aa[: n + 2, n + 3] = Bd[:, 0]
        Ba[n + 3, 0] = 1.0
    else:
        Ba[: n + 2, 0] = Bd[:, 0]
    return Aa, Ba


def _pbh(A, B) -> np.ndarray:
    """[‖[A, B]‖₂, smallest σ_min([λI − A, B]) over A's eigenvalues λ] (the PBH test).

    Controllable iff no eigenvalue leaves [λI − A, B] rank deficient; better conditioned
    than the Kalman matrix [B, AB, …, A^{n−1}B], whose powers of a sampled 7-state plant
    span 10 decades.
    """
    n = A.shape[0]
    norm = float(np.linalg.norm(np.hstack([A, B]), 2))
    smin = min(
        float(np.linalg.svd(np.hstack([lam * np.eye(n) - A, B]), compute_uv=False)[-1])
        for lam in np.linalg.eigvals(A)
    )
    return np.array([norm, smin])


def _valve_loop_radius(A, B, K, ts, omega0, zeta, delay):
    """Spectral radius of the closed loop with the servo valve (Eq. (1)) between command and plant."""
    n = A.shape[0]
    Av = np.zeros((n + 2, n + 2))
    Av[:n, :n] = A
    Av[:n, n] = B[:, 0]  # the plant sees the spool position ν
    Av[n, n + 1] = 1.0
    Av[n + 1, n] = -(omega0**2)
    Av[n + 1, n + 1] = -2.0 * zeta * omega0
    Bv = np.zeros((n + 2, 1))
    Bv[n + 1, 0] = omega0**2
    Ad, Bd = _discrete(Av, Bv, ts)
    Aa = np.zeros((n + 3, n + 3))
    Aa[: n + 2, : n + 2] = Ad
    Aa[n + 2, 2] = -ts
    Aa[n + 2, n + 2] = 1.0
    Ba = np.zeros((n + 3, 1))
    Ba[: n + 2] = Bd
    Kf = np.zeros((1, n + 3))
    Kf[0, :3] = K[0, :3]
    Kf[0, n + 2] = K[0, 3]
    return _radius(Aa, Ba, Kf, delay)


def _radius(Aa, Ba, K, delay: bool) -> float:
    """Spectral radius of x⁺ = Aa x + Ba u, u = −K x (with one sample of delay if asked)."""
    if not delay:
        return float(np.max(np.abs(np.linalg.eigvals(Aa - Ba @ K))))
    n = Aa.shape[0]
    M = np.zeros((n + 1, n + 1))
    M[:n, :n] = Aa
    M[:n, n] = Ba[:, 0]
    M[n, :n] = -K[0]
    return float(np.max(np.abs(np.linalg.eigvals(M))))


#: Closed-loop damping [1] below which the design summary comments on a cell's pole pair: a
#: pair with ζ < 0.1 overshoots a step by exp(−πζ/√(1 − ζ²)) > 73 % and needs 1/(2πζ) > 1.6
#: periods to decay by 1/e; where it sits far above the loop's bandwidth (the hydraulic mode a
#: state feedback leaves as the plant has it) it does not shape the tracking but rings after
#: every disturbance near its frequency.
DAMPING_NOTE = 0.1


def _light_damping_line(table) -> str:
    """The comment on the least damped closed-loop pole pair of the cells ('' above
    :data:`DAMPING_NOTE`)."""
    low = table[table["damping_min"] < DAMPING_NOTE]
    if not len(low):
        return ""
    row = low.loc[low["damping_min"].idxmin()]
    zeta = float(row["damping_min"])
    text = str(row.get("poles", ""))
    poles: list[complex] = [complex(p.replace(" ", "")) for p in text.split(";") if p.strip()]
    pairs = [p for p in poles if p.imag != 0.0 and abs(p) > 0.0]
    # the frequency |s|/2π of the least damped pair (ζ = −Re s/|s|)
    least = min(pairs, key=lambda p: -p.real / abs(p)) if pairs else None
    f = abs(least) / (2 * math.pi) if least is not None else math.nan
    where = f"at {f:.0f} Hz, " if math.isfinite(f) else ""
    above = (
        f"above the loop's bandwidth (<= {table['bandwidth_hz'].max():.0f} Hz), so it does not shape "
        "the tracking but rings after a disturbance near it; "
        if math.isfinite(f) and f > table["bandwidth_hz"].max()
        else ""
    )
    return (
        f"  note: damping {zeta:.3f} < {DAMPING_NOTE:g} ({where}cell {row['cell']}; {len(low)} of "
        f"{len(table)} cells below {DAMPING_NOTE:g}): such a pair overshoots by "
        f"{100 * math.exp(-math.pi * zeta / math.sqrt(1 - zeta**2)):.0f} % and takes "
        f"{1 / (2 * math.pi * zeta):.1f} periods to decay by 1/e; {above}the design model's "
        "prediction, judged by the verification on the full model"
    )


def _pole_stats(Acl, ts, Br, C):
    """Continuous-equivalent poles, min damping, dominant natural frequency [Hz], bandwidth [Hz]."""
    z = np.linalg.eigvals(Acl).astype(complex)
    z = np.where(
        np.abs(z) < 1e-300, 1e-300, z
    )  # a pole at z = 0: s = ln(1e-300)/T_s, "infinitely" fast
    s = np.log(z) / ts
    wn = np.abs(s)
    zeta = np.where(wn > 0, -s.real / np.where(wn > 0, wn, 1.0), 1.0)
    dom = int(np.argmin(np.where(s.real < 0, -s.real, np.inf))) if np.any(s.real < 0) else 0
    # closed-loop r -> x frequency response on a grid up to Nyquist
    f = np.logspace(-1, math.log10(0.499 / ts), 400)
    zz = np.exp(2j * math.pi * f * ts)
    n = Acl.shape[0]
    M = zz[:, None, None] * np.eye(n)[None] - Acl[None]  # all frequencies in one batched solve
    g = (
        C[0] @ np.linalg.solve(M, np.broadcast_to(Br.astype(complex), (zz.size, n, 1)))[..., 0].T
    ).ravel()
    g0 = abs(g[0])
    below = np.flatnonzero(np.abs(g) < g0 / math.sqrt(2.0))
    bw = float(f[below[0]]) if below.size else float(f[-1])
    return s, float(np.min(zeta)), float(wn[dom] / (2 * math.pi)), bw


def _scaling(weights: Mapping[str, float]) -> tuple[np.ndarray, float]:
    w = dict(DEFAULT_WEIGHTS)
    for k, v in weights.items():
        if k not in w:
            raise ControlError(f"unknown LQR weight {k!r}; choose from {', '.join(w)}")
        if not (isinstance(v, int | float) and math.isfinite(v) and v > 0):
            raise ControlError(f"LQR weight {k} = {v!r} must be a positive maximum in SI units")
        w[k] = float(v)
    return np.array([w["p_l"], w["v"], w["x"], w["integral"]]), w["u"]


def _cell_boxes(model, f_l):
    """(label, (g, s, o, w), lower, upper) per cell over [P_L, ẋ, x, c]; c's sign is s."""
    out: dict[Any, Any] = {}
    for idx, lo, hi in model.regions():
        g_out = int(model.dead_zone.cell(0.5 * idx.s))
        if idx.g != g_out:
            continue
        key = (idx.g, idx.s, idx.o, idx.w)
        c_lo, c_hi = (0.0, math.inf) if idx.s > 0 else (-math.inf, 0.0)
        box_lo = (lo[0], lo[1], -math.inf, c_lo)
        box_hi = (hi[0], hi[1], math.inf, c_hi)
        if key in out:  # paper form: several n cells per (o, w); merge their pressure ranges
            plo, phi = out[key][2][0], out[key][3][0]
            box_lo = (min(plo, lo[0]),) + box_lo[1:]
            box_hi = (max(phi, hi[0]),) + box_hi[1:]
        out[key] = (f"s={idx.s:+d} o={idx.o} w={idx.w}", key, box_lo, box_hi)
    return list(out.values())


def design_state_feedback(
    model,
    *,
    method: str = "lqr",
    sample_time: float = DEFAULT_SAMPLE_TIME,
    weights: Mapping[str, float] | None = None,
    poles: tuple[complex, ...] | None = None,
    delay: bool = DEFAULT_DESIGN.delay,
    load_force: float | None = None,
    dead_zone_inverse: bool = True,
    u_limits: tuple[float, float] = (-1.0, 1.0),
    anti_windup: str = "clamp",
    friction_slopes: str = "clip",
    pressure_washout: float = 0.1,
    feedforward: bool = True,
    valve: bool | None = None,
    position_noise: float | None = None,
    acceleration_noise: float = 1.0,
    spool: str = "estimated",
    dead_zone_hysteresis: float = 0.0,
) -> ControlDesign:
    """Gain-scheduled state feedback with integral action, one gain row per PWA cell.

    The gain step of the default design, not the default design itself: it adds no position
    observer and no quiet band (their sizes come from the sensor noise) and does not verify,
    so its controller is ``unverified`` and ``hydropwa control export`` refuses it without
    ``--write-unverified``. The default design, the one the CLI, the paper study and the
    tutorials use, is :func:`~hydropwa.control.design_controller`
    (:data:`~hydropwa.control.DEFAULT_DESIGN`); its sample time and delay are this function's
    defaults.

    Parameters
    ----------
    model : PwaModel
        The (identified) PWA model; cells (s, o, w) are designed in the outer dead-zone
        cell of each flow direction (the dead-zone inverse removes the band).
    method : {"lqr", "place"}
        ``control.dlqr`` with Bryson weights, or ``control.place`` at ``poles``.
    sample_time : float
        T_s [s] (default 0.5 ms, 2 kHz).
    weights : mapping, optional
        Bryson maxima (:data:`DEFAULT_WEIGHTS`): {"p_l": Pa, "v": m/s, "x": m,
        "integral": m·s, "u": 1}; Q = diag(1/max²), R = 1/u_max².
    poles : tuple of complex, optional
        ``place``: four continuous-time closed-loop poles [1/s] (mapped to e^{pT_s});
        default a 15 Hz, ζ = 0.8 pair and real poles at 2× and 3× that frequency.
    delay : bool
        Whether the controller runs with a one-sample computation delay (default
        :data:`~hydropwa.control.DEFAULT_DESIGN`'s, True: any target computes for a while; the
        valve-aware LQR designs with it, the table's radius includes it).
    load_force : float, optional
        Load force [N] at which the cells are linearized (default params.load.force).
    dead_zone_inverse : bool
        Put the identified dead zone's inverse before the valve (default).
    u_limits : (float, float)
        Valve command limits [1].
    anti_windup : str
        ``"clamp"``, ``"back-calculation"`` or ``"none"``.
    friction_slopes : {"clip", "exact"}
        ``"clip"`` (default) designs every cell with its friction slope k_w clipped to
        [0, largest slope of the two outermost (viscous) cells], and lists the clipped
        cells in ``notes``. On the paper rig the falling Stribeck branch (Table V cells
        III and V, k_w < 0) makes the cell open-loop unstable at about +1400 1/s, faster
        than the servo valve (ω0 = 628 rad/s) can act, and the stiction cell IV
        (k_w = 1.8e5 N·s/m) is a force limit, not a damper: gains designed on either
        exactly drive the full model's valve into a limit cycle (measured: bang-bang
        ±1). ``"exact"`` designs on the cells as they are.
    pressure_washout : float
        T_w [s] of the high-pass on P_L for the k_pl gains (default 0.1 s, below the
        slowest cell's bandwidth; 0 feeds back the plain P_L). The cells' gains differ, so
        k_pl acting on a static load pressure (14.6 bar at 1.5 kN) changes the command by
        Δk_pl·P_L at every cell switch; measured on the full model at ±1.5 kN without the
        washout: a 0.5 mm limit cycle at the target.
    feedforward : bool
        Flow feed-forward per flow direction with its load-pressure correction and the
        reference state [P_ref, ṙ] in the feedback (:class:`FlowFeedForward`, default);
        False: the schema-1 law (feedback only).
    valve : bool, optional
        Default True for ``"lqr"``, False for ``"place"``. Design on each cell augmented with the servo valve's second-order dynamics
        (Eq. (1)), the zero-order hold and the one-sample delay if ``delay``
        (:func:`valve_augment`); the rows then feed back the spool position and rate,
        estimated in the controller by the discrete valve model (:class:`SpoolModel`),
        and with the delay the pending command. ``method="lqr"`` only; False: the cell
        alone (schema 1).
    position_noise : float, optional
        Standard deviation [m] of the position sensor's noise: adds the position observer
        (a steady-state Kalman filter of [x, ẋ] driven by the reference acceleration,
        :func:`~hydropwa.control.position_observer_gains`) whose x̂, v̂ the law then uses.
        Measured on the paper rig with 20 µm / 0.1 bar noise: trapezoid peak error 0.064 →
        0.057 mm, hold 0.038 → 0.025 mm peak to peak; the observer is not part of the LQR
        design, so a slower one (``acceleration_noise`` 0.3 m/s² on the heavy axis) can
        destabilise the loop. Default None: no observer.
    acceleration_noise : float
        Standard deviation [m/s²] of the rod's acceleration about the reference's, the
        observer's process noise (default 1 m/s²).
    spool : {"estimated", "measured"}
        With ``valve``: feed back the spool estimate of the discrete valve model (default),
        or the spool position the valve reports (the full model's spool state) as an exact
        sensor, the spool filter's limit :attr:`SpoolModel.exact_gain` (for a noisy sensor
        :meth:`SpoolModel.with_filter`, which ``design_controller`` applies).
    dead_zone_hysteresis : float
        Band h [1] of the dead-zone inverse's side (:class:`DeadZoneInverse`, schema 2;
        default 0: none). With sensor noise the command at a hold flips its sign every few
        samples, and the inverse throws the spool across the dead zone each time; with h
        it changes side only when c leaves ±h. Measured on the full model, 20 µm / 0.1 bar
        noise, one sample of delay, 0.6 s after the paper trapezoid, with
        ``position_noise=20e-6``: h = 0.005 makes 80-95 sign changes/s instead of 625-795 and
        holds within 0.010 mm; without the observer 660/s; h = 0.01 lets the hold hunt
        (up to 0.08 mm). Not enough at the verification's ±50 % force holds (paper rig
        184/s), so off by default.

    Returns
    -------
    ControlDesign
    """
    import pandas as pd  # deferred: pandas costs ~0.3 s at import

    ts, maxima, u_max, poles, zp, valve = _checked_feedback_options(
        method, sample_time, weights, poles, valve, spool, friction_slopes
    )
    opt = _FeedbackOptions(
        method=method,
        ts=ts,
        maxima=maxima,
        u_max=u_max,
        poles=poles,
        discrete_poles=zp,
        valve=valve,
        delay=delay,
        load_force=load_force,
        dead_zone_inverse=dead_zone_inverse,
        friction_slopes=friction_slopes,
        pressure_washout=pressure_washout,
        feedforward=feedforward,
        position_noise=position_noise,
        acceleration_noise=acceleration_noise,
        spool=spool,
    )
    rows, recs, warns, notes = _design_cells(model, opt)
    if not rows:
        raise ControlError("no cell could be designed: " + "; ".join(warns))
    dzi = (
        dataclasses.replace(
            DeadZoneInverse.from_params(model.params.dead_zone),
            hysteresis=float(dead_zone_hysteresis),
        )
        if dead_zone_inverse
        else None
    )
    info = _feedback_info(model, opt, notes)
    # the loop's bandwidth r → x [Hz], its fastest cell's: what a model that runs the loop must
    # represent (control._fidelity.valve_warning reads it from the controller)
    bws = [float(r["bandwidth_hz"]) for r in recs if math.isfinite(float(r["bandwidth_hz"]))]
    info["bandwidth_hz"] = max(bws) if bws else None
    ctrl = StateFeedbackController(
        rows=tuple(rows),
        design=info,
        **_loop_options(ts, delay, u_limits, anti_windup, dzi),
        **_feedback_parts(model, opt),
    )
    return ControlDesign(ctrl, pd.DataFrame.from_records(recs), warns, info)


@dataclass(frozen=True, eq=False)
class _FeedbackOptions:
    """:func:`design_state_feedback`'s options after their checks, as the cells' design reads them.

    ``maxima`` are the Bryson maxima of [P_L, ẋ, x, ∫e] (SI) and ``u_max`` the command's
    (:func:`_scaling`); ``discrete_poles`` the placement's poles e^{pT_s} (None for LQR);
    ``valve`` the resolved valve-aware switch. The other options are kept as passed and
    converted where they are used, as the one-piece function did.
    """

    method: str
    ts: float
    maxima: np.ndarray
    u_max: float
    poles: tuple[complex, ...] | None
    discrete_poles: np.ndarray | None
    valve: bool
    delay: Any
    load_force: float | None
    dead_zone_inverse: bool
    friction_slopes: str
    pressure_washout: Any
    feedforward: Any
    position_noise: float | None
    acceleration_noise: Any
    spool: str


def _checked_feedback_options(method, sample_time, weights, poles, valve, spool, friction_slopes):
    """(T_s, Bryson maxima, u_max, poles, discrete poles, valve) of :func:`design_state_feedback`,
    the options checked in a fixed order (the first bad one raises its ControlError)."""
    if friction_slopes not in ("clip", "exact"):
        raise ControlError(f"friction_slopes {friction_slopes!r} must be 'clip' or 'exact'")
    if method not in ("lqr", "place"):
        raise ControlError(f"method {method!r} must be 'lqr' or 'place'")
    if not (
        isinstance(sample_time, int | float)
        and math.isfinite(sample_time)
        and 0 < sample_time <= 0.1
    ):
        raise ControlError(f"sample_time {sample_time!r} s must be in (0, 0.1]")
    ts = float(sample_time)
    maxima, u_max = _scaling(weights or {})
    zp = None
    if method == "place":
        poles, zp = _placement_poles(poles, ts)
    if spool not in ("estimated", "measured"):
        raise ControlError(f"spool {spool!r} must be 'estimated' or 'measured'")
    if valve is None:
        valve = method == "lqr"
    if valve and method != "lqr":
        raise ControlError(
            "the valve-aware design (valve=True) needs method='lqr'; pass valve=False for 'place'"
        )
    return ts, maxima, u_max, poles, zp, bool(valve)


def _placement_poles(poles, ts: float) -> tuple[tuple[complex, ...], np.ndarray]:
    """The four continuous-time poles [1/s] of ``place`` (default: a 15 Hz, ζ = 0.8 pair and real
    poles at 2× and 3× that frequency) and their discrete images e^{pT_s}."""
    if poles is None:
        w = 2 * math.pi * 15.0
        poles = (
            complex(-0.8 * w, 0.6 * w),
            complex(-0.8 * w, -0.6 * w),
            complex(-2 * w),
            complex(-3 * w),
        )
    poles = tuple(complex(p) for p in poles)
    if len(poles) != 4 or any(p.real >= 0 for p in poles):
        raise ControlError(
            "pole placement needs four continuous-time poles with negative real parts [1/s]"
        )
    return poles, np.exp(np.array(poles) * ts)


def friction_slope_limit(model) -> float:
    """The state-feedback design's ceiling k_w,max [N·s/m] of a cell's friction slope: the larger
    slope of the PWA friction's two outermost (viscous) cells, at least 0
    (``design_state_feedback(..., friction_slopes="clip")``)."""
    slopes = model.friction.pwa.slopes
    return float(max(slopes[0], slopes[-1], 0.0))


def clip_friction_slope(A, k_w_max: float, mass: float) -> tuple[np.ndarray, bool]:
    """(A, clipped): a cell's A with its friction slope k_w = −A[1, 1]·m [N·s/m] held to
    [0, ``k_w_max``] (a copy where it was outside; ``mass`` [kg]), as the design clips it."""
    k_w = -A[1, 1] * mass
    if 0.0 <= k_w <= k_w_max:
        return A, False
    A = np.array(A, dtype=float)
    A[1, 1] = -min(max(k_w, 0.0), k_w_max) / mass
    return A, True


def _design_cells(model, opt: _FeedbackOptions) -> tuple[list, list, list[str], list[str]]:
    """Gain rows, table records, warnings and notes over the design cells (:func:`_cell_boxes`)."""
    k_w_max = friction_slope_limit(model)
    rows, recs, warns, notes = [], [], [], []
    for cell in _cell_boxes(model, opt.load_force):
        row, rec, cell_warns, cell_notes = _design_cell(model, cell, opt, k_w_max)
        notes += cell_notes
        warns += cell_warns
        if row is not None:
            rows.append(row)
            recs.append(rec)
    return rows, recs, warns, notes


def _design_cell(model, cell, opt: _FeedbackOptions, k_w_max: float):
    """(gain row, table record, warnings, notes) of one cell; row and record None where the
    synthesis failed (its warning says why)."""
    label, key, lo, hi = cell
    prm = model.params
    A, B, _dyn = cell_plant(
        model, cells=key, f_l=opt.load_force, opening_input=opt.dead_zone_inverse
    )
    A, clipped, notes = _clipped_friction(A, label, k_w_max, prm.load.mass, opt.friction_slopes)
    Aa, Ba, T, Tinv, q = _design_plant(A, B, opt, prm.valve)
    As, Bs = Tinv @ Aa @ T, Tinv @ Ba
    ctrb = _pbh(As, Bs)
    controllable = bool(ctrb[-1] > 1e-9 * ctrb[0])
    Ks, failure = _scaled_gain(As, Bs, q, opt)
    if Ks is None:
        return None, None, [f"cell {label}: design failed ({failure})"], notes
    K = Ks @ Tinv
    loop = _cell_loop(A, B, Aa, Ba, K, opt, prm.valve)
    warns = []
    if not controllable:
        warns.append(
            f"cell {label}: not controllable (PBH σ_min/‖[A, B]‖ = {ctrb[-1] / ctrb[0]:.2e})"
        )
    warns += _stability_warnings(label, loop)
    row = _gain_row(K, cell, opt)
    return row, _cell_record(cell, row, loop, controllable, clipped), warns, notes


def _clipped_friction(A, label: str, k_w_max: float, mass: float, friction_slopes: str):
    """(A, clipped, notes): with ``"clip"`` the cell's friction slope k_w = −A[1, 1]·m outside
    [0, k_w_max] is clipped into it (a copy of A), and a note says so."""
    if friction_slopes != "clip":
        return A, False, []
    clipped_A, clipped = clip_friction_slope(A, k_w_max, mass)
    if not clipped:
        return A, False, []
    k_w = -A[1, 1] * mass
    growth = float(np.max(np.linalg.eigvals(A).real))
    note = (
        f"cell {label}: friction slope {k_w:.4g} N·s/m (open-loop eigenvalue real part up to {growth:+.0f} 1/s) "
        f"clipped to {-clipped_A[1, 1] * mass:.4g} N·s/m for the design"
    )
    return clipped_A, True, [note]


def _design_plant(A, B, opt: _FeedbackOptions, valve_prm):
    """(Aa, Ba, T, T⁻¹, q): the cell's discrete design plant, its state scaling and the LQR
    state weights q = (scale/maximum)² in the scaled states.

    With ``opt.valve`` the states are [P_L, ẋ, x, ν, ν̇, I (, pending c)]: the servo valve
    (Eq. (1)), the ZOH and the delay (:func:`valve_augment`); else [P_L, ẋ, x, I]
    (:func:`_augment`).
    """
    if opt.valve:
        Aa, Ba = valve_augment(A, B, opt.ts, valve_prm.omega0, valve_prm.zeta, opt.delay)
        m = Aa.shape[0]
        sc = _VALVE_SCALE[:m]
        mx = np.concatenate([opt.maxima[:3], _VALVE_MAXIMA, opt.maxima[3:], [opt.u_max]])[:m]
    else:
        Ad, Bd = _discrete(A, B, opt.ts)
        Aa, Ba = _augment(Ad, Bd, opt.ts)
        sc, mx = _SCALE, opt.maxima
    return Aa, Ba, np.diag(sc), np.diag(1.0 / sc), (sc / mx) ** 2


def _scaled_gain(As, Bs, q, opt: _FeedbackOptions):
    """(K_s, None) of the scaled plant (``control.dlqr`` with Q = diag(q), R = 1/u_max², or
    ``control.place``), or (None, the error's text) where python-control cannot design it."""
    import control  # deferred: python-control loads scipy.signal and matplotlib

    R = np.array([[1.0 / opt.u_max**2]])
    try:
        if opt.method == "lqr":
            Ks, _, _ = control.dlqr(As, Bs, np.diag(q), R)
        else:
            Ks = control.place(As, Bs, opt.discrete_poles)
        return np.atleast_2d(np.asarray(Ks, dtype=float)), None
    except Exception as exc:  # python-control raises several types for a singular design
        return None, str(exc)


@dataclass(frozen=True, eq=False)
class _CellLoop:
    """One cell's closed loop: spectral radii on the cell and with the servo valve, the
    continuous-equivalent poles [1/s], smallest damping, dominant frequency and bandwidth [Hz]."""

    radius: float
    radius_valve: float
    poles: np.ndarray
    damping_min: float
    natural_freq_hz: float
    bandwidth_hz: float


def _cell_loop(A, B, Aa, Ba, K, opt: _FeedbackOptions, valve_prm) -> _CellLoop:
    """The closed loop x⁺ = (Aa − Ba K) x of one cell and its response r → x (:func:`_pole_stats`)."""
    if opt.valve:
        radius = radius_v = _radius(Aa, Ba, K, False)
        i_int = 5
    else:
        radius = _radius(Aa, Ba, K, opt.delay)
        radius_v = _valve_loop_radius(A, B, K, opt.ts, valve_prm.omega0, valve_prm.zeta, opt.delay)
        i_int = 3
    Acl = Aa - Ba @ K
    Br = Ba * K[0, 2]
    Br[i_int, 0] += opt.ts
    Cx = np.zeros((1, Aa.shape[0]))
    Cx[0, 2] = 1.0
    s, zmin, fdom, bw = _pole_stats(Acl, opt.ts, Br, Cx)
    return _CellLoop(radius, radius_v, s, zmin, fdom, bw)


def _stability_warnings(label: str, loop: _CellLoop) -> list[str]:
    """The warning of a cell whose closed loop is unstable on the PWA cell or with the valve."""
    if loop.radius >= 1.0:
        return [
            f"cell {label}: closed loop unstable on the PWA cell (spectral radius {loop.radius:.4f})"
        ]
    if loop.radius_valve >= 1.0:
        return [
            f"cell {label}: unstable with the servo valve's dynamics (spectral radius {loop.radius_valve:.4f})"
        ]
    return []


def _gain_row(K, cell, opt: _FeedbackOptions) -> GainRow:
    """The cell's gain row from K over [P_L, ẋ, x, (ν, ν̇,) I (, pending c)] in SI units."""
    label, _key, lo, hi = cell
    if opt.valve:
        return GainRow(
            lo,
            hi,
            k_pl=K[0, 0],
            k_v=K[0, 1],
            k_x=K[0, 2],
            k_i=-K[0, 5],
            label=label,
            k_nu=K[0, 3],
            k_dnu=K[0, 4],
            k_up=K[0, 6] if opt.delay else 0.0,
        )
    return GainRow(lo, hi, k_pl=K[0, 0], k_v=K[0, 1], k_x=K[0, 2], k_i=-K[0, 3], label=label)


def _cell_record(cell, row: GainRow, loop: _CellLoop, controllable: bool, clipped: bool) -> dict:
    """The cell's row of the design table (engineering units: bar, mm/s, mm, Hz)."""
    label, key, lo, hi = cell
    return {
        "cell": label,
        "g": key[0],
        "s": key[1],
        "o": key[2],
        "w": key[3],
        "p_l_lo_bar": lo[0] / 1e5,
        "p_l_hi_bar": hi[0] / 1e5,
        "v_lo_mm_s": lo[1] * 1e3,
        "v_hi_mm_s": hi[1] * 1e3,
        "k_pl_per_bar": row.k_pl * 1e5,
        "k_v_s_per_m": row.k_v,
        "k_x_per_mm": row.k_x * 1e-3,
        "k_i_per_mm_s": row.k_i * 1e-3,
        "poles": "; ".join(f"{p.real:.0f}{p.imag:+.0f}j" for p in loop.poles),
        "damping_min": loop.damping_min,
        "natural_freq_hz": loop.natural_freq_hz,
        "bandwidth_hz": loop.bandwidth_hz,
        "radius": loop.radius,
        "radius_valve": loop.radius_valve,
        "controllable": controllable,
        "stable": loop.radius < 1.0,
        "friction_clipped": clipped,
    }


def _feedback_info(model, opt: _FeedbackOptions, notes: list[str]) -> dict[str, Any]:
    """The design's ``info`` (also the controller's ``design``): method, options, notes."""
    info = {
        "method": opt.method,
        "sample_time": opt.ts,
        "delay": bool(opt.delay),
        "model": PWA_KIND.name,
        "form": model.form,
        "supply_pressure": model.supply_pressure,
        "friction_slopes": opt.friction_slopes,
        "valve": opt.valve,
        "spool": opt.spool,
        "position_noise": None if opt.position_noise is None else float(opt.position_noise),
        "feedforward": bool(opt.feedforward),
        "notes": notes,
        "pressure_washout": float(opt.pressure_washout),
        "load_force": float(model.params.load.force if opt.load_force is None else opt.load_force),
        "weights": dict(zip(("p_l", "v", "x", "integral"), opt.maxima.tolist(), strict=True))
        | {"u": opt.u_max},
    }
    if opt.method == "place":
        info["poles"] = [[p.real, p.imag] for p in opt.poles]  # type: ignore[union-attr]
    return info


def _feedback_parts(model, opt: _FeedbackOptions) -> dict[str, Any]:
    """The controller's parts beside its rows: P_L washout and definition, flow feed-forward,
    spool model, position observer and machine."""
    prm = model.params
    return {
        "pressure_washout": float(opt.pressure_washout),
        "load_pressure": _load_pressure_of(model),
        "feedforward": _feedforward(model, opt.ts, opt.delay) if opt.feedforward else None,
        "spool_model": dataclasses.replace(
            SpoolModel.from_valve(prm.valve.omega0, prm.valve.zeta, opt.ts),
            measured=opt.spool == "measured",
        )
        if opt.valve
        else None,
        "position_observer": None
        if opt.position_noise is None
        else position_observer_gains(
            opt.ts, float(opt.position_noise), float(opt.acceleration_noise)
        ),
        "machine": machine_of(prm, _finite_or_none(getattr(model, "supply_pressure", None))),
    }


def _loop_options(ts: float, delay, u_limits, anti_windup, dzi) -> dict[str, Any]:
    """The keywords both controllers of this module take alike: sampling, command limits,
    anti-windup and the dead-zone inverse."""
    return {
        "sample_time": ts,
        "delay": bool(delay),
        "u_min": float(u_limits[0]),
        "u_max": float(u_limits[1]),
        "anti_windup": anti_windup,
        "dead_zone_inverse": dzi,
    }


def _finite_or_none(v) -> float | None:
    return None if v is None or not math.isfinite(float(v)) else float(v)


def _feedforward(model, ts: float, delay: bool) -> FlowFeedForward:
    """The flow feed-forward of the design model's parameters at its supply pressure."""
    return FlowFeedForward.from_params(
        model.params,
        sample_time=ts,
        delay=delay,
        supply_pressure=_finite_or_none(getattr(model, "supply_pressure", None)),
    )


def _margins(L: np.ndarray) -> tuple[float, float]:
    """Gain margin [dB] and phase margin [deg] of a loop's frequency response on a grid.

    Smallest over all crossings: |L| = 1 (phase margin 180° + ∠L) and ∠L = −180° (gain
    margin −20 log|L|), located by linear interpolation between grid points.
    """
    mag = np.abs(L)
    ph = np.unwrap(np.angle(L))
    pm = math.inf
    for i in np.flatnonzero(np.diff(np.sign(mag - 1.0)) != 0):
        f = (1.0 - mag[i]) / (mag[i + 1] - mag[i])
        p = math.degrees(ph[i] + f * (ph[i + 1] - ph[i]))
        pm = min(pm, (p + 180.0 + 180.0) % 360.0 - 180.0)
    gm = math.inf
    pc = (ph + math.pi) / (2 * math.pi)  # integer at phase −180° (mod 360°)
    for i in np.flatnonzero(np.diff(np.floor(pc)) != 0):
        k = math.floor(max(pc[i], pc[i + 1]))
        f = (k - pc[i]) / (pc[i + 1] - pc[i])
        gm = min(gm, -20.0 * math.log10(mag[i] + f * (mag[i + 1] - mag[i])))
    return gm, pm


def design_pi(
    model,
    *,
    point: Mapping[str, float] | None = None,
    sample_time: float = DEFAULT_SAMPLE_TIME,
    delay: bool = False,
    integral: bool = True,
    feedforward: bool = True,
    phase_margin: float = 60.0,
    gain_margin_db: float = 10.0,
    integral_ratio: float = 0.2,
    dead_zone_inverse: bool = True,
    include_valve: bool = True,
    u_limits: tuple[float, float] = (-1.0, 1.0),
    anti_windup: str = "clamp",
    flow_feedforward: bool = False,
) -> ControlDesign:
    """P/PI position controller with velocity feed-forward, designed at one working point.

    The plant is the PWA cell at ``point`` (default: moving out at 50 mm/s against the
    parameter set's load), with the servo valve's second-order dynamics (Eq. (1)) if
    ``include_valve``, discretised with ZOH (and a sample of delay). The loop gain
    k_p K_v (K_v the velocity gain ∂ẋ/∂c in steady state [m/s]) is the crossover
    frequency; the largest one with both margins is taken. The integral corner sits
    at ``integral_ratio`` × crossover (k_i = k_p·ratio·ω_c) and the feed-forward is
    k_ff = 1/K_v [s/m]. With ``flow_feedforward`` the constant k_ff is replaced by the
    flow feed-forward per direction with its load-pressure correction
    (:class:`FlowFeedForward`).

    Returns
    -------
    ControlDesign
        ``table`` holds the one working point: gains, margins, crossover, poles.
    """
    import pandas as pd  # deferred: pandas costs ~0.3 s at import

    prm = model.params
    ts = float(sample_time)
    if not (math.isfinite(ts) and 0 < ts <= 0.1):
        raise ControlError(f"sample_time {sample_time!r} s must be in (0, 0.1]")
    if point is None:
        p_l = prm.load.force / (
            model.force_area if hasattr(model, "force_area") else prm.cylinder.mean_area
        )
        point = {"p_l": p_l, "v": 0.1, "u": 0.3}  # the outer (viscous) friction cell: rising slope
    k_v, dyn, plant = _pi_plant(model, point, ts, delay, dead_zone_inverse, include_valve)
    loop = _pi_crossover(
        plant,
        k_v,
        ts,
        integral,
        integral_ratio,
        phase_margin=phase_margin,
        gain_margin_db=gain_margin_db,
    )
    s, zeta, bw = _pi_loop_stats(loop.cl, ts)
    dzi = DeadZoneInverse.from_params(prm.dead_zone) if dead_zone_inverse else None
    ctrl = PIController(
        load_pressure=_load_pressure_of(model),
        kp=loop.kp,
        ki=loop.ki,
        kff=(1.0 / k_v if feedforward and not flow_feedforward else 0.0),
        feedforward=_feedforward(model, ts, delay) if flow_feedforward else None,
        machine=machine_of(prm, _finite_or_none(getattr(model, "supply_pressure", None))),
        **_loop_options(ts, delay, u_limits, anti_windup, dzi),
    )
    rec = {
        "cell": f"s={dyn.cells.s:+d} o={dyn.cells.o} w={dyn.cells.w}",
        "p_l_bar": point["p_l"] / 1e5,
        "v_mm_s": point["v"] * 1e3,
        "velocity_gain_m_s": k_v,
        "crossover_hz": loop.wc / (2 * math.pi),
        "kp_per_mm": loop.kp * 1e-3,
        "ki_per_mm_s": loop.ki * 1e-3,
        "kff_s_per_m": ctrl.kff,
        "gain_margin_db": loop.gain_margin_db,
        "phase_margin_deg": loop.phase_margin,
        "poles": "; ".join(f"{p.real:.0f}{p.imag:+.0f}j" for p in s),
        "damping_min": zeta,
        "bandwidth_hz": bw,
        "radius": float(np.max(np.abs(loop.cl.poles()))),
        "radius_valve": float(np.max(np.abs(loop.cl.poles()))),
        "controllable": True,
        "stable": True,
    }
    info = {
        "method": "pi",
        "sample_time": ts,
        "delay": bool(delay),
        "point": dict(point),
        "include_valve": bool(include_valve),
        "phase_margin": phase_margin,
        "gain_margin_db": gain_margin_db,
    }
    return ControlDesign(ctrl, pd.DataFrame.from_records([rec]), [], info)


def _pi_plant(model, point, ts: float, delay, dead_zone_inverse: bool, include_valve: bool):
    """(K_v [m/s], the cell's dynamics, the sampled plant c → x) of :func:`design_pi` at ``point``.

    K_v is the steady velocity per unit input of the cell's [P_L, ẋ] subsystem; the plant is
    the cell with the servo valve (Eq. (1)) before it if ``include_valve``, sampled with ZOH,
    and a sample of delay if ``delay``.
    """
    import control  # deferred: python-control loads scipy.signal and matplotlib

    prm = model.params
    A, B, dyn = cell_plant(model, point=point, opening_input=dead_zone_inverse)
    k_v = float(-(np.linalg.solve(A[:2, :2], B[:2, 0]))[1])
    if not k_v > 0:
        raise ControlError(
            f"velocity gain {k_v:g} m/s at the working point is not positive; choose another point"
        )
    plant = control.ss(A, B, np.array([[0.0, 0.0, 1.0]]), np.zeros((1, 1)))
    if include_valve:
        w0, z0 = prm.valve.omega0, prm.valve.zeta
        plant = control.series(control.tf([w0**2], [1.0, 2 * z0 * w0, w0**2]), plant)
    pd_ = control.sample_system(plant, ts, method="zoh")
    if delay:
        pd_ = control.series(control.tf([1.0], [1.0, 0.0], ts), pd_)
    return k_v, dyn, pd_


@dataclass(frozen=True, eq=False)
class _PiLoop:
    """The kept crossover of :func:`design_pi`: ω_c [rad/s], k_p [1/m], k_i [1/(m·s)], the
    margins [dB, deg] and the closed loop r → x (a python-control transfer function)."""

    wc: float
    kp: float
    ki: float
    gain_margin_db: float
    phase_margin: float
    cl: Any


def _pi_crossover(
    plant, k_v: float, ts: float, integral, integral_ratio, *, phase_margin, gain_margin_db
) -> _PiLoop:
    """The highest crossover ω_c (240 steps from half Nyquist down to 1 rad/s) whose loop
    k_p K_v = ω_c meets both margins (``phase_margin`` [deg], ``gain_margin_db`` [dB]) and
    whose closed loop is stable; k_i = k_p·``integral_ratio``·ω_c with ``integral``."""
    import control  # deferred: python-control loads scipy.signal and matplotlib

    w_nyq = math.pi / ts
    # the plant's frequency response once; the controller's is analytic in kp, ki
    w = np.geomspace(1e-2, 0.999 * w_nyq, 4000)
    zz = np.exp(1j * w * ts)
    P = np.asarray(plant(zz), dtype=complex).ravel()
    for wc in np.geomspace(0.5 * w_nyq, 1.0, 240):
        kp = wc / k_v
        ki = kp * integral_ratio * wc if integral else 0.0
        gm_db, pm = _margins((kp + ki * ts * zz / (zz - 1.0)) * P)
        if gm_db < gain_margin_db or pm < phase_margin:
            continue
        cz = (
            control.tf([kp + ki * ts, -kp], [1.0, -1.0], ts)
            if integral
            else control.tf([kp], [1.0], ts)
        )
        cl = control.feedback(control.series(cz, plant), 1)
        if np.max(np.abs(cl.poles())) < 1.0:
            return _PiLoop(wc, kp, ki, gm_db, pm, cl)
    raise ControlError("no crossover meets the margins; relax phase_margin / gain_margin_db")


def _pi_loop_stats(cl, ts: float) -> tuple[np.ndarray, float, float]:
    """(continuous-equivalent poles ln(z)/T_s [1/s], smallest damping, bandwidth r → x [Hz])."""
    s = np.log(cl.poles().astype(complex)) / ts
    wn = np.abs(s)
    zeta = float(np.min(-s.real / np.where(wn > 0, wn, 1.0)))
    f = np.logspace(-1, math.log10(0.499 / ts), 400)
    mag = np.abs(cl(np.exp(2j * math.pi * f * ts)))
    below = np.flatnonzero(mag < abs(cl(1.0)) / math.sqrt(2.0))
    bw = float(f[below[0]]) if below.size else float(f[-1])
    return s, zeta, bw


def design_textbook_pi(
    model,
    *,
    sample_time: float = DEFAULT_SAMPLE_TIME,
    delay: bool = True,
    gain_margin_db: float = 6.0,
) -> ControlDesign:
    """The baseline of the reports: a textbook PI with velocity feed-forward from the same parameters.

    Crossover ω_c = min(ω_h, ω0)/3 (ω_h the hydraulic natural frequency, |λ| of the [P_L, ẋ]
    block of the PWA cell moving out at 50 mm/s against the parameter set's load; ω0 the
    servo valve's), lowered in 3 % steps until the gain margin on the sampled plant with the
    valve (Eq. (1)), the ZOH and the delay is ``gain_margin_db``; k_p = ω_c/K_v, the integral
    corner at ω_c/5 (k_i = k_p ω_c/5), k_ff = 1/K_v, the identified dead zone's inverse.
    """
    import control  # deferred: python-control loads scipy.signal and matplotlib
    import pandas as pd  # deferred: pandas costs ~0.3 s at import

    prm = model.params
    ts = float(sample_time)
    point = {"p_l": prm.load.force / prm.cylinder.area_a, "v": 0.05, "u": 0.3}
    A, B, _dyn = cell_plant(model, point=point)
    k_v = float(-(np.linalg.solve(A[:2, :2], B[:2, 0]))[1])
    w_h = float(np.max(np.abs(np.linalg.eigvals(A[:2, :2]))))
    w0, z0 = prm.valve.omega0, prm.valve.zeta
    plant = control.series(
        control.tf([w0**2], [1.0, 2 * z0 * w0, w0**2]),
        control.ss(A, B, np.array([[0.0, 0.0, 1.0]]), np.zeros((1, 1))),
    )
    pdz = control.sample_system(plant, ts, method="zoh")
    if delay:
        pdz = control.series(control.tf([1.0], [1.0, 0.0], ts), pdz)
    w = np.geomspace(1e-1, 0.999 * math.pi / ts, 4000)
    zz = np.exp(1j * w * ts)
    P = np.asarray(pdz(zz), dtype=complex).ravel()
    wc = min(w_h, w0) / 3.0
    gm = pm = math.nan
    while wc > 1.0:
        kp = wc / k_v
        ki = kp * wc / 5.0
        gm, pm = _margins((kp + ki * ts * zz / (zz - 1.0)) * P)
        if gm >= gain_margin_db:
            break
        wc *= 0.97
    ctrl = PIController(
        kp=wc / k_v,
        ki=wc / k_v * wc / 5.0,
        kff=1.0 / k_v,
        sample_time=ts,
        delay=bool(delay),
        dead_zone_inverse=DeadZoneInverse.from_params(prm.dead_zone),
        load_pressure=_load_pressure_of(model),
        machine=machine_of(prm, _finite_or_none(getattr(model, "supply_pressure", None))),
    )
    rec = {
        "crossover_hz": wc / (2 * math.pi),
        "hydraulic_hz": w_h / (2 * math.pi),
        "valve_hz": w0 / (2 * math.pi),
        "gain_margin_db": gm,
        "phase_margin_deg": pm,
        "kp_per_mm": ctrl.kp * 1e-3,
        "ki_per_mm_s": ctrl.ki * 1e-3,
        "kff_s_per_m": ctrl.kff,
    }
    info = {"method": "textbook-pi", "sample_time": ts, "delay": bool(delay), "point": point}
    return ControlDesign(ctrl, pd.DataFrame.from_records([rec]), [], info)


def _load_pressure_of(model) -> str:
    """The P_L definition of the design model: asymmetric (P_A − α P_B) or the paper's mean-area form."""
    return "asymmetric" if getattr(model, "form", "asymmetric") == "asymmetric" else "mean-area"
