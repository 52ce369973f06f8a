"""The default controller re-measured on an independent plant, through its generated C (issue 34).

Usage::

    python benchmarks/independent_plant.py [--seeds N] [--no-holds] [--no-pi] [--machine paper]
        [--draws N]

**The plant** (:class:`IndependentPlant`): the full-order single-rod axis written again from the
paper's Eqs. (1)–(11) in plain Python floats, with the package's documented decisions on the
paper's errata (docs/errata.md): −Q_B in the B chamber (E1), a signed root with the odd cubic
below the transition pressure (E3), the dead zone of Table IV with its creep slope (E4), the
bulk modulus falling below the air-release pressure (D1), the end stops (D2), ω0 from Table II
at the command's peak in open loop and the nominal ω0 in closed loop (D3), the counter
cylinder's damping (D4). It reads the physical fields of a ``SystemParams`` (SI), not the
packed kernel vector, and calls none of hydropwa's physics or simulation functions; scipy's
``solve_ivp`` (LSODA, rtol 1e-8) integrates it, from one sample instant to the next with the
command held (zero-order hold).

**The sensors** (:class:`Sensors`): 20 µm on the position, 0.1 bar on each chamber pressure
(the levels of ``benchmarks/control.py``; the same seeded draws as the package's
``simulate(..., sensor_noise=..., seed=...)``, so the two loops see the same noise), then a
16-bit converter over each sensor's range (round to the nearest of 2¹⁶ levels, clipped at the
range's ends): paper rig 0–250 mm (the Celesco CLP-250 of the paper's Table I) and 0–250 bar,
heavy axis 0–500 mm and 0–400 bar.

**The controller** (:class:`CompiledController`): any controller the package's ``export_c``
expresses, written with ``export_c``, compiled by gcc into a shared library and stepped through
ctypes with the structs of ``c_structs()`` (fields filled by name, so a law that adds a
measured channel only needs its name here). The one sample of computation delay is the law's
own (``delay = true``: the command computed at t_k is applied from t_(k+1)); a controller
designed without it gets it from the harness, as on a real target. ``m.v`` is the plant's
velocity (the package's loop does the same; the default law ignores it, its position observer
estimates the velocity from the position samples).

**The comparison**: the default of ``control design`` (``design_controller(verify=False,
delay=True)``) and the textbook PI with velocity feed-forward (``design_textbook_pi``), each
designed by the package on the machine's own parameters, on the package's full model
(``simulate``, rtol 1e-6, same noise) and on this plant: paper rig trapezoid 50 → 150 mm
(0.2 m/s, 5 m/s²) for 0.9 s, heavy axis (``tests/machines/industrial.toml``) 100 → 400 mm
(0.3 m/s, 3 m/s², 2 kN) for 1.6 s, as ``benchmarks/control.py``; and step holds: a step of 10 %
of the stroke from mid-stroke against ±50 % of P_S·A_A (paper rig) or ±5 kN (heavy axis), held
for 0.6 s (paper rig) or 0.8 s (heavy axis). The reference r(t_k), ṙ(t_k), ṙ(t_k + lead) and
r̈(t_k) (and ṙ(t_k + pre-open look-ahead)) is the task's motion profile or step sequence (``as_reference``), the lead read from the
exported header. Measured as ``benchmarks/control.py`` measures: peak following error |r − x| over
the run, hold peak to peak of the true position over the last 0.2 s (0.25 s for the step holds),
command sign changes per second over that window (beyond ±1 % of the command range) and the
share of samples with the command at a limit. A third row per case, ``indep. w0(|u|)``: the
same plant with the valve's ω0 following Table II at the held command's amplitude over each
sample (the package's closed loop takes the nominal ω0 throughout, docs/errata.md D3).

**Draws** (``--draws N``): the default design's step holds over the verification's parameter
draws (``draw_parameters``), both plants, worst hold and holds above 0.1 mm.
"""

