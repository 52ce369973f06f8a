"""``rig plan`` and ``data import`` (issue 50): a plan a real rig can play, its logs back in.

A small campaign (two FRF sines, two dead-zone inputs, two friction inputs) is planned for the
paper rig; its "logs" are the plan's own full-model prediction in a vendor layout (other
column names, pressures in volts, a time offset, a 2-sample delay). The import must find the
delay exactly and name, in one line, a missing run, a wrong rate, a clipped and a swapped
channel.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from hydropwa import DataError, ParameterError, load_params
from hydropwa.control import DEFAULT_DESIGN, load_controller
from hydropwa.data import import_logs, read_dataset
from hydropwa.rig import PlanLimits, parse_campaign, parse_limits, plan_campaign, size_campaign

CAMPAIGN = {
    "campaign": {"name": "small", "seed": 1},
    "frf": {"sweep": [{"opening": 0.25, "frequencies": [5.0, 20.0]}], "margin_periods": 1},
    "deadzone": {"inputs": [0.05, 0.15], "duration": 1.0},
    "friction": {"inputs": [0.2, 0.3], "duration": 1.2, "counter_force": "1 kN"},
}
VENDOR_MAP = {  # the vendor's names; pressures as 0-10 V transmitters of 0-250 bar
    "map": {"name": "vendor"},
    "channels": {
        "t": {"source": "Time_s", "unit": "s"},
        "u": {"source": "ValveCmd", "unit": "1"},
        "x": {"source": "Pos_mm", "unit": "mm"},
        "spool": {"source": "Spool", "unit": "1"},
        "p_a": {"source": "PA_V", "unit": "bar", "gain": 25.0},
        "p_b": {"source": "PB_V", "unit": "bar", "gain": 25.0},
        "f_l": {"source": "Load_N", "unit": "N"},
    },
}
DELAY = 2  # samples
REFUSED_CAMPAIGN = {"deadzone": {"inputs": [0.15], "directions": ["extend"], "duration": 0.5}}


@pytest.fixture(scope="module")
def planned(tmp_path_factory):
    paper = load_params("paper")
    plan = plan_campaign(paper, parse_campaign(CAMPAIGN, "small.toml"), rate=1000.0)
    out = tmp_path_factory.mktemp("plan") / "plan"
    plan.write(out)
    return plan, out


def _write_logs(plan, folder, *, rate_factor=1, alter=None):
    """The plan's prediction as vendor logs: 30 ms pre-trigger, a time offset, DELAY samples."""
    folder.mkdir()
    rng = np.random.default_rng(50)
    noise = {"Pos_mm": 2e-3, "Spool": 1e-3, "PA_V": 2e-3, "PB_V": 2e-3, "Load_N": 2.0}
    n_pre = 30 + DELAY  # 30 ms pre-trigger, then the recording delay

    def pad(a):
        return np.concatenate([np.full(n_pre, a[0]), a, np.full(40, a[-1])])

    for r in plan.runs:
        u = np.concatenate([np.zeros(n_pre), r.u, np.zeros(40)])
        cols = {
            "Time_s": 12.5 + np.arange(u.size) / 1000.0,
            "ValveCmd": u,
            "Pos_mm": 1e3 * pad(r.predicted["x"]),
            "Spool": pad(r.predicted["spool"]),
            "PA_V": pad(r.predicted["p_a"]) / 25e5,
            "PB_V": pad(r.predicted["p_b"]) / 25e5,
            "Load_N": pad(r.f_l if r.f_l is not None else np.zeros(r.t.size)),
        }
        for k, std in noise.items():  # sensor noise: the import's fault checks expect a sensor
            cols[k] = cols[k] + rng.normal(0.0, std, u.size)
        if alter is not None:
            alter(r.name, cols)
        cols = {k: v[::rate_factor] for k, v in cols.items()}
        np.savetxt(
            folder / f"{r.name}.csv",
            np.column_stack(list(cols.values())),
            delimiter=",",
            header=",".join(cols),
            comments="",
        )
    return folder


