"""One call from measurements to a parameter file: valve, dead zone and friction together.

:func:`identify` runs the estimators whose experiments it finds, puts their
values into a copy of the base parameters, and keeps uncertainty and
provenance in ``params.meta`` (``[uncertainty]`` and ``[meta]`` of the saved
TOML), so the models take the result as is.
"""

from __future__ import annotations

import dataclasses
import datetime as _dt
import os
import warnings
from collections.abc import Callable, Iterable, Mapping
from pathlib import Path
from typing import Any, ClassVar, Protocol

import numpy as np

from .._display import html_table
from .._errors import DataError, IdentificationError, ParameterError
from .._io import atomic_write_text, check_output
from .._result import DerivedResult, ResultStatus
from ..params import SystemParams, save_params
from ._common import (
    EXPERIMENT_ALIASES,
    IdentificationWarning,
    OptimizerStatus,
    SkippedRun,
    experiment_of,
    screen_for_estimator,
    skip,
)
from ._deadzone import DeadZoneIdentifier
from ._frf import ValveFrfIdentifier
from ._friction import StribeckIdentifier
from ._machine import machine_for

__all__ = [
    "IdentificationReport",
    "identify",
    "load_runs",
    "PARTS",
    "Estimator",
    "default_estimators",
]

#: What :func:`identify` can identify, in order.
PARTS = ("frf", "deadzone", "friction")
#: Keys of a base parameter file's ``[meta]`` that describe each part (dropped once it is identified).
_META_KEYS = {
    "frf": ("valve", "omega0", "zeta"),
    "deadzone": ("dead_zone", "beta"),
    "friction": ("friction",),
}


def load_runs(source, skipped: list | None = None, params: SystemParams | None = None) -> list:
    """The sound runs of a dataset folder, of a campaign folder (one dataset per sub-folder), or given runs.

    Each run is routed to its estimator (``meta["experiment"]``/``meta["kind"]``, else the
    name of the folder it was read from: ``frf/``, ``deadzone/``, ``friction/``, ...) and
    screened with :func:`screen_for_estimator`: only the channels and the time span that
    estimator reads are checked (time base, NaN, converter limits, clipping, dropouts,
    spikes, implausible units); runs of other kinds (``sine``) are checked whole, as the
    evaluation does. A run that fails, or whose file the manifest lists but cannot be read,
    is left out with an :class:`IdentificationWarning` naming it and the reason, and
    recorded in ``skipped`` when given. ``hydropwa identify`` and ``hydropwa paper`` both
    read their runs here, so they identify from the same set with the same findings.

    Parameters
    ----------
    source : path-like, Dataset, or iterable of Run
        A folder with ``manifest.json``, or a folder whose sub-folders hold datasets
        (as written by ``hydropwa rig``), or runs.
    skipped : list, optional
        Receives a :class:`SkippedRun` per run left out.
    params : SystemParams, optional
        Gives the stroke for the friction runs' span; without it a friction run is screened
        over its whole length (samples at an end stop included).

    Raises
    ------
    IdentificationError
        If a folder holds no dataset.
    """
    from ..data import (  # deferred: hydropwa.data loads pint
        MANIFEST,
        converter_limits,  # deferred: hydropwa.data loads pint
        read_dataset,
    )

    skipped = [] if skipped is None else skipped
    stroke = None if params is None else params.cylinder.stroke
    groups: list[tuple[Any, str | None, dict]] = []  # (runs or dataset, folder kind, limits)
    if not isinstance(source, str | os.PathLike):
        groups.append((source, None, {}))
    else:
        root = Path(source)
        if not root.is_dir():
            raise IdentificationError(f"data folder {str(root)!r} not found")
        if (root / MANIFEST).is_file():
            subs = [root]
        else:
            subs = sorted(p for p in root.iterdir() if (p / MANIFEST).is_file())
            if not subs:
                raise IdentificationError(
                    f"{str(root)!r} holds no dataset (no {MANIFEST} in it or in its sub-folders); "
                    "hint: write one with `hydropwa rig run` or `hydropwa data convert`"
                )
        for sub in subs:
            ds = read_dataset(sub, validate=False, lazy=True)
            folder = EXPERIMENT_ALIASES.get(sub.name.lower())
            groups.append(
                (ds, folder, converter_limits((ds.meta or {}).get("rig", {}).get("sensors")))
            )
    runs: list = []
    for src, folder, limits in groups:
        for run in _read_each(src, skipped):
            kind = experiment_of(run)
            if kind is None and folder is not None:
                run = dataclasses.replace(
                    run, meta={**run.meta, "kind": folder, "kind_from": "folder"}
                )
                kind = folder
            reason = screen_for_estimator(run, kind, stroke, limits)
            if reason is None:
                runs.append(run)
            else:
                skip(skipped, run.name, reason)
    return runs


