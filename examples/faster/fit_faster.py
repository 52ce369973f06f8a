"""Identify a valve-controlled cylinder on an elastic beam from the FASTER record; compare baselines.

    PYTHONPATH=src python examples/faster/fit_faster.py [--write]

Fits on t < 70 s of ``faster.csv`` (read by :func:`hydropwa.data.load_faster`), predicts
70 s … 110 s from the valve command ``u`` alone (simulation from rest at the measured
displacement at 70 s; no measured output is fed back), and prints the NRMSE [%] of the
displacement ``d`` and the normalised force ``y`` of the physical model beside an ARX model,
a DMDc model (both fitted on the same part, :mod:`hydropwa.identification`) and, where
``pykoop`` is installed, pykoop's EDMDc. ``--write`` writes ``faster.toml`` (the fitted
machine), ``heldout_u.csv`` (t, u [V] of the held-out part) and ``prediction.csv`` (the
physical model's prediction there) beside this script, and ``results.json`` (the table).

The record has no pressures and no force unit, so the machine is an *equivalent* one; every
assumption is a constant below. Only ratios are identifiable from u, d, y: the velocity gain
[m/s per V], the valve's null, the force ratio F_ref/(A·P_S) (the √(P_S − P_L) flow drop),
the leakage time constant, and the beam's stiffness and damping per F_ref.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
from pathlib import Path

import numpy as np
from scipy.optimize import least_squares

from hydropwa.data import load_faster
from hydropwa.evaluation import nrmse_fit
from hydropwa.identification import fit_dmdc, select_arx
from hydropwa.models import FullOrderModel
from hydropwa.params import (
    Cylinder,
    DeadZone,
    Friction,
    Load,
    ServoValve,
    Supply,
    SystemParams,
    ValveFlow,
    save_params,
)
from hydropwa.simulation import Sampled, simulate

HERE = Path(__file__).resolve().parent
T_FIT = 70.0  # [s] fit on t < T_FIT, predict the rest
RTOL = 1e-6  # integrator tolerance: the fit's finite differences need a smooth objective
# --- assumptions (the record states none of these; see the module docstring) ---
F_REF = 10e3  # [N] force of y = 1 (assumed: y is normalised without a stated unit)
P_S = 207e5  # [Pa] supply pressure (3000 psi, the usual rating of such rigs)
V_FULL = 10.0  # [V] command of a fully open valve (a ±10 V servo amplifier)
STROKE = 0.1  # [m] stroke; the beam's displacement d [mm] is x − STROKE/2
DEAD_VOLUME = 0.2e-3  # [m³] each chamber's dead volume (hoses and manifold)
MASS = 20.0  # [kg] moving mass (piston, rod, fixture, a share of the beam)


#: The fitted parameters θ: name, start, lower and upper bound, scale (in θ's units).
THETA = (
    ("log K [m³/(s √Pa)]", None, -30.0, -5.0, 0.1),
    ("null voltage [V]", -0.04, -1.0, 1.0, 0.01),
    ("log A_A [m²]", np.log(2.5 * F_REF / P_S), np.log(1e-5), np.log(1e-1), 0.1),
    ("log C_L [m³/(s Pa)]", np.log(1e-13), np.log(1e-16), np.log(1e-9), 1.0),
    ("log ω0 [rad/s]", np.log(2 * np.pi * 30.0), np.log(2 * np.pi * 2.0), np.log(2e3), 0.1),
    ("A_B/A_A", 0.9, 0.3, 1.0, 0.05),
    ("dead band β [1]", 0.003, 0.0, 0.05, 0.002),
    ("creep slope [1]", 0.3, 0.0, 0.99, 0.05),
)


def machine(theta: np.ndarray, k: float, c: float, rest: float) -> SystemParams:
    """The equivalent machine for θ (see :data:`THETA`) and the beam's k, c and rest position."""
    log_k, null, log_a, log_cl, log_w, ratio, band, creep = theta
    area = float(np.exp(log_a))
    return SystemParams(
        valve=ServoValve(
            omega0=float(np.exp(log_w)), zeta=0.7, command_voltage=V_FULL, null_voltage=float(null)
        ),
        dead_zone=DeadZone(alpha=1.0, beta=float(band), creep_slope=float(creep)),
        flow=ValveFlow(K=float(np.exp(log_k))),
        cylinder=Cylinder(
            area_a=area,
            area_b=area * float(ratio),
            stroke=STROKE,
            dead_volume_a=DEAD_VOLUME,
            dead_volume_b=DEAD_VOLUME,
            leakage=float(np.exp(log_cl)),
        ),
        friction=Friction(coulomb=0.0, static=0.0, viscous=0.0),  # not identifiable here
        supply=Supply(pressure=P_S),
        load=Load(
            mass=MASS,
            specimen_stiffness=k,
            specimen_damping=c,
            contact_position=0.0,  # attached: the beam is clamped to the rod
            preload=-k * rest,  # rest position x_c − F_0/k = rest
        ),
    )


