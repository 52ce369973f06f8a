"""The study's ``index.html``: one self-contained page (figures as base64 PNG, tables inline)."""

from __future__ import annotations

import base64
import html
import math
import re
from pathlib import Path

import numpy as np

from ... import __version__
from ..._io import atomic_write_text
from ..._layout import FULL_KIND, PWA_KIND, REDUCED_KIND
from ...control import METRIC_UNITS, POSITIONING_TASK
from ...data import read_dataset
from ...identification import TRUTH_OUTSIDE, truth_in_interval
from ...linearization import reproduce_paper_tables
from ...params import params_to_toml
from ._report_control import closed_loop_verification_html
from ._report_coverage import coverage_section
from ._report_engineering import engineering_section

__all__ = ["write_report", "metrics_for_display"]

_CSS = """
body{font-family:system-ui,sans-serif;max-width:1100px;margin:1.5em auto;padding:0 1em;color:#222}
h1{font-size:1.5em}h2{font-size:1.2em;border-bottom:1px solid #ccc;margin-top:1.8em}
table{border-collapse:collapse;font-size:.82em;margin:.6em 0}
td,th{border:1px solid #ccc;padding:2px 6px;text-align:right}th{background:#f0f0f0}
td:first-child,th:first-child{text-align:left}
figure{display:inline-block;margin:.4em;vertical-align:top;max-width:48%}
figure img{max-width:100%;border:1px solid #ddd}figcaption{font-size:.8em;color:#555}
.notes li{font-size:.85em}.small{font-size:.85em;color:#555}
table{display:block;max-width:100%;overflow-x:auto}td,th{white-space:normal;overflow-wrap:normal;word-break:normal;hyphens:manual}
caption{text-align:left;font-size:.9em;color:#444}
nav.toc{font-size:.9em;border:1px solid #ddd;padding:.3em 1em;display:inline-block}
.pass{color:#070;font-weight:bold}.fail{color:#b00;font-weight:bold}
.verdict{font-size:1.1em;padding:.4em .8em;border:2px solid;display:inline-block}
.warnbox{background:#fff8e0;border-left:4px solid #e0a000;padding:.3em .8em;font-size:.85em}
"""

#: The verdict's thresholds (the first screen of the report): the median position fit over
#: the sine runs each model must reach [%], the largest relative deviation of an identified
#: value from the true one (virtual rig), and the closed loop's steady-state error on the full
#: model as a fraction of its step.
VERDICT_FIT = {FULL_KIND.name: 90.0, REDUCED_KIND.name: 80.0, PWA_KIND.name: 80.0}
VERDICT_PARAM_RTOL = 0.10
VERDICT_SSE_FRACTION = 0.01

_CAPTIONS = {
    "fig01": "Fig. 1: Ĉ_q coefficient and its linearization",
    "fig02": "Fig. 2: Ĉ_qp coefficient and its linearization",
    "fig05": "Fig. 5: measured valve FRFs versus linear model fit",
    "fig06": "Fig. 6: dead-zone test and linearization",
    "fig08": "Fig. 8: measured friction points and fitted Stribeck model",
    "fig09": "Fig. 9: supply pressure during an evaluation run",
    "fig10": "Fig. 10: low amplitude, low frequency",
    "fig11": "Fig. 11: high amplitude, low frequency",
    "fig12": "Fig. 12: low amplitude, high frequency",
    "fig13": "Fig. 13: high amplitude, high frequency",
    "pwa_cells": "PWA cell occupancy and partition",
    "closed_loop": "Closed loop: one controller on the full, reduced, PWA and chamber-level PWA models",
}


def _figure(path: Path) -> str:
    data = base64.b64encode(path.read_bytes()).decode("ascii")
    key = path.stem.split("_")[0] if path.stem.startswith("fig") else path.stem
    cap = _CAPTIONS.get(key, path.stem)
    svg = "; SVG in figures/" if path.with_suffix(".svg").is_file() else ""
    return (
        f'<figure><img alt="{html.escape(cap)}" src="data:image/png;base64,{data}">'
        f"<figcaption>{html.escape(cap)} ({html.escape(path.stem)}{svg})</figcaption></figure>"
    )