def _read_each(src, skipped: list) -> list:
    """The runs of a dataset (unreadable ones skipped with their reason), or the given runs."""

    if hasattr(src, "names") and hasattr(src, "__getitem__"):
        out = []
        for name in src.names:
            try:
                out.append(src[name])
            except DataError as exc:
                skip(skipped, name, f"cannot be read: {exc}")
        return out
    if hasattr(src, "channels") and hasattr(src, "name"):
        return [src]
    return list(src)


#: The figures :meth:`IdentificationReport.save` writes, named as ``hydropwa paper`` names them
#: (the paper's figure numbers), so one figure has one file name in every command.
FIGURE_FILES = {
    "valve_bode": "fig05_valve_bode.png",
    "dead_zone": "fig06_dead_zone.png",
    "stribeck": "fig08_stribeck.png",
}


@dataclasses.dataclass
class IdentificationReport(DerivedResult):
    """What :func:`identify` found.

    Attributes
    ----------
    params : SystemParams
        Base parameters with the identified values in place; ``meta["identification"]``
        holds provenance, ``meta["uncertainty"]`` the estimates with std and CI.
    valve : ValveFrfIdentifier or None
    dead_zone : DeadZoneIdentifier or None
    friction : StribeckIdentifier or None
    skipped : list[SkippedRun]
        Every run or part left out, by any estimator, and parts not identified.
    source : str
        Where the data came from.
    """

    params: SystemParams
    valve: ValveFrfIdentifier | None = None
    dead_zone: DeadZoneIdentifier | None = None
    friction: StribeckIdentifier | None = None
    skipped: list[SkippedRun] = dataclasses.field(default_factory=list)
    source: str = ""

    def _rows(self) -> list[tuple[str, str, str]]:
        """(part, identified values, remark) per identified part, in engineering units."""
        p, rows = self.params, []
        if self.valve is not None:
            rows.append(
                (
                    "valve",
                    f"ω0 = {p.valve.omega0 / (2 * np.pi):.4g} Hz, ζ = {p.valve.zeta:.3g}",
                    "",
                )
            )
        if self.dead_zone is not None:
            dz = p.dead_zone
            rows.append(("dead zone", f"β = {dz.beta:.4g}, creep slope {dz.creep_slope:.3g}", ""))
        if self.friction is not None:
            fr = p.friction
            fit = getattr(self.friction, "fit_", None)
            unid = tuple(getattr(fit, "unidentified", ()))
            rows.append(
                (
                    "friction",
                    f"F_c = {fr.coulomb:.4g} N, F_s = {fr.static:.4g} N, "
                    f"σ = {fr.viscous:.4g} N·s/m",
                    f"not identified (given value kept): {', '.join(unid)}" if unid else "",
                )
            )
        return rows

    def __repr__(self) -> str:
        lines = [f"IdentificationReport from {self.source!r}"]
        lines += [
            f"  {part:<10} {vals}" + (f"  [{rem}]" if rem else "")
            for part, vals, rem in self._rows()
        ]
        if not self._rows():
            lines.append("  nothing identified")
        if self.skipped:
            lines.append(f"  skipped    {len(self.skipped)} run(s) or part(s); see .skipped")
        return "\n".join(lines)

    def _repr_html_(self) -> str:
        note = f"{len(self.skipped)} run(s) or part(s) skipped" if self.skipped else ""
        return html_table(
            f"Identification from {self.source}", ("part", "values", "remark"), self._rows(), note
        )

    def summary_markdown(self) -> str:
        """A short markdown summary: values, intervals, weak parameters, skipped runs."""
        return _summary(self)

    # ---------------------------------------------------------------- result protocol
    def _parts(self) -> dict[str, Any]:
        found = {"valve": self.valve, "dead_zone": self.dead_zone, "friction": self.friction}
        return {k: v for k, v in found.items() if v is not None}

    @property
    def status(self) -> ResultStatus:
        """``NOT_CONVERGED`` when a part's optimiser did not converge, ``PARTIAL`` when a run
        or part was skipped, else ``SUCCESS`` (:class:`~hydropwa._result.ResultStatus`)."""
        if any(not getattr(e, "status_", OK).success for e in self._parts().values()):
            return ResultStatus.NOT_CONVERGED
        return ResultStatus.PARTIAL if self.skipped or not self._parts() else ResultStatus.SUCCESS

    def _status_details(self) -> list[str]:
        bad = [k for k, e in self._parts().items() if not getattr(e, "status_", OK).success]
        if bad:
            return [f"not converged: {', '.join(bad)}"]
        listed = "; ".join(map(str, self.skipped[:3]))
        return [f"{len(self.skipped)} run(s) or part(s) skipped ({listed})"] if self.skipped else []

    def summary(self) -> str:
        """The identified values per part and the status, as text."""
        return f"{self!r}\n  {self.status.name}: {self.message}"

    def to_pandas(self) -> Any:
        """One row per estimate (the ``[uncertainty]`` table): ``part``, ``parameter``,
        ``value``, ``std``, ``ci_low``, ``ci_high`` (SI) and ``unit``."""
        import pandas as pd  # deferred: pandas costs ~0.3 s at import

        rows = [
            {"part": part, "parameter": name, **{k: e[k] for k in _EST_COLUMNS}}
            for part, table in self.params.meta.get("uncertainty", {}).items()
            for name, e in table.items()
            if isinstance(e, Mapping) and "value" in e
        ]
        df = pd.DataFrame(rows, columns=["part", "parameter", *_EST_COLUMNS])
        df.attrs["units"] = {f"{r['part']}.{r['parameter']}": r["unit"] for r in rows}
        return df

    def plot(self, part: str | None = None, *, ax: Any = None) -> Any:
        """The figure of one identified part (default the first): ``valve`` (Fig. 5),
        ``dead_zone`` (Fig. 6) or ``friction`` (Fig. 8), as :meth:`save` writes them."""
        from ..plotting import plot_bode, plot_dead_zone, plot_stribeck  # deferred: matplotlib

        parts = self._parts()
        if not parts or (part is not None and part not in parts):
            raise IdentificationError(
                f"no identified part {part!r} to plot; identified: {', '.join(parts) or 'none'}"
            )
        name = part or next(iter(parts))
        draws: dict[str, Callable[..., Any]] = {
            "valve": plot_bode,
            "dead_zone": plot_dead_zone,
            "friction": plot_stribeck,
        }
        draw = draws[name]
        return draw(parts[name], ax=ax)

    def save(
        self,
        out: str | os.PathLike,
        figures: str | os.PathLike | None = None,
        summary: str | os.PathLike | None = None,
        *,
        overwrite: bool = False,
    ) -> dict[str, Path]:
        """Write the parameter TOML, the figures (PNG) and the markdown summary.

        Parameters
        ----------
        out : path-like
            Parameter file (``load_params`` reads it back).
        figures : path-like, optional
            Folder for ``fig05_valve_bode.png``, ``fig06_dead_zone.png``, ``fig08_stribeck.png``
            (the paper's figure numbers, the names ``hydropwa paper`` gives them).
        summary : path-like, optional
            Markdown file (default: ``out`` with suffix ``.md``).
        overwrite : bool
            Replace existing files; by default an existing parameter file, summary or
            figure raises :class:`~hydropwa.OutputExistsError` before anything is written.

        Returns
        -------
        dict[str, Path]
            Written files by role.
        """
        from ..plotting import (  # deferred: matplotlib loads only when plotting
            plot_bode,
            plot_dead_zone,
            plot_stribeck,
            save_figure,
        )

        out = Path(out)
        summary = Path(summary) if summary is not None else out.with_suffix(".md")
        targets = [out, summary]
        if figures is not None:
            targets += [Path(figures) / n for n in FIGURE_FILES.values()]
        for target in targets:
            check_output(target, overwrite)
        header = f"identified by hydropwa from {self.source}"
        written = {"params": save_params(self.params, out, header=header, overwrite=overwrite)}
        written["summary"] = atomic_write_text(
            summary, self.summary_markdown(), overwrite=overwrite
        )
        if figures is not None:
            fdir = Path(figures)
            fdir.mkdir(parents=True, exist_ok=True)
            if self.valve is not None:
                path = fdir / FIGURE_FILES["valve_bode"]
                save_figure(plot_bode(self.valve), path, overwrite=overwrite)
                written["valve_bode"] = path
            if self.dead_zone is not None:
                save_figure(
                    plot_dead_zone(self.dead_zone),
                    fdir / FIGURE_FILES["dead_zone"],
                    overwrite=overwrite,
                )
                written["dead_zone"] = fdir / FIGURE_FILES["dead_zone"]
            if self.friction is not None:
                save_figure(
                    plot_stribeck(self.friction),
                    fdir / FIGURE_FILES["stribeck"],
                    overwrite=overwrite,
                )
                written["stribeck"] = fdir / FIGURE_FILES["stribeck"]
        return written


