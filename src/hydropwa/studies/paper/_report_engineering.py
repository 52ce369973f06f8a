"""The report's section "Small signal, poles and margins": Bode, pole map, margins, error bounds.

The numbers come from :mod:`._engineering`; this module draws, writes and embeds them. Every
figure and table a caption names is written here, into ``figures/`` and ``tables/``.
"""

from __future__ import annotations

import base64
import html
import math
from pathlib import Path

from ..._io import atomic_path
from ...control import load_controller
from ...evaluation import cell_loops, error_bound_map, small_signal_bode
from ...linearization import load_pwa

__all__ = ["engineering_section"]

_MISSING = '<p class="small">({what}: {why})</p>'


def _embed(png: Path, caption: str) -> str:
    data = base64.b64encode(png.read_bytes()).decode("ascii")
    files = f"figures/{png.name}, figures/{png.with_suffix('.svg').name}"
    return (
        f'<figure><img alt="{html.escape(caption)}" src="data:image/png;base64,{data}">'
        f"<figcaption>{html.escape(caption)} ({html.escape(files)})</figcaption></figure>"
    )


def _save(fig, out: Path, stem: str) -> Path:
    from ...plotting import save_figure  # deferred: matplotlib loads only when plotting

    (out / "figures").mkdir(parents=True, exist_ok=True)
    save_figure(fig, out / "figures" / f"{stem}.svg", overwrite=True)  # the report owns its folder
    fig.set_layout_engine("none")  # the first save's layout holds: the PNG does not redo it
    return save_figure(fig, out / "figures" / f"{stem}.png", dpi=110, overwrite=True)


def _csv(df, out: Path, stem: str) -> Path:
    (out / "tables").mkdir(parents=True, exist_ok=True)
    path = out / "tables" / f"{stem}.csv"
    with atomic_path(path, overwrite=True) as tmp:
        df.to_csv(tmp, index=False)
    return path


def _valve_frf(out: Path) -> dict:
    """The identify stage's measured valve FRF (tables/valve_frf.csv), if written."""
    import pandas as pd  # deferred: pandas costs ~0.3 s at import

    f = out / "tables" / "valve_frf.csv"
    if not f.is_file():
        return {}
    df = pd.read_csv(f)
    return {
        float(a): (
            g["frequency [Hz]"].to_numpy(float),
            g["re"].to_numpy(float) + 1j * g["im"].to_numpy(float),
        )
        for a, g in df.groupby("amplitude [1]")
    }


def _bode_part(out: Path, pwa) -> str:
    bode = small_signal_bode(pwa)
    bode = type(bode)(**{**bode.__dict__, "measured": _valve_frf(out)})
    mag, phase = bode.agreement(0.5)
    _csv(bode.to_pandas(), out, "small_signal_bode")
    png = _save(bode.plot(), out, "small_signal_bode")
    wp = bode.working_point
    return (
        "<h3>Small-signal Bode plot</h3><p>u → ẋ at mid stroke, u = "
        f"{100 * wp['u']:.0f} % (steady motion at {wp['v'] * 1e3:.0f} mm/s): the linearized "
        "model (the PWA cell there, exact Jacobian, with the servo valve of Eq. (1) in series) "
        "against the full model's small-signal response (its exact Jacobian at its own steady "
        "motion). Below half the hydraulic natural frequency "
        f"({bode.natural_frequency:.0f} Hz) they differ by at most {100 * mag:.1f} % in "
        f"magnitude and {phase:.1f}° in phase."
        + (
            " Dots: the measured valve FRF ν/u of the identify stage (tables/valve_frf.csv)."
            if bode.measured
            else " (No measured valve FRF in this study.)"
        )
        + "</p>"
        + _embed(png, "Small signal: linearized vs full model (tables/small_signal_bode.csv)")
    )


