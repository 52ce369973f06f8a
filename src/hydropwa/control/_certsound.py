"""Soundness of the certificate's disturbance set on the full model (issue 51, item 3).

The certified loop (:mod:`hydropwa.control._certify`) predicts one sample of the plant
[P_L, ẋ, x, ν, ν̇] from a gain row's cell at its two pressure vertices, with the friction
beyond its viscous slope as a bounded force |F| ≤ F_s and the Ṗ_L row's error as a bounded
rate |e_P| ≤ ``error_bound``, both held over the sample. :func:`one_step_soundness` samples
(state, command) pairs over the region the certificate is asked for and the rows' cells,
integrates the **full** model (Eqs. (1)–(11), the compiled right-hand side) over one sample
time at rtol 1e-10, and explains the one-step mismatch to the cell prediction by the set:
the best pressure vertex mix λ ∈ [0, 1] and the (F, e_P) that fit it (least squares in the
certificate's engineering scales). A sample violates the set when its F exceeds F_s, its
e_P exceeds the bound, or a leftover that no disturbance column explains exceeds
:data:`LEFTOVER_TOL` (scaled units).

The grown bound (``grown_error_bound``: the largest e_P seen × :data:`GROWTH`) is what the
certificate must carry for the set to hold on the samples; :func:`grow` writes it into the
loop data.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from .._layout import FULL_KIND
from ..components._physics import chamber_pressures_from_load
from ..models import as_model
from ..simulation import full_point_derivatives
from ._certify import _NAMES, _SCALES, REGION_SHAPE, loop_data

__all__ = ["SoundnessResult", "one_step_soundness", "grow", "LEFTOVER_TOL", "GROWTH"]

#: a mismatch left after the disturbance columns, in the certificate's scales (bar, mm/s, mm,
#: %, 1/s), that counts as a violation (the friction's change within one sample leaves ~1e-4)
LEFTOVER_TOL = 1e-2
#: the grown Ṗ_L bound is the largest error seen times this (the samples are not exhaustive)
GROWTH = 1.5
#: the pressure-vertex mixes tried per sample
_LAMBDA_GRID = np.linspace(0.0, 1.0, 11)


@dataclass(frozen=True)
class SoundnessResult:
    """The one-step check: counts, the largest disturbances needed, the grown bound (SI)."""

    samples: int
    violations: int
    max_friction: float  # [N] largest |F| needed
    friction_bound: float  # [N] the set's F_s
    max_error: float  # [Pa/s] largest |e_P| needed
    error_bound: float  # [Pa/s] the set's bound
    max_leftover: float  # [scaled] largest mismatch no column explains
    grown_error_bound: float  # [Pa/s] the bound that holds on the samples (× GROWTH)
    sector_violations: int = 0  # samples whose fitted F is not against ẋ₀ (F·ẋ₀ > 0)

    def summary(self) -> str:
        return (
            f"one-step soundness on the full model: {self.violations} of {self.samples} "
            f"samples outside the set; |F| ≤ {self.max_friction:.4g} N (set {self.friction_bound:.4g}"
            f" N), |e_P| ≤ {self.max_error / 1e5:.4g} bar/s (set {self.error_bound / 1e5:.4g} "
            f"bar/s, grown {self.grown_error_bound / 1e5:.4g} bar/s), leftover "
            f"{self.max_leftover:.3g} (scaled); friction with the motion (F·ẋ > 0) in "
            f"{self.sector_violations} samples"
        )


def _zoh(A: np.ndarray, G: np.ndarray, ts: float):
    from scipy.linalg import expm  # deferred: scipy.linalg at import costs 0.1–0.5 s

    n, m = A.shape[0], G.shape[1]
    M = np.zeros((n + m, n + m))
    M[:n, :n], M[:n, n:] = A, G
    E = expm(M * ts)
    return E[:n, :n], E[:n, n:]


def _vertex_maps(data, lo: dict, hi: dict):
    """Per λ of the grid: (Φ, Γ) of the plant [P_L, ẋ, x, ν, ν̇] with inputs [c, F, e_P, 1]."""
    om, ze = data.omega0, data.zeta
    out = []
    for lam in _LAMBDA_GRID:
        A = np.zeros((5, 5))
        A[:3, :3] = (1 - lam) * lo["A"] + lam * hi["A"]
        A[:3, 3] = (1 - lam) * lo["B"] + lam * hi["B"]
        A[3, 4], A[4, 3], A[4, 4] = 1.0, -(om**2), -2.0 * ze * om
        G = np.zeros((5, 4))
        G[4, 0], G[1, 1], G[0, 2] = om**2, 1.0 / data.mass, 1.0
        G[0, 3] = (1 - lam) * lo["f0"][0] + lam * hi["f0"][0]
        out.append(_zoh(A, G, data.sample_time))
    return out


def _full_step(full, y0: np.ndarray, u: float, ts: float, fl: float) -> np.ndarray:
    """The full model's state after one sample from y0 at the command u (Radau, rtol 1e-10,
    the kernel's exact Jacobian)."""
    from scipy.integrate import solve_ivp  # deferred: scipy.integrate costs ~0.3 s at import

    ps = float(y0[6])
    sol = solve_ivp(
        lambda _t, y: full_point_derivatives(full, y, u, ps, fl)[0],
        (0.0, ts),
        y0,
        method="Radau",
        jac=lambda _t, y: full_point_derivatives(full, y, u, ps, fl)[1],
        rtol=1e-10,
        atol=full.state_scale() * 1e-12,
    )
    return sol.y[:, -1]


