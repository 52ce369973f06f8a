"""Import of the FASTER record (real third-party servo-hydraulic data).

The logged time stamps are a uniform clock printed with five significant digits: below 10 s
they resolve 0.1 ms, from 10 s 1 ms, from 100 s 10 ms, so the step reads 0 … 11 ms and from
100 s on stamps repeat (the rows at a repeated stamp are different samples). The reader
restores the clock: it fits t_k = t_0 + k Δt to the stamps by least squares, each weighted by its printed
resolution, and keeps the fit
only if every stamp lies within half its printed resolution of it (plus 1 % of a step);
otherwise it refuses in one line. No sample is dropped, merged or interpolated.
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np

from .._errors import DataError
from ._channel_map import builtin_channel_map
from ._formats import read_run
from ._run import Run
from ._validate import validate_run

__all__ = ["load_faster", "uniform_clock"]

#: Commanded channels of the record (not screened for spikes, clipping or dropouts).
_COMMANDS = ("u", "u_v", "f_ref_norm")
#: Significant digits of the FASTER CSV's time stamps.
FASTER_TIME_DIGITS = 5


def uniform_clock(t: np.ndarray, digits: int) -> tuple[np.ndarray, float, float]:
    """The uniform clock t_0 + k Δt behind time stamps printed with ``digits`` significant digits.

    Parameters
    ----------
    t : numpy.ndarray
        Logged time stamps [s], shape (N,), N ≥ 2, non-decreasing.
    digits : int
        Significant digits the stamps were printed with.

    Returns
    -------
    t_uniform : numpy.ndarray
        t_0 + k Δt [s], shape (N,).
    dt : float
        The clock's step Δt [s].
    worst : float
        Largest |stamp − clock| as a fraction of the allowed deviation (≤ 1).

    Raises
    ------
    DataError
        If a stamp lies further from the fitted clock than half its printed resolution plus
        1 % of a step: then the samples were not taken on a uniform clock.
    """
    t = np.asarray(t, dtype=float)
    k = np.arange(t.size, dtype=float)
    mag = np.floor(np.log10(np.maximum(np.abs(t), 1e-300)))
    half_quantum = np.where(t != 0.0, 0.5 * 10.0 ** (mag - (digits - 1)), 0.0)
    allowed = half_quantum + 0.01 * float(np.polyfit(k, t, 1)[0])
    # each stamp weighted by its resolution: the early, finely printed ones fix t_0
    dt, t0 = np.polyfit(k, t, 1, w=1.0 / allowed)
    clock = t0 + k * dt
    ratio = np.abs(t - clock) / allowed
    i = int(np.argmax(ratio))
    if not ratio[i] <= 1.0:
        raise DataError(
            f"time stamp {i} (t = {t[i]:.9g} s) lies {abs(t[i] - clock[i]):.3g} s from the uniform "
            f"clock fitted to the stamps (step {dt:.6g} s), more than its {digits}-digit rounding "
            "explains; hint: the log is not uniformly sampled, resample it with "
            "validate_run(..., drop_duplicates=True, resample=True)"
        )
    return clock, float(dt), float(ratio[i])


def load_faster(path: str | os.PathLike, name: str | None = None, *, validate: bool = True) -> Run:
    """Load the FASTER record ``faster.csv`` through the built-in map, on its restored clock.

    Parameters
    ----------
    path : path-like
        The CSV file (columns ``t, r, u, y, d``).
    name : str, optional
        Run name (default: file stem).
    validate : bool
        Check the run (:func:`~hydropwa.data.validate_run`, the command channels ``u_v`` and
        ``f_ref_norm`` not screened for spikes): a time-base error raises
        :class:`~hydropwa._errors.DataError`; every other finding is kept, one line each, in
        ``meta["findings"]``, and no sample is changed (the record has force spikes, a rest
        at d = 0 before the test starts and turning points flattened by the 0.0254 mm steps
        of the displacement sensor, which the screens read as a dropout and clipping).

    Returns
    -------
    Run
        Channels ``t`` [s] (restored uniform clock, see the module notes), ``u_v`` [V] (valve
        command), ``x`` [m] (beam displacement d), ``f_norm`` [1] (force y, normalised) and
        ``f_ref_norm`` [1] (its reference r); ``fs`` = 1/Δt (128.98 Hz for the record, not the
        128 Hz its README names); ``meta["timing"]`` says what was done to the stamps.
    """
    path = Path(path)
    run = read_run(path, builtin_channel_map("faster"), name=name or path.stem, validate=False)
    stamps = run.t
    rep = np.flatnonzero(np.diff(stamps) == 0.0)
    where = f", the first at {stamps[rep[0]]:.6g} s" if rep.size else ""
    clock, dt, worst = uniform_clock(stamps, FASTER_TIME_DIGITS)
    note = (
        f"time stamps restored to the uniform clock t0 + k*dt, dt = {dt * 1e3:.6g} ms "
        f"({1.0 / dt:.6g} Hz): the stamps are that clock printed with {FASTER_TIME_DIGITS} "
        f"significant digits ({rep.size} repeated stamps{where}; largest deviation "
        f"{worst:.0%} of the rounding allowance); no sample dropped or interpolated"
    )
    if not math.isfinite(dt) or dt <= 0.0:
        raise DataError(f"{str(path)!r}: time stamps do not increase; hint: check the file")
    chans = dict(run.channels)
    chans["t"] = clock
    run = run.replace(channels=chans, fs=1.0 / dt, meta={**run.meta, "timing": note})
    if validate:
        report = validate_run(run, no_clip_check=_COMMANDS, raise_on_error=False)
        time_errors = [i for i in report.issues if i.code.startswith("time_")]
        if time_errors:
            raise DataError(str(time_errors[0]))
        findings = [str(i) for i in report.issues]
        run = run.replace(meta={**run.meta, "findings": findings})
    return run
