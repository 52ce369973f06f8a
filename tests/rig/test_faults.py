"""Faults on the virtual rig: the declared table moves exactly the named parameters.

Truths: the leakage coefficient of a flow Q rated at Δp is Q/Δp; percentages scale the
named fields; a growing fault is linear in the run index; the valve null shifts the command
the valve sees by the offset while the run records the command as sent; the external leakage
of a closed chamber drains it at Ṗ = −E C_e P / V (Eq. (9)).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from hydropwa import ParameterError
from hydropwa.components import chamber_pressure_rates
from hydropwa.rig import (
    FAULT_KINDS,
    Fault,
    RunSpec,
    execute,
    inject,
    parse_campaign,
    parse_fault_spec,
    run_seed,
    shift_command,
)
from hydropwa.simulation import Constant, Ramp, Sampled, Sine, Step

LPM = 1e-3 / 60.0


def test_leakage_faults_are_the_rated_flow_over_the_rated_drop(rig):
    base = rig.params
    for kind, field in (
        ("internal_leakage", "leakage"),
        ("external_leakage_a", "external_leakage_a"),
        ("external_leakage_b", "external_leakage_b"),
    ):
        p, offset, applied = inject(base, [Fault(kind, 0.1 * LPM, at=50e5)], 0, 1)
        assert getattr(p.cylinder, field) == pytest.approx(
            getattr(base.cylinder, field) + 0.1 * LPM / 50e5, rel=1e-12
        )
        assert offset == 0.0 and applied == [
            {
                "kind": kind,
                "size": pytest.approx(0.1),
                "unit": "L/min",
                "onset": "abrupt",
                "at_bar": 50.0,
            }
        ]


def test_percentage_faults_scale_the_declared_fields(rig):
    base = rig.params
    p, _, _ = inject(
        base, [Fault("friction", 0.3), Fault("supply", 0.1), Fault("bulk_modulus", 0.2)], 0, 1
    )
    for f in FAULT_KINDS["friction"].moves:
        comp, name = f.split(".")
        assert getattr(p.friction, name) == pytest.approx(
            1.3 * getattr(base.friction, name), rel=1e-12
        )
    assert p.supply.pressure == pytest.approx(0.9 * base.supply.pressure, rel=1e-12)
    assert p.oil.bulk_modulus == pytest.approx(0.8 * base.oil.bulk_modulus, rel=1e-12)
    assert p.cylinder == base.cylinder and p.valve == base.valve  # nothing else moves


def test_valve_null_moves_no_parameter_but_the_command(rig):
    p, offset, _ = inject(rig.params, [Fault("valve_null", -0.005)], 0, 1)
    assert p == rig.params and offset == -0.005


def test_growing_fault_is_linear_from_its_start_run():
    f = Fault("friction", 0.3, onset="growing", start=1)
    sizes = [f.size_at(i, 5) for i in range(5)]
    assert sizes == pytest.approx([0.0, 0.0, 0.1, 0.2, 0.3], abs=1e-15)
    abrupt = Fault("friction", 0.3, start=2)
    assert [abrupt.size_at(i, 5) for i in range(5)] == [0.0, 0.0, 0.3, 0.3, 0.3]


@pytest.mark.parametrize(
    "signal",
    [
        Constant(0.1),
        Step(0.2, 0.0, 0.3),
        Ramp(0.0, 1.0, -0.2, 0.2),
        Sine(0.2, 2.0, 0.05),
        Sampled(np.array([0.0, 1.0]), np.array([0.1, -0.1])),
    ],
)
def test_shift_command_adds_the_offset_at_every_time(signal):
    t = np.linspace(0.0, 1.5, 31)
    shifted = shift_command(signal, 0.005)
    assert type(shifted) is type(signal)
    np.testing.assert_allclose(shifted(t), signal(t) + 0.005, rtol=0, atol=1e-15)


def test_the_valve_sees_the_offset_and_the_run_records_the_command_as_sent(rig):
    spec = RunSpec(
        "hold", "deadzone", Constant(0.02), duration=0.3, start_position=0.1, command_offset=0.004
    )
    run = execute(rig, spec, run_seed(0, "deadzone", "hold"))
    assert np.all(run.channels["u"] == 0.02)
    late = run.channels["t"] > 0.1  # the spool (ω0 ≈ 100 Hz) has settled at u + offset
    # spool sensor noise 1e-3 over ~400 samples: the mean is known to ~5e-5
    assert np.mean(run.channels["spool"][late]) == pytest.approx(0.024, abs=3e-4)


def test_campaign_faults_table_and_command_line_spec():
    doc = {
        "campaign": {"name": "worn", "seed": 1},
        "sine": {"frequencies": ["1 Hz"], "amplitudes": ["20 %"], "periods": 2},
        "faults": [
            {"kind": "internal_leakage", "size": "0.1 L/min", "at": "50 bar", "onset": "growing"},
            {"kind": "friction", "size": "30 %", "start": 2},
        ],
    }
    camp = parse_campaign(doc, "worn.toml")
    leak, fric = camp.faults
    assert (leak.kind, leak.at, leak.onset, leak.start) == ("internal_leakage", 50e5, "growing", 0)
    assert leak.size == pytest.approx(0.1 * LPM, rel=1e-12)
    assert fric.size == pytest.approx(0.3) and fric.start == 2
    assert parse_fault_spec("internal_leakage=0.1 L/min@50 bar:growing") == leak


@pytest.mark.parametrize(
    ("table", "needle"),
    [
        ({"kind": "leak", "size": "1 %"}, "kind 'leak' is unknown; choose from internal_leakage"),
        (
            {"kind": "friction", "size": "30 %", "at": "50 bar"},
            "'at' is only for the leakage kinds",
        ),
        ({"kind": "friction"}, "needs kind and size"),
        ({"kind": "friction", "size": "3000 %"}, "size 3000 % must lie in 0…1000 %"),
        ({"kind": "supply", "size": "10 %", "when": 3}, "unknown key(s) when"),
    ],
)
def test_bad_fault_tables_are_one_line_naming_the_table(table, needle):
    doc = {"sine": {"frequencies": ["1 Hz"], "amplitudes": ["20 %"]}, "faults": [table]}
    with pytest.raises(ParameterError, match="worn.toml: \\[\\[faults\\]\\]\\[0\\]") as exc:
        parse_campaign(doc, "worn.toml")
    assert needle in str(exc.value) and "\n" not in str(exc.value)


def test_external_leakage_drains_a_closed_chamber_at_the_closed_form_rate():
    e, ce, pa, pb, x = 1.2e9, 2e-12, 80e5, 30e5, 0.05
    aa, ab, stroke, va0, vb0 = 1.3e-3, 0.76e-3, 0.2, 0.7e-3, 0.6e-3
    dpa, dpb = chamber_pressure_rates(
        0.0, 0.0, x, 0.0, pa, pb, aa, ab, stroke, va0, vb0, 0.0, e, -0.95e5, 0.0, ce, 0.0
    )
    assert dpa == pytest.approx(-e * ce * pa / (va0 + aa * x), rel=1e-14)
    assert dpb == 0.0
    # both leakages at once add their flows (continuity is linear in them)
    _, dpb2 = chamber_pressure_rates(
        0.0, 0.0, x, 0.0, pa, pb, aa, ab, stroke, va0, vb0, 1e-12, e, -0.95e5, 0.0, 0.0, ce
    )
    assert dpb2 == pytest.approx(
        e / (vb0 + ab * (stroke - x)) * (1e-12 * (pa - pb) - ce * pb), rel=1e-14
    )


def test_run_experiment_writes_each_runs_faults(rig, tmp_path):
    from hydropwa.rig import DeadZoneExperiment, run_experiment

    exp = DeadZoneExperiment(inputs=(0.15,), directions=(1, -1), duration=0.2, min_duration=0.2)
    ds = run_experiment(rig, exp, tmp_path, faults=[Fault("friction", 0.3, onset="growing")])
    sizes = [r.meta["faults"][0]["size"] if r.meta["faults"] else 0.0 for r in ds]
    assert sizes == pytest.approx([0.0, 30.0])
    assert (
        dataclasses.asdict(Fault("friction", 0.3, onset="growing"))
        in ds.meta["definition"]["faults"]
    )