def predict(prm: SystemParams, t: np.ndarray, volts: np.ndarray, d0: float, kind=FullOrderModel):
    """(d [m], y [1]) of the model driven by the command in volts from rest at displacement d0."""
    res = simulate(
        kind(prm),
        Sampled(t - t[0], prm.valve.command_from_volts(volts)),
        duration=float(t[-1] - t[0]),
        fs=1.0 / float(np.mean(np.diff(t))),
        initial_position=STROKE / 2 + d0,
        rtol=RTOL,
    )
    if not res.success or res.t.size != t.size:
        raise RuntimeError(f"simulation failed: {res.message}")
    return res["x"] - STROKE / 2, res["f_spec"] / F_REF


def beam(t: np.ndarray, d: np.ndarray, y: np.ndarray) -> tuple[float, float, float]:
    """Stiffness k [N/m], damping c [N·s/m] and rest position [m] of the beam: y F_ref = k(d − d_r) + c ḋ."""
    v = np.gradient(d, t)
    phi = np.column_stack([d, v, np.ones_like(d)])
    kn, cn, y0 = np.linalg.lstsq(phi, y, rcond=None)[0]
    return kn * F_REF, cn * F_REF, STROKE / 2 - y0 / kn


#: Starts of the fit: (A_A P_S / F_ref, valve bandwidth [Hz]); the best cost on the fit part wins.
STARTS = ((2.5, 30.0), (10.0, 10.0), (20.0, 5.0))


def fit_physical(t, volts, d, y):
    """The machine fitted to the fit part by simulation error (displacement and force).

    The objective has local minima (the area, valve bandwidth and leakage trade off against
    each other over a 70 s simulation), so it starts from each of :data:`STARTS` and keeps
    the lowest cost on the fit part; the held-out part plays no role in the choice.
    """
    k, c, rest = beam(t, d, y)

    def residual(theta):
        dm, ym = predict(machine(theta, k, c, rest), t, volts, d[0])
        return np.concatenate([(dm - d) / d.std(), (ym - y) / y.std()])

    options = {
        "x_scale": np.array([row[4] for row in THETA]),
        "bounds": ([row[2] for row in THETA], [row[3] for row in THETA]),
        "diff_step": 1e-5,
        "xtol": 1e-12,
        "ftol": 1e-12,
        "max_nfev": 50,
    }
    best = None
    for ratio, hz in STARTS:
        area0 = ratio * F_REF / P_S
        k0 = 6.4e-3 * V_FULL * area0 / np.sqrt(P_S / 2)  # the measured 6.4 mm/s per V at P_L = 0
        theta0 = np.array([row[1] for row in THETA])
        theta0[0], theta0[2], theta0[4] = np.log(k0), np.log(area0), np.log(2 * np.pi * hz)
        fit = least_squares(residual, theta0, **options)
        print(f"start A P_S/F_ref = {ratio:g}, {hz:g} Hz: cost {fit.cost:.2f} ({fit.nfev} steps)")
        if best is None or fit.cost < best.cost:
            best = fit
    # the trust region collapses on this objective's kinks (dead band, null) before the cost
    # stops falling: restart from the best point, with a fresh Jacobian, while it still falls
    for _ in range(3):
        again = least_squares(residual, best.x, **options)
        print(f"restart: cost {again.cost:.2f} ({again.nfev} steps)")
        if again.cost > best.cost * (1.0 - 1e-3):
            best = again if again.cost < best.cost else best
            break
        best = again
    return machine(best.x, k, c, rest), best


