"""The paper rig's closed-loop case of the control tests (issue 34's yardstick): the sensor noise
(20 µm position, 0.1 bar per chamber) and the 50 → 150 mm trapezoid (0.2 m/s, 5 m/s², from
0.1 s) with its hold on the full model, as benchmarks/independent_plant.py's paper-rig task."""

from __future__ import annotations

from hydropwa.control import as_reference
from hydropwa.simulation import simulate

NOISE = {"x": 20e-6, "p_a": 0.1e5, "p_b": 0.1e5}
TRAPEZOID = "trapezoid:from=50 mm,to=150 mm,v=0.2,a=5,start=0.1"


def paper_trapezoid(params, controller, duration: float = 0.9, **kwargs):
    """The trapezoid and its hold on the full model from 50 mm; ``kwargs`` go to ``simulate``
    (``sensor_noise``, ``seed``, ``rtol``, ``fs``)."""
    return simulate(
        "full",
        params=params,
        duration=duration,
        controller=controller,
        reference=as_reference(TRAPEZOID),
        initial_position=0.05,
        **kwargs,
    )
