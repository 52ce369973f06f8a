"""``hydropwa linearize``: files written, one-line errors."""

from __future__ import annotations

import json

import pytest
from typer.testing import CliRunner

from hydropwa._errors import HydropwaError, PwaError
from hydropwa.cli import app
from hydropwa.cli._linearize import linearize_command, parse_cells
from hydropwa.linearization import load_pwa


def test_cli_writes_json_figures_tables(tmp_path):
    res = CliRunner().invoke(
        app,
        [
            "linearize",
            "--params",
            "paper",
            "--out",
            str(tmp_path / "pwa.json"),
            "--supply-pressure",
            "95 bar",
            "--figures",
            str(tmp_path / "fig"),
            "--tables",
            str(tmp_path / "tab"),
        ],
    )
    assert res.exit_code == 0, res.output
    m = load_pwa(tmp_path / "pwa.json")
    assert m.supply_pressure == pytest.approx(95e5)
    for name in ("fig01_cq.png", "fig01_cq.svg", "fig02_cqp.png", "fig02_cqp.svg"):
        assert (tmp_path / "fig" / name).stat().st_size > 0
    assert (tmp_path / "tab" / "paper_table_VIII.csv").exists()
    assert json.loads((tmp_path / "pwa.json").read_text())["schema"] == "hydropwa.pwa/1"


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"cells": "cq=five"}, "not an integer"),
        ({"cells": "cq5"}, "name=count"),
        ({"cells": "cq=0"}, "positive integer"),
        ({"supply_pressure": "-3 bar"}, "supply pressure"),
        ({"supply_pressure": "3 m"}, "dimension"),
    ],
)
def test_bad_input_one_line_error(tmp_path, kwargs, match):
    with pytest.raises(HydropwaError, match=match) as exc:
        linearize_command(tmp_path / "pwa.json", params="paper", **kwargs)
    assert "\n" not in str(exc.value)


def test_parse_cells():
    assert parse_cells("cq=3, friction=9") == {"cq": 3, "friction": 9}
    with pytest.raises(PwaError):
        parse_cells("=3")