@pytest.fixture
def cmap(tmp_path):
    import tomli_w

    p = tmp_path / "vendor.toml"
    p.write_bytes(tomli_w.dumps(VENDOR_MAP).encode())
    return p


def test_the_plan_keeps_its_limits_and_writes_what_the_rig_plays(planned):
    plan, out = planned
    doc = json.loads((out / "manifest.json").read_text())
    assert plan.success and len(doc["runs"]) == 10 and doc["machine"]["cylinder"]["stroke"] == 0.2
    lim = plan.limits
    for r, e in zip(plan.runs, doc["runs"], strict=True):
        env = r.envelope
        assert min(env.to_retracted, env.to_extended) >= lim.stroke_margin
        assert lim.min_pressure <= env.p_min and env.p_max <= lim.max_pressure
        # the command file is the command at the plan's rate, ending at rest
        cmd = np.loadtxt(out / e["files"]["csv"], delimiter=",", skiprows=1)
        assert np.allclose(np.diff(cmd[:, 0]), 1e-3) and cmd[-1, 1] == 0.0
        assert (out / e["files"]["mat"]).is_file() and (out / e["files"]["positioning"]).is_file()
    # the FRF sine is sampled exactly: u = 0.25 sin(2π 5 t) at the sample times
    frf = next(r for r in plan.runs if r.name.startswith("frf_a25_f005"))
    k = frf.t <= frf.record_until
    assert np.max(np.abs(frf.u[k] - 0.25 * np.sin(2 * np.pi * 5.0 * frf.t[k]))) < 1e-12
    # the dead-zone extend run starts 2 stroke margins from the retracted stop, not against it
    dz = next(r for r in plan.runs if r.name == "deadzone_extend_u15")
    assert dz.start_position == pytest.approx(2 * lim.stroke_margin)
    assert "plan.png" in (out / "plan.html").read_text()
    # the result protocol: the table holds the envelopes, the figure one axis per quantity
    df = plan.to_pandas()
    assert list(df.index) == [r.name for r in plan.runs]
    assert df["p_max"].tolist() == [r.envelope.p_max for r in plan.runs]
    assert len(plan.plot().axes) == 4 and plan.status.name == "SUCCESS"
    assert plan.runs[0].name in plan._repr_html_()


def test_a_run_that_breaks_a_limit_is_adapted_or_refused_in_strict_mode():
    paper = load_params("paper")
    camp = parse_campaign({"deadzone": {"inputs": [0.3], "directions": ["extend"]}}, "c.toml")
    lim = PlanLimits(stroke_margin=0.05)  # 0.3 opening runs the rod 90 % of the stroke in open loop
    plan = plan_campaign(paper, camp, lim, rate=1000.0)
    (run,) = plan.runs
    assert "shortened" in run.adaptation and "stroke_margin" in run.adaptation
    assert run.envelope.to_extended >= 0.05
    with pytest.raises(ParameterError, match=r"deadzone_extend_u30.*stroke_margin"):
        plan_campaign(paper, camp, lim, rate=1000.0, strict=True)
    # an FRF sine above the opening limit is scaled to it, and its setting says so
    frf = parse_campaign({"frf": {"sweep": [{"opening": 0.9, "frequencies": [20.0]}]}}, "f.toml")
    (run,) = plan_campaign(paper, frf, PlanLimits(max_opening=0.5), rate=2000.0).runs
    assert run.adaptation.startswith("scaled by 0.556: opening 90 % above max_opening")
    assert np.max(np.abs(run.u)) == pytest.approx(0.5) and run.meta["amplitude"] == 0.5
    with pytest.raises(ParameterError, match="max_velocity = 50 m/s is implausible"):
        parse_limits({"max_velocity": "50 m/s"})


