"""The one plotting layer: a leaf that draws what it is given, writes without clobbering,
and is the only place in the package that touches matplotlib."""

from __future__ import annotations

import ast
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from matplotlib.figure import Figure

import hydropwa
from hydropwa import OutputExistsError
from hydropwa.plotting import (
    InlineFigure,
    plot_bode,
    plot_compare,
    plot_dead_zone,
    plot_greybox_fit,
    plot_greybox_profiles,
    plot_greybox_residuals,
    plot_result,
    plot_stribeck,
    save_figure,
)

SRC = Path(hydropwa.__file__).parent
PLOTTING = SRC / "plotting"
#: the leaf modules the plotting layer may use (no layer above it)
#: leaf modules (numpy and the standard library only); _display holds the one unit table
LEAVES = {"_display", "_errors", "_io", "_layout"}


def _modules():
    for path in sorted(SRC.rglob("*.py")):
        yield path, ast.parse(path.read_text(encoding="utf-8"), filename=str(path))


def _imported(node: ast.AST) -> list[str]:
    if isinstance(node, ast.Import):
        return [a.name for a in node.names]
    if isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
        return [node.module] + [f"{node.module}.{a.name}" for a in node.names]
    return []


def _type_only(tree: ast.AST) -> set[ast.AST]:
    """Nodes under ``if TYPE_CHECKING:`` (annotations only: nothing is imported at run time)."""
    out: set[ast.AST] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and getattr(node.test, "id", None) == "TYPE_CHECKING":
            for stmt in node.body:
                out.update(ast.walk(stmt))
    return out


def test_no_module_chooses_a_backend_or_draws_outside_the_plotting_layer():
    offences = []
    for path, tree in _modules():
        inside = PLOTTING in path.parents
        type_only = _type_only(tree)
        for node in ast.walk(tree):
            if node in type_only:
                continue
            if (
                isinstance(node, ast.Call)
                and isinstance(node.func, ast.Attribute)
                and node.func.attr == "use"
                and isinstance(node.func.value, ast.Name)
                and node.func.value.id == "matplotlib"
            ):
                offences.append(f"{path}:{node.lineno} calls matplotlib.use")
            names = _imported(node)
            if any(n == "matplotlib.pyplot" for n in names) and (inside or node in tree.body):
                offences.append(f"{path}:{node.lineno} imports matplotlib.pyplot")
            if not inside and any(n.split(".")[0] == "matplotlib" for n in names):
                offences.append(
                    f"{path}:{node.lineno} imports matplotlib outside hydropwa.plotting"
                )
    assert not offences, "\n".join(offences)


def test_the_plotting_layer_imports_no_layer_above_it():
    allowed_top = {"numpy", "matplotlib"} | set(sys.stdlib_module_names)
    offences = []
    for path in sorted(PLOTTING.rglob("*.py")):
        tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom) and node.level > 0:
                # level 1: inside plotting; level 2: the package root, leaves only
                target = (node.module or "").split(".")[0]
                ok = node.level == 1 or (node.level == 2 and target in LEAVES)
                if not ok:
                    offences.append(
                        f"{path.name}:{node.lineno} from {'.' * node.level}{node.module}"
                    )
            for name in _imported(node):
                parts = name.split(".")
                if parts[0] == "hydropwa":
                    ok = len(parts) > 1 and parts[1] in LEAVES | {"plotting"}
                else:
                    ok = parts[0] in allowed_top
                if not ok:
                    offences.append(f"{path.name}:{node.lineno} import {name}")
    assert not offences, "\n".join(offences)


def _result(n=50):
    t = np.linspace(0.0, 1.0, n)
    ch = {"t": t, "u": 0.1 * np.sin(t), "x": 0.1 + 0.01 * t, "p_a": 50e5 + 0 * t, "p_b": 20e5 + t}
    return SimpleNamespace(channels=ch, model="reduced", t=t)


def test_result_figure_draws_each_channel_in_its_display_unit():
    res = _result()
    fig = plot_result(res, channels=("u", "x", "p_a", "p_b", "missing"))
    assert isinstance(fig, InlineFigure)
    by_unit = {ax.get_ylabel(): ax for ax in fig.axes}
    assert set(by_unit) == {"%", "mm", "bar"}  # one axes per unit, the missing channel skipped
    np.testing.assert_allclose(by_unit["mm"].lines[0].get_ydata(), res.channels["x"] * 1e3)
    np.testing.assert_allclose(by_unit["bar"].lines[1].get_ydata(), res.channels["p_b"] * 1e-5)
    np.testing.assert_allclose(by_unit["%"].lines[0].get_ydata(), res.channels["u"] * 100)