from __future__ import annotations

import argparse
import ctypes
import math
import re
import shutil
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, replace
from pathlib import Path

# run as a script, this file's folder comes first on sys.path and benchmarks/control.py would
# hide python-control (``import control``) from hydropwa: drop the folder
_HERE = Path(__file__).resolve().parent
sys.path[:] = [p for p in sys.path if Path(p or ".").resolve() != _HERE]

import numpy as np  # noqa: E402
from scipy.integrate import solve_ivp  # noqa: E402

#: relative tolerance of the plant's integration (the package's default is 1e-3)
RTOL = 1e-8
#: sensor noise of benchmarks/control.py: x [m], p_a, p_b [Pa] (standard deviations)
NOISE = {"x": 20e-6, "p_a": 0.1e5, "p_b": 0.1e5}
INDUSTRIAL = Path(__file__).resolve().parents[1] / "tests" / "machines" / "industrial.toml"


# --------------------------------------------------------------------------------------------
# The plant, Eqs. (1)-(11)
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class IndependentPlant:
    """Full-order single-rod axis from the paper's Eqs. (1)–(11), SI, plain Python floats.

    States y = [ν, ν̇, P_A, P_B, x, ẋ] (spool [1], its rate [1/s], chamber pressures [Pa],
    position [m], velocity [m/s]); the supply is ideal (constant P_S).
    """

    omega0: float
    zeta: float
    alpha: float
    beta: float
    creep: float
    dz_offset: float
    k_flow: float
    p_tr: float
    area_a: float
    area_b: float
    stroke: float
    v_a: float
    v_b: float
    leak: float
    k_stop: float
    c_stop: float
    bulk: float
    p_vap: float
    p_rel: float
    f_c: float
    f_s: float
    sigma: float
    chi: float
    delta: float
    gamma: float
    p_s: float
    p_t: float
    mass: float
    c_load: float

    @classmethod
    def from_params(cls, prm, omega0: float | None = None) -> IndependentPlant:
        """The plant of a ``SystemParams``'s physical fields; ``omega0`` [rad/s] overrides ω0."""
        if prm.supply.model != "ideal" or prm.accumulator.gas_volume > 0.0:
            raise ValueError("the independent plant has an ideal supply and no accumulator")
        dz, cyl, fr = prm.dead_zone, prm.cylinder, prm.friction
        return cls(
            omega0=float(prm.valve.omega0 if omega0 is None else omega0),
            zeta=prm.valve.zeta,
            alpha=dz.alpha,
            beta=dz.beta,
            creep=dz.creep_slope,
            # Table IV as printed (outer cells at ±β), or continuous at β(1 − k_g) (E4)
            dz_offset=dz.beta * (1.0 - dz.creep_slope) if dz.continuous else dz.beta,
            k_flow=prm.flow.K,
            p_tr=prm.flow.transition_pressure,
            area_a=cyl.area_a,
            area_b=cyl.area_b,
            stroke=cyl.stroke,
            v_a=cyl.dead_volume_a,
            v_b=cyl.dead_volume_b,
            leak=cyl.leakage,
            k_stop=cyl.end_stop_stiffness,
            c_stop=cyl.end_stop_damping,
            bulk=prm.oil.bulk_modulus,
            p_vap=prm.oil.vapour_pressure,
            p_rel=prm.oil.release_pressure,
            f_c=fr.coulomb,
            f_s=fr.static,
            sigma=fr.viscous,
            chi=fr.stribeck_velocity,
            delta=fr.shape,
            gamma=fr.smoothness,
            p_s=prm.supply.pressure,
            p_t=prm.supply.tank_pressure,
            mass=prm.load.mass,
            c_load=prm.load.damping,
        )

    # -- Eqs. (2)/(4): dead zone and saturation of the opening ------------------------------
    def opening(self, nu: float) -> float:
        a = abs(nu)
        if a < self.beta:
            return self.creep * nu
        if a >= self.alpha + self.dz_offset:
            return math.copysign(self.alpha, nu)
        return nu - math.copysign(self.dz_offset, nu)

    # -- Eqs. (5)/(6): flow through one metering edge, signed and regularised (E3) ----------
    def edge(self, z: float, dp: float) -> float:
        if abs(dp) >= self.p_tr:
            root = math.copysign(math.sqrt(abs(dp)), dp)
        else:
            s = dp / self.p_tr
            root = math.sqrt(self.p_tr) * (1.25 * s - 0.25 * s * s * s)
        return z * self.k_flow * root

    # -- D1: bulk modulus below the air-release pressure ------------------------------------
    def modulus(self, p: float, inflow: float) -> float:
        if p >= self.p_rel:
            return self.bulk
        frac = (p - self.p_vap) / (self.p_rel - self.p_vap)
        if inflow >= 0.0:
            frac = max(frac, 1e-3)
        return self.bulk * frac

    # -- Eq. (11): Stribeck friction --------------------------------------------------------
    def friction(self, v: float) -> float:
        stribeck = math.exp(-(abs(v / self.chi) ** self.delta))
        return (
            math.tanh(self.gamma * v) * (self.f_c + (self.f_s - self.f_c) * stribeck)
            + self.sigma * v
        )

    # -- D2: end stops (push only) ---------------------------------------------------------
    def stop(self, x: float, v: float) -> float:
        if x < 0.0:
            return max(-self.k_stop * x - self.c_stop * v, 0.0)
        if x > self.stroke:
            return min(-self.k_stop * (x - self.stroke) - self.c_stop * v, 0.0)
        return 0.0

    def rhs(self, y, u: float, f_load: float) -> list[float]:
        """dy/dt at state ``y`` with the valve command ``u`` [1] and the load ``f_load`` [N]."""
        nu, dnu, pa, pb, x, v = y
        z = self.opening(nu)
        if z >= 0.0:  # Eq. (5)/(6), z > 0: P→A and B→T
            qa, qb = self.edge(z, self.p_s - pa), self.edge(z, pb - self.p_t)
        else:  # z < 0: A→T and P→B
            qa, qb = self.edge(z, pa - self.p_t), self.edge(z, self.p_s - pb)
        q_leak = self.leak * (pa - pb)
        net_a = qa - self.area_a * v - q_leak
        net_b = -qb + self.area_b * v + q_leak  # E1: Q_B leaves chamber B
        w0 = self.omega0
        force = (
            pa * self.area_a
            - pb * self.area_b
            - self.friction(v)
            - f_load
            - self.c_load * v
            + self.stop(x, v)
        )
        return [
            dnu,
            w0 * w0 * (u - nu) - 2.0 * self.zeta * w0 * dnu,  # Eqs. (1)/(3)
            self.modulus(pa, net_a) / (self.v_a + self.area_a * x) * net_a,  # Eq. (9)
            self.modulus(pb, net_b) / (self.v_b + self.area_b * (self.stroke - x)) * net_b,
            v,
            force / self.mass,  # Eq. (10)
        ]

    def rest(self, x0: float, f_load: float) -> np.ndarray:
        """At rest at ``x0`` [m]: spool centred, P_A + P_B = P_S, P_A·A_A − P_B·A_B = F_L."""
        pa = (f_load + self.p_s * self.area_b) / (self.area_a + self.area_b)
        pa = min(max(pa, 0.0), self.p_s)
        return np.array([0.0, 0.0, pa, self.p_s - pa, x0, 0.0])

    def atol(self) -> np.ndarray:
        """Absolute tolerances per state: RTOL times a typical size of each."""
        return RTOL * np.array([1.0, self.omega0, self.p_s, self.p_s, self.stroke, 0.1])


