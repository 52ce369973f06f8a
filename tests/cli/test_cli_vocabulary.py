"""One vocabulary and one error path across the ``hydropwa`` commands.

Every command with a parameter set takes ``--params PRESET|FILE`` (found by walking the
typer app, so a new command cannot skip it), resolved by one function; ``--base-params``
still works with one deprecation line; errors are one line and exit 2; help texts are
literal; importing the CLI leaves the warning machinery of library users alone.
"""

from __future__ import annotations

import errno
import json
import subprocess
import sys
import warnings

import pytest
import typer
from typer.testing import CliRunner

from hydropwa import ParameterError
from hydropwa.cli import (
    _app,
    _control,
    _core,
    _data,
    _export,
    _identify,
    _linearize,
    _monitor,
    _options,
    _paper,
    _rig,
    app,
    main,
)
from hydropwa.params import get_preset, save_params

#: Arguments each command needs besides --params to reach the parameter set ("{tmp}" is a
#: fresh folder). A command that takes --params and is missing here fails the test below.
_ARGS = {
    "simulate": ["--out", "{tmp}/run.csv"],
    "linearize": ["--out", "{tmp}/pwa.json"],
    "rig run": ["frf", "--out", "{tmp}/rig"],
    "rig plan": ["--out", "{tmp}/plan"],
    "paper": ["--out", "{tmp}/report"],
    "control design": ["--out", "{tmp}/ctrl.toml"],
    "control simulate": ["--controller", "{tmp}/c.toml", "--reference", "steps:0=0.1"],
    "control certify": ["{tmp}/c.toml"],
    "export fmu": ["--out", "{tmp}/axis.fmu"],  # --params is added by each test
    "data convert": ["{tmp}/data", "{tmp}/copy"],
    "identify frf": ["{tmp}/data", "--out", "{tmp}/i.toml"],
    "identify deadzone": ["{tmp}/data", "--out", "{tmp}/i.toml"],
    "identify friction": ["{tmp}/data", "--out", "{tmp}/i.toml"],
    "identify all": ["{tmp}/data", "--out", "{tmp}/i.toml"],
    "identify model": ["{tmp}/data", "--free", "flow.K", "--out", "{tmp}/i.toml"],
    "monitor": ["{tmp}/data", "--out", "{tmp}/health"],
}

_MODULES = (_control, _core, _data, _export, _identify, _linearize, _monitor, _paper, _rig)


def _commands(cmd, path=()):
    """(path, click command) for every leaf command of the tree."""
    subs = getattr(cmd, "commands", None)
    if not subs:
        yield " ".join(path), cmd
        return
    for name, sub in subs.items():
        yield from _commands(sub, (*path, name))


def _options_of(cmd) -> set[str]:
    return {o for p in cmd.params for o in getattr(p, "opts", ())}


def test_every_command_with_a_parameter_set_uses_params():
    root = typer.main.get_command(app)
    with_params = {path for path, cmd in _commands(root) if "--params" in _options_of(cmd)}
    assert with_params == set(_ARGS)
    for path, cmd in _commands(root):
        opts = _options_of(cmd)
        assert "--base-params" not in opts or path.startswith("identify"), path
        if "--params" in opts:
            (prm,) = [p for p in cmd.params if "--params" in p.opts]
            assert prm.metavar == "PRESET|FILE" and "-p" in prm.opts, path


@pytest.fixture
def seen(monkeypatch):
    """The parameter sets the commands resolve; each command stops right after resolving."""
    resolved = []
    real = _options.resolve_params

    def stop_after(source, option="--params"):
        resolved.append(real(source, option))
        raise ParameterError("stopped after resolving the parameter set")

    for module in _MODULES:
        monkeypatch.setattr(module, "resolve_params", stop_after)
    return resolved


def _argv(command: str, tmp_path) -> list[str]:
    return [*command.split(), *(a.format(tmp=tmp_path) for a in _ARGS[command])]


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """A TOML file, a JSON document and a PWA-export-shaped JSON with a distinctive P_S."""
    d = tmp_path_factory.mktemp("params")
    prm = get_preset("paper").replace(**{"supply.pressure": 123e5})
    save_params(prm, d / "p.toml")
    (d / "p.json").write_text(json.dumps(prm.to_dict()))
    (d / "pwa.json").write_text(json.dumps({"schema": "hydropwa.pwa/1", "params": prm.to_dict()}))
    return d


@pytest.mark.parametrize("command", sorted(_ARGS))
@pytest.mark.parametrize("source", ["symmetric", "p.toml", "p.json", "pwa.json"])
def test_params_takes_a_preset_or_a_file(command, source, seen, files, tmp_path):
    src = source if source == "symmetric" else str(files / source)
    res = CliRunner().invoke(app, [*_argv(command, tmp_path), "--params", src])
    assert res.exit_code == 2 and "stopped after resolving" in res.output, res.output
    (prm,) = seen
    if source == "symmetric":
        assert prm == get_preset("symmetric")
    else:
        assert prm.supply.pressure == 123e5


