"""The paper study: data → identification → PWA → evaluation → report, resumable by stage.

``run_paper_study(out)`` runs the paper's campaign on the virtual rig (or reads a measured
dataset folder), identifies the valve, dead-zone and Stribeck parameters, linearizes the
identified model, evaluates the full, reduced and PWA models on the sine runs and writes a
self-contained report folder::

    out/index.html        one page: figures (base64 PNG), tables, parameters, metrics
    out/figures/          PNG + SVG of every figure
    out/tables/           CSV + Markdown
    out/identified.toml   identified parameters with an [uncertainty] table
    out/pwa.json          the PWA model at the sine runs' average supply pressure
    out/data/             the virtual rig's datasets (without ``data=``)
    out/.stages/          one manifest per finished stage (inputs hash, output hashes)
"""

from __future__ import annotations

import dataclasses
import json
import os
import time
import warnings
from pathlib import Path
from typing import Any

import numpy as np

from ... import _interrupt
from ..._errors import HydropwaError, IdentificationError
from ..._io import (
    LOCK_NAME,
    atomic_path,
    atomic_write_text,
    check_output,
    output_lock,
    overwrite_flag,
)
from ..._layout import CHAMBER_KIND, FULL_KIND, MODEL_NAMES, PWA_KIND, REDUCED_KIND
from ...control import (
    closed_loop_study,
    closed_loop_verification,
    loop_bandwidth,
    model_warnings,
    save_controller,
)
from ...data import Run, read_dataset
from ...evaluation import coverage_study, evaluate_run, evaluation_params, sound_runs
from ...identification import (
    PARTS,
    IdentificationWarning,
    fit_model,
    identify,
    machine_for,
    recorded_machine,
    truth_in_interval,
)
from ...linearization import export_pwa, friction_function, linearize, load_pwa, save_pwa
from ...models import FullOrderModel
from ...params import SystemParams, get_preset, load_params, params_to_toml
from ...rig import Rig, load_campaign, run_campaign
from ...simulation import WarmUp
from ._report import write_report
from ._report_engineering import engineering_section
from ._stages import STAGE_DIR, StageRunner, file_hash, prefetch, text_hash, tree_files

__all__ = ["StudyError", "StudyResult", "run_paper_study", "EXPERIMENT_NAMES", "STUDY_VERSION"]

#: Dataset sub-folders of a study's data (the rig's layout).
EXPERIMENT_NAMES = ("frf", "deadzone", "friction", "sine")
#: Bumped when a stage's outputs change meaning (invalidates finished stages).
STUDY_VERSION = 2
_STUDY_FILE = "study.json"


class StudyError(HydropwaError, ValueError):
    """The study cannot run as asked (occupied report folder, missing sine runs, ...)."""


@dataclasses.dataclass
class StudyResult:
    """What :func:`run_paper_study` produced.

    Attributes
    ----------
    out : Path
        Report folder.
    report : Path
        ``out/index.html``.
    params : SystemParams
        Identified parameters.
    true_params : SystemParams or None
        True parameters where known (virtual rig).
    metrics : pandas.DataFrame
        Evaluation metrics (``tables/metrics.csv``).
    stages : dict[str, dict]
        Per stage: ``reused`` (bool), ``seconds`` (this call), ``work_seconds`` (when computed).
    notes : list of str
        Assumptions and skipped runs, as in the report.
    elapsed : float
        Wall time of the call [s].
    """

    out: Path
    report: Path
    params: Any
    true_params: Any
    metrics: Any
    stages: dict[str, dict]
    notes: list[str]
    elapsed: float

    def position_fit(self, model: str = FULL_KIND.name) -> Any:
        """Position NRMSE fit [%] per run of one model variant (a pandas Series)."""
        m = self.metrics
        sel = m[(m["model"] == model) & (m["channel"] == "x")]
        return sel.set_index("run")["nrmse_fit"]


# ----------------------------------------------------------------------------- inputs
@dataclasses.dataclass
class _Inputs:
    out: Path
    data: Path | None
    params: Any  # SystemParams: the rig's true params, or the identification base with data=
    params_source: str
    campaign: Any  # Campaign or None
    jobs: int

    def key(self) -> str:
        camp = (
            None
            if self.campaign is None
            else repr(self.campaign.experiments) + str(self.campaign.seed)
        )
        data = None if self.data is None else str(self.data.resolve())
        return text_hash(STUDY_VERSION, data, params_to_toml(self.params), camp)