def test_a_returned_figure_shows_inline_in_jupyter():
    """IPython's display protocol: the figure answers image/png without any backend."""
    from IPython.core.formatters import DisplayFormatter

    data, _ = DisplayFormatter().format(plot_result(_result()))
    assert data["image/png"][:8] == b"\x89PNG\r\n\x1a\n"


def test_figures_draw_into_given_axes_and_check_their_number():
    res = _result()
    outer = Figure()
    axes = outer.subplots(3, 1)
    assert plot_result(res, ax=axes) is outer
    assert len(axes[1].lines) == 1  # x [mm] alone on the second
    with pytest.raises(ValueError, match="draws into 3 axes, 2 were given"):
        plot_result(res, ax=axes[:2])


def test_save_figure_never_overwrites_without_being_told(tmp_path):
    fig = plot_result(_result())
    target = tmp_path / "r.svg"
    assert save_figure(fig, target) == target
    first = target.read_bytes()
    assert first.lstrip().startswith(b"<?xml")  # format from the suffix
    other = plot_result(_result(20), channels=("x",))
    with pytest.raises(OutputExistsError):
        save_figure(other, target)
    assert target.read_bytes() == first
    save_figure(other, target, overwrite=True)
    assert target.read_bytes() != first
    assert [p.name for p in tmp_path.iterdir()] == ["r.svg"]  # no temporary file left


def test_bode_magnitude_and_phase_are_the_measured_response():
    f = np.geomspace(1.0, 200.0, 30)
    w0, zeta = 2 * np.pi * 80.0, 0.6

    def response(omega):
        s = 1j * omega
        return w0**2 / (s**2 + 2 * zeta * w0 * s + w0**2)

    frf = {0.5: SimpleNamespace(frequency=f, response=response(2 * np.pi * f))}
    fits = {0.5: SimpleNamespace(response=response)}
    fig = plot_bode(frf, fits)
    mag, phase = fig.axes[:2]
    assert len(fig.axes) == 2  # no coherence, no coherence panel
    np.testing.assert_allclose(
        mag.lines[0].get_ydata(), 20 * np.log10(np.abs(response(2 * np.pi * f)))
    )
    # second order: -90° at the natural frequency, -180° far above it
    assert np.interp(80.0, f, phase.lines[0].get_ydata()) == pytest.approx(-90.0, abs=3.0)
    assert phase.lines[1].get_ydata()[-1] < -150.0
    with_coherence = {
        0.5: SimpleNamespace(frequency=f, response=response(2 * np.pi * f), coherence=0 * f + 0.9)
    }
    est = SimpleNamespace(frf_=with_coherence, fits_=fits, min_coherence=0.7)
    fig = plot_bode(est)
    assert fig.axes[2].get_ylabel() == "coherence γ²"
    assert fig.axes[2].lines[-1].get_ydata()[0] == 0.7  # the estimator's threshold


def test_stribeck_residuals_are_points_minus_curve():
    v = np.linspace(-0.1, 0.1, 21)

    def curve(x):
        return 300.0 * np.tanh(x / 0.005) + 2000.0 * x

    f = curve(v) + np.where(v > 0, 5.0, -5.0)
    fig = plot_stribeck({"v": v, "f": f}, curve, reference=curve)
    ax, ax_r = fig.axes
    np.testing.assert_allclose(ax.lines[0].get_xdata(), 1e3 * v)
    np.testing.assert_allclose(ax_r.lines[0].get_ydata(), f - curve(v), atol=1e-9)
    assert [line.get_label() for line in ax.lines][-1] == "true (virtual rig)"
    one = plot_stribeck({"v": v, "f": f}, ax=Figure().add_subplot())
    assert len(one.axes) == 1 and len(one.axes[0].lines) == 1  # points only


def test_dead_zone_takes_points_and_any_fitted_curve():
    u = np.linspace(-0.1, 0.1, 11)
    beta = 0.02

    def velocity(x):
        return 0.5 * np.sign(x) * np.maximum(np.abs(x) - beta, 0.0)

    fig = plot_dead_zone({"u": u, "v": velocity(u)}, SimpleNamespace(velocity=velocity))
    line = fig.axes[0].lines[-1]
    x, y = line.get_xdata(), line.get_ydata()
    assert np.all(y[np.abs(x) < 100 * beta] == 0.0)  # flat inside the dead zone [%, mm/s]
    with pytest.raises(ValueError, match="columns 'u'"):
        plot_dead_zone({"v": u})