def open_loop(plant: IndependentPlant, u_of_t, f_load: float, y0, t_out) -> np.ndarray:
    """States at ``t_out`` [s] for the command u(t) [1] and a constant load [N] (one solve)."""
    sol = solve_ivp(
        lambda t, y: plant.rhs(y, u_of_t(t), f_load),
        (float(t_out[0]), float(t_out[-1])),
        y0,
        method="LSODA",
        t_eval=t_out,
        rtol=RTOL,
        atol=plant.atol(),
    )
    if not sol.success:
        raise RuntimeError(f"independent plant: {sol.message}")
    return sol.y


# --------------------------------------------------------------------------------------------
# Sensors and the compiled controller
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Sensors:
    """Noise (standard deviations, SI) and 16-bit converters over the sensors' ranges."""

    x_range: float
    p_range: float
    noise: dict
    bits: int = 16

    @classmethod
    def of(cls, prm, noise: dict | None = NOISE) -> Sensors:
        """The paper rig's sensors (stroke ≤ 250 mm) or the heavy axis's (0–500 mm, 0–400 bar)."""
        x_range = (
            0.25 if prm.cylinder.stroke <= 0.25 else 0.5 * math.ceil(prm.cylinder.stroke / 0.5)
        )
        p_range = 250e5 if prm.supply.pressure <= 200e5 else 400e5
        return cls(x_range, p_range, dict(noise or {}))

    def convert(self, value: float, full_scale: float) -> float:
        """The converter's reading of ``value`` over [0, full_scale] (2^bits levels)."""
        lsb = full_scale / (2**self.bits - 1)
        return min(max(round(value / lsb), 0), 2**self.bits - 1) * lsb

    def draws(self, n: int, seed: int | None) -> np.ndarray:
        """Noise rows x, p_a, p_b, spool over ``n`` samples: the package loop's draws for the seed
        (the spool last, so a spool noise leaves the others' draws)."""
        rng = np.random.default_rng(seed)
        out = np.zeros((4, n))
        for i, key in enumerate(("x", "p_a", "p_b", "spool")):
            sd = float(self.noise.get(key, 0.0))
            if sd > 0.0:
                out[i] = rng.normal(0.0, sd, n)
        return out


