"""Logs of a real rig back into a dataset: mapped to the runs of a plan, aligned and checked.

:func:`import_logs` reads one log per planned run (``LOGS/<run>.csv|.parquet|.mat``, through a
channel map for a vendor's column names and volts), finds each log's delay against the planned
command by cross-correlation, keeps ``[0, record_until]`` of the run on the plan's time base,
and checks it: rate, the channels the run's experiment needs, completeness, the command it
logged against the one planned, clipping and drop-outs (:func:`~hydropwa.data.check_run`), and
channels that look swapped against the plan's prediction. The result is one dataset per
experiment with the plan's machine in each manifest (``machine``), which ``identify all`` reads
as it reads a virtual-rig campaign. Any problem is one :class:`~hydropwa.DataError` line naming
the run; nothing is written then (the output is assembled in a temporary folder).
"""

from __future__ import annotations

import dataclasses
import json
import os
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from hydropwa._errors import DataError
from hydropwa._io import atomic_folder
from hydropwa._result import ResultStatus

from ._channel_map import ChannelMap
from ._dataset import Dataset
from ._formats import FORMATS, read_run
from ._run import Run
from ._validate import check_run

if TYPE_CHECKING:
    import pandas as pd

__all__ = ["ImportedRun", "ImportResult", "import_logs", "read_plan"]

_PLAN_FORMAT = "hydropwa-plan/1"
_RATE_RTOL = 0.01
_MAX_DELAY = 1.0  # [s] the largest delay searched between a log and its command
_COMMAND_NRMSE = 0.1  # the logged command within 10 % of the planned one's range
#: Channel pairs of one unit that a wiring or channel-map slip can swap.
_SWAPPABLE = (("p_a", "p_b"), ("p_a", "p_s"), ("p_b", "p_s"), ("x", "spool"))


@dataclass(frozen=True)
class ImportedRun:
    """One log taken in: the run it belongs to and the delay found.

    Attributes
    ----------
    name, experiment, source : str
        Run name, experiment and the log file's name.
    delay : float
        Delay of the log behind the planned command [s] (positive: the log lags).
    delay_samples : int
        The same in samples of the log.
    command_error : float
        RMS of (logged − planned) command over the planned command's range [1].
    """

    name: str
    experiment: str
    source: str
    delay: float
    delay_samples: int
    command_error: float


@dataclass(frozen=True)
class ImportResult:
    """What :func:`import_logs` wrote."""

    out: Path
    runs: tuple[ImportedRun, ...]

    @property
    def status(self) -> ResultStatus:
        """``SUCCESS``: an import that fails raises instead of returning."""
        return ResultStatus.SUCCESS

    @property
    def success(self) -> bool:
        """``status.success``."""
        return self.status.success

    def to_pandas(self) -> pd.DataFrame:
        """One row per run: experiment, source file, delay [s] and in samples, command error [1]."""
        import pandas as pd  # deferred: pandas, only for the table

        return pd.DataFrame([dataclasses.asdict(r) for r in self.runs]).set_index("name")

    def plot(self, *, ax: Any = None) -> Any:
        """The delay found for each run [ms]."""
        from hydropwa.plotting import new_figure  # deferred: matplotlib loads only here

        fig, grid = new_figure(ax=ax, figsize=(7.0, 3.0))
        axis = grid.ravel()[0]
        axis.plot([1e3 * r.delay for r in self.runs], "o", ms=3)
        axis.set_xlabel("run (plan order)")
        axis.set_ylabel("delay [ms]")
        return fig

    def _repr_html_(self) -> str:
        return self.to_pandas().to_html()

    @property
    def message(self) -> str:
        """One line: runs, experiments and the delays found."""
        d = np.array([r.delay for r in self.runs])
        return (
            f"imported {len(self.runs)} run(s) into {self.out} "
            f"({', '.join(sorted({r.experiment for r in self.runs}))}); delays "
            f"{1e3 * d.min():.3g}…{1e3 * d.max():.3g} ms"
        )

    def summary(self) -> str:
        """The message and each run's delay."""
        rows = [
            f"  {r.name}: delay {1e3 * r.delay:.3g} ms ({r.delay_samples} samples)"
            for r in self.runs
        ]
        return "\n".join([self.message, *rows])