def _figures(out: Path, prefixes: tuple[str, ...]) -> str:
    files = sorted(p for p in (out / "figures").glob("*.png") if p.stem.startswith(prefixes))
    return (
        "\n".join(_figure(p) for p in files)
        or '<p class="small">(no figure: the data lacked this experiment)</p>'
    )


def _cell(v) -> str:
    if isinstance(v, float | np.floating):
        if not math.isfinite(v):
            return ""
        return f"{v:.4g}"
    return html.escape(str(v))


def _table(df, caption: str = "", raw: tuple[str, ...] = ()) -> str:
    """An HTML table of ``df``; the columns ``raw`` hold HTML already (flags)."""
    head = "".join(f"<th>{html.escape(str(c))}</th>" for c in df.columns)
    keep = [c in raw for c in df.columns]
    body = "\n".join(
        "<tr>"
        + "".join(f"<td>{v if k else _cell(v)}</td>" for v, k in zip(row, keep, strict=True))
        + "</tr>"
        for row in df.itertuples(index=False)
    )
    cap = f"<caption>{html.escape(caption)}</caption>" if caption else ""
    return f"<table>{cap}<thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>"


#: Metric rows of a derived channel → the output channel whose display unit they share
#: (the detrended position is a position: mm, as the table's note says).
_MEASURED_AS = {"x_detrended": "x"}


def metrics_for_display(metrics):
    """Metrics with RMSE, peak error and drift in engineering units (mm, bar, mm/s)."""
    from ...plotting import DISPLAY  # deferred: matplotlib loads only when plotting

    df = metrics.copy()
    shown = df["channel"].map(lambda c: DISPLAY.get(str(_MEASURED_AS.get(c, c)), (c, 1.0, "")))
    fac = shown.map(lambda d: d[1])
    df["unit"] = shown.map(lambda d: d[2])
    df["rmse"] = df["rmse"] * fac
    df["peak_error"] = df["peak_error"] * fac
    for col in ("drift_measured", "drift_model"):
        if col in df:
            df[col] = df[col] * 1e3
    df = df.rename(
        columns={
            "nrmse_fit": "fit [%]",
            "drift_measured": "drift meas. [mm/period]",
            "drift_model": "drift model [mm/period]",
        }
    )
    return df.drop(columns=[c for c in ("note",) if c in df])


def _interval_digits(lo: float, hi: float, value: float, true: float = float("nan")) -> int:
    """Significant digits that keep ``lo``, ``value``, ``hi`` and a ``true`` value apart
    (4 at least, 10 at most), so a truth just outside its interval does not print as an end."""
    vals = sorted({v for v in (lo, value, hi, true) if math.isfinite(v)})
    for d in range(4, 11):
        if len({f"{v:.{d}g}" for v in vals}) == len(vals):
            return d
    return 10


def _params_section(out: Path) -> str:
    """Identified parameters with intervals printed to the digits that tell their ends apart,
    and every true value (virtual rig) outside its interval flagged."""
    import pandas as pd  # deferred: pandas costs ~0.3 s at import

    f = out / "tables" / "identified.csv"
    if not f.is_file():
        return "<p>No identification table.</p>"
    df = pd.read_csv(f)
    rows = []
    n_out = 0
    for r in df.itertuples(index=False):
        d = _interval_digits(float(r.ci_low), float(r.ci_high), float(r.identified), float(r.true))

        def g(v, d=d):
            return "" if not math.isfinite(float(v)) else f"{float(v):.{d}g}"

        true = float(r.true)
        if str(r.true_in_ci) == "not identified":
            rows.append(
                f"<tr><td>{html.escape(str(r.parameter))}</td><td>{html.escape(str(r.unit))}</td>"
                f"<td><b>not identified</b></td><td></td><td>fit's interval {g(r.ci_low)} … "
                f"{g(r.ci_high)}: the data do not determine it; the base value is kept</td>"
                f"<td>{g(true)}</td><td></td></tr>"
            )
            continue
        flag, outside = _truth_flag(r.ci_low, r.ci_high, true)
        n_out += outside
        rows.append(
            f"<tr><td>{html.escape(str(r.parameter))}</td><td>{html.escape(str(r.unit))}</td>"
            f"<td>{g(r.identified)}</td><td>{_cell(float(r.std))}</td>"
            f"<td>{g(r.ci_low)} … {g(r.ci_high)}</td><td>{g(true)}</td><td>{flag}</td></tr>"
        )
    head = "".join(
        f"<th>{h}</th>"
        for h in (
            "parameter",
            "unit",
            "identified",
            "std",
            "confidence interval",
            "true",
            "true in interval",
        )
    )
    return (
        "<table><caption>identified parameters: estimate, standard error, confidence interval, "
        "true value (virtual rig; empty when unknown)</caption>"
        f"<thead><tr>{head}</tr></thead><tbody>{''.join(rows)}</tbody></table>{_outside_note(n_out)}"
    )