class CompiledController:
    """A package controller as its generated C (``export_c``), compiled and stepped via ctypes."""

    def __init__(self, controller, folder: Path):
        from hydropwa.control import c_structs, export_c

        gcc = shutil.which("gcc")
        if gcc is None:
            raise RuntimeError("gcc is needed to compile the exported controller")
        src = export_c(controller, Path(folder) / "c", overwrite=True)
        lib_path = Path(folder) / "libhydropwa_ctrl.so"
        cmd = [gcc, "-std=c99", "-O2", "-shared", "-fPIC", "-o", str(lib_path)]
        proc = subprocess.run(
            [*cmd, str(src / "hydropwa_ctrl.c"), "-lm"], capture_output=True, text=True
        )
        if proc.returncode != 0:
            raise RuntimeError(f"gcc failed on the exported controller: {proc.stderr}")
        header = (src / "hydropwa_ctrl.h").read_text(encoding="utf-8")
        structs = c_structs(header)
        self.State = structs["hydropwa_ctrl_state"]
        self.Meas = structs["hydropwa_ctrl_meas"]
        self.Ref = structs["hydropwa_ctrl_ref"]
        lib = ctypes.CDLL(str(lib_path))
        lib.hydropwa_ctrl_step.restype = ctypes.c_double
        lib.hydropwa_ctrl_step.argtypes = [
            ctypes.POINTER(self.State),
            ctypes.POINTER(self.Meas),
            ctypes.POINTER(self.Ref),
        ]
        lib.hydropwa_ctrl_load_pressure.restype = ctypes.c_double
        lib.hydropwa_ctrl_load_pressure.argtypes = [ctypes.c_double] * 4
        self.lib = lib
        self.sample_time = float(_define(header, "HYDROPWA_CTRL_SAMPLE_TIME"))
        self.lead = float(_define(header, "HYDROPWA_CTRL_LEAD"))
        self.pre_open = float(_define(header, "HYDROPWA_CTRL_PRE_OPEN"))
        #: a controller designed without the delay gets it here, as on any target
        self.extra_delay = not bool(getattr(controller, "delay", True))
        self.state = self.State()

    def reset(self) -> None:
        self.state = self.State()
        self.lib.hydropwa_ctrl_init(ctypes.byref(self.state))

    def step(self, channels: dict, reference: dict) -> float:
        """One sample: ``channels`` (x, v, p_a, p_b, ... SI) and ``reference`` (r, r_rate, ...)."""
        m, rf = self.Meas(), self.Ref()
        values = dict(channels)
        values["p_l"] = self.lib.hydropwa_ctrl_load_pressure(
            channels["p_a"], channels["p_b"], channels["area_a"], channels["area_b"]
        )
        for struct, given in ((m, values), (rf, reference)):
            for name, _ct in struct._fields_:
                if name not in given:
                    raise RuntimeError(
                        f"the controller's C reads {type(struct).__name__}.{name}, which this "
                        "harness does not supply; add it to closed_loop's channels"
                    )
                setattr(struct, name, float(given[name]))
        return float(self.lib.hydropwa_ctrl_step(ctypes.byref(self.state), m, rf))


