"""One vocabulary (issue 37): times and rates take units everywhere; messages name options."""

from __future__ import annotations

import pytest

from hydropwa.cli import main
from hydropwa.data import read_run


@pytest.mark.parametrize(
    "duration, sampling, n",
    [("50 ms", "1 kHz", 51), ("0.05 s", "1 ms", 51), ("0.05", "5e-4", 101), ("0.05", "2 kHz", 101)],
)
def test_simulate_takes_duration_and_sampling_with_units(tmp_path, duration, sampling, n):
    """--sample-time takes a period or a rate; a plain number is seconds."""
    out = tmp_path / "r.csv"
    argv = [
        "simulate",
        "-p",
        "paper",
        "--model",
        "reduced",
        "--duration",
        duration,
        "--sample-time",
        sampling,
    ]
    assert main([*argv, "--out", str(out)]) == 0
    run = read_run(out)
    assert run.t.size == n and run.t[-1] == pytest.approx(0.05, rel=1e-12)


def test_old_sampling_names_still_work_and_warn(tmp_path, capsys):
    """--fs (simulate) keeps working, a plain number still in Hz, with one warning line."""
    out = tmp_path / "r.csv"
    argv = ["simulate", "-p", "paper", "--model", "reduced", "--duration", "50 ms", "--fs", "1000"]
    assert main([*argv, "--out", str(out)]) == 0
    assert read_run(out).t.size == 51
    err = capsys.readouterr().err
    assert "warning: --fs is deprecated" in err and "--sample-time" in err
    assert main([*argv, "--sample-time", "1 ms", "--out", str(tmp_path / "s.csv")]) == 2
    assert "give --sample-time only" in capsys.readouterr().err


@pytest.mark.parametrize(
    "text, seconds",
    [("0.5 ms", 5e-4), ("2 kHz", 5e-4), ("0.001", 1e-3), ("500 us", 5e-4), ("1 min", 60.0)],
)
def test_sample_time_is_a_period_or_a_rate(text, seconds):
    from hydropwa.cli._options import parse_sample_time, sample_time_source

    assert parse_sample_time(text) == pytest.approx(seconds, rel=1e-12)
    assert parse_sample_time(sample_time_source(None, "2000", "--rate", "Hz")) == 5e-4


@pytest.mark.parametrize("bad", ["0", "-1 ms", "0 Hz", "2 bar", "x", "inf"])
def test_a_bad_sample_time_is_one_message(bad):
    from hydropwa import ParameterError
    from hydropwa.cli._options import parse_sample_time

    with pytest.raises(ParameterError, match=r"--sample-time .*(period|positive)"):
        parse_sample_time(bad)


@pytest.mark.parametrize("bad", ["2 bar", "x", "nan"])
def test_a_duration_of_the_wrong_kind_is_one_line(tmp_path, capsys, bad):
    code = main(["simulate", "-p", "paper", "--duration", bad, "--out", str(tmp_path / "r.csv")])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "--duration" in err, err


def test_cli_messages_name_the_option_not_the_keyword(tmp_path, capsys):
    """'pass --force (force=True)' is the library's message; the CLI shows '--force' only."""
    out = tmp_path / "r.csv"
    out.write_text("keep")
    assert main(["simulate", "-p", "paper", "--duration", "10 ms", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "--force" in err and "force=True" not in err and "overwrite=True" not in err
    assert out.read_text() == "keep"


def test_no_machine_word_ranges_in_help(tmp_path, capsys):
    assert main(["rig", "run", "--help"]) == 0
    text = capsys.readouterr().out
    assert "9223372036854775807" not in text and "[x>=0]" in text
    assert (
        main(
            ["rig", "run", "frf", "-p", "paper", "--seed", str(2**63), "--out", str(tmp_path / "x")]
        )
        == 2
    )
    assert "--seed" in (err := capsys.readouterr().err) and "below 2^32" in err  # one line
