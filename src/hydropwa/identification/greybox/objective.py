"""The output-error objective: residuals of every run's segments for log parameters.

:class:`OutputErrorObjective` simulates each run's segments (threads over parameter sets,
runs and segments: the compiled kernel releases the GIL), lays the noise-scaled errors of
the fitted channels out as fixed streams (run, segment, channel) and takes finite-difference
Jacobians. The loss functions of :func:`scipy.optimize.least_squares` and their IRLS
weights live here too, since the cost and the covariance use them alike.
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import numpy as np

from ..._errors import IdentificationError
from ...params import SystemParams
from ...simulation import Sampled
from ...simulation._simulate import PackedInputs, simulate_packed
from .data import RunData, _Segment
from .problem import VALID_UPPER

__all__ = ["LOSSES", "OutputErrorObjective", "loss_cost", "loss_weights"]

#: the losses of scipy's least_squares
LOSSES = ("linear", "soft_l1", "huber", "cauchy", "arctan")


def _run_amplitude(rd: RunData) -> float:
    """The run's command amplitude [1]: the peak of |u| over the whole run."""
    return float(np.max(np.abs(rd.u))) if rd.u.size else 0.0


def _omega0_table(base: SystemParams, changes: dict[str, float]) -> dict[str, Any]:
    """``changes`` with a free ω0 carried into the valve's ω0 schedule (Table II) when the
    base has one: the model reads the schedule, not ``valve.omega0``, so the fit's ω0 scales
    the whole table by ω0/ω0_base (the FRF fixes its shape, the campaign its level)."""
    table = base.valve.omega0_table
    if "valve.omega0" not in changes or not table or not base.valve.omega0 > 0:
        return changes
    k = changes["valve.omega0"] / base.valve.omega0
    return {**changes, "valve.omega0_table": tuple((a, w * k) for a, w in table)}