def _define(header: str, name: str) -> str:
    hit = re.search(rf"#define\s+{name}\s+(\S+)", header)
    if hit is None:
        raise RuntimeError(f"the exported header has no {name}")
    return hit.group(1)


# --------------------------------------------------------------------------------------------
# The closed loop and its measures
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Task:
    """A closed-loop task: reference spec, duration [s], start [m], load [N], hold window [s]."""

    name: str
    reference: str
    duration: float
    x0: float
    load: float
    hold: float


def closed_loop(
    prm,
    cc: CompiledController,
    task: Task,
    sensors: Sensors,
    seed: int | None,
    scheduled: bool = False,
):
    """The compiled controller on the independent plant: true x and r at every sample, and u.

    At each sample instant t_k the sensors read the plant (noise, then the converters), the C
    law gives u, and the plant integrates to t_(k+1) with u held. ``scheduled``: the valve's
    ω0 follows Table II at the held command's |u| over each sample (a real valve's amplitude
    dependence, which the package's closed loop replaces by the nominal ω0, D3).
    """
    from hydropwa.control import as_reference

    plant = IndependentPlant.from_params(prm)  # closed loop: the nominal ω0 (D3)
    ref = as_reference(task.reference)
    ts = cc.sample_time
    n = int(math.floor(task.duration / ts + 1e-9)) + 1
    tk = ts * np.arange(n)
    r, dr, ddr = ref(tk), ref.rate(tk), ref.acceleration(tk)
    dr_ff = ref.rate(tk + cc.lead) if cc.lead > 0.0 else dr
    dr_po = ref.rate(tk + cc.pre_open) if cc.pre_open > 0.0 else np.zeros(n)
    noise = sensors.draws(n, seed)
    y = plant.rest(task.x0, task.load)
    atol = plant.atol()
    cc.reset()
    xs, us = np.empty(n), np.empty(n)
    pending = 0.0
    for k in range(n):
        xs[k] = y[4]
        ch = {
            "x": sensors.convert(y[4] + noise[0, k], sensors.x_range),
            "v": y[5],
            "p_a": sensors.convert(y[2] + noise[1, k], sensors.p_range),
            "p_b": sensors.convert(y[3] + noise[2, k], sensors.p_range),
            "spool": y[0] + noise[3, k],  # the valve's spool output [1] (no converter)
            "area_a": plant.area_a,
            "area_b": plant.area_b,
        }
        rf = {"r": r[k], "r_rate": dr[k], "r_rate_ff": dr_ff[k], "r_acc": ddr[k]}
        rf["r_rate_pre"] = dr_po[k]
        u = cc.step(ch, rf)
        if cc.extra_delay:
            u, pending = pending, u
        us[k] = u
        if k + 1 < n:
            now = replace(plant, omega0=prm.valve.omega0_at(u)) if scheduled else plant
            sol = solve_ivp(
                lambda _t, yy, u=u, now=now: now.rhs(yy, u, task.load),
                (tk[k], tk[k + 1]),
                y,
                method="LSODA",
                rtol=RTOL,
                atol=atol,
            )
            if not sol.success:
                raise RuntimeError(f"independent plant at t = {tk[k]:.4f} s: {sol.message}")
            y = sol.y[:, -1]
    return {"t": tk, "x": xs, "r": np.asarray(r, dtype=float), "u": us}