def read_plan(plan: str | os.PathLike) -> dict[str, Any]:
    """The manifest of a plan folder (``hydropwa rig plan`` writes it).

    Raises
    ------
    DataError
        No manifest, not JSON, or not a plan's.
    """
    path = Path(plan) / "manifest.json"
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except OSError:
        raise DataError(
            f"{str(path)!r}: no plan manifest; hint: give the folder `hydropwa rig plan` wrote"
        ) from None
    except (ValueError, UnicodeDecodeError) as exc:
        raise DataError(f"{str(path)!r}: not a JSON plan manifest ({exc})") from None
    if not isinstance(doc, dict) or doc.get("format") != _PLAN_FORMAT:
        raise DataError(f"{str(path)!r}: not a plan manifest (format {_PLAN_FORMAT!r} expected)")
    return doc


def _logs(folder: Path) -> dict[str, Path]:
    if not folder.is_dir():
        raise DataError(f"{str(folder)!r}: no such folder of logs; hint: check the path")
    found: dict[str, Path] = {}
    for p in sorted(folder.iterdir()):
        if p.suffix.lower() in FORMATS and p.is_file():
            if p.stem in found:
                raise DataError(f"logs {found[p.stem].name} and {p.name} are both run {p.stem!r}")
            found[p.stem] = p
    return found


def _columns(path: Path) -> dict[str, np.ndarray]:
    """A plan's CSV (header line of names, then numbers) as columns."""
    names = path.read_text(encoding="utf-8").split("\n", 1)[0].strip().split(",")
    data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    return {n: data[:, i] for i, n in enumerate(names)}


def _delay(u_log: np.ndarray, u_plan: np.ndarray, max_lag: int) -> int:
    """Lag d [samples] maximising the correlation of u_log[k + d] with u_plan[k], |d| ≤ max_lag.

    The changes of the two commands are correlated, the planned one preceded by the rig's rest
    at u = 0: a constant command's only features are its start and end, which the levels'
    correlation (biased by the mean of a log with pre-trigger samples) misplaces.
    """
    a = np.diff(u_log, prepend=u_log[0])
    b = np.diff(u_plan, prepend=0.0)
    n = a.size + b.size - 1
    nfft = 1 << (n - 1).bit_length()
    c = np.fft.irfft(np.fft.rfft(a, nfft) * np.conj(np.fft.rfft(b, nfft)), nfft)
    lags = np.concatenate([np.arange(0, max_lag + 1), np.arange(-max_lag, 0)])
    return int(lags[np.argmax(c[lags])])


def _check_rate(run: Run, rate: float, name: str, source: str) -> None:
    dt = np.diff(run.t)
    fs = 1.0 / float(np.median(dt)) if dt.size else float("nan")
    if not abs(fs - rate) <= _RATE_RTOL * rate:
        raise DataError(
            f"run {name!r} ({source}): logged at {fs:.6g} Hz, the plan's rate is {rate:g} Hz; "
            "hint: log at the plan's rate (or plan at the log's: rig plan --rate)"
        )


def _aligned(run: Run, entry: Mapping, plan_dir: Path, rate: float) -> tuple[Run, ImportedRun]:
    name, source = entry["name"], str(run.meta.get("source", ""))
    cmd = _columns(plan_dir / entry["files"]["csv"])
    u_plan = cmd["u"]
    u_log = run["u"]
    d = _delay(u_log, u_plan, int(round(_MAX_DELAY * rate)))
    n_keep = int(np.searchsorted(cmd["t"], float(entry["record_until"]), side="right"))
    if d < 0 or d + n_keep > u_log.size:
        have = (u_log.size - max(d, 0)) / rate
        raise DataError(
            f"run {name!r} ({source}): incomplete, the log holds {have:.3g} s of the run's "
            f"{entry['record_until']:.3g} s (delay {d / rate:.3g} s); hint: record the whole run"
        )
    span = max(float(np.ptp(u_plan)), 1e-9)
    m = min(u_plan.size, u_log.size - d)
    err = float(np.sqrt(np.mean((u_log[d : d + m] - u_plan[:m]) ** 2)) / span)
    if err > _COMMAND_NRMSE:
        raise DataError(
            f"run {name!r} ({source}): the logged command u is not the planned one ({100 * err:.0f} % "
            "RMS of its range after alignment); hint: check the log's name and the map of 'u'"
        )
    chans = {k: v[d : d + n_keep] for k, v in run.channels.items() if k != "t"}
    chans["t"] = np.arange(n_keep) / rate
    meta = {
        **run.meta,
        **entry["meta"],
        "experiment": entry["experiment"],
        "kind": entry["experiment"],
        "import": {"delay": d / rate, "delay_samples": d, "source": source},
    }
    out = Run(name=name, channels=chans, units=dict(run.units), fs=rate, meta=meta)
    return out, ImportedRun(name, entry["experiment"], source, d / rate, d, err)