@pytest.mark.parametrize("command", sorted(_ARGS))
def test_unknown_preset_is_one_line_and_exit_2(command, tmp_path, capsys):
    code = main([*_argv(command, tmp_path), "--params", "papr"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2
    assert len(err) == 1 and err[0].startswith(
        "error: --params 'papr' not found (no such preset or file)"
    )
    assert "paper, symmetric" in err[0]


def test_base_params_is_a_deprecated_alias(seen, files, tmp_path):
    argv = _argv("identify frf", tmp_path)
    res = CliRunner().invoke(app, [*argv, "--base-params", str(files / "p.toml")])
    assert res.exit_code == 2 and seen[0].supply.pressure == 123e5
    assert res.output.count("warning: --base-params is deprecated") == 1
    both = CliRunner().invoke(app, [*argv, "--base-params", "paper", "--params", "paper"])
    assert both.exit_code == 2 and "give --params only" in both.output


def test_resolve_params_errors(tmp_path):
    with pytest.raises(
        ParameterError, match=r"^no machine given: pass --params FILE .*--params paper"
    ):
        _options.resolve_params(None)
    assert _options.resolve_params("paper") == get_preset("paper")
    with pytest.raises(ParameterError, match="is a folder"):
        _options.resolve_params(tmp_path)
    (tmp_path / "bad.json").write_text('{"a": ')
    with pytest.raises(ParameterError, match="invalid JSON"):
        _options.resolve_params(tmp_path / "bad.json")
    (tmp_path / "nopar.json").write_text('{"schema": "hydropwa.pwa/1"}')
    with pytest.raises(ParameterError, match="without its 'params'"):
        _options.resolve_params(tmp_path / "nopar.json")


def test_help_texts_are_literal(capsys):
    assert main(["sweep", "--help"]) == 0
    assert "[grid], [random], [input]" in capsys.readouterr().out
    assert main(["simulate", "--help"]) == 0
    assert "Simulated time [s]" in " ".join(capsys.readouterr().out.split())


def test_importing_the_cli_leaves_showwarning_alone():
    code = (
        "import warnings; before = warnings.showwarning; import hydropwa.cli; "
        "assert warnings.showwarning is before, warnings.showwarning"
    )
    subprocess.run([sys.executable, "-c", code], check=True)


@pytest.fixture
def demo():
    """A small app made like every CLI app: a warning, an OS error, a bug."""
    demo = _app.new_app("demo")

    @demo.command("warn")
    def _warn() -> None:
        warnings.warn("careful: this is a test", stacklevel=1)

    @demo.command("oserror")
    def _oserror() -> None:
        raise OSError(errno.EROFS, "Read-only file system", "/ro/x.csv")

    @demo.command("bug")
    def _bug() -> None:
        raise ZeroDivisionError("1/0")

    return demo


def test_warnings_are_lines_only_while_a_command_runs(demo):
    before = warnings.showwarning
    with warnings.catch_warnings():
        warnings.simplefilter("always")
        res = CliRunner().invoke(demo, ["warn"])
    assert res.exit_code == 0
    assert res.output.strip() == "warning: careful: this is a test"
    assert warnings.showwarning is before


def test_one_error_path(demo):
    res = CliRunner().invoke(demo, ["oserror"])
    assert res.exit_code == 2
    assert res.output.strip() == (
        "error: /ro/x.csv: the file system is read-only; choose an output on a writable disk"
    )
    bug = CliRunner().invoke(demo, ["bug"])
    lines = bug.output.strip().splitlines()
    assert bug.exit_code == 1 and len(lines) == 1
    assert lines[0].startswith("error: internal error (ZeroDivisionError: 1/0)")


def test_help_texts_show_no_machine_words():
    """No integer-range limits of the machine word and no keyword spelling of an option in any
    command's help; every --duration takes units (issue 37)."""
    root = typer.main.get_command(app)
    for path, cmd in _commands(root):
        res = CliRunner().invoke(app, [*path.split(), "--help"], terminal_width=200)
        assert res.exit_code == 0, path
        assert "9223372036854775807" not in res.output, path
        assert "force=True" not in res.output and "overwrite=True" not in res.output, path
        for p in cmd.params:
            if "--duration" in getattr(p, "opts", ()):
                assert p.metavar == "TIME", path


def test_one_name_and_one_default_for_out_jobs_and_sampling():
    """--out/-o always has a default file or folder (nothing overwritten without --force);
    --jobs/-j always defaults to all cores; sampling is --sample-time PERIOD|RATE, its old
    names --fs and --rate hidden."""
    root = typer.main.get_command(app)
    seen = {"--out": 0, "--jobs": 0, "--sample-time": 0}
    for path, cmd in _commands(root):
        for p in cmd.params:
            opts = set(getattr(p, "opts", ()))
            if "--out" in opts:
                seen["--out"] += 1
                assert "-o" in opts and not p.required and p.default is not None, path
            if "--jobs" in opts:
                seen["--jobs"] += 1
                assert "-j" in opts and p.default is None, path
                assert _options.JOBS_HELP in p.help, path
            if "--sample-time" in opts:
                seen["--sample-time"] += 1
                assert p.metavar == _options.SAMPLE_TIME_METAVAR, path
            if opts & {"--fs", "--rate"}:
                assert p.hidden and "Deprecated name of --sample-time" in p.help, path
    assert seen["--out"] >= 14 and seen["--jobs"] == 3 and seen["--sample-time"] == 4, seen


def test_params_paper_is_the_papers_rig_and_ends_with_no_note(tmp_path, capsys):
    """The paper's rig is named (--params paper); the result says nothing more (the old
    closing note of a default machine is gone with the default, issue 37)."""
    args = ["simulate", "--model", "reduced", "--duration", "10 ms", "--params", "paper"]
    assert main([*args, "--out", str(tmp_path / "a.csv")]) == 0
    err = capsys.readouterr().err
    assert "note:" not in err and "no machine" not in err