def measures(t, x, r, t_u, u, limits, hold_from: float) -> dict[str, float]:
    """Peak |r − x| [mm], hold peak to peak [mm] and sign changes [1/s] from ``hold_from`` on,
    saturation [%] over the run: the definitions of ``tracking_metrics``."""
    lo, hi = limits
    tol = 1e-9 * max(1.0, abs(lo), abs(hi))
    w = t >= hold_from - 1e-12
    wu = t_u >= hold_from - 1e-12
    uw = u[wu]
    sg = np.sign(uw[np.abs(uw) > 0.01 * max(abs(lo), abs(hi))])
    return {
        "peak_mm": float(np.max(np.abs(r - x))) * 1e3,
        "hold_mm": float(np.ptp(x[w])) * 1e3,
        "sign_per_s": np.count_nonzero(np.diff(sg) != 0) / max(float(t[-1]) - hold_from, 1e-12),
        "sat_pct": float(np.mean((u <= lo + tol) | (u >= hi - tol))) * 100.0,
    }


def package_run(prm, controller, task: Task, noise: dict | None, seed: int | None):
    """The same task on the package's full model (``simulate``, rtol 1e-6, outputs at 1/T_s)."""
    from hydropwa.control import as_reference
    from hydropwa.simulation import simulate

    return simulate(
        "full",
        params=prm,
        duration=task.duration,
        controller=controller,
        reference=as_reference(task.reference),
        initial_position=task.x0,
        load_force=task.load,
        sensor_noise=noise or None,
        seed=seed,
        rtol=1e-6,
        fs=1.0 / controller.sample_time,
    )


def package_measures(res, controller, task: Task) -> dict[str, float]:
    ctl = res.control
    limits = (float(controller.u_min), float(controller.u_max))
    return measures(
        res.t, res["x"], res["reference"], ctl["t"], ctl["u"], limits, task.duration - task.hold
    )


def plant_measures(run, controller, task: Task) -> dict[str, float]:
    limits = (float(controller.u_min), float(controller.u_max))
    return measures(
        run["t"], run["x"], run["r"], run["t"], run["u"], limits, task.duration - task.hold
    )


# --------------------------------------------------------------------------------------------
# The machines, the comparison and the open-loop check
# --------------------------------------------------------------------------------------------
def machines() -> dict:
    """Name → (parameters, tasks) of the paper rig and the heavy axis (see the docstring)."""
    from hydropwa.params import get_preset, load_params

    paper, heavy = get_preset("paper"), load_params(INDUSTRIAL)
    f_half = 0.5 * paper.supply.pressure * paper.cylinder.area_a
    return {
        "paper rig": (
            paper,
            [
                Task(
                    "trapezoid",
                    "trapezoid:from=50 mm,to=150 mm,v=0.2,a=5,start=0.1",
                    0.9,
                    0.05,
                    float(paper.load.force),
                    0.2,
                ),
                *(
                    Task(
                        f"step hold {s * f_half / 1e3:+.1f} kN",
                        "steps:0 s=100 mm,0.05 s=120 mm",
                        0.6,
                        0.1,
                        s * f_half,
                        0.25,
                    )
                    for s in (1.0, -1.0)
                ),
            ],
        ),
        "heavy axis": (
            heavy,
            [
                Task(
                    "trapezoid",
                    "trapezoid:from=100 mm,to=400 mm,v=0.3,a=3,start=0.1",
                    1.6,
                    0.1,
                    2000.0,
                    0.2,
                ),
                *(
                    Task(
                        f"step hold {s * 5:+.1f} kN",
                        "steps:0 s=250 mm,0.05 s=300 mm",
                        0.8,
                        0.25,
                        s * 5000.0,
                        0.25,
                    )
                    for s in (1.0, -1.0)
                ),
            ],
        ),
    }


