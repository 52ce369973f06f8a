"""No silent default machine (issue 37): the machine comes from the data, the controller file
or ``--params``; none given is one line saying how (exit 2), never the paper's cylinder."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
import tomli_w

from hydropwa._errors import IdentificationError, ParameterError
from hydropwa.cli import main
from hydropwa.data import Dataset, read_run
from hydropwa.identification import (
    StribeckIdentifier,
    fit_stribeck,
    identify,
    machine_for,
    recorded_machine,
)
from hydropwa.params import get_preset, load_params, save_params

MACHINES = Path(__file__).parents[1] / "machines"


@pytest.fixture(scope="module")
def heavy():
    """The 63/36 mm × 500 mm axis: areas and stroke far from the paper's (13/7.6 cm², 200 mm)."""
    return load_params(MACHINES / "industrial.toml")


def _deadzone_runs():
    """Constant-command runs (the dead-zone experiment) with a hinge velocity law."""
    import sys

    sys.path.insert(0, str(Path(__file__).parents[1] / "identification"))
    from ident_support import constant_input_runs, hinge_velocity

    levels = np.concatenate([np.arange(0.01, 0.2001, 0.01), -np.arange(0.01, 0.2001, 0.01)])
    return constant_input_runs(levels, lambda u: hinge_velocity(u, 0.1, 0.5, 0.02), duration=1.0)


@pytest.fixture(scope="module")
def campaign(tmp_path_factory, heavy):
    """A campaign folder as `hydropwa rig run` lays it out: deadzone/ and true_params.toml."""
    root = tmp_path_factory.mktemp("heavy")
    Dataset.create(root / "deadzone").write(_deadzone_runs(), format="csv")
    save_params(heavy, root / "true_params.toml")
    return root


def test_the_campaign_records_its_machine(campaign, heavy):
    got, src = recorded_machine(campaign)
    assert got == heavy and src.endswith("true_params.toml")
    # a dataset folder of the campaign finds its parent's parameter file
    assert recorded_machine(campaign / "deadzone")[0] == heavy
    assert machine_for(campaign) == heavy


def test_identify_without_params_uses_the_datas_machine(campaign, heavy, tmp_path, capsys):
    out = tmp_path / "id.toml"
    assert main(["identify", "deadzone", str(campaign), "--out", str(out)]) == 0
    back = load_params(out)
    # the heavy axis' geometry and untouched values, not the paper cylinder's
    assert back.cylinder.area_a == pytest.approx(heavy.cylinder.area_a, rel=1e-12)
    assert back.cylinder.stroke == pytest.approx(0.5, rel=1e-12)
    assert back.load.mass == pytest.approx(heavy.load.mass, rel=1e-12)
    assert back.dead_zone.beta == pytest.approx(0.1, abs=0.005)  # identified
    # the Python API agrees with the CLI: no params, the data's machine
    rep = identify(campaign, ("deadzone",))
    assert rep.params.cylinder == heavy.cylinder
    # the report presents itself: what was identified, no object addresses
    text = repr(rep)
    assert " at 0x" not in text and "dead zone" in text and "β = 0.1" in text
    assert "<table>" in rep._repr_html_() and " at 0x" not in rep._repr_html_()


def test_params_of_another_geometry_is_an_error(campaign, tmp_path, capsys):
    code = main(
        ["identify", "deadzone", str(campaign), "--out", str(tmp_path / "a.toml"), "-p", "paper"]
    )
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "piston area A_A 13 cm²" in err, err
    assert "31.17 cm²" in err and not (tmp_path / "a.toml").exists()
    with pytest.raises(ParameterError, match="piston area"):
        identify(campaign, ("deadzone",), params=get_preset("paper"))