class Estimator(Protocol):
    """What :func:`identify` needs of an estimator (the three of Sec. VI satisfy it)."""

    part: ClassVar[str]  # experiment kind it reads: "frf", "deadzone", "friction"
    field: ClassVar[str]  # SystemParams field it sets: "valve", "dead_zone", "friction"
    skipped_: list[SkippedRun]

    def fit(self, data: Any) -> Any: ...
    def apply(self, params: SystemParams) -> SystemParams: ...
    def uncertainty(self) -> dict: ...
    def provenance(self) -> str: ...


def default_estimators(params: SystemParams) -> dict[str, Estimator]:
    """The estimator of each part with its default settings, geometry from ``params``."""
    return {
        "frf": ValveFrfIdentifier(),
        "deadzone": DeadZoneIdentifier(params),
        "friction": StribeckIdentifier(params),
    }


def identify(
    data,
    parts: Iterable[str] = PARTS,
    *,
    params: SystemParams | None = None,
    estimators: Mapping[str, Estimator] | None = None,
) -> IdentificationReport:
    """Identify valve, dead zone and friction from measured runs and return parameters.

    Each part's estimator is fitted to the runs of its kind and applied to the parameters
    in turn (``params = est.apply(params)``), so the result equals that chain; uncertainty
    and provenance go to ``params.meta``.

    Parameters
    ----------
    data : path-like, Dataset or iterable of Run
        See :func:`load_runs`. Runs are routed by ``meta["experiment"]``/``meta["kind"]``.
    parts : iterable of str
        Any of ``"frf"``, ``"deadzone"``, ``"friction"``.
    params : SystemParams, optional
        The rig: everything not identified, plus areas, stroke and mass the estimators read.
        Default: the machine the data record (:func:`~hydropwa.identification.machine_for`:
        a campaign's ``true_params.toml``, a manifest's ``machine`` entry); there is no
        default rig. Given, its areas and stroke must be the recorded machine's.
    estimators : mapping of str to estimator, optional
        Estimator per part (with its settings), e.g.
        ``{"friction": StribeckIdentifier(params, method=InstantaneousBins())}``; a part not
        given gets :func:`default_estimators`'s.

    Returns
    -------
    IdentificationReport

    Raises
    ------
    ParameterError
        Without ``params`` on data that record no machine, with ``params`` of another
        geometry than the data's machine, or with an estimator given for a part it does not identify.
    IdentificationError
        If a single part was asked for and cannot be identified, or none of several can.
        When several parts are asked for, a part without usable runs is skipped with an
        :class:`IdentificationWarning` and listed in ``skipped``.
    """
    parts = tuple(parts)
    unknown = set(parts) - set(PARTS)
    if unknown:
        raise IdentificationError(
            f"unknown part(s) {sorted(unknown)}; choose from {', '.join(PARTS)}"
        )
    # the data's machine (a campaign's true_params.toml, a manifest's machine entry), or
    # params checked against it; neither: one line saying how to give it (no default rig)
    params = machine_for(data, params)
    chosen = {**default_estimators(params), **dict(estimators or {})}
    for key, est in chosen.items():
        if key not in PARTS or getattr(est, "part", None) != key:
            raise ParameterError(
                f"estimators[{key!r}] = {type(est).__name__} identifies "
                f"{getattr(est, 'part', 'nothing')!r}; keys are the parts {', '.join(PARTS)}"
            )
    base = params
    source = str(data) if isinstance(data, str | os.PathLike) else getattr(data, "root", "runs")
    screened: list = []
    runs = load_runs(data, screened, base)
    by_kind: dict[str, list] = {p: [] for p in PARTS}
    unlabelled = []
    for r in runs:
        k = experiment_of(r)
        if k in by_kind:
            by_kind[k].append(r)
        elif k is None:
            unlabelled.append(r.name)
    report = IdentificationReport(params=base, source=str(source))
    report.skipped += screened
    uncertainty: dict[str, Any] = {}
    provenance: dict[str, Any] = {
        "source": str(source),
        "date": _dt.date.today().isoformat(),
        "method": "hydropwa.identification (Sec. VI of the paper)",
    }
    done = []
    result = base
    for part in parts:
        est = chosen[part]
        if not _fit_part(part, est, by_kind[part], unlabelled, source, report, len(parts)):
            continue
        report.skipped += est.skipped_
        done.append(part)
        setattr(report, est.field, est)  # report.valve / .dead_zone / .friction
        result = est.apply(result)
        unid = getattr(getattr(est, "fit_", None), "unidentified", ())
        if unid:
            warnings.warn(
                f"{part}: {', '.join(unid)} not identified by the data (at a bound of the fit "
                "with a wide interval); the given value is kept, not the fit's",
                IdentificationWarning,
                stacklevel=2,
            )
        uncertainty[est.field] = est.uncertainty()
        provenance[est.field] = est.provenance()
    if not done:
        raise IdentificationError(
            "nothing identified: "
            + "; ".join(s.reason for s in report.skipped if s.run.startswith("<"))
        )
    provenance["identified"] = done
    provenance["skipped"] = [str(s) for s in report.skipped]
    meta = _identified_meta(base, source, done, provenance, uncertainty)
    report.params = dataclasses.replace(result, meta=meta)
    return report