def controllers(prm, pi: bool = True) -> dict:
    """The default of ``control design`` and (``pi``) the textbook PI + FF, designed on ``prm``."""
    from hydropwa.control import design_controller, design_textbook_pi
    from hydropwa.linearization import linearize

    pwa = linearize(prm)
    out = {"control design (default)": design_controller(pwa, verify=False, delay=True).controller}
    if pi:
        out["textbook PI + FF"] = design_textbook_pi(pwa, sample_time=5e-4, delay=True).controller
    return out


def open_loop_agreement(prm, spec: str = "sine:amplitude=0.4,frequency=2", duration: float = 1.0):
    """Largest |x| [m], |P_A|, |P_B| [Pa] differences of this plant and ``simulate(full)`` (rtol
    1e-8 both) from rest at mid-stroke under the command ``spec`` and the machine's load."""
    from hydropwa.simulation import as_signal, simulate

    x0 = 0.5 * prm.cylinder.stroke
    res = simulate("full", spec, params=prm, duration=duration, initial_position=x0, rtol=1e-8)
    u = as_signal(spec, "", "u")
    peak = float(np.max(np.abs(u(res.t))))
    plant = IndependentPlant.from_params(prm, prm.valve.omega0_at(peak))  # D3, open loop
    f = float(prm.load.force)
    y = open_loop(plant, lambda t: float(u(t)), f, plant.rest(x0, f), res.t)
    return {
        "x": float(np.max(np.abs(y[4] - res["x"]))),
        "p_a": float(np.max(np.abs(y[2] - res["p_a"]))),
        "p_b": float(np.max(np.abs(y[3] - res["p_b"]))),
        "x_span": float(np.ptp(res["x"])),
        "p_span": float(max(np.ptp(res["p_a"]), np.ptp(res["p_b"]))),
    }


def _row(name, cname, label, plant, m, step: bool) -> None:
    peak = "-" if step else f"{m['peak_mm']:.3f}"  # a step's error is the step
    print(
        f"{name:<11}{cname:<26}{label:<20}{plant:<16}{peak:>12}"
        f"{m['hold_mm']:>12.3f}{m['sign_per_s']:>11.0f}{m['sat_pct']:>7.1f}"
    )


def compare(names, seeds, pi: bool, holds: bool) -> None:
    """The table: package full model against the independent plant, per machine, controller, task."""
    print(
        f"{'machine':<11}{'controller':<26}{'task':<20}{'plant':<16}{'peak err mm':>12}"
        f"{'hold p-p mm':>12}{'sign ch./s':>11}{'sat %':>7}"
    )
    with tempfile.TemporaryDirectory() as tmp:
        for name, (prm, tasks) in machines().items():
            if name not in names:
                continue
            sensors = Sensors.of(prm)
            for cname, ctrl in controllers(prm, pi).items():
                cc = CompiledController(ctrl, Path(tmp) / f"{name}-{cname}".replace(" ", "_"))
                for task in tasks if holds else tasks[:1]:
                    for seed in seeds:
                        res = package_run(prm, ctrl, task, NOISE, seed)
                        rows = {
                            "package full": package_measures(res, ctrl, task),
                            "independent": plant_measures(
                                closed_loop(prm, cc, task, sensors, seed), ctrl, task
                            ),
                            "indep. w0(|u|)": plant_measures(
                                closed_loop(prm, cc, task, sensors, seed, scheduled=True),
                                ctrl,
                                task,
                            ),
                        }
                        label = task.name if len(seeds) == 1 else f"{task.name} s{seed}"
                        step = task.reference.startswith("steps")
                        for plant, m in rows.items():
                            _row(name, cname, label, plant, m, step)