def test_no_machine_anywhere_stops_with_one_line(tmp_path, capsys):
    Dataset.create(tmp_path / "log" / "deadzone").write(_deadzone_runs(), format="csv")
    out = tmp_path / "id.toml"
    code = main(["identify", "all", str(tmp_path / "log"), "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1
    assert "records no machine" in err and "--params" in err
    assert not out.exists()
    with pytest.raises(ParameterError, match="records no machine"):
        identify(tmp_path / "log")


def test_a_manifests_machine_entry(tmp_path, heavy):
    """A converted log's manifest names its machine: a parameter table or a file next to it."""
    runs = _deadzone_runs()[:2]
    ds = Dataset.create(tmp_path / "a", meta={"machine": heavy.to_dict()})
    ds.write(runs, format="csv")
    assert recorded_machine(tmp_path / "a")[0] == heavy
    save_params(heavy, tmp_path / "b" / "axis.toml")
    Dataset.create(tmp_path / "b", meta={"machine": "axis.toml"}).write(runs, format="csv")
    assert recorded_machine(tmp_path / "b")[0] == heavy
    Dataset.create(tmp_path / "c", meta={"machine": "../secret.toml"}).write(runs, format="csv")
    with pytest.raises(ParameterError, match="machine"):
        recorded_machine(tmp_path / "c")
    # two datasets of one campaign that record two machines: refused, not one picked
    camp = tmp_path / "camp"
    Dataset.create(camp / "x", meta={"machine": heavy.to_dict()}).write(runs, format="csv")
    Dataset.create(camp / "y", meta={"machine": get_preset("paper").to_dict()}).write(
        runs, format="csv"
    )
    with pytest.raises(ParameterError, match="different machines"):
        machine_for(camp)


def _pi_controller(tmp_path: Path, machine: dict | None) -> Path:
    ctrl = tmp_path / "pi.toml"
    argv = ["control", "design", "-p", "paper", "--method", "pi", "--no-verify"]
    assert main([*argv, "--out", str(ctrl)]) == 0
    import tomllib

    doc = tomllib.loads(ctrl.read_text())
    if machine is None:  # a file that records only the areas and stroke (hand-written, schema 2)
        del doc["machine"]["parameters"]
    else:
        doc["machine"]["parameters"] = machine
    ctrl.write_text(tomli_w.dumps(doc))
    return ctrl


def test_control_design_writes_its_machine_for_control_simulate(tmp_path):
    """design --params M writes M as [machine.parameters]; simulate then runs on M without
    --params (a new user's two commands, issue 37), and refuses another machine."""
    low = get_preset("paper").replace(**{"supply.pressure": 60e5})
    save_params(low, tmp_path / "low.toml")
    ctrl, out = tmp_path / "pi.toml", tmp_path / "run.csv"
    design = ["control", "design", "--method", "pi", "--no-verify"]
    design += ["--params", str(tmp_path / "low.toml")]
    assert main([*design, "--out", str(ctrl)]) == 0
    args = ["--reference", "steps:0=100 mm,0.05=110 mm", "--duration", "0.2", "--model", "reduced"]
    assert main(["control", "simulate", "--controller", str(ctrl), "--out", str(out), *args]) == 0
    assert read_run(out).meta["inputs"]["p_s"]["value"] == pytest.approx(60e5, rel=1e-12)


def test_control_simulate_takes_the_machine_from_the_controller_file(tmp_path, capsys):
    args = ["--reference", "steps:0=100 mm,0.05=110 mm", "--duration", "0.2", "--model", "reduced"]
    bare = _pi_controller(tmp_path, None)
    capsys.readouterr()
    out = tmp_path / "run.csv"
    code = main(["control", "simulate", "--controller", str(bare), "--out", str(out), *args])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1, err
    assert "records no machine parameters" in err and "--params" in err
    assert not out.exists()
    # the file records the whole parameter set of a machine with a 60 bar supply (the paper's:
    # 100 bar) as [machine.parameters]: the trajectory was simulated on it
    low = get_preset("paper").replace(**{"supply.pressure": 60e5})
    ctrl = tmp_path / "m" / "pi.toml"
    ctrl.parent.mkdir()
    _pi_controller(ctrl.parent, low.to_dict())
    assert main(["control", "simulate", "--controller", str(ctrl), "--out", str(out), *args]) == 0
    assert read_run(out).meta["inputs"]["p_s"]["value"] == pytest.approx(60e5, rel=1e-12)


def test_an_undetermined_friction_value_is_not_written():
    """Points only at 50-200 mm/s with 40 N noise do not determine F_c (true 0): the fit ends
    at its bound (≈ 3e-6 N, CI ±412 N). It is reported as not identified and apply() keeps
    the given value; the determined viscous coefficient is written."""
    rng = np.random.default_rng(0)
    v = np.concatenate([np.linspace(0.05, 0.2, 15), -np.linspace(0.05, 0.2, 15)])
    f = 1100.0 * v + rng.normal(0.0, 40.0, v.size)
    fit = fit_stribeck(v, f, n_starts=4)
    assert "coulomb" in fit.unidentified and "viscous" not in fit.unidentified
    est = fit.estimates["coulomb"]
    assert est.value < 1e-3 and est.ci[1] - est.ci[0] > 400.0
    base = get_preset("paper").replace(
        **{"friction.coulomb": 10.0, "friction.static": 20.0, "friction.viscous": 500.0}
    )
    ident = StribeckIdentifier(base)
    ident.fit_, ident.friction_, ident.notes_ = fit, fit.friction, []
    applied = ident.apply(base)
    for name in fit.unidentified:
        assert getattr(applied.friction, name) == getattr(base.friction, name)
    assert applied.friction.viscous == pytest.approx(fit.friction.viscous)
    assert ident.uncertainty()["not_identified"] == list(fit.unidentified)
    # the given values cannot hold with the fitted ones (F_s < F_c): an error, no file
    bad = base.replace(**{"friction.coulomb": 90.0, "friction.static": 150.0})
    with pytest.raises(IdentificationError, match="not identified"):
        ident.apply(bad)


def test_data_convert_records_the_machine(tmp_path, heavy, capsys):
    """`data convert --params` writes the manifest's machine entry that identify then reads."""
    raw = tmp_path / "raw"
    Dataset.create(raw).write(_deadzone_runs()[:2], format="csv")
    save_params(heavy, tmp_path / "axis.toml")
    dst = tmp_path / "conv"
    assert (
        main(["data", "convert", str(raw), str(dst), "--params", str(tmp_path / "axis.toml")]) == 0
    )
    assert recorded_machine(dst)[0] == heavy
    one = next(raw.glob("*.csv"))
    code = main(["data", "convert", str(one), str(tmp_path / "one.csv"), "-p", "paper"])
    err = capsys.readouterr().err
    assert code == 2 and "no manifest" in err and not (tmp_path / "one.csv").exists()


def test_export_fmu_without_params_stops_with_one_line(tmp_path, capsys):
    """An axis FMU is a machine: none given is one line (exit 2), and nothing is written."""
    out = tmp_path / "axis.fmu"
    assert main(["export", "fmu", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--params" in err, err
    assert not out.exists()


#: Every command that needs a machine and has no data or controller file to take it from:
#: its arguments without --params, and what it would have written ("{tmp}": a fresh folder).
_NO_MACHINE = {
    "simulate": (["simulate", "--duration", "10 ms", "--out", "{tmp}/r.csv"], "r.csv"),
    "linearize": (["linearize", "--out", "{tmp}/pwa.json"], "pwa.json"),
    "control design": (["control", "design", "--out", "{tmp}/c.toml"], "c.toml"),
    "rig run": (["rig", "run", "frf", "--out", "{tmp}/rig", "-q"], "rig"),
    "export fmu": (["export", "fmu", "--out", "{tmp}/axis.fmu"], "axis.fmu"),
}


@pytest.mark.parametrize("command", sorted(_NO_MACHINE))
def test_a_command_without_a_machine_stops_with_one_line(command, tmp_path, capsys):
    """No --params: exit 2, one line naming both ways to give the machine, nothing written
    (these commands ran on the paper's rig before, issue 37)."""
    argv, written = _NO_MACHINE[command]
    code = main([a.format(tmp=tmp_path) for a in argv])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1, err
    assert err.startswith("error: no machine given: pass --params FILE"), err
    assert "--params paper for the paper's rig" in err
    assert not (tmp_path / written).exists()


def test_a_sweep_file_names_its_machine(tmp_path, capsys):
    """A sweep file without ``base`` is refused (it swept the paper's rig); ``base = "paper"``
    names the paper's rig."""
    from hydropwa.sweep import parse_sweep

    body = '[grid]\n"load.mass" = [1.0, 2.0]\n[input]\nduration = 0.02\nmodel = "reduced"\n'
    (tmp_path / "s.toml").write_text(body)
    code = main(["sweep", str(tmp_path / "s.toml"), "-q", "--out", str(tmp_path / "o.csv")])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "names no machine" in err, err
    assert 'base = "paper"' in err and not (tmp_path / "o.csv").exists()
    spec = parse_sweep({"base": "paper", "grid": {"load.mass": [1.0, 2.0]}})
    assert spec.params_for(spec.cases()[0]).cylinder == get_preset("paper").cylinder


def test_the_python_api_needs_the_machine_too(heavy):
    """Models, the rig and simulation by name take the machine from the caller; none given
    raises one line saying how, never the paper's cylinder in silence."""
    from hydropwa import FullOrderModel, ReducedModel, simulate
    from hydropwa.models import as_model
    from hydropwa.rig import Rig
    from hydropwa.simulation import simulate_batch

    for make in (FullOrderModel, ReducedModel, Rig):
        with pytest.raises(TypeError, match="params"):
            make()
    for call in (
        lambda: as_model("full"),
        lambda: simulate("reduced", 0.1, duration=0.01),
        lambda: simulate_batch(["reduced"], 0.1, duration=0.01),
    ):
        with pytest.raises(ParameterError, match=r"needs the machine.*get_preset\('paper'\)"):
            call()
    with pytest.raises(ParameterError, match=r"Rig.from_params\('paper'\)"):
        Rig.from_params(None)
    with pytest.raises(ParameterError, match="SystemParams"):
        Rig("paper")  # a name is for from_params
    # named, each runs on that machine
    assert as_model("reduced", heavy).params.cylinder.stroke == 0.5
    assert Rig.from_params("paper").params.cylinder == get_preset("paper").cylinder
    assert Rig(heavy).params.cylinder == heavy.cylinder


def test_a_pwa_document_of_another_machine_is_refused(heavy, tmp_path, capsys):
    """``control design --pwa F --params P``: P was ignored; now F must be P's machine."""
    from hydropwa.cli import _control
    from hydropwa.linearization import linearize, save_pwa

    pwa = tmp_path / "pwa.json"
    save_pwa(linearize(get_preset("paper")), pwa)
    save_params(heavy, tmp_path / "heavy.toml")
    argv = ["control", "design", "--pwa", str(pwa), "--out", str(tmp_path / "c.toml")]
    assert main([*argv, "--params", str(tmp_path / "heavy.toml")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "the PWA document's" in err and "13 cm²" in err, err
    assert not (tmp_path / "c.toml").exists()
    # the same machine, or none named: the document's model
    assert _control._pwa_model("paper", pwa).params.cylinder == get_preset("paper").cylinder
    assert _control._pwa_model(None, pwa).params.cylinder == get_preset("paper").cylinder


def test_a_replayed_run_brings_its_machine(heavy, tmp_path, capsys):
    """``simulate --input-file``: the run's dataset records the heavy axis (210 bar), so the
    replay runs on it without --params; the paper's rig (100 bar) given with it is refused;
    a lone run that records no machine needs --params."""
    runs = _deadzone_runs()[:1]
    Dataset.create(tmp_path / "ds", meta={"machine": heavy.to_dict()}).write(runs, format="csv")
    (run_file,) = (tmp_path / "ds").glob("*.csv")
    sim = ["simulate", "--input-file", str(run_file), "--model", "reduced", "--duration", "10 ms"]
    assert main([*sim, "--out", str(tmp_path / "a.csv")]) == 0
    assert read_run(tmp_path / "a.csv").meta["inputs"]["p_s"]["value"] == heavy.supply.pressure
    capsys.readouterr()
    assert main([*sim, "-p", "paper", "--out", str(tmp_path / "b.csv")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "the run's machine" in err and "31.17 cm²" in err, err
    lone = tmp_path / "lone.csv"
    lone.write_bytes(run_file.read_bytes())
    sim[2] = str(lone)
    assert main([*sim, "--out", str(tmp_path / "c.csv")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "lone.csv records no machine: pass --params FILE" in err, err
    assert main([*sim, "-p", "paper", "--out", str(tmp_path / "c.csv")]) == 0
    assert read_run(tmp_path / "c.csv").meta["inputs"]["p_s"]["value"] == 100e5


@pytest.mark.parametrize(
    "section, names",
    [("cylinder", ("stroke",)), ("cylinder", ("area_a", "area_b")), ("load", ("mass",))],
)
def test_a_parameter_file_states_what_makes_the_machine(heavy, tmp_path, capsys, section, names):
    """A complete file (no ``base``) that leaves out the stroke, an area or the mass took the
    paper rig's value (200 mm, 13 cm², 1.394 kg) in silence; now one line names the field."""
    import tomllib

    save_params(heavy, tmp_path / "full.toml")
    doc = tomllib.loads((tmp_path / "full.toml").read_text())
    for name in names:
        del doc[section][name]
    (tmp_path / "gap.toml").write_text(tomli_w.dumps(doc))
    with pytest.raises(
        ParameterError,
        match=rf"{', '.join(f'{section}.{n}' for n in names)} not given.*base = \"paper\"",
    ):
        load_params(tmp_path / "gap.toml")
    assert main(["params", "show", str(tmp_path / "gap.toml")]) == 2
    assert capsys.readouterr().err.count("\n") == 1
    # with base = "paper" the paper rig's value is asked for by name
    (tmp_path / "based.toml").write_text(tomli_w.dumps({"base": "paper", **doc}))
    based = getattr(load_params(tmp_path / "based.toml"), section)
    paper, own = getattr(get_preset("paper"), section), getattr(heavy, section)
    for f in dataclasses.fields(based):
        want = paper if f.name in names else own
        assert getattr(based, f.name) == pytest.approx(getattr(want, f.name), rel=1e-12), f.name
