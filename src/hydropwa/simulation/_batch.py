"""Many simulations at once: ``simulate_batch`` and the per-case summary metrics.

The compiled kernel releases the GIL (``nogil=True``), so a pool of threads
runs one trajectory per core with no pickling and no process start-up. Every
case goes through :func:`~hydropwa.simulation.simulate` itself, so a batch
gives bit-for-bit the results of the same cases run one by one.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor, as_completed
from typing import Any

import numpy as np

from .._errors import SignalError
from .._layout import DEFAULT_KIND
from ..models import Model, as_model
from ..params import SystemParams
from ._simulate import SimulationResult, simulate

__all__ = ["simulate_batch", "summarize", "SUMMARY_COLUMNS"]

#: Summary metric → unit, in column order (see :func:`summarize`).
SUMMARY_COLUMNS: dict[str, str] = {
    "final_x": "m",
    "min_x": "m",
    "max_x": "m",
    "peak_velocity": "m/s",
    "max_p_a": "Pa",
    "min_p_a": "Pa",
    "max_p_b": "Pa",
    "min_p_b": "Pa",
    "drift_per_period": "m",
    "steps": "1",
    "rejected": "1",
    "rhs_evaluations": "1",
    "status": "1",
    "wall_time": "s",
}


def _input_period(result: SimulationResult) -> float:
    """Period [s] of a sine command, NaN for any other input."""
    desc = result.inputs.get("u", {})
    freq = desc.get("frequency") if isinstance(desc, dict) else None
    if desc.get("type", desc.get("kind")) in ("sine", "Sine") and freq:
        return 1.0 / float(freq)
    return math.nan


def summarize(result: SimulationResult) -> dict[str, float]:
    """Summary metrics of one trajectory (units in :data:`SUMMARY_COLUMNS`).

    Parameters
    ----------
    result : SimulationResult

    Returns
    -------
    dict
        final, smallest and largest rod position x [m]; peak |ẋ| [m/s]; extreme
        chamber pressures [Pa]; ``drift_per_period`` [m], the change of x over
        one period of a sine command at the end of the run (NaN otherwise);
        solver statistics and the kernel wall time [s].
    """
    ch = result.channels
    x, t = ch["x"], result.t
    period = _input_period(result)
    drift = math.nan
    if math.isfinite(period) and t.size > 1 and t[-1] - t[0] >= period:
        k = int(np.searchsorted(t, t[-1] - period))
        drift = float(x[-1] - x[k])
    st = result.stats
    return {
        "final_x": float(x[-1]),
        "min_x": float(np.min(x)),
        "max_x": float(np.max(x)),
        "peak_velocity": float(np.max(np.abs(ch["v"]))),
        "max_p_a": float(np.max(ch["p_a"])),
        "min_p_a": float(np.min(ch["p_a"])),
        "max_p_b": float(np.max(ch["p_b"])),
        "min_p_b": float(np.min(ch["p_b"])),
        "drift_per_period": drift,
        "steps": st.steps,
        "rejected": st.rejected,
        "rhs_evaluations": st.rhs_evaluations,
        "status": int(st.status),
        "wall_time": st.wall_time,
    }


def _as_list(value, n: int | None, what: str) -> list:
    if isinstance(value, list | tuple) and not _is_pair_signal(value):
        if n is not None and len(value) not in (1, n):
            raise SignalError(f"{what} has {len(value)} entries but the batch has {n} cases")
        return list(value)
    return [value]


def _is_pair_signal(value) -> bool:
    """A (t, values) pair of arrays describes one sampled signal, not two cases."""
    return (
        isinstance(value, tuple)
        and len(value) == 2
        and all(
            isinstance(v, np.ndarray) or (isinstance(v, list) and v and not isinstance(v[0], str))
            for v in value
        )
    )


def _to_model(item: Any, model: str) -> Model:
    if isinstance(item, SystemParams):
        return as_model(model, item)
    return as_model(item)


def simulate_batch(
    models_or_params,
    inputs: Any = 0.0,
    *,
    model: str = DEFAULT_KIND.name,
    jobs: int | None = None,
    summary: bool = False,
    progress: Callable[[int, int], None] | None = None,
    **kwargs,
) -> list[SimulationResult] | list[dict[str, float]]:
    """Simulate many parameter sets and/or inputs on all cores.

    Parameters
    ----------
    models_or_params : model, SystemParams, str, or a sequence of them
        One entry per case: models, or parameter sets used with ``model``. A bare name
        (``"full"``) names no machine and raises :class:`~hydropwa.ParameterError`.
    inputs : valve command or a sequence of them
        One command u per case (anything :func:`simulate` accepts), or a single
        command for all cases. A single model with N inputs, or N models with
        one input, broadcast.
    model : str
        Model kind for entries given as :class:`~hydropwa.params.SystemParams`: the full model
        (the default, ``hydropwa._layout.DEFAULT_KIND``) or the reduced model (for the PWA
        model pass ``[linearize(p) for p in params]``).
    jobs : int, optional
        Worker threads (default: all cores, ``os.cpu_count()``).
    summary : bool
        Return :func:`summarize` dicts instead of full results (saves memory).
    progress : callable, optional
        ``progress(done, total)`` after each finished case (from the caller's thread).
    **kwargs
        Passed to :func:`simulate` for every case (``duration``, ``fs``, ``rtol``,
        ``supply_pressure``, ``load_force``, ``solver``...).

    Returns
    -------
    list of SimulationResult, or list of dict with ``summary=True``
        In case order.

    Notes
    -----
    The kernel releases the GIL, so threads scale with cores; each case is an
    ordinary :func:`simulate` call, so results equal one-by-one runs exactly.
    """
    cases_m = _as_list(models_or_params, None, "models_or_params")
    cases_u = _as_list(inputs, None, "inputs")
    n = max(len(cases_m), len(cases_u))
    if len(cases_m) not in (1, n) or len(cases_u) not in (1, n):
        raise SignalError(
            f"cannot pair {len(cases_m)} models with {len(cases_u)} inputs; give one or the same number"
        )
    mdls = [_to_model(m, model) for m in cases_m]
    pairs = [
        (mdls[i if len(mdls) > 1 else 0], cases_u[i if len(cases_u) > 1 else 0]) for i in range(n)
    ]

    def one(pair):
        res = simulate(pair[0], pair[1], **kwargs)
        if summary:
            return summarize(res)
        len(res.channels)  # the output pass (else run on first read) here, on the pool's threads
        return res

    workers = max(1, min(jobs or os.cpu_count() or 1, n))
    if workers == 1:
        out = []
        for i, pair in enumerate(pairs):
            out.append(one(pair))
            if progress is not None:
                progress(i + 1, n)
        return out
    results: list = [None] * n
    with ThreadPoolExecutor(max_workers=workers) as pool:
        futures = {pool.submit(one, pair): i for i, pair in enumerate(pairs)}
        for done, fut in enumerate(as_completed(futures), start=1):
            results[futures[fut]] = fut.result()
            if progress is not None:
                progress(done, n)
    return results
