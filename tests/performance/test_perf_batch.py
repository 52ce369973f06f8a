"""simulate_batch gives exactly the one-by-one results, in case order."""

import dataclasses

import numpy as np
import pytest

from hydropwa import ReducedModel
from hydropwa.simulation import SUMMARY_COLUMNS, simulate, simulate_batch, summarize


def _params(paper, mass):
    return dataclasses.replace(paper, load=dataclasses.replace(paper.load, mass=mass))


@pytest.mark.parametrize("model", ["full", "reduced"])
def test_batch_over_parameters_equals_one_by_one(paper, model):
    params = [_params(paper, m) for m in (1.0, 1.394, 3.0)]
    u = "sine:amplitude=0.4,frequency=2"
    batch = simulate_batch(params, u, model=model, duration=0.6, rtol=1e-3, jobs=3)
    # the output pass ran on the pool's threads, not on the caller's first read
    assert all(res.channels._pending is None for res in batch)
    for prm, res in zip(params, batch, strict=True):
        one = simulate(model, u, params=prm, duration=0.6, rtol=1e-3)
        assert res.params == prm
        for ch in one.channels:
            np.testing.assert_array_equal(res[ch], one[ch], err_msg=ch)


def test_batch_over_inputs_broadcasts_one_model_and_summarizes(paper):
    inputs = [f"sine:amplitude={a},frequency=2" for a in (0.2, 0.4, 0.8)]
    rows = simulate_batch(
        ReducedModel(paper), inputs, duration=1.0, rtol=1e-3, summary=True, jobs=2
    )
    assert [list(r) for r in rows] == [list(SUMMARY_COLUMNS)] * 3
    for u, row in zip(inputs, rows, strict=True):
        ref = summarize(simulate(ReducedModel(paper), u, duration=1.0, rtol=1e-3))
        assert {k: v for k, v in row.items() if k != "wall_time"} == {
            k: v for k, v in ref.items() if k != "wall_time"
        }
    # a larger command moves the rod faster
    assert rows[0]["peak_velocity"] < rows[1]["peak_velocity"] < rows[2]["peak_velocity"]


def test_batch_reports_progress_and_rejects_mismatched_lengths(paper):
    seen = []
    simulate_batch(
        [ReducedModel(paper)] * 2,
        0.1,
        duration=0.05,
        progress=lambda d, n: seen.append((d, n)),
        jobs=1,
    )
    assert seen == [(1, 2), (2, 2)]
    from hydropwa._errors import SignalError

    with pytest.raises(SignalError, match="cannot pair 2 models with 3 inputs"):
        simulate_batch([ReducedModel(paper)] * 2, [0.1, 0.2, 0.3], duration=0.05)