def _truth_flag(low: float, high: float, true: float) -> tuple[str, bool]:
    """The cell of a table's "true in interval" column (the one rule,
    :func:`~hydropwa.identification.truth_in_interval`; a miss in red) and whether it is one."""
    verdict = truth_in_interval(float(low), float(high), float(true))
    if verdict == TRUTH_OUTSIDE:
        return f"<b style='color:#b00'>{html.escape(verdict)}</b>", True
    return html.escape(verdict), False


def _outside_note(n_out: int) -> str:
    """The line under a table with ``n_out`` true values outside their intervals."""
    if not n_out:
        return ""
    return (
        f"<p class='small'><b>{n_out} true value(s) outside their interval</b>: the interval covers the "
        "statistical error of the fit, not a bias of the method (see docs/architecture_identification.md).</p>"
    )


def _headline(metrics, fit, fit_detrended, paper_forms: bool = False) -> str:
    """A few numbers per model: median fits of position (plain, detrended) and of the load
    pressure, median RMSE of position [mm] and load pressure [bar] over the sine runs; the
    package's models, or (``paper_forms``) the paper's mean-area forms."""
    import pandas as pd  # deferred: pandas costs ~0.3 s at import

    rows = []
    models = [c for c in fit.columns if c != "run" and c.endswith("-paper") == paper_forms]
    if not models:
        return ""
    for model in models:
        m = metrics[metrics["model"] == model]

        def med(ch, col, fac=1.0, m=m):
            v = m.loc[m["channel"] == ch, col]
            return float(v.median()) * fac if len(v) else float("nan")

        runs_fit = fit.loc[fit["run"] != "mean", model]
        runs_det = (
            fit_detrended.loc[fit_detrended["run"] != "mean", model]
            if model in fit_detrended
            else pd.Series([], dtype=float)
        )
        rows.append(
            {
                "model": model,
                "position fit [%]": float(runs_fit.median()),
                "position fit, trend removed [%]": float(runs_det.median())
                if len(runs_det)
                else float("nan"),
                "position RMSE [mm]": med("x", "rmse", 1e3),
                "load-pressure fit [%]": med("p_l", "nrmse_fit"),
                "load-pressure RMSE [bar]": med("p_l", "rmse", 1e-5),
            }
        )
    what = "the paper's forms" if paper_forms else "headline"
    return _table(pd.DataFrame(rows), f"{what}: medians over the sine runs")


def _paper_tables_section() -> str:
    """Tables IV–IX as printed (typos corrected, see docs/errata.md E6, E8) and regenerated:
    the paper's rig, so the report shows them for that machine only."""
    head = (
        "<h2>The paper's Tables IV–IX</h2>\n<p class='small'>Printed values (typos corrected: "
        "docs/errata.md E6, E8) next to the values this package regenerates from the paper's "
        "equations.</p>"
    )
    try:
        tables = reproduce_paper_tables()
    except Exception as exc:  # noqa: BLE001 - the report must still be written
        return (
            head
            + f"<p class='small'>Tables IV–IX could not be regenerated: {html.escape(str(exc))}</p>"
        )
    return head + "".join(
        f"<details><summary>Table {name}</summary>{_table(df, f'Table {name}: printed vs regenerated')}</details>"
        for name, df in tables.items()
    )


