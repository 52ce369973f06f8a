"""Every figure reads its argument through a protocol declared in ``plotting/_shapes.py``; the
result classes of the layers above carry every member their protocol names (checked on the
classes, so a rename upstream fails here rather than in a figure)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from hydropwa.control import TrackingMetrics, Verification, VerificationCriteria
from hydropwa.data import Run
from hydropwa.evaluation import EvaluationResult
from hydropwa.evaluation._engineering import BodeComparison, CellLoops
from hydropwa.identification import GreyBoxFit
from hydropwa.identification._deadzone import DeadZoneFit
from hydropwa.identification._frf import FrequencyResponse
from hydropwa.identification._friction_curve import StribeckFit
from hydropwa.identification._inverse_dynamics import EmpsResult, InverseDynamicsResult
from hydropwa.plotting import plot_closed_loop, plot_inverse_dynamics, plot_metrics
from hydropwa.plotting._shapes import (
    BodeComparisonShape,
    CellLoopsShape,
    ClosedLoopRun,
    EvaluationShape,
    ForceFit,
    ForceModel,
    FrequencyResponseShape,
    FrictionPoints,
    HoldsForceFit,
    MetricTable,
    Recorded,
    TracedFit,
    VelocityModel,
)
from hydropwa.simulation import SimulationResult

PAIRS = [
    (BodeComparison, BodeComparisonShape),
    (CellLoops, CellLoopsShape),
    (InverseDynamicsResult, ForceFit),
    (SimulationResult, ClosedLoopRun),
    (TrackingMetrics, MetricTable),
    (Verification, MetricTable),
    (GreyBoxFit, TracedFit),
    (EvaluationResult, EvaluationShape),
    (SimulationResult, Recorded),
    (Run, Recorded),
    (DeadZoneFit, VelocityModel),
    (StribeckFit, FrictionPoints),
    (StribeckFit, ForceModel),
    (FrequencyResponse, FrequencyResponseShape),
    (EmpsResult, HoldsForceFit),
]


def _members(proto: type) -> set[str]:
    own = {n for n in vars(proto) if not n.startswith("_") or n == "__getitem__"}
    return own - {"__protocol_attrs__", "__non_callable_proto_members__"}


@pytest.mark.parametrize(("cls", "proto"), PAIRS, ids=lambda c: c.__name__)
def test_result_classes_carry_what_their_figure_reads(cls, proto):
    have = set(dir(cls))
    if dataclasses.is_dataclass(cls):
        have |= {f.name for f in dataclasses.fields(cls)}
    missing = _members(proto) - have
    assert not missing, f"{cls.__name__} lacks {sorted(missing)} of {proto.__name__}"


def _verdict() -> Verification:
    worst = {"hold_peak_to_peak_mm": 0.15, "saturation_percent": 2.0, "limit_cycles": 0.0}
    crit = dataclasses.asdict(VerificationCriteria())
    return Verification(False, worst, ["hold over"], [], {"criteria": crit})


def test_metric_bars_mark_a_value_over_its_limit():
    v = _verdict()
    fig = v.plot()
    bars = fig.axes[0].patches
    assert len(bars) == 3
    # 0.15 mm peak to peak against the 0.1 mm limit is red; 2 % saturation of 10 % is not
    widths = [b.get_width() for b in bars]
    assert widths == pytest.approx([0.15, 2.0, 0.0])
    red = [b.get_facecolor()[:3] for b in bars]
    assert red[0] != red[1] and red[1] == red[2]
    labels = [t.get_text() for t in fig.axes[0].get_yticklabels()]
    assert labels == ["hold_peak_to_peak_mm [mm]", "saturation_percent [%]", "limit_cycles [1]"]


def test_a_wrong_argument_is_one_line():
    with pytest.raises(TypeError, match="plot_metrics: a dict has no display, display_units"):
        plot_metrics({"x": 1.0})
    with pytest.raises(TypeError, match="plot_closed_loop: a list has no model, t, control"):
        plot_closed_loop({"full": [1, 2]})
    with pytest.raises(TypeError, match="plot_inverse_dynamics: a ndarray has no time, force"):
        plot_inverse_dynamics(np.zeros(3))