def _sample_states(rng, data, cells: list[dict], n: int, opening: float):
    """n (row pair, ξ₀ [P_L dev, ẋ, x dev, opening, opening rate], opening command c), the
    opening and the command within ``opening`` and the rows' boxes."""
    p_lo = max(c["lower"][0] for c in data.cells) - data.hold_pressure
    p_hi = min(c["upper"][0] for c in data.cells) - data.hold_pressure
    dp = min(REGION_SHAPE[2], -p_lo, p_hi)
    v_max = min(REGION_SHAPE[1], data.velocity_limit)
    out = []
    for k in range(n):
        j = 2 * (k % (len(cells) // 2))
        lo = cells[j]
        c_lo = max(lo["lower"][3], -opening)
        c_hi = min(lo["upper"][3], opening)
        v_lo, v_hi = max(lo["lower"][1], -v_max), min(lo["upper"][1], v_max)
        if not (c_lo < c_hi and v_lo < v_hi):
            continue
        xi = np.array(
            [
                rng.uniform(-dp, dp),
                rng.uniform(v_lo, v_hi),
                rng.uniform(-REGION_SHAPE[0], REGION_SHAPE[0]),
                rng.uniform(c_lo, c_hi),
                rng.uniform(-1.0, 1.0) * data.omega0 * 0.02,
            ]
        )
        out.append((j, xi, rng.uniform(c_lo, c_hi)))
    return out


def _explain(maps, xi0: np.ndarray, c: float, full: np.ndarray, scales: np.ndarray):
    """(F, e_P, leftover) of the best vertex mix: the mismatch full − Φξ₀ − Γ_c c − Γ_1 fitted
    by the friction and Ṗ_L columns in the scaled states."""
    best = None
    for Phi, Gam in maps:
        r = (full - Phi @ xi0 - Gam[:, 0] * c - Gam[:, 3]) / scales
        C = Gam[:, 1:3] / scales[:, None]
        coef, *_ = np.linalg.lstsq(C, r, rcond=None)
        left = float(np.abs(r - C @ coef).max())
        key = (left > LEFTOVER_TOL, abs(coef[1]), left)
        if best is None or key < best[0]:
            best = (key, float(coef[0]), float(coef[1]), left)
    assert best is not None
    return best[1:]


def one_step_soundness(
    controller,
    model,
    *,
    samples: int = 200,
    seed: int = 0,
    split_offset: float = 0.0,
    opening: float | None = None,
    data=None,
) -> SoundnessResult:
    """Check the certificate's disturbance set against the full model, one sample at a time.

    Parameters
    ----------
    controller : StateFeedbackController
    model : PwaModel
        The machine's PWA model (its parameters give the full model).
    samples : int
        (state, command) pairs drawn over the region's box and the hold's rows.
    seed : int
        Random seed.
    split_offset : float
        [Pa] added to P_A (and /α to P_B, P_L unchanged) away from the quasi-steady split the
        cells assume (the full model's sixth state).
    opening : float, optional
        Largest |opening| and |command| [1] sampled (default the region's command limit).
    data : LoopData, optional
        The certified loop (default :func:`~hydropwa.control._certify.loop_data`).
    """
    data = loop_data(controller, model) if data is None else data
    prm = model.params
    full = as_model(FULL_KIND.name, prm)
    alpha = prm.cylinder.area_b / prm.cylinder.area_a
    x_h = float(model.x_capacitance)
    y_t = full.initial_state(x_h)
    scales = np.array([_SCALES[k] for k in _NAMES])
    cells = list(data.cells)
    rng = np.random.default_rng(seed)
    fs, es, lefts, bad, sector = [], [], [], 0, 0
    bound_f = data.bounds["friction"]
    c_max = data.command_limit if opening is None else float(opening)
    for j, xi0, c in _sample_states(rng, data, cells, samples, c_max):
        lo, hi = cells[j], cells[j + 1]
        g = int(model.dead_zone.cell(0.5 * np.sign(lo["upper"][3] + lo["lower"][3])))
        k_g, o_g = float(model.dead_zone.slopes[g]), float(model.dead_zone.offsets[g])
        y0 = y_t.copy()
        pl = data.hold_pressure + xi0[0]
        pa, pb = chamber_pressures_from_load(xi0[3], pl, float(y_t[6]), alpha)
        y0[2:6] = [pa + split_offset, pb + split_offset / alpha, x_h + xi0[2], xi0[1]]
        y0[0], y0[1] = (xi0[3] - o_g) / k_g, xi0[4] / k_g
        y1 = _full_step(full, y0, (c - o_g) / k_g, data.sample_time, prm.load.force)
        if int(model.dead_zone.cell(y1[0])) != g:
            continue  # the spool left its dead-zone cell within the sample
        z1 = np.array(
            [y1[2] - alpha * y1[3] - data.hold_pressure, y1[5], y1[4] - x_h, k_g * y1[0] + o_g]
            + [k_g * y1[1]]
        )
        F, e, left = _explain(_vertex_maps(data, lo, hi), xi0, c, z1, scales)
        sector += int(F * xi0[1] > 0 and abs(F) > 1e-3 * bound_f)
        fs.append(abs(F))
        es.append(abs(e))
        lefts.append(left)
        eb = max(lo["error_bound"], hi["error_bound"])
        bad += int(abs(F) > bound_f * (1 + 1e-6) or abs(e) > eb * (1 + 1e-6) or left > LEFTOVER_TOL)
    return SoundnessResult(
        samples=len(fs),
        violations=bad,
        max_friction=max(fs, default=0.0),
        friction_bound=bound_f,
        max_error=max(es, default=0.0),
        error_bound=max(c["error_bound"] for c in cells),
        max_leftover=max(lefts, default=0.0),
        grown_error_bound=GROWTH * max(es, default=0.0),
        sector_violations=sector,
    )


def grow(data, result: SoundnessResult):
    """``data`` with every cell's Ṗ_L bound raised to the grown bound of ``result``."""
    cells = tuple(
        c | {"error_bound": max(c["error_bound"], result.grown_error_bound)} for c in data.cells
    )
    return dataclasses.replace(data, cells=cells)
