"""What a control engineer checks first: small-signal Bode, pole map, per-cell margins, error bounds.

Each function computes its numbers from the package's models (the PWA cells' exact Jacobian,
the full model's Jacobian from the compiled kernel, the designed controller's gain rows) and
returns a result object with a table view; the figures are drawn by :mod:`hydropwa.plotting`
and shown by the study's report.

* :func:`small_signal_bode`: u → ẋ of the linearized model (the PWA cell at mid stroke, in
  series with the servo valve of Eq. (1)) against the full model's small-signal response at
  the same working point (its exact Jacobian at the steady motion), with the measured valve
  FRF (the identify stage's) where there is one.
* :func:`cell_poles`: per cell, the poles of the cell with the servo valve (open loop) and, with
  a controller, of the sampled closed loop (valve, zero-order hold, integral, delay).
* :func:`cell_loops` with a controller: per cell, gain and phase margin of that loop broken at
  the valve command (:func:`loop_margins`).
* :func:`error_bound_map`: the guaranteed per-cell bound on the PWA model's Ṗ_L error
  (:meth:`~hydropwa.linearization.PwaModel.error_bound`) over the partition.
"""

from __future__ import annotations

import dataclasses
import math
import re
from typing import Any

import numpy as np

from .._errors import HydropwaError
from ..control import (  # the design's own plant, clipping and augmentation (one assembly)
    cell_plant,
    clip_friction_slope,
    friction_slope_limit,
    valve_augment,
    valve_series,
)
from ..linearization import export_pwa
from ..models import FullOrderModel
from ..simulation import full_small_signal

__all__ = [
    "BodeComparison",
    "CellLoops",
    "EngineeringError",
    "cell_loops",
    "loop_margins",
    "error_bound_map",
    "small_signal_bode",
]


class EngineeringError(HydropwaError, ValueError):
    """An engineering view cannot be computed as asked (no cell, no controller rows)."""


# ----------------------------------------------------------------------------- Bode
@dataclasses.dataclass(frozen=True)
class BodeComparison:
    """u → ẋ frequency responses of the linearized and the full model at one working point.

    Attributes
    ----------
    frequency : ndarray (K,)
        [Hz].
    linearized, full : ndarray of complex (K,)
        ẋ/u [m/s per unit command] of the PWA cell in series with the servo valve (Eq. (1)),
        and of the full model's Jacobian at its steady motion.
    natural_frequency : float
        Hydraulic natural frequency [Hz] of the cell: |λ| of its complex [P_L, ẋ] pole pair.
    valve_frequency : float
        ω0/2π [Hz] of the servo valve at small amplitude.
    working_point : dict
        x [m], u [1], P_L [Pa], ẋ [m/s] and P_S [Pa] of the PWA cell; cell (g, s, o, n, w).
    measured : dict of float → (ndarray, ndarray)
        Per command amplitude: frequency [Hz] and the measured valve FRF ν/u [1].
    """

    frequency: np.ndarray
    linearized: np.ndarray
    full: np.ndarray
    natural_frequency: float
    valve_frequency: float
    working_point: dict
    measured: dict = dataclasses.field(default_factory=dict)

    def agreement(self, below: float = 0.5) -> tuple[float, float]:
        """Largest relative magnitude error [1] and phase error [deg] of the linearized model
        against the full one at frequencies up to ``below`` × the natural frequency."""
        keep = self.frequency <= below * self.natural_frequency
        r = self.linearized[keep] / self.full[keep]
        return float(np.max(np.abs(np.abs(r) - 1.0))), float(
            np.max(np.abs(np.degrees(np.angle(r))))
        )

    def __repr__(self) -> str:
        mag, ph = self.agreement(0.5)
        u = self.working_point["u"]
        return (
            f"BodeComparison({self.frequency.size} frequencies, u = {100 * u:.0f} %: hydraulic "
            f"{self.natural_frequency:.0f} Hz, valve {self.valve_frequency:.0f} Hz; below half "
            f"the hydraulic one within {100 * mag:.2g} % / {ph:.2g}°)"
        )

    def _repr_html_(self) -> str:
        mag, ph = self.agreement(0.5)
        rows = (
            ("hydraulic natural frequency", f"{self.natural_frequency:.4g}", "Hz"),
            ("valve ω0/2π", f"{self.valve_frequency:.4g}", "Hz"),
            ("static gain, linearized", f"{abs(self.linearized[0]) * 10:.4g}", "(mm/s)/%"),
            ("static gain, full", f"{abs(self.full[0]) * 10:.4g}", "(mm/s)/%"),
            ("largest magnitude error below f_h/2", f"{100 * mag:.3g}", "%"),
            ("largest phase error below f_h/2", f"{ph:.3g}", "deg"),
        )
        body = "".join(f"<tr><td>{a}</td><td>{b}</td><td>{c}</td></tr>" for a, b, c in rows)
        return f"<div><table><tbody>{body}</tbody></table></div>"

    def to_pandas(self):
        """One row per frequency: magnitude [(mm/s)/%] and phase [deg] of both models."""
        import pandas as pd  # deferred: pandas costs ~0.3 s at import

        g = 1e3 / 100.0  # m/s per unit command -> (mm/s) per % of command
        return pd.DataFrame(
            {
                "frequency [Hz]": self.frequency,
                "linearized |ẋ/u| [(mm/s)/%]": np.abs(self.linearized) * g,
                "linearized phase [deg]": np.degrees(np.unwrap(np.angle(self.linearized))),
                "full |ẋ/u| [(mm/s)/%]": np.abs(self.full) * g,
                "full phase [deg]": np.degrees(np.unwrap(np.angle(self.full))),
            }
        )

    def plot(self, ax=None):
        """Bode plot (:func:`hydropwa.plotting.plot_small_signal_bode`)."""
        from ..plotting import plot_small_signal_bode  # deferred: matplotlib

        return plot_small_signal_bode(self)


