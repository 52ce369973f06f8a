"""The health monitor on the virtual rig: no alarm when healthy, the injected fault found and sized.

Truths are the faults injected by the rig (hydropwa.rig.inject), whose sizes the indicators
must recover: the internal leakage coefficient Q/Δp, the valve null offset, the supply set
pressure, the friction level; and the rig's own bulk modulus. Each run here is one counter-force
load run of the paper campaign's [sine] experiment (3.1 s), the excitation under which a small
leakage shows; the statistics over a thousand runs are benchmarks/monitor_study.py's.
"""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest
from typer.testing import CliRunner

from hydropwa import DataError, OutputExistsError
from hydropwa.cli import app, main
from hydropwa.data import Dataset, Run
from hydropwa.monitor import HealthMonitor, draw_within
from hydropwa.params import get_preset, load_params, save_params
from hydropwa.rig import Fault, Rig, execute, inject, load_campaign, plan, run_seed

LPM = 1e-3 / 60.0
ROOT = __import__("pathlib").Path(__file__).resolve().parents[2]


def _load_run(rig: Rig, name: str = "sine_load_retract_u20"):
    (spec,) = [s for s in plan(load_campaign("paper")["sine"], rig) if s.name == name]
    return spec


def _measure(rig: Rig, spec, faults=(), seed=0, true=None):
    true = rig.params if true is None else true
    params, offset, _ = inject(true, faults, 0, 1)
    faulty = dataclasses.replace(rig, params=params, supply=params.supply)
    return execute(
        faulty, dataclasses.replace(spec, command_offset=offset), run_seed(seed, "sine", spec.name)
    )


@pytest.fixture(scope="module")
def paper():
    rig = Rig(get_preset("paper"))
    return rig, _load_run(rig), HealthMonitor().fit(rig.params)


def test_healthy_runs_within_the_intervals_do_not_alarm(paper):
    rig, spec, mon = paper
    true = draw_within(rig.params, mon.intervals_, np.random.default_rng(4))
    for run in (_measure(rig, spec, seed=1), _measure(rig, spec, seed=2, true=true)):
        h = mon.check(run)
        assert not h.alarm, h.summary()
        assert h.success and h.faults == ()


@pytest.mark.parametrize(
    ("fault", "indicator", "truth", "rel"),
    [
        # the leakage's standard error on this run is ~2.5 % of 0.1 L/min; 4 of them
        (Fault("internal_leakage", 0.1 * LPM, at=50e5), "internal_leakage", 0.1 * LPM / 50e5, 0.10),
        (
            Fault("external_leakage_a", 0.1 * LPM, at=50e5),
            "external_leakage_a",
            0.1 * LPM / 50e5,
            0.15,
        ),
        # the spool sensor gives the null directly: standard error 1.4e-5 of 5e-3
        (Fault("valve_null", 0.005), "valve_null", 0.005, 0.02),
        # the pump's droop corrected: within the droop law's steady-state error
        (Fault("supply", 0.10), "supply_pressure", 90e5, 0.005),
        # standard error ~2 % plus the filter's attenuation near reversals
        (Fault("friction", 0.30), "friction_scale", 1.30, 0.05),
    ],
)
def test_the_fault_is_detected_named_and_sized(paper, fault, indicator, truth, rel):
    rig, spec, mon = paper
    h = mon.check(_measure(rig, spec, [fault], seed=3))
    assert h.alarm and h.faults[0] == fault.kind, h.summary()
    assert h.indicators[indicator].value == pytest.approx(truth, rel=rel)


def test_the_bulk_modulus_is_the_rigs(paper):
    rig, spec, mon = paper
    h = mon.check(_measure(rig, spec, seed=5))
    # continuity's 1/E column: ~0.1 % standard error; 2 % covers the filter's lag
    assert h.indicators["bulk_modulus"].value == pytest.approx(
        rig.params.oil.bulk_modulus, rel=0.02
    )


def test_heavy_axis_healthy_and_leaking():
    rig = Rig(load_params(ROOT / "tests" / "machines" / "industrial.toml"))
    spec = _load_run(rig, "sine_load_extend_u20")
    mon = HealthMonitor().fit(rig.params)
    assert not mon.check(_measure(rig, spec, seed=1)).alarm
    h = mon.check(_measure(rig, spec, [Fault("internal_leakage", 0.1 * LPM, at=50e5)], seed=1))
    assert h.faults[:1] == ("internal_leakage",)
    # its threshold (the smallest leakage that alarms) is below the 0.1 L/min the issue asks for
    assert h.indicators["internal_leakage"].threshold[1] < 0.05 * LPM / 50e5


def test_report_files_and_no_clobber(paper, tmp_path):
    rig, spec, mon = paper
    report = mon.check_dataset([_measure(rig, spec, seed=1)])
    report.write(tmp_path / "r")
    doc = json.loads((tmp_path / "r" / "health.json").read_text())
    (entry,) = doc["runs"]
    assert set(entry) >= {"run", "alarm", "faults", "indicators"}
    assert set(entry["indicators"]["internal_leakage"]) >= {"value", "interval", "threshold"}
    assert "<svg" in (tmp_path / "r" / "health.html").read_text()
    with pytest.raises(OutputExistsError):
        report.write(tmp_path / "r")
    report.write(tmp_path / "r", overwrite=True)


def test_a_run_without_pressures_is_one_error(paper):
    _rig, _spec, mon = paper
    run = Run("bare", {"t": np.linspace(0, 1, 101), "u": np.zeros(101), "x": np.zeros(101)})
    with pytest.raises(DataError, match="run 'bare' has no p_a, p_b; the monitor needs"):
        mon.check(run)


def test_cli_monitor_writes_the_report_and_refuses_to_overwrite(paper, tmp_path):
    rig, spec, _mon = paper
    ds = Dataset.create(tmp_path / "data")
    ds.add_run(_measure(rig, spec, seed=1))
    ds.add_run(
        dataclasses.replace(_measure(rig, spec, [Fault("supply", 0.1)], seed=1), name="weak_pump")
    )
    save_params(rig.params, tmp_path / "identified.toml")
    argv = [
        "monitor",
        str(tmp_path / "data"),
        "--params",
        str(tmp_path / "identified.toml"),
        "--out",
        str(tmp_path / "h"),
    ]
    res = CliRunner().invoke(app, argv)
    assert res.exit_code == 0, res.output
    doc = json.loads((tmp_path / "h" / "health.json").read_text())
    assert [(r["run"], r["alarm"], r["faults"][:1]) for r in doc["runs"]] == [
        (spec.name, False, []),
        ("weak_pump", True, ["supply"]),
    ]
    assert main(argv) == 2  # exists: one error line, exit 2