# ----------------------------------------------------------------------------- evaluation
class OutputErrorObjective:
    """Residuals of all runs for a parameter vector in log coordinates θ = ln(p/ref).

    ``ref`` are the parameter values at θ = 0 (default ones), ``fd_step`` the difference
    step in θ of :meth:`jac` (callers pass it, as the stages do).
    """

    def __init__(
        self,
        base_model: Any,
        runs: list[RunData],
        free: tuple[str, ...],
        channels: Sequence[str],
        rtol: float,
        jobs: int | None,
        sigma: dict[str, float],
        ref: np.ndarray | None = None,
        fd_step: float = 1e-2,
    ):
        self.base_model = base_model
        self.runs = runs
        self.free = free
        self.channels = channels
        self.rtol = rtol
        self.jobs = max(1, int(jobs or os.cpu_count() or 1))
        self.sigma = sigma
        self.nfev = 0
        self.failures = 0
        #: the last ``jac`` call's difference points: (θ, the points, their residuals)
        self.probes: tuple[np.ndarray, list[np.ndarray], list[np.ndarray]] | None = None
        # fixed layout of the residual vector: (run, segment, channel) streams
        self.streams: list[tuple[int, int, str, int, int]] = []  # run, seg, channel, start, length
        pos = 0
        for ri, rd in enumerate(runs):
            # the fitted channels, then any other the run compares (a steady stretch's speed)
            own = [c for c in channels if c in rd.y] + [c for c in rd.y if c not in channels]
            for si, seg in enumerate(rd.segments):
                for c in own:
                    if c in rd.y:
                        n = seg.i1 - seg.i0 - 1
                        self.streams.append((ri, si, c, pos, n))
                        pos += n
        self.size = pos
        self._cache: dict[bytes, np.ndarray] = {}
        self._packed: dict[tuple, Any] = {}
        self.ref = np.ones(len(free)) if ref is None else np.asarray(ref, dtype=float).copy()
        self.fd_step = fd_step

    # parameters ----------------------------------------------------------------
    def params_at(self, values: np.ndarray) -> SystemParams:
        # the optimiser stays inside the bounds (never past VALID_UPPER), but a difference
        # point a step beyond one lying at the limit is evaluated at the limit
        changes = {
            n: min(float(v), VALID_UPPER.get(n, np.inf))
            for n, v in zip(self.free, values, strict=True)
        }
        base = self.base_model.params
        fc = changes.get("friction.coulomb", base.friction.coulomb)
        if "friction.static" in changes and changes["friction.static"] < fc:
            changes["friction.static"] = fc  # Eq. (11) needs F_s >= F_c; the fit may probe below
        elif (
            "friction.coulomb" in changes
            and "friction.static" not in changes
            and fc > base.friction.static
        ):
            changes["friction.coulomb"] = base.friction.static
        return base.replace(**_omega0_table(base, changes))

    # simulation ---------------------------------------------------------------------
    def _simulate_segment(
        self, mdl, rd: RunData, seg: _Segment, rtol: float
    ) -> dict[str, np.ndarray]:
        a, b = seg.i0, seg.i1
        # the segment's inputs are packed once for all parameter sets (simulate_packed: the
        # same kernel call as simulate, without its per-call checks, which cost twice the
        # integration of a 20 ms window); a constant P_S or F_L comes from the parameters
        ps = None if rd.p_s is not None else float(mdl.params.supply.pressure)
        fl = None if rd.f_l is not None else float(mdl.params.load.force)
        key = (id(rd), a, b, ps, fl)
        inputs = self._packed.get(key)
        if inputs is None:
            lo, hi = max(a - 1, 0), min(b + 1, rd.t.size)
            ts = rd.t[lo:hi]
            inputs = PackedInputs.from_signals(
                Sampled(ts, rd.u[lo:hi]),
                Sampled(ts, rd.p_s[lo:hi]) if rd.p_s is not None else ps,
                Sampled(ts, rd.f_l[lo:hi]) if rd.f_l is not None else fl,
                rd.t[a:b],
            )
            # the valve's ω0 schedule (Table II) is read at the run's command amplitude, as
            # the run was driven, not at the peak within this segment (a 20 ms window of a
            # 90 % sine would otherwise get ω0 at 50 %: 0.1 of spool error on the paper rig)
            inputs = dataclasses.replace(inputs, command_amplitude=_run_amplitude(rd))
            self._packed[key] = inputs
        channels, n_done, status = simulate_packed(
            mdl, inputs, rd.t[a:b], seg.y0, rtol=rtol, max_steps=1_000_000
        )
        out = {}
        for c in rd.y:
            v = np.asarray(channels[c], dtype=float)
            if n_done < b - a:
                # a failed integration holds its last value: a large but finite error
                v = np.concatenate([v, np.full(b - a - n_done, v[-1] if n_done else rd.y[c][a])])
            out[c] = v
        if status != 0:
            self.failures += 1
        return out

    def simulate_all(self, values: np.ndarray) -> list[list[dict[str, np.ndarray]]]:
        """Simulated channels per run and segment."""
        return self.simulate_many([values])[0]

    def simulate_many(
        self, value_sets: list[np.ndarray], rtol: float | None = None
    ) -> list[list[list[dict[str, np.ndarray]]]]:
        """Simulated channels per parameter set, run and segment (threads over all of them);
        ``rtol`` instead of the problem's tolerance."""
        tol = self.rtol if rtol is None else rtol
        mdls = [self._model(v) for v in value_sets]
        damped = self._damped(mdls)
        tasks = [
            (k, ri, si)
            for k in range(len(mdls))
            for ri, rd in enumerate(self.runs)
            for si in range(len(rd.segments))
        ]
        out: list[list[list]] = [[[None] * len(rd.segments) for rd in self.runs] for _ in mdls]

        def one(task):
            k, ri, si = task
            rd = self.runs[ri]
            mdl = mdls[k] if rd.damping is None else damped.get((k, rd.damping), mdls[k])
            return self._simulate_segment(mdl, rd, rd.segments[si], tol)

        if self.jobs == 1 or len(tasks) == 1:
            results = [one(tk) for tk in tasks]
        else:
            # long segments first: better balance between the threads
            order = sorted(
                range(len(tasks)),
                key=lambda i: (
                    -(
                        self.runs[tasks[i][1]].segments[tasks[i][2]].i1
                        - self.runs[tasks[i][1]].segments[tasks[i][2]].i0
                    )
                ),
            )
            with ThreadPoolExecutor(max_workers=self.jobs) as pool:
                got = list(
                    pool.map(
                        one,
                        [tasks[i] for i in order],
                        chunksize=max(1, len(tasks) // (8 * self.jobs)),
                    )
                )
            results = [None] * len(tasks)
            for i, r in zip(order, got, strict=True):
                results[i] = r
        for (k, ri, si), r in zip(tasks, results, strict=True):
            out[k][ri][si] = r
        self.nfev += len(mdls)
        return out

    def values(self, theta: np.ndarray) -> np.ndarray:
        """Parameter values [SI] at θ = ln(p/p_start)."""
        return self.ref * np.exp(theta)

    def _model(self, values: np.ndarray):
        return type(self.base_model)(self.params_at(values))

    def _damped(self, mdls: list) -> dict[tuple[int, float], Any]:
        """Per parameter set and run damping that differs from the model's: the model with
        that ``load.damping`` (a run whose measured F_L had c·ẋ taken out, see ``RunData``)."""
        out = {}
        for d in {rd.damping for rd in self.runs if rd.damping is not None}:
            for k, m in enumerate(mdls):
                if d != m.params.load.damping:
                    out[(k, d)] = type(m)(m.params.replace(**{"load.damping": d}))
        return out

    def residual_vector(self, sims) -> np.ndarray:
        r = np.empty(self.size)
        for ri, si, c, pos, n in self.streams:
            rd = self.runs[ri]
            seg = rd.segments[si]
            sig = self.sigma.get(c, 1.0)
            r[pos : pos + n] = (sims[ri][si][c][1:] - rd.y[c][seg.i0 + 1 : seg.i1]) / sig
            if seg.weight is not None:
                r[pos : pos + n] *= seg.weight.get(c, 1.0)
        return r

    def costs(
        self, thetas: list[np.ndarray], cost: Callable[[np.ndarray], float], rtol=None
    ) -> list[float]:
        """The cost of the residuals at each θ, simulated in one batch."""
        sims = self.simulate_many([self.values(t) for t in thetas], rtol)
        return [cost(self.residual_vector(sm)) for sm in sims]

    # least_squares callbacks (in log coordinates) ---------------------------------
    def fun(self, theta: np.ndarray) -> np.ndarray:
        key = theta.tobytes()
        if key not in self._cache:
            self._cache = {key: self.residual_vector(self.simulate_all(self.values(theta)))}
        return self._cache[key]

    def jac(
        self, theta: np.ndarray, step: float, r0: np.ndarray | None = None, central: bool = False
    ) -> np.ndarray:
        p = theta.size
        sets, thetas = [], []
        for j in range(p):
            e = np.zeros(p)
            e[j] = step
            thetas.append(theta + e)
            if central:
                thetas.append(theta - e)
        sets = [self.values(th) for th in thetas]
        if r0 is None and not central:
            sets.append(self.values(theta))
        sims = self.simulate_many(sets)
        cols = [self.residual_vector(s) for s in sims]
        # the difference points are neighbours of θ: fit_model restarts from one that is lower
        self.probes = (theta.copy(), thetas, cols[: len(thetas)])
        J = np.empty((self.size, p))
        if central:
            for j in range(p):
                J[:, j] = (cols[2 * j] - cols[2 * j + 1]) / (2 * step)
        else:
            base = r0 if r0 is not None else cols[-1]
            for j in range(p):
                J[:, j] = (cols[j] - base) / step
        return J

    def with_runs(self, runs: list[RunData]) -> OutputErrorObjective:
        """The same objective (model, parameters, scaling) over other runs or segments."""
        return OutputErrorObjective(
            self.base_model,
            runs,
            self.free,
            self.channels,
            self.rtol,
            self.jobs,
            self.sigma,
            ref=self.ref,
            fd_step=self.fd_step,
        )


def loss_weights(r: np.ndarray, loss: str, f_scale: float) -> np.ndarray:
    """√ρ'(z) of scipy's losses, z = (r/f_scale)²: the IRLS weights of a robust fit."""
    z = (r / f_scale) ** 2
    if loss == "linear":
        return np.ones_like(r)
    if loss == "soft_l1":
        rho1 = 1.0 / np.sqrt(1.0 + z)
    elif loss == "huber":
        rho1 = np.where(z <= 1.0, 1.0, 1.0 / np.sqrt(np.maximum(z, 1e-300)))
    elif loss == "cauchy":
        rho1 = 1.0 / (1.0 + z)
    elif loss == "arctan":
        rho1 = 1.0 / (1.0 + z**2)
    else:  # pragma: no cover - validated earlier
        raise IdentificationError(f"unknown loss {loss!r}")
    return np.sqrt(rho1)


def loss_cost(r: np.ndarray, loss: str, f_scale: float) -> float:
    """½ f_scale² Σρ((r/f_scale)²): the cost least_squares minimises for ``loss``."""
    z = (r / f_scale) ** 2
    if loss == "linear":
        rho = z
    elif loss == "soft_l1":
        rho = 2.0 * (np.sqrt(1.0 + z) - 1.0)
    elif loss == "huber":
        rho = np.where(z <= 1.0, z, 2.0 * np.sqrt(z) - 1.0)
    elif loss == "cauchy":
        rho = np.log1p(z)
    else:
        rho = np.arctan(z)
    return 0.5 * f_scale**2 * float(np.sum(rho))