def _resolve(out, data, params, campaign) -> _Inputs:
    if isinstance(params, SystemParams):
        prm, src = params, "given SystemParams"
    elif params is None:
        true_file = Path(data) / "true_params.toml" if data is not None else None
        if true_file is not None and true_file.is_file():
            prm, src = load_params(true_file), f"{true_file} (true parameters of the data)"
        elif data is not None and Path(data).is_dir():
            # measured data: their machine (a manifest's machine entry), never a preset
            found = recorded_machine(data)
            if found is None:
                raise StudyError(
                    f"{str(data)!r} records no machine (no true_params.toml, no 'machine' "
                    "entry in its manifests); give the machine's parameters with --params FILE"
                )
            prm, src = found[0], f"{found[1]} (the data's machine)"
        else:
            prm, src = get_preset("paper"), "preset 'paper'"
    elif isinstance(params, str) and not Path(params).exists():
        prm, src = get_preset(params), f"preset {params!r}"
    else:
        prm, src = load_params(params), str(params)
    if data is not None:
        d = Path(data)
        if not d.is_dir():
            raise StudyError(
                f"data folder {str(d)!r} does not exist; give a folder with frf/, deadzone/, "
                "friction/, sine/ datasets (the layout `hydropwa rig run all` writes)"
            )
        machine_for(d, prm)  # the given parameters' geometry must be the data's machine
        if not (d / "sine" / "manifest.json").is_file():
            raise StudyError(
                f"data folder {str(d)!r} has no sine/ dataset; the evaluation needs the sine runs"
            )
        camp = None
    else:
        d = None
        camp = load_campaign(campaign if campaign is not None else "paper")
        if "sine" not in camp.experiments:
            raise StudyError(
                f"campaign {camp.name!r} has no [sine] experiment; the evaluation needs it"
            )
    return _Inputs(Path(out), d, prm, src, camp, max(1, min(os.cpu_count() or 1, 4)))


def _claim(out: Path, key: str, force: bool) -> None:
    """Refuse a report folder made from other inputs unless ``force``; record ours."""
    study = out / STAGE_DIR / _STUDY_FILE
    if study.is_file():
        try:
            old = json.loads(study.read_text(encoding="utf-8")).get("inputs")
        except ValueError:
            old = None
        if old != key and not force:
            raise StudyError(
                f"{str(out)!r} holds a report made from other inputs; pass --force (overwrite=True) "
                "to overwrite it, or choose another folder"
            )
    elif out.is_dir() and any(p.name != LOCK_NAME for p in out.iterdir()) and not force:
        raise StudyError(
            f"{str(out)!r} is not empty and holds no hydropwa report; pass --force (overwrite=True) "
            "to write into it, or choose another folder"
        )
    if force and study.is_file():
        for p in (out / STAGE_DIR).glob("*.json"):
            p.unlink()
    atomic_write_text(study, json.dumps({"inputs": key, "version": STUDY_VERSION}) + "\n")


# ----------------------------------------------------------------------------- progress
class _Progress:
    """Rich progress bars per stage, or nothing."""

    def __init__(self, enabled: bool) -> None:
        self.bar = None
        if enabled:
            # deferred: rich, only for progress on a terminal
            from rich.progress import (
                BarColumn,
                MofNCompleteColumn,
                Progress,
                TextColumn,
                TimeElapsedColumn,
            )

            self.bar = Progress(
                TextColumn("{task.description:<22}"),
                BarColumn(),
                MofNCompleteColumn(),
                TimeElapsedColumn(),
            )
        self.tasks: dict[str, Any] = {}

    def __enter__(self):
        if self.bar is not None:
            self.bar.start()
        return self

    def __exit__(self, *exc):
        if self.bar is not None:
            self.bar.stop()

    def update(self, name: str, done: int, total: int) -> None:
        if self.bar is None:
            return
        if name not in self.tasks:
            self.tasks[name] = self.bar.add_task(name, total=total)
        self.bar.update(self.tasks[name], completed=done, total=total)

    def stage_done(self, name: str, reused: bool, seconds: float) -> None:
        self.update(f"{name}{' (reused)' if reused else ''}", 1, 1)


# ----------------------------------------------------------------------------- stages
def _read(root: Path, name: str):
    """A dataset of the study's data, or None when the folder lacks it.

    Runs are not validated on reading: constant-input runs start at an end stop on purpose,
    which the data layer's saturation check would reject.
    """
    if not (root / name / "manifest.json").is_file():
        return None
    return read_dataset(root / name, validate=False, lazy=True)