def _loops_part(out: Path, pwa) -> str:
    f = out / "controller.toml"
    ctrl = load_controller(f) if f.is_file() else None
    loops = cell_loops(pwa, ctrl)
    t = loops.table
    _csv(t, out, "cell_margins" if ctrl is not None else "cell_poles")
    parts = [
        "<h3>Pole map with the valve</h3><p>Per cell: the cell's exact Jacobian with the servo "
        "valve before it (open loop, ×)"
        + (
            " and the sampled closed loop under the cell's gain row (o: ln z / T_s)"
            if ctrl is not None
            else ""
        )
        + ". Open-loop poles in the right half plane are the falling Stribeck branch's "
        "(negative friction slope)"
        + (
            f"; {int(t['friction_clipped'].sum())} cell(s) were designed with that slope "
            "clipped (design_state_feedback, friction_slopes='clip'), and their closed-loop "
            "poles here are on the clipped slope, as the design saw them"
            if ctrl is not None
            else ""
        )
        + ".</p>",
        _embed(_save(_plot("plot_pole_map", loops), out, "pole_map"), "Pole map"),
    ]
    if ctrl is None:
        return "".join(parts) + _MISSING.format(
            what="per-cell margins", why="no controller was designed in this study"
        )
    gm = t["gain_margin [dB]"]
    worst_pm = t.loc[t["phase_margin [deg]"].idxmin()]
    parts += [
        "<h3>Per-cell margins</h3><p>Each cell's sampled loop (cell, valve, zero-order hold, "
        "integral) broken at the valve command, python-control <code>stability_margins</code>: "
        f"smallest phase margin {worst_pm['phase_margin [deg]']:.1f}° (cell "
        f"{html.escape(str(worst_pm['cell']))}), smallest gain margin "
        + (f"{gm.min():.1f} dB" if math.isfinite(gm.min()) else "unbounded (∞ dB) in every cell")
        + f", largest closed-loop spectral radius {t['radius [1]'].max():.4f} "
        "(stable below 1). Lower gain margin: the gain decrease that destabilises (integral "
        "action makes the loop conditionally stable).</p>",
        _table_html(t),
        _embed(_save(_plot("plot_cell_margins", loops), out, "cell_margins"), "Per-cell margins"),
    ]
    return "".join(parts)


def _plot(name: str, obj):
    from ... import plotting  # deferred: matplotlib loads only when plotting

    return getattr(plotting, name)(obj)


def _table_html(df) -> str:
    cols = [
        "cell",
        "open_loop_max_real [1/s]",
        "friction_clipped",
        "radius [1]",
        "gain_margin [dB]",
        "lower_gain_margin [dB]",
        "phase_margin [deg]",
        "gain_crossover [Hz]",
        "stability_margin [1]",
    ]
    head = "".join(f"<th>{html.escape(c)}</th>" for c in cols)

    def cell(v) -> str:
        if isinstance(v, float):
            return "∞" if v == math.inf else ("−∞" if v == -math.inf else f"{v:.4g}")
        return html.escape(str(v))

    body = "".join(
        "<tr>" + "".join(f"<td>{cell(r[c])}</td>" for c in cols) + "</tr>" for _, r in df.iterrows()
    )
    return (
        "<details><summary>margins per cell (tables/cell_margins.csv)</summary><table>"
        f"<thead><tr>{head}</tr></thead><tbody>{body}</tbody></table></details>"
    )


def _bounds_part(out: Path, pwa) -> str:
    b = error_bound_map(pwa)
    _csv(b, out, "pwa_error_bound_map")
    return (
        "<h3>Error-bound map</h3><p>The guaranteed bound on the PWA model's Ṗ_L error against "
        "each cell's affine system, over the cell (PwaModel.error_bound, the value "
        f"export_pwa writes): median {b['error_bound'].median() / 1e5:.3g} bar/s, largest "
        f"{b['error_bound'].max() / 1e5:.3g} bar/s (the outer pressure and command cells).</p>"
        + _embed(
            _save(_plot("plot_error_bound_map", b), out, "pwa_error_bound_map"),
            "Error-bound map (tables/pwa_error_bound_map.csv)",
        )
    )


def engineering_section(out: Path) -> str:
    """The report's engineering section from the study's pwa.json (and controller.toml).

    Each part that cannot be computed says why in one line instead of its figure.
    """
    out = Path(out)
    if not (out / "pwa.json").is_file():
        return ""
    pwa = load_pwa(out / "pwa.json")
    html_parts = ["<h2>Small signal, poles and margins</h2>"]
    for what, part in (
        ("Bode plot", _bode_part),
        ("pole map and margins", _loops_part),
        ("error-bound map", _bounds_part),
    ):
        try:
            html_parts.append(part(out, pwa))
        except Exception as exc:  # noqa: BLE001 - the report must still be written
            html_parts.append(_MISSING.format(what=what, why=html.escape(str(exc))))
    return "".join(html_parts)
