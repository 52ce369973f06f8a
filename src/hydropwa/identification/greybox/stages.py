"""The stages of each start of the grey-box fit: locate, valley scan, coarse, full, restart.

:class:`StagePlan` holds the objectives of one fit (the full data, and where they apply the
locating windows and the coarse subset); :meth:`StagePlan.run_start` walks one start through
them and :meth:`StagePlan.minimize` runs every start and keeps the lowest cost.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from .intervals import valley
from .jacobian import FiniteDifferenceJacobian
from .objective import loss_cost
from .optimize import LeastSquares
from .problem import GreyBoxProblem
from .result import FULL_STAGE, StageResult, StartRecord

__all__ = ["STICK", "FitProgress", "StagePlan", "restart_from_probes", "valley_scan"]

#: Friction parameters that decide whether and when the rod sticks (the locating stage).
STICK = frozenset(
    ("friction.coulomb", "friction.static", "friction.stribeck_velocity", "friction.shape")
)


@dataclasses.dataclass(frozen=True)
class FitProgress:
    """One progress event of the grey-box fit (passed to ``progress`` callbacks).

    Attributes
    ----------
    stage : str
        ``locate``, ``scan``, ``coarse``, ``full``, ``restart``, ``start`` (one start
        as a Dask task), ``uncertainty``, ``sliding``, ``profiles``, ``validation`` or
        ``done``.
    start : int
        Start number (1-based; 0 outside the starts).
    starts : int
        Number of starts.
    event : str
        ``begin`` or ``end``.
    cost : float
        The stage's cost at its end (NaN at its beginning) [1].
    nfev : int
        Evaluations of the stage (0 at its beginning).
    elapsed : float
        Seconds since the fit started.
    """

    stage: str
    start: int
    starts: int
    event: str
    cost: float = math.nan
    nfev: int = 0
    elapsed: float = 0.0

    def __str__(self) -> str:
        where = f"start {self.start}/{self.starts} " if self.start else ""
        if self.event == "begin":
            return f"[{self.elapsed:6.1f} s] {where}{self.stage} …"
        return (
            f"[{self.elapsed:6.1f} s] {where}{self.stage}: cost {self.cost:.6g} "
            f"({self.nfev} evaluations)"
        )


def valley_scan(
    prob: Any,
    theta: np.ndarray,
    J: np.ndarray,
    idx: list[int],
    tlo: np.ndarray,
    thi: np.ndarray,
    cost: Callable[[np.ndarray], float],
    steps: tuple[float, ...] = (-0.2, -0.1, 0.1, 0.2),
) -> tuple[np.ndarray, int]:
    """Scan the single-shooting cost along each stick parameter's valley from the located point.

    The direction moves parameter i by one and the others by their regression on it
    (H⁻¹e_i / (H⁻¹)_ii, from the locating stage's Jacobian): along it the linearised cost is
    least. Returns the lowest of the point and the scanned ones, and the evaluations spent.
    """
    if not idx:
        return theta, 0
    Hinv = np.linalg.pinv(J.T @ J)
    cands = [theta]
    for i in idx:
        if not Hinv[i, i] > 0:
            continue
        d = valley(Hinv, i)
        cands += [np.clip(theta + s * d, tlo + 1e-9, thi - 1e-9) for s in steps]
    return cands[int(np.argmin(prob.costs(cands, cost)))], len(cands)


def restart_from_probes(
    prob: Any,
    sol: Any,
    solve: Callable[[np.ndarray], Any],
    cost: Callable[[np.ndarray], float],
    n: int = 2,
) -> tuple[Any, int]:
    """Restart the solver from a difference point that is lower than where it stopped.

    On runs with stick events the cost is rough on the scale of the solver's last steps (the
    timing of a stick moves with the integrator's step choice): the trust region shrinks on a
    ridge and the solver stops there with ``xtol``, though the central-difference points
    around it, a few per cent away, lie lower (measured on the 5 s sine runs: stops at F_c
    +15 … +19 %, costs above the truth's). Those points are computed anyway (the Jacobian at
    the optimum, for the covariance): when the lowest is lower than the stop by more than
    one part in 10⁶, the solver starts again from it, at most ``n`` times.

    Returns the best solution and the number of restarts taken.
    """
    taken, nfev = 0, int(sol.nfev)
    for _ in range(n):
        at = prob.probes
        if at is None or not np.array_equal(at[0], sol.x):
            prob.jac(sol.x, prob.fd_step, central=True)
            at = prob.probes
        _x, thetas, cols = at
        costs = [cost(c) for c in cols]
        k = int(np.argmin(costs))
        if not costs[k] < sol.cost * (1.0 - 1e-6):
            break
        new = solve(thetas[k])
        taken, nfev = taken + 1, nfev + int(new.nfev)
        if not new.cost < sol.cost:
            break
        sol = new
    sol.nfev = nfev  # every restart's evaluations, kept or not
    return sol, taken


@dataclasses.dataclass
class StartResult:
    """One start's way through the stages.

    ``sol`` is the full stage's scipy result (after restarts), ``initial_cost`` the cost at the
    start on the full data, ``log`` the start's record for ``GreyBoxFit.starts_``, ``stages``
    its stages' outcomes and ``central`` the last central-difference Jacobian (θ, J) of the
    full stage.
    """

    sol: Any
    initial_cost: float
    log: StartRecord
    stages: list[StageResult]
    central: tuple[np.ndarray, np.ndarray] | None


@dataclasses.dataclass
class StagePlan:
    """The objectives and settings of one fit's stages.

    Attributes
    ----------
    problem : GreyBoxProblem
    full : OutputErrorObjective
        All prepared segments.
    locate : OutputErrorObjective or None
        Multiple-shooting windows of the single-shot runs (with a stick parameter free):
        their cost is smooth in the friction and finds the single-shooting cost's well.
    coarse : OutputErrorObjective or None
        Every k-th segment: the long walk from the start at a fraction of the simulations.
    optimizer : LeastSquares
    differences, refresh, fd_step :
        The Jacobian's scheme, Broyden refresh and step (:class:`FiniteDifferenceJacobian`).
    progress : callable or None
        Called with a :class:`FitProgress` at each stage's beginning and end.
    t0 : float
        ``time.perf_counter()`` at the fit's start (for ``elapsed``).
    """

    problem: GreyBoxProblem
    full: Any
    locate: Any
    coarse: Any
    optimizer: LeastSquares
    differences: str = "central"
    refresh: int = 1
    fd_step: float = 3e-2
    progress: Callable[[FitProgress], None] | None = None
    t0: float = 0.0

    def cost(self, r: np.ndarray) -> float:
        """½Σρ(r²) with the optimiser's loss."""
        return loss_cost(r, self.optimizer.loss, self.optimizer.f_scale)

    def report(self, stage: str, start: int, starts: int, res: Any = None, **kw: Any) -> None:
        """Send a progress event (``res``: the stage's scipy result at its end)."""
        if self.progress is None:
            return
        if res is not None:
            kw.setdefault("cost", float(res.cost))
            kw.setdefault("nfev", int(res.nfev))
        ev = FitProgress(
            stage, start, starts, "end" if res is not None or "cost" in kw else "begin", **kw
        )
        self.progress(dataclasses.replace(ev, elapsed=time.perf_counter() - self.t0))

    def jacobian(self, objective: Any) -> FiniteDifferenceJacobian:
        """A fresh Jacobian strategy for one stage on ``objective``."""
        return FiniteDifferenceJacobian(objective, self.fd_step, self.differences, self.refresh)

    def _locate(self, th0: np.ndarray, k: tuple[int, int]) -> tuple[np.ndarray, int, StageResult]:
        """The locating stage (1 % tolerance: it only locates the well) and the valley scan."""
        tlo, thi = self.problem.theta_bounds
        self.report("locate", *k)
        sol_l = self.optimizer.with_tolerance(1e-2).solve(
            self.locate.fun, th0, self.jacobian(self.locate), (tlo, thi)
        )
        self.report("locate", *k, res=sol_l)
        # the windows' F_c follows their smoothed initial velocity (±10–20 %), and the
        # single-shooting cost has a minimum per stick pattern: from a located point in the
        # wrong one the fit stopped at F_c +12 … +19 %, costs above the truth's. The
        # single-shooting cost along each stick parameter's valley picks the basin
        th, n_scan = valley_scan(
            self.coarse or self.full,
            sol_l.x,
            sol_l.jac,
            self.problem.index(STICK),
            tlo,
            thi,
            self.cost,
        )
        return (
            th,
            int(sol_l.nfev + (sol_l.njev or 0)) + n_scan,
            StageResult.from_scipy("locate", sol_l),
        )

    def run_start(self, th0: np.ndarray, k: tuple[int, int]) -> StartResult:
        """One start (number ``k[0]`` of ``k[1]``) through locate, coarse, full and restarts."""
        bounds = self.problem.theta_bounds
        th, coarse_nfev, locate_nfev = th0, 0, 0
        stages: list[StageResult] = []
        if self.locate is not None:
            th, locate_nfev, st = self._locate(th0, k)
            stages.append(st)
        if self.coarse is not None:
            self.report("coarse", *k)
            sol0 = self.optimizer.solve(self.coarse.fun, th, self.jacobian(self.coarse), bounds)
            self.report("coarse", *k, res=sol0)
            th, coarse_nfev = sol0.x, int(sol0.nfev + (sol0.njev or 0))
            stages.append(StageResult.from_scipy("coarse", sol0))
        last = [self.jacobian(self.full)]

        def restart(theta0: np.ndarray) -> Any:
            last[0] = self.jacobian(self.full)
            self.report("restart", *k)
            return self.optimizer.solve(self.full.fun, self.problem.clip(theta0), last[0], bounds)

        self.report(FULL_STAGE, *k)
        sol = self.optimizer.solve(self.full.fun, th, last[0], bounds)
        sol, restarts = restart_from_probes(self.full, sol, restart, self.cost)
        self.report(FULL_STAGE, *k, res=sol)
        stages.append(StageResult.from_scipy(FULL_STAGE, sol))
        values = self.problem.values
        full = stages[-1]
        log = StartRecord(
            start=dict(zip(self.problem.names, values(th0).tolist(), strict=True)),
            value=dict(zip(self.problem.names, values(sol.x).tolist(), strict=True)),
            cost=full.cost,
            status=full.status,
            nfev=full.nfev,
            njev=full.njev,
            coarse_evaluations=coarse_nfev,
            locate_evaluations=locate_nfev,
            restarts=int(restarts),
        )
        return StartResult(sol, math.nan, log, stages, last[0].central)

    def minimize(
        self, theta_starts: list[np.ndarray], client: Any = None
    ) -> tuple[StartResult, list[StartRecord]]:
        """Every start; the one with the lowest cost (its ``initial_cost`` set) and the log.

        ``client``: a ``dask.distributed.Client`` that runs the starts as tasks (each walks
        its stages alone, as in-process; the plan travels pickled, without its progress
        callback: each start reports its beginning and end from here).
        """
        n = len(theta_starts)
        if client is not None and n > 1:
            shipped = dataclasses.replace(self, progress=None)
            futures = []
            for j, th0 in enumerate(theta_starts):
                self.report("start", j + 1, n)
                futures.append(client.submit(_run_start, shipped, th0, (j + 1, n), pure=False))
            results = []
            for j, fut in enumerate(futures):
                results.append(fut.result())
                self.report("start", j + 1, n, res=results[-1].sol)
        else:
            results = [self.run_start(th0, (j + 1, n)) for j, th0 in enumerate(theta_starts)]
        best: StartResult | None = None
        logs = []
        for th0, got in zip(theta_starts, results, strict=True):
            logs.append(got.log)
            if best is None or got.sol.cost < best.sol.cost:
                got.initial_cost = self.cost(self.full.fun(th0))
                best = got
        assert best is not None  # theta_starts holds at least the base start
        return best, logs


def _run_start(plan: StagePlan, th0: np.ndarray, k: tuple[int, int]) -> StartResult:
    """One start on a worker (a module-level function: Dask pickles it by name)."""
    return plan.run_start(th0, k)


def theta_starts(problem: GreyBoxProblem, starts: int, rng: np.random.Generator) -> list:
    """The base start and ``starts − 1`` log-uniform points within ×/÷ 3 of it, inside the
    bounds."""
    tlo, thi = problem.theta_bounds
    out = [problem.clip(np.zeros(len(problem.names)))]
    for _ in range(max(0, starts - 1)):
        out.append(rng.uniform(np.maximum(tlo, -math.log(3.0)), np.minimum(thi, math.log(3.0))))
    return out