def _stage_data(
    inp: _Inputs, runner: StageRunner, prog: _Progress, rerun: bool
) -> tuple[Path, str]:
    """Virtual-rig campaign into out/data (or hash the user's data folder)."""
    if inp.data is not None:
        files = tree_files(inp.data)
        key = text_hash([(p.relative_to(inp.data).as_posix(), file_hash(p)) for p in files])
        prog.update("data (given)", 1, 1)
        return inp.data, key
    root = inp.out / "data"

    def work():
        rig = Rig(params=inp.params)
        run_campaign(
            rig,
            inp.campaign,
            root,
            jobs=inp.jobs,
            overwrite=rerun,
            progress=lambda e, d, t: prog.update(f"rig: {e}", d, t),
        )
        return tree_files(root), {}

    m = runner.run("data", text_hash(inp.key(), "data"), work)
    return root, text_hash(m["outputs"])


#: Columns of the identified-parameter table (also when nothing was identified).
_ESTIMATE_COLUMNS = [
    "parameter",
    "unit",
    "identified",
    "std",
    "ci_low",
    "ci_high",
    "true",
    "true_in_ci",
]


def _estimates_rows(name_unit_est: list[tuple[str, str, Any, float | None]]) -> list[dict]:
    rows = []
    for name, unit, est, true in name_unit_est:
        inside = truth_in_interval(est.ci[0], est.ci[1], true)
        rows.append(
            {
                "parameter": name,
                "unit": unit,
                "identified": est.value,
                "std": est.std,
                "ci_low": est.ci[0],
                "ci_high": est.ci[1],
                "true": np.nan if true is None else true,
                "true_in_ci": inside,
            }
        )
    return rows


def _identify(data_root: Path, base, notes: list[str]):
    """Identify from the study's data with :func:`hydropwa.identification.identify`.

    The same entry point as ``hydropwa identify all``, so both read the same runs with the
    same findings. Experiments that are missing (or hold no usable run) keep the base
    values, and the notes say so.
    """
    fitted: dict[str, Any] = {}
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", IdentificationWarning)
        try:
            rep = identify(data_root, PARTS, params=base)
        except IdentificationError as exc:
            rep = None
            notes.append(
                f"nothing identified ({exc}); every parameter is kept from the base parameters"
            )
    notes.extend(str(w.message) for w in caught if issubclass(w.category, IdentificationWarning))
    if rep is not None:
        for part, est in (
            ("frf", rep.valve),
            ("deadzone", rep.dead_zone),
            ("friction", rep.friction),
        ):
            if est is not None:
                fitted[part] = est
    for part, what in (
        ("frf", "valve ω0 and ζ"),
        ("deadzone", "dead zone"),
        ("friction", "friction"),
    ):
        if part not in fitted:
            notes.append(
                f"no usable {part}/ runs: the {what} parameters are kept from the base parameters"
            )
    return fitted


def _identified_params(base, fitted: dict[str, Any]):
    params = base
    unc: dict[str, Any] = {}
    for est in fitted.values():  # each estimator puts its values into the parameters
        params = est.apply(params)
        unc[est.field] = est.uncertainty()
    meta = {
        "source": "hydropwa paper study: identified "
        + (", ".join(unc) or "nothing")
        + "; the other values are the base (datasheet) parameters",
        "uncertainty": unc,
    }
    return params.replace(meta=meta)


def _parameter_table(fitted: dict[str, Any], true) -> list[dict]:
    rows: list[tuple[str, str, Any, float | None]] = []
    if "frf" in fitted:
        f = fitted["frf"]
        rows.append(("valve.zeta", "1", f.zeta_, None if true is None else true.valve.zeta))
        for amp, fit in f.fits_.items():
            tv = None if true is None else true.valve.omega0_at(amp)
            rows.append((f"valve.omega0 at u = {100 * amp:g} %", "rad/s", fit.omega0, tv))
    if "deadzone" in fitted:
        d = fitted["deadzone"].fit_
        rows.append(("dead_zone.beta", "1", d.beta, None if true is None else true.dead_zone.beta))
        rows.append(
            (
                "dead_zone.creep_slope",
                "1",
                d.creep_slope,
                None if true is None else true.dead_zone.creep_slope,
            )
        )
    unidentified = set()
    if "friction" in fitted:
        unidentified = {
            f"friction.{k}" for k in getattr(fitted["friction"].fit_, "unidentified", ())
        }
        for k, est in fitted["friction"].fit_.estimates.items():
            tv = None if true is None else getattr(true.friction, k, None)
            rows.append((f"friction.{k}", est.unit, est, tv))
    out = _estimates_rows(rows)
    for row in out:  # the data do not determine it: no value, the base's is kept
        if row["parameter"] in unidentified:
            row["identified"], row["true_in_ci"] = np.nan, "not identified"
    return out


