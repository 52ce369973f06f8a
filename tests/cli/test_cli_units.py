"""One vocabulary (issue 37): times and rates take units everywhere; messages name options."""

from __future__ import annotations

import pytest

from hydropwa.cli import main
from hydropwa.data import read_run


@pytest.mark.parametrize(
    "duration, fs, n",
    [("50 ms", "1 kHz", 51), ("0.05 s", "1000", 51), ("0.05", "2 kHz", 101)],
)
def test_simulate_takes_duration_and_rate_with_units(tmp_path, duration, fs, n):
    out = tmp_path / "r.csv"
    argv = ["simulate", "--model", "reduced", "--duration", duration, "--fs", fs, "--out", str(out)]
    assert main(argv) == 0
    run = read_run(out)
    assert run.t.size == n and run.t[-1] == pytest.approx(0.05, rel=1e-12)


@pytest.mark.parametrize("bad", ["2 bar", "x", "nan"])
def test_a_duration_of_the_wrong_kind_is_one_line(tmp_path, capsys, bad):
    code = main(["simulate", "--duration", bad, "--out", str(tmp_path / "r.csv")])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "--duration" in err, err


def test_cli_messages_name_the_option_not_the_keyword(tmp_path, capsys):
    """'pass --force (force=True)' is the library's message; the CLI shows '--force' only."""
    out = tmp_path / "r.csv"
    out.write_text("keep")
    assert main(["simulate", "--duration", "10 ms", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "--force" in err and "force=True" not in err and "overwrite=True" not in err
    assert out.read_text() == "keep"


def test_no_machine_word_ranges_in_help(tmp_path, capsys):
    assert main(["rig", "run", "--help"]) == 0
    text = capsys.readouterr().out
    assert "9223372036854775807" not in text and "[x>=0]" in text
    assert main(["rig", "run", "frf", "--seed", str(2**63), "--out", str(tmp_path / "x")]) == 2
    assert "2**63" in capsys.readouterr().err