def _check_swaps(run: Run, predicted: Mapping[str, np.ndarray], source: str) -> None:
    n = min(run.n_samples, next(iter(predicted.values())).size)

    def miss(a: str, b: str) -> float:
        return float(np.sqrt(np.mean((run[a][:n] - predicted[b][:n]) ** 2)))

    for a, b in _SWAPPABLE:
        if not (run.has(a) and run.has(b) and a in predicted and b in predicted):
            continue
        if run.units.get(a) != run.units.get(b):
            continue
        straight, crossed = miss(a, a) + miss(b, b), miss(a, b) + miss(b, a)
        if crossed < 0.5 * straight:
            raise DataError(
                f"run {run.name!r} ({source}): channels {a!r} and {b!r} look swapped (each "
                "follows the other's prediction); hint: swap their sources in the channel map"
            )


def _checked(run: Run, entry: Mapping, columns: list[str], source: str) -> None:
    missing = [c for c in columns if c != "t" and not run.has(c)]
    if missing:
        raise DataError(
            f"run {run.name!r} ({source}): no channel {', '.join(map(repr, missing))} (a "
            f"{entry['experiment']} run needs {', '.join(columns)}); hint: map it in the channel map"
        )
    for issue in check_run(run, measured=True):
        if issue.severity == "error":
            raise DataError(f"{issue} ({source})")


def import_logs(
    logs: str | os.PathLike,
    plan: str | os.PathLike,
    out: str | os.PathLike,
    *,
    channel_map: ChannelMap | str | os.PathLike | None = None,
    format: str = "parquet",
    overwrite: bool = False,
) -> ImportResult:
    """Import a real rig's logs of a plan into a dataset ``identify all`` reads.

    Parameters
    ----------
    logs : path-like
        Folder with one log per planned run, named ``<run>.csv|.parquet|.mat``.
    plan : path-like
        The plan folder (``hydropwa rig plan``).
    out : path-like
        Output folder: ``OUT/<experiment>/`` datasets, each manifest with the plan's machine.
    channel_map : ChannelMap or path-like, optional
        The vendor's columns → channels (gains for volts, offsets); None: hydropwa's columns.
    format : {"parquet", "csv", "mat"}
        Format of the dataset's runs.
    overwrite : bool
        Replace an existing output folder.

    Returns
    -------
    ImportResult
        The runs taken in and the delay found for each.

    Raises
    ------
    DataError
        One line: a planned run without a log (all of them named), a log of no planned run, a
        wrong rate, a missing channel, an incomplete run, another command, a clipped or dropped
        channel, or swapped channels.
    """
    plan_dir = Path(plan)
    doc = read_plan(plan_dir)
    files = _logs(Path(logs))
    entries = doc["runs"]
    names = [e["name"] for e in entries]
    missing = [n for n in names if n not in files]
    if missing:
        shown = ", ".join(missing[:5]) + (", ..." if len(missing) > 5 else "")
        raise DataError(
            f"{len(missing)} of {len(names)} planned run(s) have no log in {str(logs)!r}: {shown}; "
            "hint: name each log after its run (<run>.csv)"
        )
    extra = sorted(set(files) - set(names))
    if extra:
        raise DataError(
            f"log {files[extra[0]].name} matches no run of the plan; hint: rename or remove it"
        )
    rate = float(doc["rate"])
    imported: dict[str, list[Run]] = {}
    found: list[ImportedRun] = []
    for e in entries:
        path = files[e["name"]]
        run = read_run(path, channel_map, name=e["name"], validate=False)
        run = run.replace(meta={**run.meta, "source": path.name})
        _check_rate(run, rate, e["name"], path.name)
        if not run.has("u"):
            raise DataError(f"run {e['name']!r} ({path.name}): no command channel 'u' to align on")
        run, info = _aligned(run, e, plan_dir, rate)
        _checked(run, e, list(doc["log_columns"][e["experiment"]]), path.name)
        pred = _columns(plan_dir / e["files"]["predicted"])
        _check_swaps(run, pred, path.name)
        imported.setdefault(e["experiment"], []).append(run)
        found.append(info)
    with atomic_folder(out, overwrite=overwrite) as tmp:
        for exp, runs in imported.items():
            meta = {
                "experiment": exp,
                "campaign": doc.get("campaign", ""),
                "machine": doc["machine"],
                "generator": f"hydropwa data import of plan {plan_dir.name!r}",
            }
            Dataset.create(tmp / exp, meta=meta).write(runs, format=format)
    return ImportResult(Path(out), tuple(found))