def holds_over_draws(names, draws: int) -> None:
    """The default design's step holds over parameter draws (``draw_parameters``: the nominal
    set and draws − 1 of E ±20 %, friction ±30 %, ω0 ±10 %, mass +0…50 %, P_S −0…10 %), on the
    package's full model and on the independent plant, noise seed = draw number + 1: the worst
    hold peak to peak, the holds above 0.1 mm and the most sign changes per second."""
    from hydropwa.control import draw_parameters

    print(f"step holds over {draws} parameter draws (default design, both loads)")
    with tempfile.TemporaryDirectory() as tmp:
        for name, (prm, tasks) in machines().items():
            if name not in names:
                continue
            ctrl = controllers(prm, pi=False)["control design (default)"]
            cc = CompiledController(ctrl, Path(tmp) / name.replace(" ", "_"))
            sensors = Sensors.of(prm)  # the machine's sensors, whatever the draw
            out: dict[str, list] = {"package full": [], "independent": []}
            for i, drawn in enumerate(draw_parameters(prm, draws)):
                for task in tasks[1:]:
                    res = package_run(drawn, ctrl, task, NOISE, i + 1)
                    out["package full"].append(package_measures(res, ctrl, task))
                    run = closed_loop(drawn, cc, task, sensors, i + 1)
                    out["independent"].append(plant_measures(run, ctrl, task))
            for plant, ms in out.items():
                pps = [m["hold_mm"] for m in ms]
                print(
                    f"  {name:<11}{plant:<14} worst hold {max(pps):.3f} mm, above 0.1 mm "
                    f"{sum(p > 0.1 for p in pps)} of {len(pps)}, sign changes <= "
                    f"{max(m['sign_per_s'] for m in ms):.0f}/s"
                )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seeds", type=int, default=1, help="noise seeds 1..N (default 1)")
    ap.add_argument("--machine", choices=("paper", "heavy", "both"), default="both")
    ap.add_argument("--no-pi", action="store_true", help="skip the textbook PI + FF")
    ap.add_argument("--no-holds", action="store_true", help="only the trapezoids")
    ap.add_argument(
        "--draws", type=int, default=0, metavar="N", help="step holds over N parameter draws"
    )
    args = ap.parse_args()
    names = {"paper": ["paper rig"], "heavy": ["heavy axis"]}.get(
        args.machine, ["paper rig", "heavy axis"]
    )
    t0 = time.perf_counter()
    for name, (prm, _tasks) in machines().items():
        if name not in names:
            continue
        for spec, dur in (
            ("sine:amplitude=0.4,frequency=2", 1.0),
            ("sine:amplitude=1.2,frequency=1", 2.0),  # saturated, into the end stop
        ):
            a = open_loop_agreement(prm, spec, dur)
            print(
                f"{name}: open loop ({spec}, {dur:g} s), independent plant vs simulate(full): "
                f"max |dx| {a['x'] * 1e6:.3g} um of {a['x_span'] * 1e3:.1f} mm, max |dP_A| "
                f"{a['p_a']:.3g} Pa, |dP_B| {a['p_b']:.3g} Pa of {a['p_span'] / 1e5:.1f} bar"
            )
    compare(names, list(range(1, args.seeds + 1)), not args.no_pi, not args.no_holds)
    if args.draws > 0:
        holds_over_draws(names, args.draws)
    print(f"({time.perf_counter() - t0:.0f} s)")


if __name__ == "__main__":
    main()
