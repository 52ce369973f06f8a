"""Tables IV–IX of the paper as printed, what is recovered from them, and their reproduction.

Tables VI–IX hold the C_q and C_qp cells (k_o, d_o, k_n, d_n) of four simulations with
different average supply pressures (docs/errata.md E6). Each printed cell is the tangent
of Eq. (18) or (19) at one working point P̂ (Eqs. (17)–(19)):

    k_o = −K / (4√(½(P_S − P̂))),    d_o = K√(½(P_S − P̂)) − k_o P̂
    k_n =  K / (16 (½(P_S − P̂))^{3/2}), d_n = K / (4√(½(P_S − P̂))) − k_n P̂

so P_S and P̂ follow from the numbers. Two typos are corrected before use:

* Table VII, cell IV, column 1: printed 0.388e-3, read 3.88e-3 (docs/errata.md E6).
* Table VIII: every entry is printed ten times too large (e-15 where e-16 is meant).
  With the printed values the C_qp tangents would need P_S ≈ 9.5 bar for cells IV–V and
  the working points of Table VIII would disagree with those of Table IX and VI–VII;
  with e-16 all four tables give the same P_S and P̂ per column to within 0.5 %.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from scipy.optimize import least_squares

from ..params import (
    TABLE_IV,
    TABLE_V,
    TABLE_V_AS_PRINTED,
    DeadZone,
    Friction,
    ValveFlow,
    recover_stribeck_from_table_v,
    table_v_pwa,
)
from ._cells import (
    PAPER_WORKING_POINTS,
    cq_cells,
    cq_shape,
    dead_zone_cells,
    friction_cells,
    table_v_residual,
)
from ._fit import approximation_errors

__all__ = [
    "TABLE_VI",
    "TABLE_VII",
    "TABLE_VII_CORRECTED",
    "TABLE_VIII",
    "TABLE_VIII_CORRECTED",
    "TABLE_IX",
    "TABLE_VIII_FACTOR",
    "PaperColumn",
    "recover_paper_columns",
    "reproduce_table_iv",
    "reproduce_table_v",
    "reproduce_tables_vi_ix",
    "reproduce_paper_tables",
]

_ROMAN = ("I", "II", "III", "IV", "V", "VI", "VII")

#: Table VI as printed: k_o [m³/(s·Pa)], rows = cells I..V, columns = the four simulations.
TABLE_VI = (
    np.array(
        [
            [-0.034, -0.038, -0.035, -0.037],
            [-0.053, -0.058, -0.053, -0.056],
            [-0.092, -0.100, -0.092, -0.097],
            [-0.412, -0.447, -0.411, -0.435],
            [-0.920, -0.998, -0.919, -0.972],
        ]
    )
    * 1e-9
)
TABLE_VI.setflags(write=False)

#: Table VII as printed: d_o [m³/s].
TABLE_VII = (
    np.array(
        [
            [0.554, 0.510, 0.554, 0.525],
            [0.647, 0.597, 0.648, 0.613],
            [0.949, 0.874, 0.950, 0.899],
            [0.388, 3.573, 3.882, 3.671],
            [8.632, 7.957, 8.646, 8.177],
        ]
    )
    * 1e-3
)
TABLE_VII.setflags(write=False)

#: Table VII with cell IV, column 1 read 3.88e-3 (printed 0.388e-3).
TABLE_VII_CORRECTED = TABLE_VII.copy()
TABLE_VII_CORRECTED[3, 0] = 3.88e-3
TABLE_VII_CORRECTED.setflags(write=False)

#: Table VIII as printed (headed k_o, holds k_n) [m³/(s·Pa²)].
TABLE_VIII = (
    np.array(
        [
            [0.027, 0.034, 0.026, 0.031],
            [0.095, 0.121, 0.094, 0.111],
            [0.491, 0.627, 0.489, 0.578],
            [43.93, 56.09, 43.71, 51.68],
            [491.1, 627.1, 488.8, 577.8],
        ]
    )
    * 1e-15
)
TABLE_VIII.setflags(write=False)

#: The power-of-ten typo of Table VIII: the printed values are 10× the tangent slopes.
TABLE_VIII_FACTOR = 0.1

#: Table VIII corrected: e-16 instead of e-15.
TABLE_VIII_CORRECTED = TABLE_VIII * TABLE_VIII_FACTOR
TABLE_VIII_CORRECTED.setflags(write=False)

#: Table IX as printed (headed d_o, holds d_n) [m³/(s·Pa)].
TABLE_IX = (
    np.array(
        [
            [0.027, 0.030, 0.027, 0.029],
            [-0.009, -0.009, -0.009, -0.009],
            [-0.322, -0.349, -0.321, -0.340],
            [-40.54, -43.98, -40.48, -42.80],
            [-458.8, -497.7, -458.1, -484.3],
        ]
    )
    * 1e-9
)
TABLE_IX.setflags(write=False)


def tangent_coefficients(K: float, p_s: float, p_hat) -> tuple[np.ndarray, ...]:
    """Tangents of Eqs. (18), (19) at P̂ [Pa] for supply P_S [Pa] and flow coefficient K.

    Returns
    -------
    k_o [m³/(s·Pa)], d_o [m³/s], k_n [m³/(s·Pa²)], d_n [m³/(s·Pa)] : ndarray
        For z > 0 and |z| = 1.
    """
    p_hat = np.asarray(p_hat, dtype=float)
    h = 0.5 * (p_s - p_hat)
    r = np.sqrt(h)
    k_o = -K / (4.0 * r)
    d_o = K * r - k_o * p_hat
    k_n = K / (16.0 * h**1.5)
    d_n = K / (4.0 * r) - k_n * p_hat
    return k_o, d_o, k_n, d_n


@dataclass(frozen=True)
class PaperColumn:
    """Supply pressure and working points recovered from one column of Tables VI–IX.

    Attributes
    ----------
    column : int
        1..4, the order of the paper's four simulations.
    supply_pressure : float
        P_S [Pa] (least squares over the 20 numbers of the column, free working points).
    working_points : ndarray, shape (5,)
        P̂ [Pa] of cells I..V.
    normalised : ndarray, shape (5,)
        P̂/P_S [1].
    supply_pressure_common : float
        P_S [Pa] fitted with the working points fixed at ``PAPER_WORKING_POINTS``·P_S.
    max_rel_residual : float
        Largest relative residual of the free fit [1].
    """

    column: int
    supply_pressure: float
    working_points: np.ndarray
    normalised: np.ndarray
    supply_pressure_common: float
    max_rel_residual: float


def _printed_column(c: int) -> np.ndarray:
    return np.concatenate(
        [t[:, c] for t in (TABLE_VI, TABLE_VII_CORRECTED, TABLE_VIII_CORRECTED, TABLE_IX)]
    )


def _rel_residual(K, p_s, p_hat, target):
    model = np.concatenate(tangent_coefficients(K, p_s, p_hat))
    return (model - target) / np.abs(target)


@lru_cache(maxsize=8)
def recover_paper_columns(K: float | None = None) -> tuple[PaperColumn, ...]:
    """Recover P_S and the working points of each column of Tables VI–IX.

    Parameters
    ----------
    K : float, optional
        Flow coefficient [m³/(s·√Pa)]; default that of the ``paper`` preset (0.252e-6).

    Returns
    -------
    tuple of PaperColumn
        One per column. Least squares on relative residuals of the 20 corrected numbers
        of a column (Tables VI, VII, VIII/10, IX), with P_S and the five P̂ free; a second
        fit keeps P̂ = :data:`PAPER_WORKING_POINTS`·P_S and frees only P_S.
    """
    if K is None:
        K = ValveFlow().K
    out = []
    wp = np.array(PAPER_WORKING_POINTS)
    for c in range(4):
        target = _printed_column(c)
        theta0 = np.concatenate(([90e5], wp))

        def res_free(th, target=target):
            return _rel_residual(K, th[0], th[0] * th[1:], target)

        lb = np.concatenate(([1e5], np.full(5, -1.0)))
        ub = np.concatenate(([1e8], np.full(5, 0.99999)))
        free = least_squares(
            res_free, theta0, bounds=(lb, ub), x_scale=np.concatenate(([1e6], np.full(5, 1e-3)))
        )
        common = least_squares(
            lambda th, target=target: _rel_residual(K, th[0], th[0] * wp, target),
            [90e5],
            x_scale=[1e6],
        )
        ps = float(free.x[0])
        out.append(
            PaperColumn(
                c + 1,
                ps,
                ps * free.x[1:],
                free.x[1:].copy(),
                float(common.x[0]),
                float(np.max(np.abs(free.fun))),
            )
        )
    return tuple(out)


def _frame(rows):
    import pandas as pd  # deferred: pandas costs ~0.3 s at import

    df = pd.DataFrame(
        rows,
        columns=["table", "cell", "column", "coefficient", "printed", "corrected", "regenerated"],
    )
    df["rel_error"] = (df["regenerated"] - df["corrected"]).abs() / df["corrected"].abs()
    return df


def reproduce_table_iv(dead_zone: DeadZone | None = None):
    """Table IV (k_g, d_g) from :func:`dead_zone_cells`; equal to the printed values exactly.

    Returns
    -------
    pandas.DataFrame
        Columns table, cell, column, coefficient, printed, corrected, regenerated, rel_error.
    """
    dz = dead_zone_cells(dead_zone if dead_zone is not None else DeadZone())
    rows = []
    for i, (k, d) in enumerate(TABLE_IV):
        rows.append(("IV", _ROMAN[i], 1, "k_g", k, k, float(dz.slopes[i])))
        rows.append(("IV", _ROMAN[i], 1, "d_g", d, d, float(dz.offsets[i])))
    df = _frame(rows)
    df["rel_error"] = (df["regenerated"] - df["corrected"]).abs()  # absolute: some entries are 0
    return df


def reproduce_table_v(friction: Friction | None = None):
    """Table V from the Stribeck parameters recovered from it (paper breakpoints, LSQ fit).

    Returns
    -------
    pandas.DataFrame
        Coefficient rows (rel_error per coefficient) with ``attrs["rms_curve_difference"]``:
        the RMS difference [N] between the regenerated and printed curves over ±0.2 m/s.
    """
    fr = friction if friction is not None else recover_stribeck_from_table_v().friction
    fit = friction_cells(fr, 7, "paper")
    rows = []
    for i, ((kp, dp), (kc, dc)) in enumerate(zip(TABLE_V_AS_PRINTED, TABLE_V, strict=True)):
        rows.append(("V", _ROMAN[i], 1, "k_w", kp, kc, float(fit.pwa.slopes[i])))
        rows.append(("V", _ROMAN[i], 1, "d_w", dp, dc, float(fit.pwa.offsets[i])))
    df = _frame(rows)
    df.attrs["rms_curve_difference"] = table_v_residual(fr, fit)
    df.attrs["breakpoints_table_v"] = table_v_pwa().breakpoints.tolist()
    return df


def reproduce_tables_vi_ix(K: float | None = None, common_working_points: bool = False):
    """Regenerate Tables VI–IX from the recovered P_S and working points of each column.

    Parameters
    ----------
    K : float, optional
        Flow coefficient [m³/(s·√Pa)].
    common_working_points : bool
        If True use P̂ = PAPER_WORKING_POINTS·P_S with one fitted P_S per column (6 numbers
        for 80 printed ones); otherwise the free working points of each column.

    Returns
    -------
    pandas.DataFrame
        One row per printed coefficient; ``corrected`` applies the two typo fixes.
    """
    if K is None:
        K = ValveFlow().K
    cols = recover_paper_columns(K)
    printed = {"VI": TABLE_VI, "VII": TABLE_VII, "VIII": TABLE_VIII, "IX": TABLE_IX}
    corrected = {
        "VI": TABLE_VI,
        "VII": TABLE_VII_CORRECTED,
        "VIII": TABLE_VIII_CORRECTED,
        "IX": TABLE_IX,
    }
    names = {"VI": "k_o", "VII": "d_o", "VIII": "k_n", "IX": "d_n"}
    rows = []
    for col in cols:
        c = col.column - 1
        if common_working_points:
            ps = col.supply_pressure_common
            p_hat = ps * np.array(PAPER_WORKING_POINTS)
        else:
            ps, p_hat = col.supply_pressure, col.working_points
        regen = dict(
            zip(("VI", "VII", "VIII", "IX"), tangent_coefficients(K, ps, p_hat), strict=True)
        )
        for t in ("VI", "VII", "VIII", "IX"):
            for i in range(5):
                rows.append(
                    (
                        t,
                        _ROMAN[i],
                        col.column,
                        names[t],
                        printed[t][i, c],
                        corrected[t][i, c],
                        regen[t][i],
                    )
                )
    return _frame(rows)


def reproduce_paper_tables(K: float | None = None) -> dict:
    """All reproduced tables: keys ``IV``, ``V``, ``VI``, ``VII``, ``VIII``, ``IX`` → DataFrame."""
    out = {"IV": reproduce_table_iv(), "V": reproduce_table_v()}
    df = reproduce_tables_vi_ix(K)
    for t in ("VI", "VII", "VIII", "IX"):
        out[t] = df[df["table"] == t].reset_index(drop=True)
    return out


def cq_error_comparison(n_cells: int = 5, interval=(0.0, 1.0)) -> dict[str, float]:
    """Max error of C_q: the paper's tangent cells versus minimax-optimised breakpoints.

    Parameters
    ----------
    n_cells : int
        Cells of the optimised fit (the paper uses 5).
    interval : (float, float)
        Normalised load-pressure range p̃ = P_L/P_S [1]; default 0 <= P_L <= P_S, the
        branch of Fig. 1.

    Returns
    -------
    dict
        ``paper`` and ``optimized``: max |C_q − Ĉ_q| / (K√(P_S/2)) [1] (multiply by
        K√(P_S/2) for m³/s), and ``optimized_breakpoints`` is not included (see cq_cells).
    """
    paper = cq_cells(5, "paper", interval=interval)
    opt = cq_cells(n_cells, "optimized", interval=interval)
    return {
        "paper": approximation_errors(cq_shape, paper.pwa, interval)[0],
        "optimized": approximation_errors(cq_shape, opt.pwa, interval)[0],
    }
