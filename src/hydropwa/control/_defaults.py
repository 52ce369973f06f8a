"""The one default controller design, declared once (issue 49).

:data:`DEFAULT_DESIGN` is what every entry point designs when it is told nothing:
``hydropwa control design``, :func:`~hydropwa.control.design_controller` (the Python API), the
paper study's closed-loop stage and its report, and the tutorials. Each reads its defaults
from this record instead of writing its own, so that the controller a user gets does not
depend on the door they came in by. Before it, the CLI designed with the computation delay,
the position observer and the quiet band while the study and ``design_state_feedback(pwa)``
designed without them; measured on the paper rig (20 µm / 0.1 bar sensor noise, one sample of
delay) that design made 1072 valve-command sign changes per second at the holds and failed the
verification the CLI's design passed.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any

from ._controllers import DEFAULT_SAMPLE_TIME

__all__ = ["DEFAULT_DESIGN", "DesignDefaults"]


def _noise() -> MappingProxyType[str, float]:
    return MappingProxyType({"x": 20e-6, "p_a": 0.1e5, "p_b": 0.1e5})


@dataclass(frozen=True)
class DesignDefaults:
    """The default design's settings (read-only; :data:`DEFAULT_DESIGN` is the one instance).

    Attributes
    ----------
    method : str
        ``"lqr"``: the valve-aware LQR per PWA cell (:func:`design_state_feedback`).
    sample_time : float
        T_s [s] (0.5 ms, the rig's 2 kHz).
    delay : bool
        One sample of computation delay (True: what any real target has; the command
        computed at t_k is applied from t_{k+1}).
    sensor_noise : mapping
        Standard deviations the design answers and the verification applies (SI):
        x 20 µm, p_a and p_b 0.1 bar (the paper rig's sensors, rig/_sensors.py).
    quiet : bool
        The position observer for the position noise and the quiet band sized from the
        noise (:func:`~hydropwa.control.quiet_band_for`), with the integral's band and leak.
    verify : bool
        Verify on the full model over the task set before the controller is used.
    draws : int
        Parameter sets of the verification (the nominal one and ``draws − 1`` draws).
    seed : int
        Seed of the draws and of the sensor noise.
    retune : int
        Re-tuning rounds of a default LQR that fails a check a softer loop can fix.
    """

    method: str = "lqr"
    sample_time: float = DEFAULT_SAMPLE_TIME
    delay: bool = True
    sensor_noise: MappingProxyType[str, float] = field(default_factory=_noise)
    quiet: bool = True
    verify: bool = True
    draws: int = 4
    seed: int = 0
    retune: int = 3

    def design_kwargs(self) -> dict[str, Any]:
        """The keywords of the design function this record fixes (``sample_time``, ``delay``)."""
        return {"sample_time": self.sample_time, "delay": self.delay}


#: The default design of every entry point (CLI, Python API, paper study, report, tutorials).
DEFAULT_DESIGN = DesignDefaults()