def _write_table(df, stem: Path, floatfmt: str = ".4g") -> list[Path]:
    """CSV and Markdown of a DataFrame, atomically."""
    csv = stem.with_suffix(".csv")
    with atomic_path(csv) as tmp:
        df.to_csv(tmp, index=False)
    md = stem.with_suffix(".md")
    atomic_write_text(md, _markdown(df, floatfmt) + "\n")
    return [csv, md]


def _markdown(df, floatfmt: str = ".4g") -> str:
    cols = list(df.columns)

    def fmt(v):
        if isinstance(v, float | np.floating):
            return "" if not np.isfinite(v) else format(float(v), floatfmt)
        return str(v).replace("|", "\\|")

    lines = [
        "| " + " | ".join(map(str, cols)) + " |",
        "| " + " | ".join("---" for _ in cols) + " |",
    ]
    lines += ["| " + " | ".join(fmt(v) for v in row) + " |" for row in df.itertuples(index=False)]
    return "\n".join(lines)


def _save(fig, stem: Path) -> list[Path]:
    from ...plotting import save_figure  # deferred: matplotlib loads only when plotting

    # the stage runner owns the folder and decides what may be replaced
    svg = save_figure(fig, stem.with_suffix(".svg"), overwrite=True)
    fig.set_layout_engine("none")  # the first save's layout holds: the PNG does not redo it
    png = save_figure(fig, stem.with_suffix(".png"), dpi=110, overwrite=True)
    return [png, svg]


def _stage_identify(
    inp: _Inputs, runner: StageRunner, data_root: Path, data_key: str, notes: list[str]
):
    out = inp.out
    true = _true_params(inp, data_root)

    def work():
        import pandas as pd  # deferred: pandas costs ~0.3 s at import

        from ...plotting import (  # deferred: matplotlib loads only when plotting
            plot_bode,
            plot_dead_zone,
        )

        stage_notes: list[str] = []
        fitted = _identify(data_root, inp.params, stage_notes)
        ident = _identified_params(inp.params, fitted)
        files = [
            atomic_write_text(
                out / "identified.toml", params_to_toml(ident, "identified by `hydropwa paper`")
            )
        ]
        files += _write_table(
            pd.DataFrame(_parameter_table(fitted, true), columns=_ESTIMATE_COLUMNS),
            out / "tables" / "identified",
        )
        if "frf" in fitted:
            f = fitted["frf"]
            files += _save(plot_bode(f.frf_, f.fits_), out / "figures" / "fig05_valve_bode")
            files += _write_table(_frf_table(f.frf_), out / "tables" / "valve_frf")
        if "deadzone" in fitted:
            d = fitted["deadzone"]
            files += _write_table(d.points_, out / "tables" / "deadzone_points")
            files += _save(plot_dead_zone(d.points_, d.fit_), out / "figures" / "fig06_dead_zone")
        if "friction" in fitted:
            files += _write_table(fitted["friction"].points_, out / "tables" / "friction_points")
        return files, {"notes": stage_notes}

    m = runner.run("identify", text_hash(inp.key(), data_key, "identify"), work)
    notes.extend(m.get("notes", []))
    return load_params(out / "identified.toml"), true, runner.outputs_hash("identify")


def _frf_table(frf: dict):
    """The measured valve FRFs ν/u per command amplitude, one row per frequency."""
    import pandas as pd  # deferred: pandas costs ~0.3 s at import

    return pd.DataFrame(
        [
            {"amplitude [1]": a, "frequency [Hz]": f, "re": h.real, "im": h.imag}
            for a, r in frf.items()
            for f, h in zip(r.frequency, r.response, strict=True)
        ]
    )


