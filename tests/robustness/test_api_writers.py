"""The library's writers refuse an existing target unless told to overwrite (issue: nothing is
lost), and leave the existing file untouched when they refuse."""

from __future__ import annotations

import pytest

from hydropwa import OutputExistsError, PwaError, get_preset, simulate
from hydropwa.linearization import linearize, save_pwa, save_pwa_mat
from hydropwa.params import save_params


@pytest.fixture(scope="module")
def result():
    return simulate(
        "reduced", "sine:amplitude=0.3,frequency=2", duration=0.05, params=get_preset("paper")
    )


@pytest.mark.parametrize(
    "writer", ["to_csv", "to_parquet", "save_params", "save_pwa", "save_pwa_mat"]
)
def test_writers_refuse_an_existing_file(tmp_path, result, writer):
    suffix = {
        "to_csv": ".csv",
        "to_parquet": ".parquet",
        "save_params": ".toml",
        "save_pwa": ".json",
        "save_pwa_mat": ".mat",
    }[writer]
    target = tmp_path / f"out{suffix}"
    target.write_bytes(b"precious")
    pwa = linearize(get_preset("paper")) if writer.startswith("save_pwa") else None
    calls = {
        "to_csv": lambda **kw: result.to_csv(target, **kw),
        "to_parquet": lambda **kw: result.to_parquet(target, **kw),
        "save_params": lambda **kw: save_params(get_preset("paper"), target, **kw),
        "save_pwa": lambda **kw: save_pwa(pwa, target, **kw),
        "save_pwa_mat": lambda **kw: save_pwa_mat(pwa, target, **kw),
    }
    with pytest.raises((OutputExistsError, PwaError)) as info:
        calls[writer]()
    assert "exist" in str(info.value)
    assert target.read_bytes() == b"precious"
    calls[writer](overwrite=True)
    assert target.read_bytes() != b"precious"