def _pwa_steady(pwa, u: float, x: float, ps: float, fl: float) -> tuple[float, float]:
    """(P_L, ẋ) of the PWA model's steady motion at command u and position x (Ṗ_L = v̇ = 0)."""
    from scipy.optimize import root  # deferred: scipy submodules cost 0.1-0.5 s at import

    def resid(z):
        f = pwa.rhs(0.0, np.array([z[0] * ps, z[1], x]), u, ps, fl)
        return [f[0] / (ps * 1e3), f[1] / 1e3]

    for guess in ((0.0, 0.0), (0.3 * np.sign(u), 0.05 * np.sign(u)), (-0.3, 0.05)):
        sol = root(resid, np.array(guess, dtype=float), method="hybr")
        if sol.success and max(abs(v) for v in sol.fun) < 1e-9:
            return float(sol.x[0] * ps), float(sol.x[1])
    raise EngineeringError(
        f"the PWA model has no steady motion at u = {u:g}; choose another command"
    )


def default_command(pwa) -> float:
    """A small-signal working point's command: a fifth of the way from the dead zone's
    outer edge to full opening, extending (outside the dead zone, so the flow gain is the
    valve's, not the creep band's)."""
    edge = float(pwa.params.dead_zone.beta) if hasattr(pwa.params.dead_zone, "beta") else 0.0
    return edge + 0.2 * (1.0 - edge)