def _stage_greybox(
    inp: _Inputs, runner: StageRunner, ident, true, key: str, runs, notes: list[str]
) -> str:
    """Grey-box fit (issue 19), kept cheap: E and K on the first second of two sine runs."""
    out = inp.out

    def work():
        from ...plotting import (  # deferred: matplotlib loads only when plotting
            plot_greybox_fit,
            plot_greybox_residuals,
        )

        short = []
        for r in runs[:2]:
            keep = np.asarray(r.channels["t"]) <= r.channels["t"][0] + 1.0
            short.append(
                Run(
                    name=r.name,
                    channels={c: np.asarray(v)[keep] for c, v in r.channels.items()},
                    units=r.units,
                    fs=r.fs,
                    meta=r.meta,
                )
            )
        try:
            fit = fit_model(
                FullOrderModel(ident),
                short,
                ("oil.bulk_modulus", "flow.K"),
                jobs=2,
                max_nfev=15,
                profile="none",
            )
        except HydropwaError as exc:
            return [], {"notes": [f"grey-box fit skipped: {exc}"]}
        df = fit.to_pandas().reset_index()
        if true is not None:
            df["true"] = [
                float(getattr(getattr(true, n.split(".")[0]), n.split(".")[1]))
                for n in df["parameter"]
            ]
        files = _write_table(df, out / "tables" / "greybox")
        files += _save(plot_greybox_fit(fit, fit.runs_[0].name), out / "figures" / "greybox_fit")
        files += _save(
            plot_greybox_residuals(fit, fit.runs_[0].name), out / "figures" / "greybox_residuals"
        )
        line = f"grey-box fit: {fit.message}, {fit.nfev} evaluations, {fit.wall_time:.1f} s"
        # a normal termination is the fit's status line, not a warning (issue 49)
        return files, {"notes": [] if fit.success else [line], "status": line}

    m = runner.run("greybox", text_hash(inp.key(), key, "greybox"), work)
    notes.extend(m.get("notes", []))
    return str(m.get("status", ""))


def _true_params(inp: _Inputs, data_root: Path):
    if inp.data is None:
        return inp.params
    f = data_root / "true_params.toml"
    return load_params(f) if f.is_file() else None


def _sine_runs(data_root: Path) -> list:
    ds = _read(data_root, "sine")
    if ds is None or len(ds) == 0:
        raise StudyError(
            f"{str(data_root / 'sine')!r} holds no runs; the evaluation needs the sine runs"
        )
    runs = sound_runs(ds)
    if not runs:
        raise StudyError(
            f"no sound sine run in {str(data_root / 'sine')!r}; see the warnings above"
        )
    return runs


def _mean_supply(runs, params) -> float:
    vals = [float(np.mean(r.channels["p_s"])) for r in runs if "p_s" in r.channels]
    return float(np.mean(vals)) if vals else float(params.supply.pressure)


def _stage_linearize(inp: _Inputs, runner: StageRunner, ident, true, key: str, runs):
    out = inp.out

    def work():
        import pandas as pd  # deferred: pandas costs ~0.3 s at import

        from ...linearization._report import (  # deferred: matplotlib loads only when plotting
            cq_figure,
            cqp_figure,
        )
        from ...plotting import plot_stribeck  # deferred: matplotlib loads only when plotting

        ps = _mean_supply(runs, ident)
        pwa = linearize(evaluation_params(ident), supply_pressure=ps)
        files = [
            save_pwa(pwa, out / "pwa.json", overwrite=True)
        ]  # the stage runner owns the folder
        # the guaranteed vector-field error of each exported cell (docs/reduced_asymmetric.md)
        cells = export_pwa(pwa, units="engineering")["cells"]
        bounds = pd.DataFrame(
            [{**c["index"], "error_bound_bar_per_s": c["error_bound"]} for c in cells]
        )
        summary = (
            bounds.groupby("g")["error_bound_bar_per_s"]
            .agg(["count", "median", "max"])
            .reset_index()
        )
        summary.columns = ["dead-zone cell g", "cells", "median bound [bar/s]", "max bound [bar/s]"]
        files += _write_table(summary, out / "tables" / "pwa_error_bounds")
        files += _save(cq_figure(pwa), out / "figures" / "fig01_cq")
        files += _save(cqp_figure(pwa), out / "figures" / "fig02_cqp")
        pts_file = out / "tables" / "friction_points.csv"
        if pts_file.is_file():
            pts = pd.read_csv(pts_file)
            fig = plot_stribeck(
                pts,
                friction_function(ident.friction),
                cells=pwa.cells_at()["friction"],
                reference=None if true is None else friction_function(true.friction),
            )
            files += _save(fig, out / "figures" / "fig08_stribeck")
        return files, {"supply_pressure": ps}

    m = runner.run("linearize", text_hash(inp.key(), key, "linearize"), work)
    return load_pwa(out / "pwa.json"), m["supply_pressure"], runner.outputs_hash("linearize")


