"""Bounds on what a user may ask for: tolerances, input quantities and resource sizes.

The command line and the sweep files take quantities that the parameter files also hold
(supply pressure, initial position); they get the same bounds here, by validating them
through the parameter classes. Requests that cannot fit (``duration × fs`` samples, sweep
cases) are refused before anything is allocated, with the estimate in the message.
"""

from __future__ import annotations

import dataclasses
import math
import os

import numpy as np

from ._errors import ParameterError, SignalError
from ._io import human_bytes
from .simulation import as_signal
from .simulation._simulate import RTOL_RANGE as _RTOL_RANGE

__all__ = [
    "RTOL_RANGE",
    "BYTES_PER_SAMPLE",
    "MAX_SWEEP_CASES",
    "check_rtol",
    "check_samples",
    "check_supply_pressure",
    "check_position",
    "memory_budget",
    "human_bytes",
    "check_jobs",
]

#: Accepted relative tolerances of the integrator (declared where ``simulate`` checks them).
RTOL_RANGE = _RTOL_RANGE

#: Memory one output sample costs on the way to the file (float64 states, stages and
#: channels, the table and its text), measured on the full model with CSV output.
BYTES_PER_SAMPLE = 800

#: A sweep larger than this is refused: its case list alone would take minutes to build.
MAX_SWEEP_CASES = 1_000_000


def memory_budget() -> float:
    """Bytes a single request may use: half of the memory available now (or of the total)."""
    try:
        pages = os.sysconf("SC_AVPHYS_PAGES") or os.sysconf("SC_PHYS_PAGES")
        return 0.5 * pages * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):  # pragma: no cover - not POSIX
        return 4e9


def check_rtol(rtol: float, where: str = "--rtol") -> float:
    """A relative tolerance inside :data:`RTOL_RANGE`."""
    lo, hi = RTOL_RANGE
    try:
        r = float(rtol)
    except (TypeError, ValueError):
        raise ParameterError(f"{where} = {rtol!r} is not a number; give e.g. 1e-3") from None
    if not (lo <= r <= hi):
        raise ParameterError(
            f"{where} = {rtol!r} is outside [{lo:g}, {hi:g}]; the default 1e-3 keeps the "
            "position within 0.1 mm, 1e-5 gives measurement-grade pressures"
        )
    return r


def check_samples(duration: float, fs: float, what: str = "--duration", copies: int = 1) -> int:
    """Number of output samples of ``duration`` at ``fs``; refused when it cannot fit in memory.

    Parameters
    ----------
    duration : float
        Simulated time [s], > 0.
    fs : float
        Output rate [Hz], > 0.
    what : str
        How the request was named (for the message).
    copies : int
        Results held in memory at once (threads of a sweep).
    """
    for name, v, unit in (
        (what, duration, "s"),
        ("--sample-time" if what.startswith("--") else "fs", fs, "Hz"),
    ):
        if not isinstance(v, int | float) or isinstance(v, bool) or not math.isfinite(v) or v <= 0:
            raise ParameterError(f"{name} = {v!r} {unit} must be a positive, finite number")
    n = duration * fs + 1
    if duration * fs < 0.5:  # rounds to one sample (and inf, from 1e308 s, is caught below)
        raise ParameterError(
            f"{what} {duration:g} s at {fs:g} Hz gives fewer than two output samples; lengthen "
            "the duration or raise the output rate fs"
        )
    if not math.isfinite(n):
        raise ParameterError(
            f"{what} {duration:g} s at {fs:g} Hz is more output samples than can be counted; "
            "shorten the duration or lower the output rate fs"
        )
    need = n * BYTES_PER_SAMPLE * max(1, copies)
    budget = memory_budget()
    if need > budget:
        raise ParameterError(
            f"{what} {duration:g} s at {fs:g} Hz is {n:.3g} samples, about {human_bytes(need)} "
            f"of memory, and {human_bytes(budget)} are available; shorten the duration or lower "
            "the output rate fs"
        )
    return int(n)


def _signal_values(value, unit: str, name: str, duration: float) -> np.ndarray:
    sig = as_signal(value, unit, name)
    t = np.linspace(0.0, float(duration), 4001)
    return np.asarray([float(sig(ti)) for ti in t])


def check_supply_pressure(value, params, duration: float, where: str = "--supply-pressure") -> None:
    """P_S (a constant or a signal over ``duration``) within the bounds of ``Supply.pressure``.

    The same bounds a parameter file gets: above the tank pressure and at most 1e9 Pa.
    """
    if value is None:
        return
    try:
        vals = _signal_values(value, "Pa", "supply_pressure", duration)
    except (
        SignalError
    ) as exc:  # name the option: "Constant.value = inf is not finite" alone does not
        raise SignalError(f"{where} {value!r}: {exc}") from None
    if not np.all(np.isfinite(vals)):
        raise ParameterError(
            f"{where} {value!r}: P_S is not finite everywhere; give a finite pressure"
        )
    for v in (float(vals.min()), float(vals.max())):
        try:
            dataclasses.replace(params.supply, pressure=v)
        except ParameterError as exc:
            raise ParameterError(f"{where} {value!r}: {exc}") from None


def check_position(x0: float | None, params, where: str = "--x0") -> None:
    """An initial rod position on the stroke, 0 ≤ x0 ≤ l."""
    if x0 is None:
        return
    stroke = params.cylinder.stroke
    if not (math.isfinite(x0) and 0.0 <= x0 <= stroke):
        raise ParameterError(
            f"{where} = {x0:g} m is off the stroke [0, {stroke:g}] m; give a position on it "
            "(e.g. '100 mm')"
        )


def check_jobs(jobs: int | None, where: str = "--jobs") -> None:
    """Workers: at most 4 per core (more processes or threads only thrash)."""
    if jobs is None:
        return
    cores = os.cpu_count() or 1
    if jobs > 4 * cores:
        raise ParameterError(
            f"{where} {jobs} is more than 4 workers per core ({cores} cores here); give at most "
            f"{4 * cores}"
        )
