"""Force control (issue 52): the fatigue rig, the designed law against the PI baseline.

Usage::

    python benchmarks/force_control.py [--machines paper,heavy] [--hz 1,2,5,10] [--duration 1.2]
        [--random] [--no-noise]

Fatigue rig: a 1e7 N/m specimen (attached at the contact 0.1 m out on the paper rig, 0.25 m
on the heavy axis of ``tests/machines/industrial.toml``, its load force set to 0), a sine force
reference of ±15 % of A_A·P_S about 40 % of it, full model, the design's one sample of delay,
sensor noise 20 µm / 0.1 bar / 0.1 bar (seed 1); RMS of the true force error after the first
0.3 s, the law (``design_force``) and the baseline (``design_force_pi``), and their ratio.
``--random`` adds the band-limited random reference of the issue: ``random_reference`` of the
sine's RMS (0.15/√2 of A_A·P_S) over 1-10 Hz about the same mean, periodic in 2 s (seed 1), run
2 s (row "1-10 rnd"). ``--no-noise``: exact sensors (to separate the noise's share).

``--limit-cycles N``: the issue's "no limit cycle at a force hold over N parameter draws". The
law designed on the nominal machine holds 40 % of A_A·P_S for 1.2 s on the full model over
the nominal machine and N − 1 draws of the verification's parameter ranges
(``control._verify.draw_parameters``: E, friction, ω0, mass, P_S), each with the specimen's
stiffness drawn in ±50 % (seed 7), from rest at the contact; the true force's peak-to-peak over
the last 0.6 s is read twice: without sensor noise, where any oscillation is self-sustained (a
limit cycle; flagged above 0.1 % of the hold force), and with the noise above (flagged above
1 %, the press cycle's hold accuracy).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

# run as a script, this file's folder comes first on sys.path and benchmarks/control.py would
# hide python-control
_HERE = Path(__file__).resolve().parent
sys.path[:] = [p for p in sys.path if Path(p or ".").resolve() != _HERE]

import numpy as np  # noqa: E402

from hydropwa import load_params  # noqa: E402
from hydropwa.control import (  # noqa: E402
    PressSpec,
    design_controller,
    design_force,
    design_force_pi,
    design_pi,
    press_cycle,
    random_reference,
)
from hydropwa.linearization import linearize  # noqa: E402
from hydropwa.params import get_preset  # noqa: E402
from hydropwa.simulation import Sine, simulate  # noqa: E402

NOISE = {"x": 20e-6, "p_a": 0.1e5, "p_b": 0.1e5}
MACHINES = Path(__file__).parents[1] / "tests" / "machines"


def machine(name: str, stiffness: float = 1e7):
    """The paper rig or the heavy axis with the specimen attached."""
    if name == "paper":
        prm, x_c = get_preset("paper"), 0.1
    else:
        prm, x_c = load_params(MACHINES / "industrial.toml"), 0.25
    return prm.replace(
        **{"load.specimen_stiffness": stiffness, "load.contact_position": x_c, "load.force": 0.0}
    )


def rms_error(
    prm, ctrl, hz: float, duration: float, random: bool = False, noise: dict | None = NOISE
) -> tuple[float, float]:
    """RMS of the true force error after 0.3 s and the sine's amplitude; ``random``: the
    band-limited random reference of the same RMS over 1-10 Hz instead of the sine."""
    f_max = prm.cylinder.area_a * prm.supply.pressure
    amp, mean = 0.15 * f_max, 0.4 * f_max
    ld = prm.load
    ref = (
        random_reference(amp / np.sqrt(2.0), 1.0, 10.0, duration, offset=mean, seed=1)
        if random
        else Sine(amplitude=amp, frequency=hz, offset=mean)
    )
    res = simulate(
        "full",
        params=prm,
        controller=ctrl,
        reference=ref,
        duration=duration,
        initial_position=ld.contact_position + float(ref(0.0)) / ld.specimen_stiffness,
        sensor_noise=noise,
        seed=1,
    )
    keep = res["t"] > 0.3
    e = res["force_error"][keep]
    return float(np.sqrt(np.mean(e**2))), amp


def limit_cycles(name: str, n: int, seed: int = 7) -> None:
    """The force hold over the nominal machine and n − 1 parameter draws (module docstring)."""
    from hydropwa.control._verify import draw_parameters

    prm = machine(name)
    law = design_force(prm).controller
    hold = 0.4 * prm.cylinder.area_a * prm.supply.pressure
    rng = np.random.default_rng(seed)
    p2p = {"exact": [], "noise": []}
    t0 = time.process_time()
    for i, drawn in enumerate(draw_parameters(prm, n, seed)):
        k = prm.load.specimen_stiffness * (1.0 if i == 0 else rng.uniform(0.5, 1.5))
        p = drawn.replace(**{"load.specimen_stiffness": k})
        for key, noise in (("exact", None), ("noise", NOISE)):
            res = simulate(
                "full",
                params=p,
                controller=law,
                reference=hold,
                duration=1.2,
                initial_position=p.load.contact_position,
                sensor_noise=noise,
                seed=i,
            )
            f = res["force"][res["t"] >= 0.6]
            p2p[key].append(float(np.ptp(f)) if res.success else np.inf)
    cpu = time.process_time() - t0
    ex, no = np.array(p2p["exact"]), np.array(p2p["noise"])
    print(
        f"| {name} | {n} | {hold / 1e3:.2f} | {100 * ex.max() / hold:.3f} | "
        f"{int(np.sum(ex > 1e-3 * hold))} | {100 * np.median(no) / hold:.3f} | "
        f"{100 * no.max() / hold:.3f} | {int(np.sum(no > 1e-2 * hold))} | {cpu:.0f} |",
        flush=True,
    )


def press(speed: float = 0.1) -> None:
    """The press cycle on the heavy axis (63/36 x 500 mm): a 5e7 N/m part at 0.3 m, approach
    100 mm at 0.1 m/s, 20 kN in 50 ms, hold 0.5 s, release, retract; the position law is the
    default design of ``control design`` (no verification), the force law ``design_force``; the
    same with the PI baseline as the force law."""
    prm = load_params(MACHINES / "industrial.toml").replace(
        **{"load.specimen_stiffness": 5e7, "load.contact_position": 0.3, "load.force": 0.0}
    )
    t0 = time.process_time()
    position = design_controller(linearize(prm), verify=False).controller
    position_pi = design_pi(linearize(prm), delay=True, flow_feedforward=True).controller
    laws = {"law": design_force(prm).controller, "PI": design_force_pi(prm).controller}
    print(f"(designs: {time.process_time() - t0:.1f} CPU-s)")
    print(
        "| force law | hold max err % (from 0.1 s) | hold mean err % | overshoot % | jump at contact % | "
        "jump at release % | steps after contact / release % | largest step % | lowest chamber bar |"
    )
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for name, law in laws.items():
        m = press_cycle(prm, position, law, PressSpec(speed=speed), sensor_noise=NOISE).metrics
        if name == "law":  # the same with the position PI (design_pi) as the approach law
            m_pi = press_cycle(
                prm, position_pi, law, PressSpec(speed=speed), sensor_noise=NOISE
            ).metrics
            _press_row("law, PI approach", m_pi)
        _press_row(name, m)


def _press_row(name: str, m: dict) -> None:
    print(
        f"| {name} | {100 * m['hold_error'] / 20e3:.2f} | {100 * m['hold_mean_error'] / 20e3:.3f} | "
        f"{100 * m['overshoot']:.2f} | {100 * m['jump_contact']:.2f} | {100 * m['jump_release']:.2f} | "
        f"{100 * m['step_after_contact']:.2f} / {100 * m['step_after_release']:.2f} | "
        f"{100 * m['largest_command_step']:.2f} | {m['p_min'] / 1e5:.2f} |",
        flush=True,
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--machines", default="paper,heavy")
    ap.add_argument("--hz", default="1,2,5,10")
    ap.add_argument("--duration", type=float, default=1.2)
    ap.add_argument("--press", action="store_true", help="only the press cycle")
    ap.add_argument("--random", action="store_true", help="add the band-limited random row")
    ap.add_argument("--no-noise", action="store_true", help="exact sensors")
    ap.add_argument("--limit-cycles", type=int, default=0, help="force holds over N draws")
    a = ap.parse_args()
    if a.press:
        press()
        return
    if a.limit_cycles:
        print(
            "| machine | draws | hold kN | exact: max p2p % | exact: > 0.1 % | noise: median p2p % "
            "| noise: max p2p % | noise: > 1 % | CPU-s |"
        )
        print("| --- | --- | --- | --- | --- | --- | --- | --- | --- |")
        for name in a.machines.split(","):
            limit_cycles(name, a.limit_cycles)
        return
    noise = None if a.no_noise else NOISE
    print("| machine | f Hz | amplitude kN | law RMS N | PI RMS N | law/PI |")
    print("| --- | --- | --- | --- | --- | --- |")
    for name in a.machines.split(","):
        prm = machine(name)
        t0 = time.process_time()
        law, pi = design_force(prm).controller, design_force_pi(prm).controller
        design_cpu = time.process_time() - t0
        for hz in (float(h) for h in a.hz.split(",")):
            e_law, amp = rms_error(prm, law, hz, a.duration, noise=noise)
            e_pi, _ = rms_error(prm, pi, hz, a.duration, noise=noise)
            print(
                f"| {name} | {hz:g} | {amp / 1e3:.2f} | {e_law:.1f} | {e_pi:.1f} | {e_law / e_pi:.3f} |",
                flush=True,
            )
        if a.random:
            e_law, amp = rms_error(prm, law, 0.0, 2.0, random=True, noise=noise)
            e_pi, _ = rms_error(prm, pi, 0.0, 2.0, random=True, noise=noise)
            print(
                f"| {name} | 1-10 rnd | {amp / 1e3:.2f} | {e_law:.1f} | {e_pi:.1f} | {e_law / e_pi:.3f} |",
                flush=True,
            )
        print(f"(design of both on {name}: {design_cpu:.1f} CPU-s)")


if __name__ == "__main__":
    main()