def small_signal_bode(
    pwa, *, command: float | None = None, frequency=None, valve_frf=None
) -> BodeComparison:
    """The linearized model's u → ẋ response against the full model's small-signal response.

    Parameters
    ----------
    pwa : PwaModel
        The PWA model (its parameters define the full model too).
    command : float, optional
        Working-point command u [1] (default :func:`default_command`); the rod is at mid stroke.
    frequency : array_like, optional
        Frequencies [Hz] (default 0.5 Hz … 3× the larger of the valve and the hydraulic
        natural frequency, 300 points).
    valve_frf : mapping of float → FrequencyResponse, optional
        The measured valve FRFs (``ValveFrfIdentifier.frf_``).

    Returns
    -------
    BodeComparison

    Notes
    -----
    Linearized: ẋ/u = C (sI − A)⁻¹ B · ω0²/(s² + 2ζω0 s + ω0²) with (A, B) the PWA cell's
    exact Jacobian at the steady motion (Eqs. (23)–(28), the cell the working point lies in)
    and the servo valve of Eq. (1) in series (python-control ``series``). Full: the exact
    Jacobian of Eqs. (1)–(11) at the full model's own steady motion (valve, both chambers,
    P_S held). Below the hydraulic natural frequency the two agree to within the cells'
    approximation of the orifice flow; above it the full model's two chamber stiffnesses and
    the friction slope of the operating velocity set the difference.
    """
    import control  # deferred: python-control loads scipy.signal and matplotlib

    prm = pwa.params
    ps = float(pwa.supply_pressure)
    fl = float(prm.load.force)
    u = default_command(pwa) if command is None else float(command)
    x = 0.5 * prm.cylinder.stroke
    p_l, v = _pwa_steady(pwa, u, x, ps, fl)
    dyn = pwa.state_space({"p_l": p_l, "v": v, "u": u, "x": x}, f_l=fl)
    w0, zeta = float(prm.valve.omega0_at(0.0)), float(prm.valve.zeta)
    valve = control.tf([w0**2], [1.0, 2 * zeta * w0, w0**2])
    cell = control.ss(dyn.A, dyn.B, [[0.0, 1.0, 0.0]], [[0.0]])
    lin = control.series(valve, cell)
    full_prm = prm if prm.supply.model == "ideal" else prm.replace(**{"supply.model": "ideal"})
    ss = full_small_signal(FullOrderModel(full_prm), u, x, ps, fl)
    c_full = np.zeros((1, ss.A.shape[0]))
    c_full[0, ss.states.index("v")] = 1.0
    full = control.ss(ss.A, ss.B, c_full, [[0.0]])
    lam = np.linalg.eigvals(dyn.A[:2, :2])
    wn = float(np.max(np.abs(lam))) / (2 * math.pi)
    if frequency is None:
        frequency = np.logspace(math.log10(0.5), math.log10(3 * max(wn, w0 / (2 * math.pi))), 300)
    f = np.asarray(frequency, dtype=float)
    s = 2j * math.pi * f
    measured = {
        float(a): (np.asarray(r.frequency, float), np.asarray(r.response, complex))
        for a, r in (valve_frf or {}).items()
    }
    return BodeComparison(
        frequency=f,
        linearized=np.asarray(lin(s), complex).ravel(),
        full=np.asarray(full(s), complex).ravel(),
        natural_frequency=wn,
        valve_frequency=w0 / (2 * math.pi),
        working_point={"x": x, "u": u, "p_l": p_l, "v": v, "p_s": ps, "cell": tuple(dyn.cells)},
        measured=measured,
    )


# ----------------------------------------------------------------------------- per-cell loops
_LABEL = re.compile(r"s=([+-]?\d+)\s+o=(\d+)\s+w=(\d+)")


@dataclasses.dataclass(frozen=True)
class CellLoops:
    """Per PWA cell: poles with the servo valve, and the designed loop's margins.

    Attributes
    ----------
    table : pandas.DataFrame
        One row per cell (``cell`` label, g, s, o, w): ``open_loop_max_real [1/s]``, the
        largest real part of the cell's poles with the valve; with a controller
        ``friction_clipped`` (the design clipped the cell's friction slope), ``radius [1]``
        (spectral radius of the sampled closed loop) and the margins of :func:`loop_margins`.
    open_loop : dict of str → ndarray of complex
        Continuous-time poles [1/s] of each cell with the servo valve (Eq. (1)).
    closed_loop : dict of str → ndarray of complex
        Continuous-time equivalents ln(z)/T_s [1/s] of the sampled closed loop's poles.
    sample_time : float or None
        T_s [s] of the controller.
    """

    table: Any
    open_loop: dict
    closed_loop: dict
    sample_time: float | None = None

    def to_pandas(self):
        """The per-cell table."""
        return self.table.copy()

    def _repr_html_(self) -> str:
        table = self.table.to_html(index=False, float_format=lambda v: f"{v:.4g}", border=0)
        plain = table.replace('<table class="dataframe">', "<table>")
        return f"<div>{plain}</div>"

    def __repr__(self) -> str:
        t = self.table
        if "radius [1]" not in t:
            worst = float(t["open_loop_max_real [1/s]"].max()) if len(t) else math.nan
            return f"CellLoops({len(t)} cells, open loop only: largest real part {worst:.4g} 1/s)"
        return (
            f"CellLoops({len(t)} cells: closed-loop radius ≤ {t['radius [1]'].max():.4f}, "
            f"phase margin ≥ {t['phase_margin [deg]'].min():.1f}°, "
            f"gain margin ≥ {t['gain_margin [dB]'].min():.1f} dB)"
        )