def _corners(runs) -> dict[int, Any]:
    """Figs. 10–13: (low, high) amplitude × (low, high) frequency runs."""
    keyed = [(r.meta.get("amplitude"), r.meta.get("frequency"), r) for r in runs]
    keyed = [k for k in keyed if isinstance(k[0], int | float) and isinstance(k[1], int | float)]
    if not keyed:
        return dict(zip((10, 11, 12, 13), runs, strict=False))
    amps = sorted({k[0] for k in keyed})
    freqs = sorted({k[1] for k in keyed})
    out: dict[int, Any] = {}
    for num, (a, f) in zip(
        (10, 11, 12, 13),
        ((amps[0], freqs[0]), (amps[-1], freqs[0]), (amps[0], freqs[-1]), (amps[-1], freqs[-1])),
        strict=True,
    ):
        hit = [k[2] for k in keyed if k[0] == a and k[1] == f]
        if hit and all(hit[0] is not r for r in out.values()):
            out[num] = hit[0]
    return out


def _summary(metrics, channel: str = "x"):
    """Position fit [%] per run (rows) and model (columns), plus the mean."""
    x = metrics[metrics["channel"] == channel].pivot(
        index="run", columns="model", values="nrmse_fit"
    )
    x.loc["mean"] = x.mean()
    return x.reset_index()


def _coverage_tables(cov, out: Path) -> list[Path]:
    """The partition's coverage (evaluation/_coverage.py) as tables/coverage_*.csv/.md."""
    files = _write_table(cov.load_pressure, out / "tables" / "coverage_load_pressure")
    files += _write_table(cov.bands, out / "tables" / "coverage_bands")
    return files + _write_table(cov.cells, out / "tables" / "coverage_cells")


def _stage_evaluate(
    inp: _Inputs,
    runner: StageRunner,
    ident,
    true,
    key: str,
    runs,
    prog: _Progress,
    notes: list[str],
):
    out = inp.out

    def work():
        import pandas as pd  # deferred: pandas costs ~0.3 s at import

        from ...plotting import plot_cell_occupancy  # deferred: matplotlib loads only when plotting

        corners = _corners(runs)
        frames: list[Any] = []
        cells: list[Any] = []
        results: list[Any] = []
        stage_notes: list[str] = []
        files: list[Any] = []
        example = None
        for k, run in enumerate(runs):
            _interrupt.checkpoint()
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                res = evaluate_run(
                    run,
                    ident,
                    models=(
                        FULL_KIND.name,
                        REDUCED_KIND.name,
                        PWA_KIND.name,
                        "pwa-scheduled",
                        "reduced-paper",
                        "pwa-paper",
                        CHAMBER_KIND.name,
                    ),
                )
                if true is not None:
                    ref = evaluate_run(run, true, models=(FULL_KIND.name,))
            stage_notes.extend(f"{run.name}: {n}" for n in res.notes)
            stage_notes.extend(
                f"{run.name}: {w.message}"
                for w in caught
                if not issubclass(w.category, DeprecationWarning)
                and str(w.message) not in res.notes
            )
            df = res.metrics
            if true is not None:
                df = pd.concat(
                    [df, ref.metrics.assign(model="full (true params)")], ignore_index=True
                )
            frames.append(df)
            cells.append(res.cell_metrics)
            results.append(res)
            for num, r in corners.items():
                if r is run:
                    files += _save(
                        res.plot(channels=("u", "x", "p_l")),
                        out / "figures" / f"fig{num}_{run.name}",
                    )
            if example is None or run is corners.get(13):
                example = res
            prog.update("evaluate: sine runs", k + 1, len(runs))
        metrics = pd.concat(frames, ignore_index=True)
        cell_df = pd.concat(cells, ignore_index=True)
        files += _write_table(metrics, out / "tables" / "metrics")
        files += _write_table(_summary(metrics), out / "tables" / "position_fit", ".1f")
        files += _write_table(
            _summary(metrics, "x_detrended"), out / "tables" / "position_fit_detrended", ".1f"
        )
        files += _write_table(cell_df, out / "tables" / "pwa_cells")
        files += _coverage_tables(coverage_study(results, ident), out)
        traj = example.simulations.get(PWA_KIND.name) if example is not None else None
        load_pressure_forms = cell_df[cell_df["model"] != CHAMBER_KIND.name]
        files += _save(
            plot_cell_occupancy(load_pressure_forms, load_pwa(out / "pwa.json"), traj),
            out / "figures" / "pwa_cells",
        )
        return files, {"notes": stage_notes}

    m = runner.run("evaluate", text_hash(inp.key(), key, "evaluate"), work)
    notes.extend(m.get("notes", []))
    import pandas as pd  # deferred: pandas costs ~0.3 s at import

    return pd.read_csv(out / "tables" / "metrics.csv"), runner.outputs_hash("evaluate")


