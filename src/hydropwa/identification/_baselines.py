"""Linear black-box baselines for a grey-box fit: ARX and DMDc, fitted and simulated from u alone.

A physical model earns its place when it predicts held-out data at least as well as a linear
model fitted on the same samples. Both baselines here are fitted by linear least squares on
the one-step equation and then *simulated* (each prediction feeds back the model's own past
outputs, never the measured ones), which is the comparison a simulation model must win.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._errors import ParameterError

__all__ = ["ArxModel", "DmdcModel", "fit_arx", "fit_dmdc", "select_arx"]


def _check_signals(u: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    u = np.asarray(u, dtype=float).reshape(-1)
    y = np.asarray(y, dtype=float)
    y = y.reshape(-1, 1) if y.ndim == 1 else y
    if y.shape[0] != u.size or not (np.isfinite(u).all() and np.isfinite(y).all()):
        raise ParameterError(
            f"baseline fit needs finite u and y of one length (u: {u.size}, y: {y.shape[0]} samples)"
        )
    return u, y


@dataclass(frozen=True)
class ArxModel:
    """ARX model y_k = Σ a_i y_{k−i} + Σ b_j u_{k−nk−j+1} + c, one row per output.

    Attributes
    ----------
    a : numpy.ndarray
        Output coefficients, shape (n_y, n_a) (each output on its own past).
    b : numpy.ndarray
        Input coefficients, shape (n_y, n_b).
    c : numpy.ndarray
        Constant, shape (n_y,) (the command's offset, in output units).
    delay : int
        Input delay n_k [samples].
    """

    a: np.ndarray
    b: np.ndarray
    c: np.ndarray
    delay: int

    @property
    def lag(self) -> int:
        """Samples of history one step needs."""
        return max(self.a.shape[1], self.b.shape[1] + self.delay - 1, 1)

    def simulate(self, u: np.ndarray, y0: np.ndarray) -> np.ndarray:
        """Outputs [units of y] driven by u alone from rest at y0 (shape (n_y,)), shape (N, n_y)."""
        u = np.asarray(u, dtype=float).reshape(-1)
        na, nb, ny = self.a.shape[1], self.b.shape[1], self.a.shape[0]
        lag = self.lag
        y = np.empty((u.size + lag, ny))
        y[:lag] = np.asarray(y0, dtype=float).reshape(1, ny)
        up = np.concatenate([np.full(lag, u[0]), u])
        for k in range(lag, y.shape[0]):
            past_u = up[k - self.delay - np.arange(nb)]
            y[k] = (
                np.einsum("ij,ji->i", self.a, y[k - 1 - np.arange(na)]) + self.b @ past_u + self.c
            )
        return y[lag:]


def fit_arx(u: np.ndarray, y: np.ndarray, na: int, nb: int, delay: int = 1) -> ArxModel:
    """Least-squares ARX fit of each column of y on its own past and the input's.

    Parameters
    ----------
    u : numpy.ndarray
        Input, shape (N,).
    y : numpy.ndarray
        Outputs, shape (N,) or (N, n_y).
    na, nb : int
        Orders (≥ 1).
    delay : int
        Input delay n_k [samples] (≥ 0).
    """
    u, y = _check_signals(u, y)
    if na < 1 or nb < 1 or delay < 0:
        raise ParameterError(f"ARX orders na = {na}, nb = {nb} need >= 1 and delay {delay} >= 0")
    lag = max(na, nb + delay - 1, 1)
    rows = np.arange(lag, u.size)
    a, b, c = np.empty((y.shape[1], na)), np.empty((y.shape[1], nb)), np.empty(y.shape[1])
    for i in range(y.shape[1]):
        cols = [y[rows - j, i] for j in range(1, na + 1)]
        cols += [u[rows - delay - j] for j in range(nb)]
        phi = np.column_stack([*cols, np.ones(rows.size)])
        theta = np.linalg.lstsq(phi, y[rows, i], rcond=None)[0]
        a[i], b[i], c[i] = theta[:na], theta[na : na + nb], theta[-1]
    return ArxModel(a, b, c, delay)


def select_arx(
    u: np.ndarray, y: np.ndarray, orders: range, delays: range, holdout: float = 0.25
) -> ArxModel:
    """ARX orders by simulation fit on the last ``holdout`` share of the given data, then refit on all.

    Parameters
    ----------
    u, y : numpy.ndarray
        Input (N,) and outputs (N, n_y) of the fitting part only.
    orders : range
        Candidate n_a = n_b.
    delays : range
        Candidate input delays [samples].
    holdout : float
        Share of the samples kept back to rank the candidates (0 < holdout < 1).
    """
    u, y = _check_signals(u, y)
    cut = int(u.size * (1.0 - holdout))
    best, best_err = None, np.inf
    for n in orders:
        for nk in delays:
            model = fit_arx(u[:cut], y[:cut], n, n, nk)
            with np.errstate(over="ignore", invalid="ignore"):  # an unstable candidate diverges
                sim = model.simulate(u[cut:], y[cut])
                err = float(np.mean(((sim - y[cut:]) / y.std(axis=0)) ** 2))
            if np.isfinite(err) and err < best_err:
                best, best_err = (n, nk), err
    if best is None:
        raise ParameterError("no ARX candidate simulated to a finite error; give lower orders")
    return fit_arx(u, y, best[0], best[0], best[1])


@dataclass(frozen=True)
class DmdcModel:
    """DMD with control: z_{k+1} = A z_k + B u_k + c on the delay-embedded outputs z.

    z_k stacks the outputs y_k, …, y_{k−d+1} (d = ``delays``); its first n_y entries are the
    prediction. The lifting is the identity with delays, the linear Koopman approximation.

    Attributes
    ----------
    A : numpy.ndarray
        State matrix, shape (n_z, n_z).
    B : numpy.ndarray
        Input column, shape (n_z,).
    c : numpy.ndarray
        Constant, shape (n_z,).
    delays : int
        Output delays d in the state.
    n_outputs : int
        n_y.
    """

    A: np.ndarray
    B: np.ndarray
    c: np.ndarray
    delays: int
    n_outputs: int

    def simulate(self, u: np.ndarray, y0: np.ndarray) -> np.ndarray:
        """Outputs driven by u alone from rest at y0 (shape (n_y,)), shape (N, n_y)."""
        u = np.asarray(u, dtype=float).reshape(-1)
        z = np.tile(np.asarray(y0, dtype=float).reshape(-1), self.delays)
        out = np.empty((u.size, self.n_outputs))
        for k in range(u.size):
            out[k] = z[: self.n_outputs]
            z = self.A @ z + self.B * u[k] + self.c
        return out


def fit_dmdc(u: np.ndarray, y: np.ndarray, delays: int = 1) -> DmdcModel:
    """Least-squares DMDc fit of the delay-embedded outputs (see :class:`DmdcModel`)."""
    u, y = _check_signals(u, y)
    if delays < 1:
        raise ParameterError(f"DMDc delays = {delays} needs >= 1")
    n, ny = y.shape
    z = np.column_stack([y[delays - 1 - j : n - j] for j in range(delays)])  # z_k, k ≥ d−1
    phi = np.column_stack([z[:-1], u[delays - 1 : n - 1], np.ones(z.shape[0] - 1)])
    theta = np.linalg.lstsq(phi, z[1:], rcond=None)[0]
    nz = z.shape[1]
    return DmdcModel(theta[:nz].T, theta[nz], theta[nz + 1], delays, ny)