def _cell_keys(pwa, controller) -> list[tuple[str, tuple[int, int, int, int], Any]]:
    """(label, (g, s, o, w), gain row or None) per cell the loop meets."""
    if controller is not None:
        rows = getattr(controller, "rows", None)
        if not rows:
            raise EngineeringError(
                "the controller has no per-cell gain rows (a PI controller); the per-cell "
                "margins need a gain-scheduled state feedback (hydropwa control design)"
            )
        out = []
        for row in rows:
            m = _LABEL.search(row.label)
            if m is None:
                raise EngineeringError(f"gain row {row.label!r} names no cell 's=±1 o=… w=…'")
            s, o, w = (int(v) for v in m.groups())
            g = int(pwa.dead_zone.cell(0.5 * s))
            out.append((row.label, (g, s, o, w), row))
        return out
    seen: dict = {}
    for idx, _lo, _hi in pwa.regions():
        if idx.g != int(pwa.dead_zone.cell(0.5 * idx.s)):
            continue  # the dead-zone inverse leaves the outer cells only
        key = (idx.g, idx.s, idx.o, idx.w)
        seen.setdefault(key, (f"s={idx.s:+d} o={idx.o} w={idx.w}", key, None))
    return list(seen.values())


def _design_plant(pwa, key, f_l, opening: bool, clip: bool):
    """Continuous (A, B) of a cell as the design saw it, and whether its friction slope was clipped.

    ``clip``: the design's ``friction_slopes="clip"`` rule (``design_state_feedback``): the
    cell's friction slope k_w held to [0, the larger slope of the two outer viscous cells].
    """
    A, B, _ = cell_plant(pwa, cells=key, f_l=f_l, opening_input=opening)
    if not clip:
        return A, B, False
    A, clipped = clip_friction_slope(A, friction_slope_limit(pwa), pwa.params.load.mass)
    return A, B, clipped


def _loop(A, B, row, controller, valve):
    """Sampled loop of one cell: (Aa, Ba, K) with u = −K·state, as the design builds it."""
    ts, delay = float(controller.sample_time), bool(controller.delay)
    Aa, Ba = valve_augment(A, B, ts, valve.omega0, valve.zeta, delay)
    K = np.zeros((1, Aa.shape[0]))
    K[0, :6] = (row.k_pl, row.k_v, row.k_x, row.k_nu, row.k_dnu, -row.k_i)
    if delay:
        K[0, 6] = row.k_up
    return Aa, Ba, K


def _radius_at(Aa, Ba, K, k: float) -> float:
    return float(np.max(np.abs(np.linalg.eigvals(Aa - k * (Ba @ K)))))


def _gain_limit(Aa, Ba, K, up: bool) -> float:
    """The gain factor, above (``up``) or below 1, at which a closed-loop pole first reaches
    |z| = 1 (inf or 0 if none within 10⁶): scanned in 1 dB steps, then bisected."""
    step = 10 ** (1 / 20) if up else 10 ** (-1 / 20)
    k_in = 1.0
    while 1e-6 < k_in < 1e6:
        k_out = k_in * step
        if _radius_at(Aa, Ba, K, k_out) >= 1.0:
            for _ in range(40):
                mid = math.sqrt(k_in * k_out)
                k_in, k_out = (mid, k_out) if _radius_at(Aa, Ba, K, mid) < 1.0 else (k_in, mid)
            return math.sqrt(k_in * k_out)
        k_in = k_out
    return math.inf if up else 0.0


