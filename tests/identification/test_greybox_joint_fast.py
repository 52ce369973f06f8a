"""A fast joint grey-box fit of a small whole campaign on two machines (issue 36).

``tests/machines/joint_small.toml`` (two FRF runs, four friction runs against 1 kN with the
counter cylinder's damping, one sine) on the virtual rig of the paper rig and of the heavy
axis; ``fit_campaign`` fits valve ω0 and ζ, flow coefficient, bulk modulus and the sliding
friction (F_c, σ) jointly from K −10 %, E +20 %, ζ +10 %, F_c and σ +20 % (``start="params"``:
no identify all), with a 3 s selection, 20 iterations, no nuisance draws and no interval
scan: some 10 s per machine on two cores.

Tolerances: the per-experiment methods' (``test_greybox_joint.py``): ω0, ζ and K 2 %, E and
the friction 10 %. Measured: ω0 −0.6/−0.4 %, ζ −0.8/−0.3 %, K −0.01/−0.01 %, E +0.03/−0.05 %,
F_c −0.3/+6.6 %, σ +0.1/−3.6 % (paper/heavy axis), and the friction runs' steady means agree
with the joint friction on both (``check_friction``).
"""

from __future__ import annotations

import warnings

import pytest
from test_greybox_joint import MACHINES, machine
from test_greybox_joint import TOLERANCE as JOINT_TOLERANCE

from hydropwa.identification import IdentificationWarning, fit_campaign
from hydropwa.identification.greybox import Selection
from hydropwa.rig import Rig, load_campaign, run_campaign

FREE = (
    "valve.omega0",
    "valve.zeta",
    "flow.K",
    "oil.bulk_modulus",
    "friction.coulomb",
    "friction.viscous",
)
#: the start: factors on the truth (ω0 stays: the model reads its Table II schedule)
START = {
    "valve.zeta": 1.1,
    "flow.K": 0.9,
    "oil.bulk_modulus": 1.2,
    "friction.coulomb": 1.2,
    "friction.viscous": 1.2,
}
#: the per-experiment methods' tolerances (the slow recovery test's), for the free parameters
TOLERANCE = {name: tol for name, tol in JOINT_TOLERANCE.items() if name in FREE}


def _value(params, name: str) -> float:
    comp, field = name.split(".")
    return float(getattr(getattr(params, comp), field))


@pytest.mark.parametrize("name", ["paper", "industrial"])
def test_a_small_campaign_is_fitted_jointly(name, tmp_path):
    truth = machine(name)
    run_campaign(Rig(params=truth), load_campaign(MACHINES / "joint_small.toml"), tmp_path)
    start = truth.replace(**{n: f * _value(truth, n) for n, f in START.items()})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", IdentificationWarning)
        got = fit_campaign(
            tmp_path, FREE, params=start, start="params", jobs=2, max_nfev=20,
            nuisance_draws=0, scan_intervals=False,
            selection=Selection(method="events", by_experiment=True, budget=3.0),
        )  # fmt: skip
    est = got.fit.estimates_
    for n, tol in TOLERANCE.items():
        assert est[n].value == pytest.approx(_value(truth, n), rel=tol), n
    # every experiment contributed, and the friction runs' means agree with the joint fit
    assert {r.name.split("_")[0] for r in got.fit.runs_} >= {"frf", "friction", "sine"}
    assert any("friction runs alone agree" in note for note in got.fit.data_)
