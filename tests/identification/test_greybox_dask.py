"""Multi-start and profiles of the grey-box fit as Dask tasks (issue 36): the same estimates
as in-process.

A LocalCluster of two single-threaded workers in this process (``processes=False``: worker
processes would each load the compiled kernel first, seconds on a loaded machine, and test
nothing more: the tasks travel pickled either way). The fit: flow coefficient and bulk
modulus from one 0.5 s sine run, two starts, both parameters profiled. The connection error
(one line) is the shared ``hydropwa._dask`` path, tested with the sweeps.
"""

from __future__ import annotations

import distributed
import numpy as np
import pytest
from ident_support import noisy_run

from hydropwa.identification import fit_model
from hydropwa.models import FullOrderModel
from hydropwa.simulation import Sine

FREE = ("flow.K", "oil.bulk_modulus")


def _fit(truth, runs, **kw):
    start = FullOrderModel(truth.replace(**{"flow.K": 1.05 * truth.flow.K}))
    seen = []
    fit = fit_model(
        start, runs, FREE, jobs=1, starts=2, profile="all", nuisance_draws=0,
        scan_intervals=False, progress=seen.append, **kw,
    )  # fmt: skip
    return fit, seen


def test_starts_and_profiles_on_a_local_cluster_match_the_in_process_fit(truth):
    m = FullOrderModel(truth)
    runs = [noisy_run(m, Sine(amplitude=0.5, frequency=2.0), 0.5, 1, name="s")]
    here, _ = _fit(truth, runs)
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=False, dashboard_address=None
    ) as cluster:
        there, seen = _fit(truth, runs, scheduler=cluster.scheduler_address)
    # the same computations on the workers: equal to far below the optimiser's xtol (1e-4)
    for n in FREE:
        assert there.estimates_[n].value == pytest.approx(here.estimates_[n].value, rel=1e-9)
        np.testing.assert_allclose(
            there.profiles_[n].cost, here.profiles_[n].cost, rtol=1e-9, atol=1e-9
        )
    assert [s.cost for s in there.starts_] == pytest.approx([s.cost for s in here.starts_])
    # each start reported from the caller as it was sent and as it came back
    starts = [(e.start, e.event) for e in seen if e.stage == "start"]
    assert starts == [(1, "begin"), (2, "begin"), (1, "end"), (2, "end")]