def _fit_part(
    part: str,
    est: Estimator,
    selected: list,
    unlabelled: list[str],
    source: str,
    report: IdentificationReport,
    n_parts: int,
) -> bool:
    """Fit one part's estimator to its runs. When several parts are asked for, a part that
    cannot be identified is skipped with an :class:`IdentificationWarning` (False)."""
    try:
        if not selected:
            why = ""
            if unlabelled:
                why = (
                    f"; {len(unlabelled)} run(s) say no kind (e.g. {unlabelled[0]!r}): add "
                    f'"kind": "{part}" to their metadata, or put them in a dataset folder '
                    f"named {part}/"
                )
            raise IdentificationError(f"no runs of kind {part!r} in {source}{why}")
        est.fit(selected)
    except IdentificationError as exc:
        if n_parts == 1:
            raise
        report.skipped.append(SkippedRun(f"<{part}>", str(exc)))
        warnings.warn(f"{part} not identified: {exc}", IdentificationWarning, stacklevel=3)
        return False
    return True


def _identified_meta(
    base: SystemParams, source: str, done: list[str], provenance: dict, uncertainty: dict
) -> dict[str, Any]:
    """The identified parameters' ``meta``: the base's, less its provenance lines about the
    parts identified here (stale now), plus this identification's."""
    identified_keys = {"source", "uncertainty", "identification", "base_source"} | {
        k for part in done for k in _META_KEYS[part]
    }
    return {
        **{k: v for k, v in base.meta.items() if k not in identified_keys},
        "source": f"identified by hydropwa from {source} ({', '.join(done)}); "
        "the other values from the base parameters",
        "base_source": str(base.meta.get("source", "defaults of hydropwa.params")),
        "identification": provenance,
        "uncertainty": uncertainty,
    }