def _stage_control(
    inp: _Inputs, runner: StageRunner, true, key: str, notes: list[str] | None = None
) -> str:
    """Closed loop: the default design on the identified PWA model, verified on the full model."""
    out = inp.out

    def work():
        from ...plotting import plot_closed_loop  # deferred: matplotlib loads only when plotting

        pwa = load_pwa(out / "pwa.json")
        runs, table, design = closed_loop_study(pwa, true)
        files = [save_controller(design.controller, out / "controller.toml", overwrite=True)]
        files += _write_table(table.reset_index(), out / "tables" / "closed_loop")
        # the design's own verdict beside the PI's (same task set, draws, seed and noise)
        ver = closed_loop_verification(pwa, design.controller, verification=design.verification)
        files += _write_table(ver.reset_index(), out / "tables" / "closed_loop_verification")
        files += _write_table(design.table, out / "tables" / "closed_loop_cells")
        # every model and the baseline (the run with the true parameters repeats "full")
        shown = {k: v for k, v in runs.items() if k != "full (true params)"}
        files += _save(
            plot_closed_loop(
                shown, "LQR designed on the identified PWA model; textbook PI baseline"
            ),
            out / "figures" / "closed_loop",
        )
        notes = [f"closed loop design: {w}" for w in design.warnings[:3]]
        # which model can represent the loop (the valve left out near ω_h, cells left, limit cycles)
        bw = loop_bandwidth(design.controller)
        notes += [
            f"closed loop: {w}" for w in model_warnings(shown, pwa.params, pwa=pwa, bandwidth=bw)
        ]
        return files, {"notes": notes}

    m = runner.run("control", text_hash(inp.key(), key, "control"), work)
    if notes is not None:  # the design's warnings (cells unstable with the valve) are shown
        notes.extend(m.get("notes", []))
    return runner.outputs_hash("control")


def _stage_report(
    inp: _Inputs,
    runner: StageRunner,
    ident,
    true,
    key: str,
    notes: list[str],
    info: dict,
    engineering: str | None = None,
):
    def work():
        return [write_report(inp.out, ident, true, notes, info, engineering)], {}

    runner.run("report", text_hash(inp.key(), key, notes, "report"), work)


def _overlapped(
    inp: _Inputs, runner: StageRunner, ident, true, runs, keys, serial: bool = False
) -> str | None:
    """The stages after linearize that do not depend on each other, on two cores.

    A second process runs the greybox and evaluate stages while this one runs control and,
    when control ran, the report's engineering section (it reads only pwa.json,
    controller.toml and the identify stage's tables; returned as HTML for the report, else
    None): about 7 and 8 CPU-s on the paper rig. The caller then calls the stages in their
    order; they reuse what was written (:func:`._stages.prefetch`), so notes and records come
    out as in one process. ``serial``: all of it here (the study's warm-up process is
    compiling: a forked process would wait for kernels that the warm-up's reader thread, not
    forked with it, reports).
    """
    k1, k2, data_key = keys

    def second() -> None:
        _stage_greybox(inp, runner, ident, true, text_hash(k1, data_key), runs, [])
        _stage_evaluate(
            inp, runner, ident, true, text_hash(k1, k2, data_key), runs, _Progress(False), []
        )

    join = prefetch(runner, second, here=serial)
    try:
        _stage_control(inp, runner, true, k2, [])
        html = None if runner.record["control"]["reused"] else engineering_section(inp.out)
    except BaseException:
        join(abort=True)
        raise
    join()
    return html


