"""The paper's published numbers (Tables II–V) and what is recovered from them.

Table V prints only the seven cells of the linearized Stribeck curve; the
Stribeck parameters of Eq. (11) are recovered here by least squares
(docs/errata.md E8). The cell labels are read I..VII and the middle slope is
read 1.833e5 (printed 1.833e3), which makes neighbouring lines intersect at
±0.79 mm/s, ±14.5 mm/s and ±54.4 mm/s.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from ..components import PiecewiseAffine, stribeck_friction
from ._params import Friction

__all__ = [
    "TABLE_II",
    "TABLE_IV",
    "TABLE_V",
    "TABLE_V_AS_PRINTED",
    "table_v_pwa",
    "StribeckRecovery",
    "recover_stribeck_from_table_v",
    "table_v_friction",
]

#: Table II: valve opening [1] → (ω0 [rad/s], ζ [1]).
TABLE_II = ((0.10, 816.8, 0.7), (0.25, 628.3, 0.7), (0.90, 220.0, 0.7))

#: Table IV: (k_g, d_g) per cell I..V, as printed.
TABLE_IV = ((0.0, -1.0), (1.0, 0.1), (0.04, 0.0), (1.0, -0.1), (0.0, 1.0))

#: Table V as printed: (k_w [N·s/m], d_w [N]) for cells labelled I, II, III, IV, IV, IV, IV.
TABLE_V_AS_PRINTED = (
    (1105.0, -30.7),
    (-0.254, -90.8),
    (-3867.0, -147.0),
    (1.833e3, 0.0),
    (-3867.0, 147.0),
    (-0.819, 90.7),
    (1105.0, 30.7),
)

#: Table V corrected: cells I..VII, middle slope 1.833e5 (docs/errata.md E8).
TABLE_V = tuple((1.833e5, 0.0) if i == 3 else kd for i, kd in enumerate(TABLE_V_AS_PRINTED))


def table_v_pwa() -> PiecewiseAffine:
    """Table V (corrected) as a continuous PWA friction curve f(ẋ) [N] over ẋ [m/s]."""
    k, d = np.array(TABLE_V).T
    return PiecewiseAffine.from_lines(k, d)


@dataclass(frozen=True)
class StribeckRecovery:
    """Result of fitting Eq. (11) to the Table V curve.

    Attributes
    ----------
    friction : Friction
        Recovered Stribeck parameters.
    rms_residual : float
        RMS difference [N] between Eq. (11) and the Table V curve on the fit grid.
    max_residual : float
        Largest absolute difference [N] on the fit grid.
    velocities : ndarray
        Fit grid [m/s].
    """

    friction: Friction
    rms_residual: float
    max_residual: float
    velocities: np.ndarray


def _fit_grid(pwa: PiecewiseAffine, v_max: float, per_cell: int = 60) -> np.ndarray:
    """Velocity grid with the same number of points in every cell of the PWA curve."""
    edges = np.concatenate(([-v_max], pwa.breakpoints, [v_max]))
    pts = [
        np.linspace(a, b, per_cell, endpoint=False)
        for a, b in zip(edges[:-1], edges[1:], strict=True)
    ]
    return np.concatenate(pts + [np.array([v_max])])


#: :func:`recover_stribeck_from_table_v` at its default grid, as the ``paper`` preset uses it:
#: F_c, F_s [N], σ [N·s/m], χ [m/s], δ, γ [s/m], and the fit's RMS residual [N]. Stored so
#: that loading the preset does not run a least-squares fit (0.9 s with scipy.optimize's
#: import); ``tests/core/test_params.py`` re-runs the fit and checks these digits.
TABLE_V_STRIBECK = (
    21.153094207286184,
    174.77081523356574,
    1158.4453232999103,
    0.015674979331178663,
    0.7305242624497573,
    1324.680656301685,
)
TABLE_V_RMS_RESIDUAL = 3.9316432000367674


def table_v_friction() -> Friction:
    """The ``paper`` preset's friction: the stored result of :func:`recover_stribeck_from_table_v`."""
    fc, fs, sigma, chi, delta, gamma = TABLE_V_STRIBECK
    return Friction(
        coulomb=fc,
        static=fs,
        viscous=sigma,
        stribeck_velocity=chi,
        shape=delta,
        smoothness=gamma,
    )


@lru_cache(maxsize=4)
def recover_stribeck_from_table_v(v_max: float = 0.2) -> StribeckRecovery:
    """Recover F_c, F_s, σ, χ, δ, γ of Eq. (11) from the cells of Table V.

    Parameters
    ----------
    v_max : float
        Largest speed [m/s] of the fit grid: the fastest Stribeck run (50 % opening at
        100 bar) reaches about 0.17–0.2 m/s. With 0.12 m/s the optimum puts F_c at 0.

    Returns
    -------
    StribeckRecovery
        The parameters and the residual of the fit.

    Notes
    -----
    Bounded least squares on log-scaled χ and γ with equal weight per cell,
    since the parameters span six orders of magnitude.
    """
    pwa = table_v_pwa()
    v = _fit_grid(pwa, v_max)
    target = pwa(v)

    def model(theta):
        fc, dfs, sigma, log_chi, delta, log_gamma = theta
        return stribeck_friction(v, fc, fc + dfs, sigma, 10.0**log_chi, delta, 10.0**log_gamma)

    theta0 = np.array([90.0, 60.0, 1000.0, -2.0, 1.0, 4.0])
    lb = np.array([0.0, 0.0, 0.0, -5.0, 0.2, 1.0])
    ub = np.array([1e3, 1e3, 1e5, 0.0, 5.0, 7.0])
    from scipy.optimize import least_squares  # deferred: scipy submodules cost 0.1-0.5 s at import

    res = least_squares(
        lambda th: model(th) - target,
        theta0,
        bounds=(lb, ub),
        x_scale=np.array([10, 10, 100, 0.3, 0.3, 0.3]),
    )
    fc, dfs, sigma, log_chi, delta, log_gamma = res.x
    fr = Friction(
        coulomb=float(fc),
        static=float(fc + dfs),
        viscous=float(sigma),
        stribeck_velocity=float(10.0**log_chi),
        shape=float(delta),
        smoothness=float(10.0**log_gamma),
    )
    r = res.fun
    return StribeckRecovery(fr, float(np.sqrt(np.mean(r**2))), float(np.max(np.abs(r))), v)