def _fig9(out: Path, info: dict) -> str:
    """Fig. 9: the supply pressure recorded during the evaluation runs (first sine run)."""
    try:
        # deferred: matplotlib loads only when a figure is drawn
        from ...plotting import plot_supply_pressure, save_figure

        # the study's own data (virtual rig: out/data) or the measured dataset it was given
        folders = [r / "sine" for r in (out / "data", Path(str(info.get("data", ""))))] + [
            Path(str(info.get("data", "")))
        ]
        ds = read_dataset(next(d for d in folders if (d / "manifest.json").is_file()))
        run = next(r for r in ds if r.has("p_s"))
        fig = plot_supply_pressure(run.t, run["p_s"], name=run.name)
        path = out / "figures" / "fig09_supply_pressure.png"
        path.parent.mkdir(parents=True, exist_ok=True)
        save_figure(fig, path, dpi=110, overwrite=True)  # the report owns its folder
        return _figure(path)
    except Exception:  # noqa: BLE001 - no sine run with P_S in the data: no figure
        return '<p class="small">(no figure: the data hold no sine run with a recorded supply pressure)</p>'


def _summary_section(info: dict, true, metrics, fit, fit_detrended) -> str:
    virtual = true is not None
    if virtual:
        what = (
            "<p><b>Self-consistency, not validation.</b> The data come from the <b>virtual rig</b>: the "
            "full-order model with the paper's parameters, plus sensors, converters and a sagging pump "
            "supply. A full-model fit near 100 % shows that identification, simulation and evaluation "
            "recover what the rig put in; it says nothing about how well the equations describe a real "
            "cylinder. Validation needs measured data: <code>hydropwa paper --data DIR</code>.</p>"
        )
    else:
        what = (
            f"<p><b>Validation on measured data</b> ({html.escape(str(info.get('data')))}): the models were "
            "identified on the identification runs and are compared with sine runs they were not fitted to.</p>"
        )
    return (
        "<h2>Summary</h2>"
        + what
        + "<p>The <b>reduced</b> and <b>PWA</b> models carry both piston areas and follow the single-rod "
        "cylinder's drift. The paper's own mean-area forms are compared in their own section "
        '(<a href="#the-papers-forms">The paper\'s forms</a>).</p>'
        + _headline(metrics, fit, fit_detrended)
    )


def _paper_forms_section(metrics, fit, fit_detrended) -> str:
    """The paper's mean-area forms, apart from the headline: low plain fits by construction."""
    table = _headline(metrics, fit, fit_detrended, paper_forms=True)
    if not table:
        return ""
    return (
        "<h2>The paper's forms</h2><p>The paper's forms (<b>reduced-paper</b>, <b>pwa-paper</b>) "
        "use the mean piston area Ā, so a zero-mean sine moves them back and forth without the "
        "single-rod cylinder's drift to +x (docs/errata.md D5): their plain position fit is low "
        "by construction (it can be negative: NRMSE below 0 % means worse than the mean). The "
        "fit with each trend removed and the load-pressure fit score their dynamics.</p>" + table
    )