# ----------------------------------------------------------------------------- main
def run_paper_study(
    out,
    data=None,
    params=None,
    campaign=None,
    fresh: bool = False,
    overwrite: bool = False,
    progress: bool = True,
    force: bool | None = None,
) -> StudyResult:
    """Run the paper's study end to end and write the report folder.

    Parameters
    ----------
    out : path-like
        Report folder (created).
    data : path-like, optional
        Measured dataset folder with frf/, deadzone/, friction/, sine/ sub-folders (each a
        :class:`hydropwa.data.Dataset`). Without it the campaign runs on the virtual rig.
    params : SystemParams, path-like or str, optional
        Without ``data``: the rig's true parameters. With ``data``: the base (datasheet)
        parameters the identification completes. A TOML file or a preset name; default the
        data's ``true_params.toml`` when present, else the ``paper`` preset.
    campaign : path-like or str, optional
        Campaign TOML or built-in name for the virtual rig (default ``"paper"``, the full
        campaign of Sec. VI–VII).
    fresh : bool
        Recompute every stage (including the rig runs).
    overwrite : bool
        Overwrite a report folder made from other inputs (else :class:`StudyError`).
    progress : bool
        Show rich progress bars per stage.
    force : bool, optional
        Former name of ``overwrite`` (deprecated).

    Returns
    -------
    StudyResult

    Raises
    ------
    StudyError
        Occupied report folder, missing sine data.
    HydropwaError
        From the layers underneath (bad parameters, campaign, data, failed identification).
    """
    t0 = time.perf_counter()
    overwrite = overwrite_flag(overwrite, force, "run_paper_study")
    inp = _resolve(out, data, params, campaign)
    check_output(inp.out, True, folder=True, option="--out")  # a file there is not a folder
    inp.out.mkdir(parents=True, exist_ok=True)
    with output_lock(inp.out, "hydropwa paper"):  # one run per folder; clears stale temp files
        return _run_study(inp, fresh, overwrite, progress, t0)


#: The compiled kernels the study uses besides the full model's, in the order it needs them.
_STUDY_KERNELS = (
    "point",
    *(name for name in MODEL_NAMES if name != FULL_KIND.name),
    *(f"closed-{name}" for name in MODEL_NAMES),
)


def _run_study(inp, fresh, force, progress, t0) -> StudyResult:
    """The stages of :func:`run_paper_study`, under the folder's lock."""
    _claim(inp.out, inp.key(), force)
    notes: list[str] = []
    if inp.data is not None and _true_params(inp, inp.data) is None:
        notes.append(
            f"base parameters: {inp.params_source}; no true parameters known for this data"
        )
    # the rig compiles the full model's solver here; one background process compiles the
    # others' meanwhile (nothing where the disk cache has them): a cold start on two cores
    # costs about half as long (docs/performance.md)
    with _Progress(progress) as prog, WarmUp(_STUDY_KERNELS) as warm:
        runner = StageRunner(inp.out, fresh or force, prog.stage_done)
        data_root, data_key = _stage_data(inp, runner, prog, fresh or force)
        by_stage: dict[str, list[str]] = {"inputs": list(notes)}
        n0 = len(notes)
        ident, true, k1 = _stage_identify(inp, runner, data_root, data_key, notes)
        by_stage["identify"], n0 = notes[n0:], len(notes)
        runs = _sine_runs(data_root)
        pwa, ps, k2 = _stage_linearize(inp, runner, ident, true, k1, runs)
        engineering = _overlapped(
            inp, runner, ident, true, runs, (k1, k2, data_key), serial=bool(warm.names)
        )
        greybox_status = _stage_greybox(
            inp, runner, ident, true, text_hash(k1, data_key), runs, notes
        )
        by_stage["greybox"], n0 = notes[n0:], len(notes)
        metrics, k3 = _stage_evaluate(
            inp, runner, ident, true, text_hash(k1, k2, data_key), runs, prog, notes
        )
        by_stage["evaluate"], n0 = notes[n0:], len(notes)
        info = {
            "data": str(inp.data)
            if inp.data is not None
            else "virtual rig, campaign " + (inp.campaign.source or inp.campaign.name),
            "params_source": inp.params_source,
            # the paper's Tables IV–IX describe its rig: shown only for that machine
            "paper_machine": inp.params == get_preset("paper"),
            "greybox_status": greybox_status,
            "supply_pressure": ps,
            "n_sine_runs": len(runs),
        }
        k4 = _stage_control(inp, runner, true, k2, notes)
        by_stage["control"] = notes[n0:]
        info["stage_notes"] = by_stage
        _stage_report(
            inp, runner, ident, true, text_hash(k1, k2, k3, k4, info), notes, info, engineering
        )
    return StudyResult(
        out=inp.out,
        report=inp.out / "index.html",
        params=ident,
        true_params=true,
        metrics=metrics,
        stages=runner.record,
        notes=notes,
        elapsed=time.perf_counter() - t0,
    )
