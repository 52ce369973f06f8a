"""Per-cell steady-state Kalman filter of the state-feedback law (issue 34).

Every gain row of a :class:`~hydropwa.control.StateFeedbackController` gets a discrete
filter of its cell's plant, so the law feeds back estimates instead of the raw noisy
position and load pressure. The estimator state is

    z = [P_L (Pa), ẋ (m/s), x (m), ν (1), ν̇ (1/s), d_a (m/s²), d_p (Pa/s)],

the cell's affine dynamics (Eqs. (23)–(28), its own friction slope)
with the servo valve of Eq. (1) in series (ν the spool in units of the opening c), and two
constant disturbances: an acceleration d_a (load, Coulomb friction and the cell's affine
force term) and a load-pressure rate d_p (the cell's affine flow term, leakage). With as
many integrating disturbances as measured channels the filter is offset free: at rest the
innovations are zero mean and x̂ has no bias, whatever the cell's affine terms are.

Discrete model (zero-order hold at T_s of the opening command the valve receives, i.e.
with the one-sample computation delay the command computed one sample earlier)::

    z⁻_k = Φ z_{k−1} + Γ c_apply,k−1          (Φ, Γ = expm of the continuous model)
    z_k  = z⁻_k + L (y_k − H z⁻_k),   y = [P_L, x],  H picks z[0] and z[2]

L = P Hᵀ (H P Hᵀ + R)⁻¹ the steady-state (measurement-update) Kalman gain, P the a-priori
covariance of the discrete Riccati equation; python-control's ``dlqe`` gives the predictor
gain Φ L of the same filter (tested). R = diag(σ_PL², σ_x²) from the sensor noise; the
process noise (the design knob, :data:`DEFAULT_PROCESS_NOISE`) is white noise on d_a and
d_p per sample, i.e. random walks of the disturbances, plus a white acceleration on ẋ.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ._controllers import SPOOL_COMMAND_NOISE, ControlError, kalman_gain
from ._design import _discrete, cell_plant, valve_series

__all__ = [
    "CellEstimator",
    "DEFAULT_PROCESS_NOISE",
    "N_EST",
    "cell_estimator",
    "design_cell_estimator",
    "kalman_gain",
    "load_pressure_noise",
]

#: estimator states [P_L, ẋ, x, ν, ν̇, d_a, d_p] and measured channels [P_L, x] (and the spool
#: where it is measured: 3)
N_EST = 7
N_MEAS = 2
MEASURED = ("p_l", "x")
MEASURED_SPOOL = ("p_l", "x", "spool")
#: process noise, the design knob (standard deviations per sample): "acceleration" [m/s²] a
#: white acceleration held over one sample (on ẋ), "force_drift" the random-walk step of d_a
#: [m/s²], "pressure_drift" that of d_p [Pa/s], "pressure" [Pa] white on P_L (the flow model
#: of a cell linearized at u = ±0.6 is poor near a closed valve: the filter then follows the
#: measured P_L). Closed loop on the paper trapezoid (full model, delay, 20 µm / 0.1 bar): peak
#: error 0.056 mm, hold 0.044 mm, but 765 command sign changes/s (docs/control.md)
DEFAULT_PROCESS_NOISE = {
    "acceleration": 0.3,
    "force_drift": 1.0,
    "pressure_drift": 2e3,
    "pressure": 1e5,
}
#: scales of the estimator states (bar, mm/s, mm, %, 1/s, m/s², bar/s) for the Riccati equation
_EST_SCALE = np.array([1e5, 1e-3, 1e-3, 1e-2, 1.0, 1.0, 1e5])


def load_pressure_noise(noise: Mapping[str, float], area_ratio: float, mean_area: bool) -> float:
    """Standard deviation [Pa] of the measured load pressure from the chamber sensors' noise.

    P_L = P_A − α P_B (asymmetric) or (P_A − α P_B)·2/(1 + α) (the paper's mean-area form),
    with independent noise on P_A and P_B (``noise["p_a"]``, ``noise["p_b"]`` [Pa]).
    """
    s = math.hypot(float(noise.get("p_a", 0.0)), area_ratio * float(noise.get("p_b", 0.0)))
    return s * 2.0 / (1.0 + area_ratio) if mean_area else s


def _cell_model(A, B, omega0: float, zeta: float):
    """Continuous (F, G) of z = [P_L, ẋ, x, ν, ν̇, d_a, d_p], input the opening command c."""
    Av, Bv = valve_series(A, B, omega0, zeta)
    F = np.zeros((N_EST, N_EST))
    F[:5, :5] = Av
    F[1, 5] = 1.0  # d_a acts on the acceleration
    F[0, 6] = 1.0  # d_p on the load-pressure rate
    G = np.zeros((N_EST, 1))
    G[:5] = Bv
    return F, G


def cell_estimator(A, B, f, *, sample_time, omega0, zeta, sigma_pl, sigma_x, process, sigma_nu=0.0):
    """Φ (7 × 7), Γ (7), φ₀ (7), L (7 × 2) and the initial values' coefficients of one cell.

    ``A``, ``B``, ``f``: the cell's continuous affine plant ẏ = A y + B c + f, y = [P_L, ẋ, x],
    c the opening (the cell's own friction slope); ``sigma_nu`` > 0: the spool is measured too
    (y = [P_L, x, ν], L is 7 × 3, R = diag(σ_PL², σ_x², σ_ν²)), and white noise of
    :data:`~hydropwa.control.SPOOL_COMMAND_NOISE` on the opening the valve holds (Γ w) is added
    to the process noise, as in the spool filter (without it the valve states are exact in the
    model and the measured spool would get no gain); ``process``:
    :data:`DEFAULT_PROCESS_NOISE`'s keys. Returns (phi, gamma, affine, gain, init): ``init`` =
    (A[1, 0], A[0, 0], f[1], f[0]), so that at the first sample d_a = −A[1,0] P_L − f[1],
    d_p = −A[0,0] P_L − f[0] make the measured rest an equilibrium of the model.
    """
    F, G = _cell_model(A, B, omega0, zeta)
    G2 = np.zeros((N_EST, 2))
    G2[:, 0] = G[:, 0]
    G2[:3, 1] = f
    phi, gam2 = _discrete(F, G2, sample_time)
    gam, aff = gam2[:, :1], gam2[:, 1]
    T, Ti = np.diag(_EST_SCALE), np.diag(1.0 / _EST_SCALE)
    m = N_MEAS + (1 if sigma_nu > 0.0 else 0)
    W = np.zeros((N_EST, 4 + m - N_MEAS))
    W[1, 0] = sample_time * process["acceleration"]
    W[0, 3] = process["pressure"]
    W[5, 1] = process["force_drift"]
    W[6, 2] = process["pressure_drift"]
    if m > N_MEAS:  # the valve states get noise to measure: white noise on the opening held
        W[:, 4] = gam[:, 0] * SPOOL_COMMAND_NOISE
    H = np.zeros((m, N_EST))
    H[0, 0], H[1, 2] = 1.0, 1.0
    R = np.diag([sigma_pl**2, sigma_x**2, sigma_nu**2][:m])
    if m > N_MEAS:
        H[2, 3] = 1.0
    Ls, _P = kalman_gain(Ti @ phi @ T, H @ T, Ti @ W @ W.T @ Ti, R)
    L = T @ Ls
    return phi, gam[:, 0], aff, L, (float(A[1, 0]), float(A[0, 0]), float(f[1]), float(f[0]))


@dataclass(frozen=True)
class CellEstimator:
    """The per-row Kalman filters of a state-feedback controller (schema 2, ``estimator``).

    Attributes
    ----------
    phi : tuple of tuples
        Per gain row, Φ row-major (49 values) [SI ratios of the states above].
    gamma : tuple of tuples
        Per row, Γ (7 values) [state units per unit opening].
    affine : tuple of tuples
        Per row, φ₀ (7 values) [state units]: the cell's affine term over one sample.
    gain : tuple of tuples
        Per row, L row-major (7 × m: one column per entry of ``measured``) (14 or 21 values).
    init : tuple of tuples
        Per row, (a_vp [m/(s²·Pa)], a_pp [1/s], f_a [m/s²], f_p [Pa/s]):
        d_a = −a_vp P_L − f_a, d_p = −a_pp P_L − f_p at k = 0.
    noise : dict
        The design: sensor noise {"x": m, "p_l": Pa (, "spool": 1)} and process noise (SI).
    measured : tuple of str
        The measured channels, the columns of L: ("p_l", "x"), or ("p_l", "x", "spool") where
        the valve reports the spool (y = [P_L, x, ν_m], ν_m mapped to the opening).
    """

    phi: tuple[tuple[float, ...], ...]
    gamma: tuple[tuple[float, ...], ...]
    affine: tuple[tuple[float, ...], ...]
    gain: tuple[tuple[float, ...], ...]
    init: tuple[tuple[float, ...], ...]
    noise: dict = field(default_factory=dict, compare=False)
    measured: tuple[str, ...] = MEASURED

    def __post_init__(self) -> None:
        meas = tuple(self.measured)
        if meas not in (MEASURED, MEASURED_SPOOL):
            raise ControlError(
                f"CellEstimator.measured {list(meas)} must be {list(MEASURED)} or {list(MEASURED_SPOOL)}"
            )
        object.__setattr__(self, "measured", meas)
        shapes = (
            ("phi", N_EST * N_EST),
            ("gamma", N_EST),
            ("affine", N_EST),
            ("gain", N_EST * len(meas)),
            ("init", 4),
        )
        n = None
        for name, size in shapes:
            a = np.asarray(getattr(self, name), dtype=float)
            if a.ndim != 2 or a.shape[1] != size or not np.all(np.isfinite(a)):
                raise ControlError(
                    f"CellEstimator.{name} must hold {size} finite values per gain row"
                )
            if n is not None and a.shape[0] != n:
                raise ControlError(
                    "CellEstimator: phi, gamma, affine, gain and init need one entry per row"
                )
            n = a.shape[0]
            object.__setattr__(self, name, tuple(tuple(float(v) for v in r) for r in a))
        if not isinstance(self.noise, dict):
            raise ControlError("CellEstimator.noise must be a dict")

    @property
    def rows(self) -> int:
        """Number of gain rows the filters are for."""
        return len(self.phi)

    @property
    def measures_spool(self) -> bool:
        """Whether the filter measures the spool too (y = [P_L, x, ν_m])."""
        return len(self.measured) > N_MEAS

    def packed_rows(self) -> np.ndarray:
        """Per row [Φ (49), Γ (7), φ₀ (7), L (14), init (4)]: the compiled law's layout (``EROW``);
        with the spool measured, L's P_L and x columns here and :meth:`spool_columns` after."""
        m = len(self.measured)
        gain = (
            np.asarray(self.gain).reshape(-1, N_EST, m)[:, :, :N_MEAS].reshape(-1, N_EST * N_MEAS)
        )
        parts = (self.phi, self.gamma, self.affine, gain, self.init)
        return np.hstack([np.asarray(p) for p in parts])

    def spool_columns(self) -> np.ndarray:
        """Per row the spool column of L (7 values; rows × 0 without the spool measured)."""
        m = len(self.measured)
        cols = np.asarray(self.gain).reshape(-1, N_EST, m)[:, :, N_MEAS:]
        return cols.transpose(0, 2, 1).reshape(len(self.gain), N_EST * (m - N_MEAS))

    def describe(self) -> dict[str, Any]:
        """Plain dict (SI) as written to controller files."""
        return {
            "states": ["p_l", "v", "x", "spool", "spool_rate", "d_acceleration", "d_pressure_rate"],
            "measured": list(self.measured),
            "noise": dict(self.noise),
            "phi": [list(r) for r in self.phi],
            "gamma": [list(r) for r in self.gamma],
            "affine": [list(r) for r in self.affine],
            "gain": [list(r) for r in self.gain],
            "init": [list(r) for r in self.init],
        }

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> CellEstimator:
        """Inverse of :meth:`describe`."""
        try:
            return cls(
                phi=d["phi"],
                gamma=d["gamma"],
                affine=d["affine"],
                gain=d["gain"],
                init=d["init"],
                noise=dict(d.get("noise", {})),
                measured=tuple(d.get("measured", MEASURED)),
            )
        except KeyError as exc:
            raise ControlError(f"controller file: estimator lacks {exc.args[0]!r}") from None


def _cell_plant_as_designed(model, key, info):
    """The cell's continuous (A, B, f) with the design's input, the opening c.

    With the dead-zone inverse z = k_g u + b_g = c, so B_c = B/k_g and f_c = f − B_c b_g. The
    friction slope is the cell's own (not clipped as for the gains: with the clipped slopes
    x̂ was 35-50 µm off at the end of the paper trapezoid, with the exact ones within 11 µm;
    a viscous slope everywhere did not reduce the heavy axis's sign changes either).
    """
    dzi = info.get("dead_zone_inverse", True)
    A, B, dyn = cell_plant(model, cells=key, f_l=info.get("load_force"), opening_input=dzi)
    f = np.asarray(dyn.f, dtype=float).copy()
    if dzi:
        f -= B[:, 0] * float(model.dead_zone.offsets[dyn.cells.g])
    return A, B, f


def design_cell_estimator(
    model,
    design,
    sensor_noise: Mapping[str, float],
    process_noise: Mapping[str, float] | None = None,
) -> CellEstimator:
    """The per-cell steady-state Kalman filters for a state-feedback design.

    Parameters
    ----------
    model : PwaModel
        The model the design was made on.
    design : ControlDesign
        A valve-aware :func:`~hydropwa.control.design_state_feedback` result (its table's
        g, s, o, w columns name each row's cell).
    sensor_noise : mapping
        Standard deviations {"x": m, "p_a": Pa, "p_b": Pa} of the measured channels; with the
        design's spool measured (``spool="measured"``) and ``"spool"`` [1] > 0 the filter
        measures the spool too (y = [P_L, x, ν_m], L 7 × 3).
    process_noise : mapping, optional
        :data:`DEFAULT_PROCESS_NOISE` overrides (the design knob).

    Returns
    -------
    CellEstimator
    """
    ctrl = design.controller
    if ctrl.spool_model is None:
        raise ControlError(
            "the per-cell Kalman filter needs the valve-aware design (valve=True, method='lqr')"
        )
    proc = dict(DEFAULT_PROCESS_NOISE)
    for k, v in (process_noise or {}).items():
        if k not in proc:
            raise ControlError(f"unknown process noise {k!r}; choose from {', '.join(proc)}")
        if not (isinstance(v, int | float) and math.isfinite(v) and v > 0):
            raise ControlError(f"process noise {k} = {v!r} must be a positive number (SI)")
        proc[k] = float(v)
    sx = float(sensor_noise.get("x", 0.0))
    prm = model.params
    alpha = float(prm.cylinder.area_b / prm.cylinder.area_a)
    spl = load_pressure_noise(sensor_noise, alpha, ctrl.load_pressure == "mean-area")
    if not (sx > 0 and spl > 0):
        raise ControlError(
            "the per-cell Kalman filter needs positive sensor noise on x and on p_a or p_b "
            "(e.g. --sensor-noise 'x=20 um,p_a=0.1 bar,p_b=0.1 bar')"
        )
    snu = float(sensor_noise.get("spool", 0.0)) if ctrl.spool_model.measured else 0.0
    info = dict(design.info) | {"dead_zone_inverse": ctrl.dead_zone_inverse is not None}
    parts: list[list[Any]] = [[], [], [], [], []]
    for rec in design.table.itertuples():
        A, B, f = _cell_plant_as_designed(model, (rec.g, rec.s, rec.o, rec.w), info)
        phi, gam, aff, L, init = cell_estimator(
            A,
            B,
            f,
            sample_time=ctrl.sample_time,
            omega0=prm.valve.omega0,
            zeta=prm.valve.zeta,
            sigma_pl=spl,
            sigma_x=sx,
            process=proc,
            sigma_nu=snu,
        )
        for lst, val in zip(parts, (phi.ravel(), gam, aff, L.ravel(), init), strict=True):
            lst.append(tuple(val))
    spool = {"spool": snu, "command": SPOOL_COMMAND_NOISE} if snu > 0.0 else {}
    noise = {"x": sx, "p_l": spl} | spool | proc
    phis, gams, affs, gains, inits = (tuple(p) for p in parts)
    meas = MEASURED_SPOOL if snu > 0.0 else MEASURED
    return CellEstimator(
        phi=phis, gamma=gams, affine=affs, gain=gains, init=inits, noise=noise, measured=meas
    )