def test_import_finds_the_delay_and_gives_identify_its_dataset(planned, tmp_path, cmap):
    plan, out = planned
    logs = _write_logs(plan, tmp_path / "logs")
    res = import_logs(logs, out, tmp_path / "ds", channel_map=cmap)
    assert {r.delay_samples for r in res.runs} == {30 + DELAY}  # pre-trigger + delay, exactly
    assert (res.to_pandas()["delay"] == (30 + DELAY) / 1000.0).all() and res.success
    ds = read_dataset(tmp_path / "ds" / "friction")
    assert ds.meta["machine"]["cylinder"]["stroke"] == 0.2
    run = ds["friction_extend_u20"]
    ref = next(r for r in plan.runs if r.name == "friction_extend_u20")
    assert run.t[0] == 0.0 and run.duration == pytest.approx(ref.record_until, abs=1e-3)
    # volts → Pa through the map; aligned to the planned command sample for sample
    n = run.n_samples
    err = run["p_a"] - ref.predicted["p_a"][:n]  # 0.05 bar sensor noise (2 mV of 0-10 V)
    assert abs(err.mean()) < 1e3 and np.max(np.abs(err)) < 6 * 5e3
    assert np.array_equal(run["u"], ref.u[:n])
    assert run.meta["level"] == pytest.approx(0.2) and run.meta["valve_delay"] == 0.4


@pytest.mark.parametrize(
    ("case", "match"),
    [
        ("missing", r"1 of 10 planned run\(s\) have no log.*deadzone_retract_u05"),
        ("rate", r"logged at 500 Hz, the plan's rate is 1000 Hz"),
        ("clipped", r"friction_extend_u30.*channel 'p_a'.*stuck at its maximum"),
        ("swapped", r"channels 'p_a' and 'p_b' look swapped"),
    ],
)
def test_a_log_that_does_not_match_its_run_is_one_line(planned, tmp_path, cmap, case, match):
    plan, out = planned

    def alter(name, cols):
        if case == "clipped" and name == "friction_extend_u30":
            cols["PA_V"] = np.minimum(cols["PA_V"], np.percentile(cols["PA_V"], 60))
        if case == "swapped" and name == "frf_a25_f005p00":
            cols["PA_V"], cols["PB_V"] = cols["PB_V"], cols["PA_V"]

    logs = _write_logs(plan, tmp_path / "logs", rate_factor=2 if case == "rate" else 1, alter=alter)
    if case == "missing":
        (logs / "deadzone_retract_u05.csv").unlink()
    with pytest.raises(DataError, match=match) as err:
        import_logs(logs, out, tmp_path / "ds", channel_map=cmap)
    assert "\n" not in str(err.value)
    assert not (tmp_path / "ds").exists()  # nothing half-written


def test_the_sized_campaign_fits_the_machine():
    """The 50/20 × 700 mm axis: FRF and sine amplitudes fit the stroke, friction outside the band."""
    from hydropwa.rig import no_load_velocity

    paper = load_params("paper")
    axis = paper.replace(
        **{
            "cylinder.area_a": np.pi * 0.05**2 / 4,
            "cylinder.area_b": np.pi * (0.05**2 - 0.02**2) / 4,
            "cylinder.stroke": 0.7,
            "supply.pressure": 200e5,
            "supply.relief_pressure": 220e5,
            "valve.omega0": 2 * np.pi * 40.0,
            "valve.omega0_table": (),
            "load.mass": 100.0,
        }
    )
    for p in (paper, axis):
        c = size_campaign(p)
        beta = p.dead_zone.beta
        assert min(c["friction"].inputs) > beta  # every friction run moves the rod
        assert max(c["deadzone"].inputs) == pytest.approx(2 * beta)
        for sw in c["frf"].sweeps:  # rod amplitude v/(2πf) ≤ 30 % of the stroke
            v = no_load_velocity(p, sw.opening - beta)
            assert v / (2 * np.pi * min(sw.frequencies)) <= 0.3 * p.cylinder.stroke * 1.01
        assert max(c["frf"].sweeps[0].frequencies) == pytest.approx(
            p.valve.omega0 / (2 * np.pi), rel=0.01
        )
        assert c["sine"].frequencies == (1.0, 2.0, 3.0) and c["sine"].load is not None