def loop_margins(Aa, Ba, K, ts: float) -> dict[str, float]:
    """Margins of the sampled loop L(z) = K (zI − Aa)⁻¹ Ba (negative feedback, u = −K·state).

    Returns
    -------
    dict
        ``gain_margin [dB]``: the smallest gain increase at which a closed-loop pole reaches
        the unit circle (inf if none); ``lower_gain_margin [dB]``: the smallest decrease that
        does (−inf if none); ``phase_margin [deg]``: 180° + ∠L at the gain crossover
        |L(e^{jωT_s})| = 1 where it is smallest, and that ``gain_crossover [Hz]``;
        ``stability_margin [1]``: least distance of L(e^{jωT_s}) to −1 (0.01 Hz … Nyquist).
        NaN margins for a loop that is unstable as designed.

    Notes
    -----
    Gain margins come from the closed-loop eigenvalues and phase margins from crossings
    solved on L(e^{jωT_s}) (Brent's method between grid points), not from python-control's
    ``stability_margins``: on the sampled state space (through its transfer function, poles
    at z = 1 from the rod's integrator and the integral action) it reported a gain margin of
    4.76 for a paper-rig cell whose poles stay inside the unit circle up to 14.1, and on a
    frequency-response object it took 1.6 s per cell. Its phase margin on a frequency-response
    object agrees with this one (tests/evaluation/test_engineering.py).
    """
    from scipy.optimize import brentq  # deferred: scipy submodules cost 0.1-0.5 s at import

    n = Aa.shape[0]

    def loop(f):
        z = np.exp(2j * math.pi * np.atleast_1d(f) * ts)
        M = z[:, None, None] * np.eye(n)[None] - Aa[None]
        rhs = np.broadcast_to(Ba.astype(complex), (z.size, n, 1))
        return (K[0] @ np.linalg.solve(M, rhs)[..., 0].T).ravel()

    stable = _radius_at(Aa, Ba, K, 1.0) < 1.0
    f = np.logspace(-2.0, math.log10(0.5 / ts), 1500)
    resp = loop(f)
    pm, wgc = math.inf, math.nan
    for i in np.flatnonzero(np.diff(np.sign(np.abs(resp) - 1.0)) != 0):
        fc = brentq(lambda x: abs(loop(x)[0]) - 1.0, f[i], f[i + 1], xtol=1e-9 * f[i])
        p = (math.degrees(float(np.angle(loop(fc)[0]))) + 360.0) % 360.0 - 180.0
        if abs(p) < abs(pm):
            pm, wgc = p, fc
    # an unstable loop has no gain margin (nan): there is no stable gain to start from
    up = _gain_limit(Aa, Ba, K, True) if stable else math.nan
    down = _gain_limit(Aa, Ba, K, False) if stable else math.nan
    return {
        "gain_margin [dB]": 20 * math.log10(up) if up > 0 and math.isfinite(up) else up,
        "lower_gain_margin [dB]": 20 * math.log10(down)
        if down > 0
        else (-math.inf if down == 0 else down),
        "phase_margin [deg]": pm if stable else math.nan,
        "gain_crossover [Hz]": wgc,
        "stability_margin [1]": float(np.min(np.abs(1.0 + resp))),
    }