def _verdict_section(out: Path, fit, true) -> str:
    """The first screen: what was checked, against which threshold, pass or fail."""
    import pandas as pd  # deferred: pandas costs ~0.3 s at import

    rows: list[tuple[str, str, str, bool | None]] = []
    runs = fit[fit["run"] != "mean"]
    for model, need in VERDICT_FIT.items():
        if model in runs:
            got = float(runs[model].median())
            rows.append(
                (
                    f"{model} model reproduces the sine runs (median position fit)",
                    f"≥ {need:g} %",
                    f"{got:.1f} %",
                    got >= need,
                )
            )
    f = out / "tables" / "identified.csv"
    if true is not None and f.is_file():
        df = pd.read_csv(f)
        for col in ("true", "identified"):  # an empty table reads as text columns
            df[col] = pd.to_numeric(df[col], errors="coerce").astype(float)
        df = df[np.isfinite(df["true"]) & (df["true"] != 0) & np.isfinite(df["identified"])]
        if len(df):
            rel = (df["identified"] - df["true"]).abs() / df["true"].abs()
            worst = int(rel.to_numpy().argmax())
            rows.append(
                (
                    "identified values near the rig's true ones (largest relative deviation)",
                    f"≤ {100 * VERDICT_PARAM_RTOL:g} %",
                    f"{100 * float(rel.max()):.1f} % ({df['parameter'].iloc[worst]})",
                    bool(float(rel.max()) <= VERDICT_PARAM_RTOL),
                )
            )
    f = out / "tables" / "closed_loop.csv"
    if f.is_file():
        cl = pd.read_csv(f)
        full = cl[cl.iloc[:, 0] == FULL_KIND.name]
        if len(full) and {"steady_state_error", "step"} <= set(cl.columns):
            sse = abs(float(full["steady_state_error"].iloc[0]))
            step = abs(float(full["step"].iloc[0]))
            rows.append(
                (
                    "closed loop on the full model: steady-state error over the step",
                    f"≤ {100 * VERDICT_SSE_FRACTION:g} % of the step",
                    f"{sse:.3g} mm of {step:.3g} mm",
                    bool(sse <= VERDICT_SSE_FRACTION * step),
                )
            )
    rows.extend(_controller_verdict_rows(out))
    failed = [r for r in rows if r[3] is False]
    verdict = (
        f"<span class='fail'>FAIL</span>: {len(failed)} of {len(rows)} checks"
        if failed
        else f"<span class='pass'>PASS</span>: all {len(rows)} checks"
    )
    body = "".join(
        f"<tr><td>{html.escape(w)}</td><td>{html.escape(t)}</td><td>{html.escape(v)}</td>"
        f"<td class='{'pass' if ok else 'fail'}'>{'pass' if ok else 'fail'}</td></tr>"
        for w, t, v, ok in rows
    )
    return (
        f"<h2>Verdict</h2><p class='verdict'>{verdict}</p>"
        "<table><thead><tr><th>what was checked</th><th>threshold</th><th>value</th>"
        f"<th>result</th></tr></thead><tbody>{body}</tbody></table>"
    )


def _controller_verdict_rows(out: Path) -> list[tuple[str, str, str, bool]]:
    """The verdict's row of the controller's verification (``closed_loop_verification.csv``):
    the report says PASS only where the closed-loop design passed its verification too."""
    import pandas as pd  # deferred: pandas costs ~0.3 s at import

    f = out / "tables" / "closed_loop_verification.csv"
    if not f.is_file():
        return []
    ver = pd.read_csv(f, keep_default_na=False)
    design = ver[ver["controller"] == "design"]
    if not len(design):
        return []
    row = design.iloc[0]
    ok = str(row["verdict"]) == "pass"
    value = "pass" if ok else f"fail: {int(row['failed_checks'])} checks ({row['first_failure']})"
    return [
        (
            "closed-loop design verified on the full model (task set, draws, sensor noise, delay)",
            "every check of the verification",
            value,
            ok,
        )
    ]


def _warnings(stage_notes: dict, stage: str) -> str:
    """The warnings a stage recorded, shown in its section."""
    notes = stage_notes.get(stage) or []
    if not notes:
        return ""
    items = "".join(f"<li>{html.escape(n)}</li>" for n in notes)
    return (
        f"<div class='warnbox'><b>{len(notes)} warning(s) of this stage</b><ul>{items}</ul></div>"
    )


def _toc(page: str) -> tuple[str, str]:
    """Put an anchor before every ``<h2>``; return the page and a table of contents linking them."""
    entries = []

    def anchor(m):
        title = m.group(1)
        slug = re.sub(r"[^a-z0-9]+", "-", re.sub(r"<[^>]+>|&#x27;|'", "", title.lower())).strip("-")
        entries.append((slug, re.sub(r"<[^>]+>", "", title)))
        return f'<a id="{slug}"></a><h2>{title}</h2>'

    page = re.sub(r"<h2>(.*?)</h2>", anchor, page)
    items = "".join(f'<li><a href="#{s}">{t}</a></li>' for s, t in entries)
    return page, f'<nav class="toc"><b>Contents</b><ol>{items}</ol></nav>'


