"""Falsification of the loop certificate on the full model (issue 51): random and adversarial
starts of the default design in closed loop with noise and delay, the tightness reported.

    python -P benchmarks/certificate_falsify.py [--machine paper|heavy] [--random 10000]
        [--adversarial 1000] [--seed 0]

The bound ē is the certificate's where the design is certified; otherwise that of the
invariant ellipsoid the certifier found (its region empty, so there is no certified 𝓡: the
starts are drawn from the issue's box |e| ≤ 20 mm, |ẋ| ≤ 100 mm/s, |ΔP_L| ≤ 30 bar) and the
reach time 1 s. The integral band is set to 0, as the certifier requires. (``-P``: the
folder's own ``control.py`` would shadow python-control.) Cost measured 2026-12-02 (load
≈ 11): 10⁴ + 10³ runs of 1.2 s on the paper rig in 53 CPU-s after ~35 s of design and
certificate.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import time
from pathlib import Path

from hydropwa import get_preset
from hydropwa.control import certify, design_controller
from hydropwa.control._certfalsify import falsify
from hydropwa.linearization import linearize
from hydropwa.params import load_params

HEAVY = Path(__file__).resolve().parents[1] / "tests" / "machines" / "industrial.toml"
#: the heavy axis of the issue: 20 µm and 0.1 bar of noise
HEAVY_NOISE = {"x": 20e-6, "p_a": 1e4, "p_b": 1e4}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--machine", choices=("paper", "heavy"), default="paper")
    ap.add_argument("--random", type=int, default=10_000)
    ap.add_argument("--adversarial", type=int, default=1_000)
    ap.add_argument("--seed", type=int, default=0)
    a = ap.parse_args()
    prm = get_preset("paper") if a.machine == "paper" else load_params(HEAVY)
    noise = None if a.machine == "paper" else HEAVY_NOISE
    pwa = linearize(prm)
    ctrl = design_controller(pwa, verify=False, delay=True, sensor_noise=noise).controller
    dz = dataclasses.replace(ctrl.dead_zone_inverse, integral_band=0.0)
    ctrl = dataclasses.replace(ctrl, dead_zone_inverse=dz)
    cert = certify(ctrl, pwa, sensor_noise=noise)
    print(cert.summary())
    box = cert.box if cert.success else (20e-3, 0.1, 30e5)
    reach = cert.reach_time if cert.success else 1.0
    e_bar = cert.e_bar if math.isfinite(cert.e_bar) else 0.1e-3
    t0 = time.process_time()
    res = falsify(
        ctrl,
        prm,
        e_bar=e_bar,
        box=box,
        reach_time=reach,
        starts=a.random,
        adversarial=a.adversarial,
        seed=a.seed,
        sensor_noise=noise,
    )
    print(res.summary())
    print(f"worst start (e, v, dP_L): {res.worst_start}; {time.process_time() - t0:.1f} CPU-s")


if __name__ == "__main__":
    main()