def cell_loops(
    pwa, controller=None, *, load_force: float | None = None, friction: str = "design"
) -> CellLoops:
    """Poles with the servo valve per cell and, with a controller, each cell's loop margins.

    Parameters
    ----------
    pwa : PwaModel
        The model the controller was designed on.
    controller : StateFeedbackController, optional
        Gain-scheduled state feedback (one gain row per cell, ``hydropwa control design``).
    load_force : float, optional
        F_L [N] of the cells' linearization (default the controller's design load force,
        else ``params.load.force``).
    friction : {"design", "exact"}
        Closed loop on the cells as the design saw them (``"design"``: friction slopes clipped
        where the design clipped them, so the poles are the design table's) or on the cells'
        exact friction slopes (``"exact"``: what the loop meets on the falling Stribeck branch).

    Returns
    -------
    CellLoops

    Notes
    -----
    Open loop: the eigenvalues of the cell's exact Jacobian (Eqs. (23)–(28), its friction
    slope as it is) with the servo valve ν̈ = ω0²(c − ν) − 2ζω0ν̇ (Eq. (1)) before it. Closed
    loop: the cell, valve and integral sampled with a zero-order hold at T_s (with the
    one-sample delay where the controller has it) under the cell's gain row, u = −K·state,
    as ``design_state_feedback`` builds it; the loop L(z) = K (zI − A_d)⁻¹ B_d broken at the
    command gives the margins (:func:`loop_margins`).
    """
    import pandas as pd  # deferred: pandas costs ~0.3 s at import

    if friction not in ("design", "exact"):
        raise EngineeringError(f"friction {friction!r} must be 'design' or 'exact'")
    prm = pwa.params
    design = (getattr(controller, "design", None) or {}) if controller is not None else {}
    if load_force is None:
        load_force = design.get("load_force")
    fl = float(prm.load.force if load_force is None else load_force)
    clip = friction == "design" and design.get("friction_slopes", "clip") == "clip"
    opening = getattr(controller, "dead_zone_inverse", None) is not None or controller is None
    keys = _cell_keys(pwa, controller)
    recs, ol, cl = [], {}, {}
    for label, key, row in keys:
        A, B, _ = _design_plant(pwa, key, fl, opening, clip=False)
        poles = np.linalg.eigvals(valve_series(A, B, prm.valve.omega0, prm.valve.zeta)[0])
        ol[label] = poles
        rec: dict[str, Any] = {
            "cell": label,
            "g": key[0],
            "s": key[1],
            "o": key[2],
            "w": key[3],
            "open_loop_max_real [1/s]": float(np.max(poles.real)),
        }
        if row is not None:
            A, B, clipped = _design_plant(pwa, key, fl, opening, clip=clip)
            Aa, Ba, K = _loop(A, B, row, controller, prm.valve)
            ts = float(controller.sample_time)
            z = np.linalg.eigvals(Aa - Ba @ K).astype(complex)
            cl[label] = np.log(np.where(np.abs(z) < 1e-300, 1e-300, z)) / ts
            rec |= {"friction_clipped": clipped, "radius [1]": float(np.max(np.abs(z)))}
            rec |= loop_margins(Aa, Ba, K, ts)
        recs.append(rec)
    return CellLoops(
        pd.DataFrame.from_records(recs),
        ol,
        cl,
        None if controller is None else float(controller.sample_time),
    )


# ----------------------------------------------------------------------------- error bounds
def error_bound_map(pwa, p_s: float | None = None):
    """The PWA model's guaranteed Ṗ_L error bound per cell over the partition.

    Parameters
    ----------
    pwa : PwaModel
    p_s : float, optional
        Supply pressure [Pa] (default the model's).

    Returns
    -------
    pandas.DataFrame
        One row per cell combination (g, s, o, n, w) with its box (``p_l_lo``, ``p_l_hi``
        [Pa], ``v_lo``, ``v_hi`` [m/s], ``u_lo``, ``u_hi`` [1]) and ``error_bound`` [Pa/s]:
        the guaranteed max over the box of |Ṗ_L(PWA) − (A y + B u + f)₀| of the cell's affine
        system at its working point (:meth:`~hydropwa.linearization.PwaModel.error_bound`,
        the value ``export_pwa`` writes), and ``relative_bound`` [1]: that bound over the
        largest |Ṗ_L| the cell's affine system reaches at the box's corners.
    """
    import pandas as pd  # deferred: pandas costs ~0.3 s at import

    doc = export_pwa(pwa, supply_pressure=p_s)
    regions = pwa.regions(p_s)
    if len(regions) != len(doc["cells"]):  # no refinement: one exported cell per region
        raise EngineeringError("the export's cells do not match the model's regions")
    rows = []
    for (idx, lo, hi), cell in zip(regions, doc["cells"], strict=True):
        A, B, f = np.asarray(cell["A"]), np.asarray(cell["B"]), np.asarray(cell["f"])
        corners = [
            A[0] @ np.array([p, v, x]) + B[0, 0] * u + f[0]
            for p in (lo[0], hi[0])
            for v in (lo[1], hi[1])
            for x in (lo[2], hi[2])
            for u in (lo[3], hi[3])
        ]
        scale = max(abs(c) for c in corners)
        rows.append(
            {
                **idx._asdict(),
                "p_l_lo": lo[0],
                "p_l_hi": hi[0],
                "v_lo": lo[1],
                "v_hi": hi[1],
                "u_lo": lo[3],
                "u_hi": hi[3],
                "error_bound": float(cell["error_bound"]),
                "relative_bound": float(cell["error_bound"]) / scale if scale > 0 else math.nan,
            }
        )
    return pd.DataFrame(rows)
