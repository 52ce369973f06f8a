"""Faulty measurements: dropouts, spikes, clipped converters, missing runs (reliability issue).

Identification and evaluation either use what is sound and say what they skipped, or stop
with a clear error; a result never silently includes the bad part. The campaign is the small
test campaign on the virtual rig; single runs are then damaged on disk.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

from hydropwa.data import check_run, read_dataset, read_run, write_run
from hydropwa.params import get_preset

CAMPAIGN = Path(__file__).parents[1] / "evaluation" / "small_campaign.toml"


@pytest.fixture(scope="module")
def campaign(tmp_path_factory):
    import hydropwa.rig as rig

    out = tmp_path_factory.mktemp("faulty") / "rig"
    rig.run_campaign(rig.Rig.from_params("paper"), rig.load_campaign(CAMPAIGN), out, seed=3, jobs=2)
    return out


def _copy(src: Path, dst: Path) -> Path:
    import shutil

    shutil.copytree(src, dst)
    return dst


def _damage(dataset: Path, name: str, fn) -> str:
    ds = read_dataset(dataset, validate=False)
    path = ds.path_of(name)
    run = read_run(path, validate=False)
    chans = {k: np.array(v) for k, v in run.channels.items()}
    fn(chans)
    write_run(run.replace(channels=chans), path)
    return name


def _stuck(ch, key="p_a", start=800, n=300):
    ch[key][start : start + n] = ch[key][start]


def _spike(ch, key="x", at=700, size=0.02):
    ch[key][at] += size  # default: 20 mm of position for one sample


def _clip(ch, key="spool"):
    top = np.max(ch[key])
    ch[key][100:400] = top


def test_check_run_reports_dropouts_and_spikes(campaign):
    ds = read_dataset(campaign / "friction", validate=False)
    run = ds[ds.names[0]]
    chans = {k: np.array(v) for k, v in run.channels.items()}
    _stuck(chans)
    _spike(chans, "p_b", 500, size=20e5)  # 20 bar for one sample
    issues = {i.code: i for i in check_run(run.replace(channels=chans))}
    assert issues["stuck"].channel == "p_a" and issues["stuck"].sample == 800
    assert issues["spike"].channel == "p_b" and issues["spike"].sample == 500
    assert "dropout" in str(issues["stuck"]) and run.name in str(issues["spike"])


def _identify(root, part):
    from hydropwa.identification import IdentificationWarning, identify

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        report = identify(root, parts=(part,), params=get_preset("paper"))
    messages = [str(w.message) for w in caught if issubclass(w.category, IdentificationWarning)]
    return report, messages


@pytest.mark.parametrize(
    "experiment, part, damage, word",
    [
        ("friction", "friction", _stuck, "dropout"),
        ("deadzone", "deadzone", _spike, "spike"),
        ("frf", "frf", _clip, "stuck at its maximum"),
    ],
)
def test_identification_skips_a_damaged_run_and_says_so(
    campaign, tmp_path, experiment, part, damage, word
):
    root = _copy(campaign / experiment, tmp_path / experiment)
    name = read_dataset(root, validate=False).names[1]
    _damage(root, name, damage)
    report, messages = _identify(root, part)
    assert any(name in m and word in m for m in messages), messages
    assert any(s.run == name and word in s.reason for s in report.skipped)
    # the damaged run is not in the data the estimate was made from
    clean, _ = _identify(_copy(campaign / experiment, tmp_path / "clean"), part)
    assert report.params != clean.params or experiment == "frf"


def test_missing_run_file_is_skipped_with_its_name(campaign, tmp_path):
    root = _copy(campaign / "deadzone", tmp_path / "deadzone")
    ds = read_dataset(root, validate=False)
    name = ds.names[0]
    ds.path_of(name).unlink()
    report, messages = _identify(root, "deadzone")
    assert any(name in m and "cannot be read" in m for m in messages), messages
    assert report.params.dead_zone.beta == pytest.approx(0.1, abs=0.005)


def test_nothing_sound_left_is_one_clear_error(campaign, tmp_path):
    from hydropwa import IdentificationError

    root = _copy(campaign / "friction", tmp_path / "friction")
    for name in read_dataset(root, validate=False).names:
        _damage(root, name, _stuck)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        from hydropwa.identification import identify

        with pytest.raises(IdentificationError):
            identify(root, parts=("friction",), params=get_preset("paper"))


def test_evaluation_skips_a_damaged_run_and_says_so(campaign, tmp_path):
    from hydropwa import get_preset
    from hydropwa.evaluation import EvaluationWarning, evaluate_dataset

    root = _copy(campaign / "sine", tmp_path / "sine")
    ds = read_dataset(root, validate=False)
    bad = ds.names[0]
    _damage(root, bad, lambda ch: ch["p_s"].__setitem__(slice(300, 340), np.nan))
    with pytest.warns(
        EvaluationWarning,
        match=rf"run '{bad}' skipped: bad data: .*p_s.*non-finite|run '{bad}' skipped",
    ):
        df = evaluate_dataset(
            read_dataset(root, validate=False), get_preset("paper"), models=("full",)
        )
    assert bad not in set(df["run"]) and len(set(df["run"])) == len(ds.names) - 1