def _closed_loop_section(out: Path) -> str:
    import pandas as pd  # deferred: pandas costs ~0.3 s at import

    f = out / "tables" / "closed_loop.csv"
    if not f.is_file():
        return ""

    return f"""<h2>Closed loop</h2>
<p>Positioning task: {html.escape(POSITIONING_TASK)}. The gain-scheduled LQR (one gain row per
cell, integral action, dead-zone inverse; controller.toml) is designed on the identified PWA model
only and verified on the full model; the chamber-level PWA model (pwa-chamber: valve and both
chambers kept) shows how well a design model predicts the closed loop. Times in ms, errors in mm, IAE in mm·s, saturation in %,
chattering in sign changes of the command per second; overshoot beyond the target and settling
time from the start of the move out, those of the move back in the last columns. No rise time:
the reference is a trapezoid, whose 10 → 90 % time is its own ramp's.</p>
{_table(_with_units(pd.read_csv(f)), "tracking metrics per model")}
{closed_loop_verification_html(out)}
{_figures(out, ("closed_loop",))}"""


def _with_units(df):
    """Closed-loop metric columns named with their units (``rise_time [ms]``)."""

    def name(col: str) -> str:
        base = col.removesuffix("_back")
        unit = METRIC_UNITS.get(base)
        return f"{col} [{unit}]" if unit and unit != "1" else col

    return df.rename(columns={c: name(str(c)) for c in df.columns})


def _percent(df):
    """Fit tables: every model column in %."""
    return df.rename(columns={c: f"{c} [%]" for c in df.columns if c != "run"})


def _greybox_section(out: Path, status: str = "") -> str:
    """The grey-box estimates, under the fit's status line (a warning only if it failed)."""
    import pandas as pd  # deferred: pandas costs ~0.3 s at import

    f = out / "tables" / "greybox.csv"
    if not f.is_file():
        return "<p>No grey-box fit (see the notes).</p>"
    line = f"<p class='small'>{html.escape(status)}</p>" if status else ""
    df = pd.read_csv(f)
    n_out = 0
    if "true" in df:  # virtual-rig data: every interval checked against the truth
        flags = [
            _truth_flag(lo, hi, t)
            for lo, hi, t in zip(df["ci_low"], df["ci_high"], df["true"], strict=True)
        ]
        df["true in interval"] = [c for c, _ in flags]
        n_out = sum(o for _, o in flags)
    return (
        line
        + _table(
            df,
            "grey-box estimates: value, standard error, 95 % interval, variance inflation"
            + (", true value (virtual rig)" if "true" in df else ""),
            raw=("true in interval",),
        )
        + _outside_note(n_out)
    )


def _true_params_html(true) -> str:
    """The rig's true parameters as a folded TOML block (virtual-rig data only)."""
    if true is None:
        return ""
    return (
        "<details><summary>true parameters (TOML)</summary><pre>"
        + html.escape(params_to_toml(true))
        + "</pre></details>"
    )


def write_report(
    out: Path, ident, true, notes: list[str], info: dict, engineering: str | None = None
) -> Path:
    """Write ``out/index.html`` from the study's tables and figures; returns its path.

    ``engineering``: the engineering section's HTML where it was made already (the study
    makes it while the evaluate stage runs); else it is made here.
    """
    import pandas as pd  # deferred: pandas costs ~0.3 s at import

    metrics = pd.read_csv(out / "tables" / "metrics.csv")
    fit = pd.read_csv(out / "tables" / "position_fit.csv")
    fit_detrended = pd.read_csv(out / "tables" / "position_fit_detrended.csv")
    notes_html = "".join(f"<li>{html.escape(n)}</li>" for n in notes) or "<li>none</li>"
    by_stage: dict = info.get("stage_notes") or {}
    true_toml = _true_params_html(true)
    page = f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>hydropwa paper study</title>