def test_cli_plan_reads_the_campaigns_limits_and_import_names_a_missing_run(tmp_path):
    """`rig plan` with a [limits] table, then `data import` of an empty folder: exit 2, one line."""
    import tomli_w
    from typer.testing import CliRunner

    from hydropwa.cli import app

    camp = {
        "deadzone": {"inputs": [0.15], "directions": ["extend"], "duration": 0.5},
        "limits": {"stroke_margin": "8 mm", "max_velocity": "0.8 m/s"},
    }
    (tmp_path / "c.toml").write_bytes(tomli_w.dumps(camp).encode())
    runner = CliRunner()
    args = ["rig", "plan", "--params", "paper", "--campaign", str(tmp_path / "c.toml")]
    res = runner.invoke(app, [*args, "--out", str(tmp_path / "plan"), "--max-opening", "0.9"])
    assert res.exit_code == 0, res.output
    doc = json.loads((tmp_path / "plan" / "manifest.json").read_text())
    assert doc["limits"]["stroke_margin"] == 0.008 and doc["limits"]["max_velocity"] == 0.8
    assert doc["limits"]["max_opening"] == 0.9 and doc["runs"][0]["start_position"] == 0.016
    assert doc["status"] == "success" and doc["refused"] == []
    # no --controller: the default design at the plan's 1 ms, verified, written with its verdict
    ctrl = load_controller(tmp_path / "plan" / doc["controller"])
    design = doc["controller_design"]
    assert design["source"].startswith("designed by rig plan (the default design")
    assert ctrl.sample_time == 1e-3 == design["settings"]["sample_time"]
    assert design["settings"]["delay"] is DEFAULT_DESIGN.delay
    assert design["verification"]["verdict"] == "pass" == ctrl.verification["verdict"]
    assert "controller_hint" not in doc
    res = runner.invoke(app, [*args, "--out", str(tmp_path / "plan")])
    assert res.exit_code == 2 and "--force" in res.output  # nothing overwritten without it
    (tmp_path / "logs").mkdir()
    res = runner.invoke(
        app,
        [
            "data",
            "import",
            str(tmp_path / "logs"),
            "--plan",
            str(tmp_path / "plan"),
            "-o",
            str(tmp_path / "ds"),
        ],
    )
    assert res.exit_code == 2
    assert "1 of 1 planned run(s) have no log" in res.output and "deadzone_extend_u15" in res.output


def test_cli_plan_with_a_refused_run_writes_the_rest_and_exits_1(tmp_path):
    """A refused run: the plan is written for the rest, exit 1, the manifest names the run and
    the limit; --strict: exit 2 and nothing written. A given controller's verdict is recorded."""
    import tomli_w
    from typer.testing import CliRunner

    from hydropwa.cli import app
    from hydropwa.control import design_state_feedback, save_controller
    from hydropwa.linearization import linearize

    paper = load_params("paper")
    (tmp_path / "c.toml").write_bytes(tomli_w.dumps(REFUSED_CAMPAIGN).encode())
    ctrl = tmp_path / "ctrl.toml"
    unverified = design_state_feedback(linearize(paper)).controller  # no verification run
    save_controller(unverified, ctrl, machine_parameters=paper)
    runner = CliRunner()
    args = ["rig", "plan", "--params", "paper", "--campaign", str(tmp_path / "c.toml")]
    args += ["--max-pressure", "40 bar", "--controller", str(ctrl)]  # rest: 63 bar in a chamber
    res = runner.invoke(app, [*args, "--out", str(tmp_path / "plan")])
    assert res.exit_code == 1, res.output
    assert "1 run(s) refused" in res.output
    doc = json.loads((tmp_path / "plan" / "manifest.json").read_text())
    assert doc["status"] == "partial" and doc["runs"] == []
    (refused,) = doc["refused"]
    assert refused["name"] == "deadzone_extend_u15" and refused["limit"] == "max_pressure"
    assert "limit 40 bar" in refused["message"]
    assert doc["controller"] == "controller.toml"
    assert doc["controller_design"]["source"] == f"given (--controller {ctrl})"
    assert doc["controller_design"]["verification"] == {}  # the file carries no verdict
    res = runner.invoke(app, [*args, "--out", str(tmp_path / "strict"), "--strict"])
    assert res.exit_code == 2 and "deadzone_extend_u15" in res.output
    assert not (tmp_path / "strict").exists()