def baselines(u_fit, dy_fit, u_test, dy0):
    """Held-out simulations (N, 2) of the linear baselines fitted on the fit part."""
    out = {}
    arx = select_arx(u_fit, dy_fit, orders=range(1, 7), delays=range(0, 3))
    out[f"ARX (na = nb = {arx.a.shape[1]}, nk = {arx.delay})"] = arx.simulate(u_test, dy0)
    for delays in (1, 4):
        dmdc = fit_dmdc(u_fit, dy_fit, delays)
        out[f"DMDc ({delays} output delay{'s' if delays > 1 else ''})"] = dmdc.simulate(u_test, dy0)
    try:
        import pykoop  # optional (MIT, but it pulls GPL-3 picos/optht: not a hydropwa dependency)
    except ImportError:
        return out
    scale = dy_fit.std(axis=0)  # the valve's null needs a constant: a second input of ones
    x_fit = np.column_stack([np.zeros(len(u_fit)), dy_fit / scale, u_fit, np.ones(len(u_fit))])
    x_test = np.column_stack(
        [
            np.zeros(len(u_test)),
            np.tile(dy0 / scale, (len(u_test), 1)),
            u_test,
            np.ones(len(u_test)),
        ]
    )
    for name, lift in (
        ("pykoop DMDc (no lift)", None),
        ("pykoop EDMDc (3 delays)", [("dl", pykoop.DelayLiftingFn(3, 3))]),
        ("pykoop EDMDc (quadratic)", [("pl", pykoop.PolynomialLiftingFn(order=2))]),
    ):
        pipe = pykoop.KoopmanPipeline(lifting_functions=lift, regressor=pykoop.Edmd())
        pipe.fit(x_fit, n_inputs=2, episode_feature=True)
        pred = pipe.predict_trajectory(x_test, relift_state=True)
        out[name] = np.asarray(pred)[:, 1:3] * scale
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--write", action="store_true", help="write faster.toml and the prediction")
    args = ap.parse_args(argv)
    run = load_faster(HERE / "faster.csv")
    print(run.meta["timing"])
    t, volts, d, y = run.t, run["u_v"], run["x"], run["f_norm"]
    fit_part, test = t < T_FIT, t >= T_FIT
    prm, fit = fit_physical(t[fit_part], volts[fit_part], d[fit_part], y[fit_part])
    print(f"fit: {fit.message} ({fit.nfev} simulations)")
    th, dh = t[test], d[test]
    d_phys, y_phys = predict(prm, th, volts[test], dh[0])
    ld, cyl = prm.load, prm.cylinder
    print(
        f"beam k = {ld.specimen_stiffness:.4g} N/m ({ld.specimen_stiffness / F_REF * 1e-3:.4f} "
        f"y/mm), c = {ld.specimen_damping:.4g} N s/m; K = {prm.flow.K:.4g}, "
        f"null = {prm.valve.null_voltage * 1e3:.1f} mV, A = {cyl.area_a * 1e4:.3g} cm², "
        f"A P_S / F_ref = {cyl.area_a * P_S / F_REF:.3g}, A_B/A_A = {cyl.area_b / cyl.area_a:.3g}, "
        f"C_L = {cyl.leakage:.3g} m³/(s Pa), omega0 = {prm.valve.omega0 / (2 * np.pi):.3g} Hz"
    )
    dy = np.column_stack([d, y])
    models = {"physical (full model, faster.toml)": np.column_stack([d_phys, y_phys])}
    models.update(baselines(volts[fit_part], dy[fit_part], volts[test], dy[test][0]))
    table = {
        name: {"d": nrmse_fit(dh, sim[:, 0]), "y": nrmse_fit(y[test], sim[:, 1])}
        for name, sim in models.items()
    }
    print(f"\nheld-out {th[0]:.1f} … {th[-1]:.1f} s, NRMSE [%] (simulation from u alone)")
    print(f"{'model':42s} {'d':>8s} {'y':>8s}")
    for name, row in table.items():
        print(f"{name:42s} {row['d']:8.2f} {row['y']:8.2f}")
    if args.write:
        header = "\n".join(
            [
                "FASTER actuator (NRC Canada fatigue rig), identified from examples/faster/faster.csv",
                f"(fit on t < {T_FIT:g} s) by examples/faster/fit_faster.py; see its results.json.",
                "An equivalent machine (the record has no pressures and no force unit): assumed",
                f"y = 1 <-> F_ref = {F_REF:g} N, P_S = {P_S / 1e5:g} bar, stroke {STROKE:g} m,",
                f"mass {MASS:g} kg, dead volumes {DEAD_VOLUME * 1e3:g} L; friction not identified (0).",
                "Volt-to-opening scale: u [1] = (u [V] - valve.null_voltage) / valve.command_voltage,",
                "so `simulate --input-file RUN.csv` takes RUN.csv's column u in volts.",
                "Beam displacement d = x - stroke/2 (start a run with --x0 = stroke/2 + d at its start);",
                "the beam is an attached spring (contact_position = 0, rest at -preload/k);",
                "normalised force y = f_spec / F_ref (channel f_spec [N]).",
            ]
        )
        save_params(prm, HERE / "faster.toml", header=header, overwrite=True)
        np.savetxt(
            HERE / "heldout_u.csv",
            np.column_stack([th - th[0], volts[test]]),
            delimiter=",",
            header="t,u",
            comments="",
            fmt="%.9g",
        )
        np.savetxt(
            HERE / "prediction.csv",
            np.column_stack([th - th[0], d_phys, y_phys]),
            delimiter=",",
            header="t,d,y",
            comments="",
            fmt="%.9g",
        )
        results = {
            "fit_until_s": T_FIT,
            "heldout_start_s": float(th[0]),
            "heldout_d0_m": float(dh[0]),
            "assumptions": {
                "F_ref_N": F_REF,
                "P_S_Pa": P_S,
                "V_full_V": V_FULL,
                "stroke_m": STROKE,
            },
            "identified": dataclasses.asdict(prm.load)
            | {
                "K": prm.flow.K,
                "area": cyl.area_a,
                "leakage": cyl.leakage,
                "null_voltage": prm.valve.null_voltage,
            },
            "nrmse_percent": table,
        }
        (HERE / "results.json").write_text(json.dumps(results, indent=2) + "\n", encoding="utf-8")
        print("wrote faster.toml, heldout_u.csv, prediction.csv, results.json")
    return 0


if __name__ == "__main__":
    sys.exit(main())
