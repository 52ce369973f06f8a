"""Which data of a campaign enter the grey-box fit: the segments that excite the free parameters.

A campaign (dozens of runs, minutes of data) repeats itself: the steady part of a
constant-input run says the same at every instant, while what separates the parameters is
concentrated in short transients. :class:`Selection` keeps, per run, the segments around the
events that excite the free parameters and a few steady ones, within a budget of segments over
the campaign:

* friction: the rod's motion events — leaving standstill or an end stop (breakaway through the
  Stribeck peak), stopping, reversing (:data:`EXCITED_BY`);
* valve dynamics (ω0, ζ): steps of the command;
* bulk modulus, leakage, dead volumes: pressure transients, driven by command and load steps;
* every other parameter: command steps and motion events.

Kept segments count as measured (no weights): the cost and its covariance stay those of the
data actually fitted, and the intervals widen honestly with the data left out.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence

import numpy as np

from ..._errors import IdentificationError
from .data import RunData, _mask_runs

__all__ = ["EXCITED_BY", "Selection", "events", "restrict", "spans"]

#: the events that excite each parameter group (by the component part of its name)
EXCITED_BY: dict[str, tuple[str, ...]] = {
    "friction": ("motion",),
    "valve": ("command",),
    "oil": ("command", "load"),
    "cylinder": ("command", "load"),
}
_DEFAULT_EVENTS = ("command", "motion")


@dataclasses.dataclass(frozen=True)
class Selection:
    """How segments are chosen from a campaign.

    Attributes
    ----------
    method : {"auto", "all", "events"}
        ``auto``: select when the prepared data hold more than ``threshold`` seconds of
        simulation (the benchmark's nine 5 s sine runs, 45 s, are fitted whole);
        ``events``: always select; ``all``: fit every segment.
    threshold : float
        Seconds of prepared data above which ``auto`` selects.
    budget : float
        Seconds of simulated data over the campaign after the selection. One evaluation of
        the paper rig's model runs about 6 s of data per second of one core, and a fit of six
        parameters takes some 300 evaluations: 6 s keep it within minutes on two cores.
    segment : float
        Length [s] of the single-shooting segments of a selected campaign (a transient and a
        steady stretch each fill one).
    transient : float
        Length [s] after an event whose segments count as exciting (the breakaway and the
        pressure transient of the paper rig settle within 0.1 s).
    steady_per_run : float
        Seconds of segments kept per run outside the events, evenly spaced (the steady
        friction at that run's speed); at least one segment.
    per_run : float
        Seconds of segments kept per run at most (the events' first); at least two segments.
    departures : bool
        Keep the rod's departures from the end stops (from 50 µm away) when friction is
        free: the breakaway. Off by default: on the virtual rig's friction campaign the rod
        leaves the stop at 20–70 mm/s within 50 µm, and the smoothed initial velocity across
        that kink is biased (cost at the true parameters 1.6× that without them).
    feedback : bool
        Estimate the load's velocity-proportional force from the runs' steady parts and
        apply it in the model from the simulated velocity (``load_feedback``).
    steady_means : bool
        Add each run's steady stretch as its means (:func:`~hydropwa.identification.greybox.steady.steady_runs`): the
        information of the samples the selection leaves out, at the cost of one short
        simulation per run. On the virtual rig's friction campaign, fitted alone (see
        ``transients``), they took the Coulomb friction from −15.8 % to −0.6 % (paper set)
        and from −21.4 % to +1.3 % (set B).
    transients : bool or None
        Fit segments of the runs (None: unless only friction parameters are free, the load
        feedback applies and the steady means are there; then the steady means alone are
        fitted). The measured force then holds c·ẋ: within the milliseconds of a motion
        event the smoothed velocity taken out of it misses c·(ẋ − ẋ̂), tens of newtons,
        and each segment starts from smoothed measurements whose errors the model turns into
        a drift. On the virtual rig's friction campaign (paper set) F_c came out −22.6 %
        with the event segments, −4.0 … −26.1 % with steady segments only (by which
        segment of each run was kept), −0.6 % from the means alone (F_s −0.3 %, σ +0.2 %;
        set B: +1.3, −4.7, −0.3 %); the smoothness, which acts only around standstill, is
        then reported as not determined.
    standstill : bool
        Keep the segments that start near standstill (the creeping runs, the breakaway).
        With the load feedback they inform F_s, the Stribeck velocity and the smoothness:
        on the virtual rig's friction campaign (paper set) F_s −2.6 % with them against
        −7.6 % without, the smoothness +2 % against undetermined; on a set with
        F_c 40 N, F_s 120 N, v_s 10 mm/s F_s +15 % against +115 %. Without them the
        paper set's F_c came out closer (−7.7 % against −15.8 %).
    by_experiment : bool
        Share the budget equally between the experiments (``meta["experiment"]``) and
        spread the runs within each (the joint fit of a whole campaign: otherwise the many
        runs of one experiment, or the FRF runs' common zero speed, decide which are kept).
    """

    method: str = "auto"
    threshold: float = 60.0
    budget: float = 6.0
    segment: float = 0.1
    transient: float = 0.1
    steady_per_run: float = 0.1
    per_run: float = 0.2
    departures: bool = False
    feedback: bool = True
    standstill: bool = True
    steady_means: bool = True
    transients: bool | None = None
    by_experiment: bool = False

    def __post_init__(self) -> None:
        if self.method not in ("auto", "all", "events"):
            raise IdentificationError(
                f"Selection.method = {self.method!r}; choose auto, all or events"
            )
        for name in ("threshold", "budget", "segment", "transient"):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and math.isfinite(v) and v > 0):
                raise IdentificationError(f"Selection.{name} = {v!r} s must be > 0")

    def applies(self, seconds: float) -> bool:
        """Whether a campaign whose prepared segments hold ``seconds`` of data is selected."""
        return self.method == "events" or (self.method == "auto" and seconds > self.threshold)

    def wanted(self, names: Sequence[str]) -> tuple[str, ...]:
        """The event kinds that excite the parameters ``names``."""
        kinds: list[str] = []
        for n in names:
            for k in EXCITED_BY.get(n.split(".", 1)[0], _DEFAULT_EVENTS):
                if k not in kinds:
                    kinds.append(k)
        return tuple(kinds)

    def select(
        self,
        runs: list[RunData],
        names: Sequence[str],
        v_move: float,
        transients: bool = True,
        groups: Sequence[str | None] | None = None,
    ) -> tuple[list[RunData], str]:
        """The runs with their selected segments, and a sentence saying what was kept.

        Each run offers its segments after the events and ``steady_per_run`` steady ones,
        at most ``per_run``; when that exceeds the budget, runs are kept evenly spaced over
        the campaign's operating points (ordered by their median speed, signed): neighbouring
        constant-input runs repeat each other. ``transients=False``: no segment (the steady
        means alone are fitted, see the attribute ``transients``). ``groups``: each run's
        experiment; the budget is then shared equally between the experiments (at least two
        runs each) and the runs are spread within each, so that every experiment of a whole
        campaign contributes (the joint fit: FRF runs all stand at zero median speed).
        """
        kinds = self.wanted(names)
        seconds = sum(_duration(rd) for rd in runs)
        per_segment = seconds / max(sum(len(rd.segments) for rd in runs), 1)
        n_run = max(2, int(round(self.per_run / per_segment)))
        n_steady = min(n_run - 1, max(1, int(round(self.steady_per_run / per_segment))))
        n_keep = max(1, int(self.budget / (n_run * per_segment)))
        kept_runs = _spread(runs, n_keep, groups)
        out, n_event, got_steady, n_all = [], 0, 0, 0
        for k, rd in enumerate(runs):
            if k not in kept_runs:
                out.append(dataclasses.replace(rd, segments=[]))
                continue
            ev = events(rd, kinds, v_move)
            if "motion" in kinds:
                rd = rd if self.standstill else _moving_starts(rd, v_move)
            keep_e, keep_s = _pick(rd, ev, self.transient, n_steady, n_run)
            if not transients:  # the steady means carry it (see ``transients``)
                keep_e, keep_s = [], []
            n_event += len(keep_e)
            got_steady += len(keep_s)
            n_all += len(rd.segments)
            chosen = sorted(keep_e + keep_s)
            out.append(dataclasses.replace(rd, segments=[rd.segments[i] for i in chosen]))
        what = ", ".join(_KIND_WORDS[k] for k in kinds)
        kept = sum(_duration(rd) for rd in out)
        note = (
            f"Selected {kept:.3g} s of {seconds:.3g} s of data (budget {self.budget:g} s): "
            f"{len(kept_runs)} of {len(runs)} runs, evenly spaced over their speeds "
            f"{_per_group(kept_runs, groups)}"
            f"(neighbouring operating points repeat each other), and of those {n_event + got_steady}"
            f" of {n_all} segments: {n_event} within {1e3 * self.transient:.0f} ms after {what} "
            f"(they excite {', '.join(names)}) and {got_steady} steady ones "
            f"({n_steady} per run, spread over its steady part: the rest repeats them)."
        )
        return out, note


def _spread(runs: list[RunData], n_keep: int, groups: Sequence[str | None] | None) -> set[int]:
    """Indices of ``n_keep`` runs evenly spaced over their median speeds, within each group
    (an equal share each, at least two) when ``groups`` is given."""
    labels = list(groups) if groups is not None else [None] * len(runs)
    members: dict[str | None, list[int]] = {}
    for k, g in enumerate(labels):
        members.setdefault(g, []).append(k)
    share = max(2, n_keep // len(members)) if groups is not None else n_keep
    kept: set[int] = set()
    for idx in members.values():
        order = sorted(idx, key=lambda k: _median_speed(runs[k]))
        if share < len(order):
            pick = np.unique(np.round(np.linspace(0, len(order) - 1, share)).astype(int))
            order = [order[int(i)] for i in pick]
        kept.update(order)
    return kept


def _per_group(kept: set[int], groups: Sequence[str | None] | None) -> str:
    """ "(per experiment: frf 3, …) " for a selection by experiment, else ""."""
    if groups is None:
        return ""
    count: dict[str, int] = {}
    for k in sorted(kept):
        g = str(groups[k] or "unlabelled")
        count[g] = count.get(g, 0) + 1
    return "(per experiment: " + ", ".join(f"{g} {n}" for g, n in count.items()) + ") "


_KIND_WORDS = {
    "motion": "the rod's motion events (leaving standstill or an end stop, stopping, reversing)",
    "command": "command steps",
    "load": "load-force steps",
}


def _steps(y: np.ndarray, t: np.ndarray, rel: float) -> list[float]:
    """Times where ``y`` changes by more than ``rel`` of its range within 5 ms (the start of
    those 5 ms: a window that starts there holds the state before the step)."""
    span = float(np.ptp(y)) if y.size else 0.0
    if span <= 0:
        return []
    dt = float(np.median(np.diff(t)))
    k = max(1, int(round(0.005 / dt)))
    jump = np.abs(y[k:] - y[:-k]) > rel * span
    return [float(t[s]) for s, _e in _mask_runs(jump)]


def events(rd: RunData, kinds: Sequence[str], v_move: float) -> list[float]:
    """Times [s] of the run's events of ``kinds``: ``motion`` (|v| crossing ``v_move``, or
    five noise levels of the smoothed velocity, either way for 10 ms at least; sign changes
    while moving), ``command`` (steps of u by 5 % of its range), ``load``
    (steps of F_L by 5 % of its range)."""
    t = rd.t
    out: list[float] = []
    if "motion" in kinds and rd.speed is not None:
        # above the smoothed velocity's noise too, and for 10 ms at least: the noise of a
        # rod at rest crosses a small threshold now and then
        v_lim = max(v_move, 5.0 * rd.meas_sd.get("v", 0.0))
        k = max(1, int(round(0.01 / float(np.median(np.diff(t))))))
        moving = np.zeros(t.size, bool)
        for s, e in _mask_runs(np.abs(rd.speed) > v_lim):
            moving[s:e] = e - s >= k
        for s, e in _mask_runs(moving):
            out.append(float(t[s]))
            if e < t.size:
                out.append(float(t[e - 1]))
        sign = np.sign(rd.speed)
        flips = np.flatnonzero((sign[1:] * sign[:-1] < 0) & moving[1:])
        out += [float(t[i]) for i in flips]
    if "command" in kinds:
        out += _steps(rd.u, t, 0.05)
    if "load" in kinds and rd.f_l is not None:
        out += _steps(rd.f_l, t, 0.05)
    return sorted(out)


def _pick(
    rd: RunData, ev: list[float], transient: float, n_steady: int, per_run: int
) -> tuple[list[int], list[int]]:
    """Indices of the segments after an event (earliest after each event first, at most
    ``per_run`` − the steady ones) and of the steady ones (evenly spaced)."""
    t0 = np.array([rd.t[s.i0] for s in rd.segments])
    t1 = np.array([rd.t[s.i1 - 1] for s in rd.segments])
    lag = np.full(t0.size, np.inf)
    for te in ev:
        hit = (t1 >= te) & (t0 <= te + transient)
        lag = np.where(hit, np.minimum(lag, np.maximum(t0 - te, 0.0)), lag)
    event_idx = [int(i) for i in np.argsort(lag, kind="stable") if np.isfinite(lag[i])]
    rest = [i for i in range(t0.size) if not np.isfinite(lag[i])]
    steady = min(n_steady, len(rest), per_run)
    keep_e = event_idx[: max(per_run - steady, 0)]
    # evenly spaced through the rest, away from its ends (the approach to an event)
    pick = sorted({int((k + 0.5) * len(rest) / steady) for k in range(steady)})
    keep_s = [rest[int(i)] for i in pick]
    return keep_e, keep_s


def _duration(rd: RunData) -> float:
    """Simulated seconds of a prepared run's segments."""
    return float(sum(rd.t[s.i1 - 1] - rd.t[s.i0] for s in rd.segments))


def spans(rd: RunData) -> list[tuple[float, float]]:
    """The time spans [s] of a run's segments."""
    return [(float(rd.t[s.i0]), float(rd.t[s.i1 - 1])) for s in rd.segments]


def restrict(rd: RunData, keep: list[tuple[float, float]]) -> RunData:
    """``rd`` with the segments that overlap one of the spans ``keep`` [s]."""
    segs = [s for s in rd.segments if any(rd.t[s.i0] <= b and rd.t[s.i1 - 1] >= a for a, b in keep)]
    return dataclasses.replace(rd, segments=segs)


def _median_speed(rd: RunData) -> float:
    """The run's median smoothed speed [m/s] (signed) over its segments."""
    if rd.speed is None or not rd.segments:
        return 0.0
    return float(np.median(np.concatenate([rd.speed[s.i0 : s.i1] for s in rd.segments])))


def _moving_starts(rd: RunData, v_move: float) -> RunData:
    """``rd`` without the segments that start near standstill (|v| below ``v_move`` or five
    noise levels of the smoothed velocity): their initial velocity is within its noise of
    zero, where the friction's sign and the stick decide everything after it
    (``Selection(standstill=False)``)."""
    v_lim = max(v_move, 5.0 * rd.meas_sd.get("v", 0.0))
    segs = [s for s in rd.segments if abs(s.meas["v"]) > v_lim]
    return dataclasses.replace(rd, segments=segs)