def test_compare_figure_draws_the_reference_over_the_models():
    t = np.linspace(0, 1, 20)
    fig = plot_compare(
        t, 0.1 + 0 * t, {"pwa (90.0 %)": 0.1 + 0.01 * t}, channel="x", reference_label="run"
    )
    ax = fig.axes[0]
    assert ax.get_ylabel() == "rod position [mm]"
    assert ax.lines[-1].get_label() == "run" and ax.lines[-1].get_zorder() == 10
    np.testing.assert_allclose(ax.lines[0].get_ydata(), (0.1 + 0.01 * t) * 1e3)


@pytest.mark.parametrize("preset", ["paper", "symmetric"])
def test_fig1_cells_stay_within_their_fit_error_of_the_drawn_curve(preset):
    """Figs. 1–2 draw the exact Ĉ_q, Ĉ_qp of the model's own form (asymmetric: edge pressure
    P_e = P_S − α P_T, not P_S), so the cells lie within the fit's max error of the curve."""
    from hydropwa.linearization import linearize
    from hydropwa.linearization._report import cq_figure, cqp_figure

    pwa = linearize(hydropwa.get_preset(preset))
    pe, root = pwa.edge_pressure(pwa.supply_pressure, 1)
    exact, cells = cq_figure(pwa).axes[0].lines[:2]
    gap = np.abs(exact.get_ydata() - cells.get_ydata())  # [L/min]
    bound = pwa.cq.max_error * pwa.params.flow.K * root * 6e4  # shape error → L/min
    assert gap.max() <= bound * (1 + 1e-9)
    assert gap.max() > 0.5 * bound  # the worst cell error is on the drawn range
    lines = cqp_figure(pwa).axes[0].lines
    exact, cells = lines[-3], lines[-2]  # z = 1
    gap = np.abs(exact.get_ydata() - cells.get_ydata())  # [L/min per bar]
    assert gap.max() <= pwa.cqp.max_error * pwa.params.flow.K / (4 * root) * 6e9


def _greybox_fit():
    t = np.linspace(0.0, 1.0, 200)
    rng = np.random.default_rng(1)
    x = 0.1 + 0.01 * np.sin(2 * np.pi * t)
    run = SimpleNamespace(
        name="s1",
        t=t,
        method="multiple",
        measured={"x": x + rng.normal(0, 1e-5, t.size)},
        simulated={"x": x},
        sigma={"x": 1e-5},
        n_eff={"x": 180.0},
    )
    profile = SimpleNamespace(
        name="flow.K", values=np.geomspace(1e-7, 1e-5, 7), cost=np.arange(7.0)
    )
    return SimpleNamespace(
        runs_=[run],
        profiles_={"flow.K": profile},
        estimates_={"flow.K": SimpleNamespace(value=1e-6)},
    )


def test_greybox_figures_draw_the_fit_its_white_residuals_and_profiles():
    fit = _greybox_fit()
    run = fit.runs_[0]
    ax = plot_greybox_fit(fit).axes[0]
    np.testing.assert_allclose(ax.lines[1].get_ydata(), 1e3 * run.simulated["x"])  # mm
    res, acf = plot_greybox_residuals(fit, "s1").axes
    e = (run.simulated["x"] - run.measured["x"]) / run.sigma["x"]
    np.testing.assert_allclose(res.lines[0].get_ydata(), e)
    rho = acf.lines[0].get_ydata()
    assert rho[0] == pytest.approx(1.0)
    # white noise: |ρ(k)| < 4/√n at every lag k > 0 (n = 200 samples)
    assert np.all(np.abs(rho[1:]) < 4 / np.sqrt(run.t.size))
    prof = plot_greybox_profiles(fit).axes[0]
    assert prof.get_xscale() == "log" and prof.get_xlabel() == "flow.K"
    with pytest.raises(KeyError, match="no run 'nope'"):
        plot_greybox_fit(fit, "nope")


def test_the_partition_colour_bar_is_one_colour_per_cq_cell():
    """A trajectory that stays in one C_q cell drew a colour bar of −0.1…0.1 (issue 37): the
    bar now spans the model's cells, one tick per cell index."""
    import hydropwa as hp
    from hydropwa.linearization import linearize
    from hydropwa.plotting import plot_cell_occupancy

    pwa = linearize(hp.get_preset("paper"))
    res = hp.simulate(pwa, 0.0, duration=0.05)  # the valve closed: one C_q cell all along
    assert np.unique(res.channels["cell_o"]).size == 1
    n = len(pwa.cells_at(pwa.supply_pressure)["cq"].breakpoints) + 1
    fig = plot_cell_occupancy([], pwa=pwa, trajectory=res)
    bar = fig.axes[-1]
    lo, hi = bar.get_ylim()
    assert (lo, hi) == pytest.approx((-0.5, n - 0.5)) and n >= 3
    assert [int(t) for t in bar.get_yticks()] == list(range(n))