_EST_COLUMNS = ("value", "std", "ci_low", "ci_high", "unit")
#: the status of an estimator that carries none (treated as converged)
OK = OptimizerStatus.closed_form()


def _fmt_est(e) -> str:
    return f"{e.value:.5g} | {e.std:.2g} | [{e.ci[0]:.5g}, {e.ci[1]:.5g}] {e.unit}"


def _summary(rep: IdentificationReport) -> str:
    lines = [f"# Identification summary ({rep.source})", ""]
    if rep.valve is not None:
        lines += _valve_summary(rep.valve)
    if rep.dead_zone is not None:
        lines += _dead_zone_summary(rep.dead_zone)
    if rep.friction is not None:
        lines += _friction_summary(rep.friction, rep.params)
    if rep.skipped:
        lines += ["## Skipped", ""] + [f"- {s}" for s in rep.skipped] + [""]
    return "\n".join(lines)


def _valve_summary(valve: ValveFrfIdentifier) -> list[str]:
    """The valve's section: ω0 and ζ per amplitude, the pooled ζ."""
    lines: list[str] = []
    lines += [
        "## Servo valve (Sec. VI-A, Eq. (1), Table II)",
        "",
        "| amplitude | ω0 [rad/s] | std | 95 % CI | ζ | std | 95 % CI | points |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for a, f in valve.fits_.items():
        lines.append(
            f"| {100 * a:.3g} % | {f.omega0.value:.1f} | {f.omega0.std:.2g} | "
            f"[{f.omega0.ci[0]:.1f}, {f.omega0.ci[1]:.1f}] | {f.zeta.value:.3f} | {f.zeta.std:.2g} | "
            f"[{f.zeta.ci[0]:.3f}, {f.zeta.ci[1]:.3f}] | {f.n_points} |"
        )
    lines += ["", f"Pooled ζ = {valve.zeta_.value:.3f} ± {valve.zeta_.std:.2g}.", ""]
    return lines


def _dead_zone_summary(dead_zone: DeadZoneIdentifier) -> list[str]:
    """The dead zone's section: the hinge fit's estimates."""
    lines: list[str] = []
    dz = dead_zone.fit_
    lines += [
        "## Dead zone (Sec. VI-B, Table IV, Fig. 6)",
        "",
        "| quantity | value | std | 95 % CI |",
        "|---|---|---|---|",
    ]
    for name, e in (
        ("β (symmetric)", dz.beta),
        ("β+", dz.beta_pos),
        ("β−", dz.beta_neg),
        ("k_g (creep opening slope)", dz.creep_slope),
        ("creep velocity slope", dz.creep_velocity_slope),
        ("outer gain +", dz.gain_pos),
        ("outer gain −", dz.gain_neg),
        ("drift u ≥ 0 (leakage, load)", dz.drift_pos),
        ("drift u < 0 (leakage, load)", dz.drift_neg),
        ("piston leakage C_L seen by the fit (not applied)", dz.leakage),
    ):
        if e is None:
            continue
        lines.append(f"| {name} | {_fmt_est(e)} |")
    lines += [
        "",
        f"{dz.n_points} runs; RMS velocity residual {1e3 * dz.rms_residual:.3g} mm/s.",
        "",
    ]
    return lines


def _friction_summary(friction: StribeckIdentifier, params: SystemParams) -> list[str]:
    """The friction section: estimates, weak and unidentified parameters, notes."""
    lines: list[str] = []
    fit = friction.fit_
    lines += [
        "## Stribeck friction (Sec. VI-C, Eqs. (10)–(11), Fig. 8)",
        "",
        "| parameter | value | std | 95 % CI |",
        "|---|---|---|---|",
    ]
    for k, e in fit.estimates.items():
        if k in fit.unidentified:
            given = getattr(params.friction, k)
            lines.append(
                f"| {k} | **not identified** (fit {e.value:.4g}, CI [{e.ci[0]:.4g}, "
                f"{e.ci[1]:.4g}] {e.unit}; given value {given:.4g} kept) | | |"
            )
            continue
        lines.append(f"| {k} | {_fmt_est(e)} |")
    lines += [
        "",
        f"{len(fit.velocity)} points; RMS residual {fit.rms_residual:.3g} N; loss {fit.loss}.",
    ]
    if fit.weak:
        lines.append(
            f"Weakly identified (wide CI or at a bound): {', '.join(fit.weak)}. The runs move at "
            "|v| ≥ a few mm/s, so the shape of the curve near zero speed is an extrapolation."
        )
    if fit.unidentified:
        lines.append(
            f"Not identified (at a bound of the fit with a wide interval, or an interval "
            f"covering the whole range; the given value is kept): "
            f"{', '.join(fit.unidentified)}. Give runs that determine them or the "
            "machine's values with --params."
        )
    lines += _band_lines(fit)
    lines += [f"Note: {n}." for n in friction.notes_]
    lines.append("")
    return lines


def _band_lines(fit: Any) -> list[str]:
    """The fitted curve's 95 % band at five of the speeds the data excite: where single
    parameters trade against each other (F_s against δ and χ) the curve is still known."""
    vb, lo, hi = fit.band
    if vb.size == 0:
        return []
    pick = np.unique(np.round(np.linspace(0, vb.size - 1, 5)).astype(int))
    return [
        "",
        f"Friction curve, {100 * fit.estimates[fit.free[0]].level:g} % band over the speeds the "
        f"data excite ({1e3 * vb[0]:.3g}–{1e3 * vb[-1]:.3g} mm/s; the curve is odd):",
        "",
        "| speed [mm/s] | force [N] |",
        "|---|---|",
        *(f"| {1e3 * vb[k]:.3g} | {lo[k]:.4g} … {hi[k]:.4g} |" for k in pick),
        "",
    ]