<style>{_CSS}</style></head><body>
<h1>Valve-controlled hydraulic cylinder: identification, PWA linearization and model evaluation</h1>
<p class="small">hydropwa {html.escape(__version__)} · data: {html.escape(str(info.get("data")))} ·
parameters: {html.escape(str(info.get("params_source")))} · {info.get("n_sine_runs")} sine runs ·
PWA cells at the average supply pressure {info.get("supply_pressure", float("nan")) / 1e5:.2f} bar</p>

{_verdict_section(out, fit, true)}
@@TOC@@
{_warnings(by_stage, "inputs")}
{_summary_section(info, true, metrics, fit, fit_detrended)}

<h2>Position fit (NRMSE, %)</h2>
<p>100·(1 − ‖x − x̂‖/‖x − mean x‖) over the runs from the first full period in steady state
(Sec. VII). <b>full</b>: full-order model with the measured P_S(t); <b>reduced</b>, <b>pwa</b>:
the asymmetric models (both piston areas), average P_S as in the paper; <b>pwa-scheduled</b>: PWA
cells rescheduled on the measured P_S(t); <b>reduced-paper</b>, <b>pwa-paper</b>: the paper's
mean-area forms; <b>full (true params)</b>: the full model with the rig's true parameters, for
reference.</p>
{_warnings(by_stage, "evaluate")}
{_table(_percent(fit), "position fit [%] per run and model")}
<p>With each signal's own straight-line trend removed, the fit scores the shape of the motion
(the paper's mean-area forms lack the single-rod drift; see the next section):</p>
{_table(_percent(fit_detrended), "position fit [%] with linear trends removed")}

{_paper_forms_section(metrics, fit, fit_detrended)}

{coverage_section(out, _table)}

<h2>Supply pressure (Fig. 9)</h2>
{_fig9(out, info)}

<h2>Measurement and simulation (Figs. 10–13)</h2>
<p class="small">The measurement is smoothed by a 10 ms moving average for display only; metrics use the raw samples.</p>
{_figures(out, ("fig10", "fig11", "fig12", "fig13"))}

<h2>Identified parameters</h2>
{_warnings(by_stage, "identify")}
{_params_section(out)}
<details><summary>identified parameters (identified.toml)</summary><pre>{html.escape(params_to_toml(ident))}</pre></details>
{true_toml}

<h2>Grey-box fit</h2>
<p class="small">Bulk modulus and flow coefficient fitted by output error to the first second of two
sine runs (<code>hydropwa identify model</code>), starting from the identified parameters; intervals
corrected for the residuals' autocorrelation. Not written into identified.toml.</p>
{_warnings(by_stage, "greybox")}
{_greybox_section(out, str(info.get("greybox_status", "")))}
{_figures(out, ("greybox",))}

<h2>Identification (Figs. 5, 6, 8)</h2>
{_figures(out, ("fig05", "fig06", "fig08"))}

<h2>Piecewise-affine model (Figs. 1, 2, cells)</h2>
<p class="small">pwa.json holds the model with one affine system per cell.</p>
{_figures(out, ("fig01", "fig02", "pwa_cells"))}
{engineering_section(out) if engineering is None else engineering}

{_paper_tables_section() if info.get("paper_machine", True) else ""}

{_closed_loop_section(out)}
{_warnings(by_stage, "control")}

<h2>All metrics</h2>
<details><summary>per run, model and channel ({len(metrics)} rows)</summary>
<p class="small">RMSE and peak error in mm, bar, mm/s; drift of the position per input period in
mm. v is measured as the smoothed derivative of x.</p>
{_table(metrics_for_display(metrics), "metrics")}
</details>

<h2>Notes</h2><p class="small">Every warning of every stage, in order (each also shown in its
section above).</p><ul class="notes">{notes_html}</ul>
</body></html>
"""
    page, toc = _toc(page)
    return atomic_write_text(out / "index.html", page.replace("@@TOC@@", toc))
