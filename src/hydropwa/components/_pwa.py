"""A continuous or discontinuous piecewise-affine scalar function y = k_i·x + d_i.

This is the data type of every PWA cell set (dead-zone, C_q, C_qp, friction),
Eqs. (16), (20)–(22). Fitting lives in :mod:`hydropwa.linearization`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._errors import PwaError

__all__ = ["PiecewiseAffine", "read_only"]


def read_only(a) -> np.ndarray:
    """A float copy of ``a`` (at least 1-D) that cannot be written: the arrays of frozen
    model objects. An edit in place raises ``ValueError: assignment destination is read-only``
    instead of changing a model (and the cell fits that models share) behind its back."""
    out = np.atleast_1d(np.array(a, dtype=float))
    out.setflags(write=False)
    return out


@dataclass(frozen=True)
class PiecewiseAffine:
    """Cells of a scalar piecewise-affine function.

    Attributes
    ----------
    breakpoints : ndarray, shape (n-1,)
        Strictly increasing cell boundaries; cell i covers
        [breakpoints[i-1], breakpoints[i]) with the outer cells unbounded.
    slopes : ndarray, shape (n,)
        Slope k_i of each cell (unit of y per unit of x).
    offsets : ndarray, shape (n,)
        Offset d_i of each cell (unit of y).
    """

    breakpoints: np.ndarray
    slopes: np.ndarray
    offsets: np.ndarray

    def __post_init__(self) -> None:
        b = np.atleast_1d(np.asarray(self.breakpoints, dtype=float))
        k = np.atleast_1d(np.asarray(self.slopes, dtype=float))
        d = np.atleast_1d(np.asarray(self.offsets, dtype=float))
        if k.size == 0:
            raise PwaError("a piecewise-affine function needs at least one cell")
        if k.shape != d.shape or b.size != k.size - 1:
            raise PwaError(
                f"{k.size} slopes, {d.size} offsets and {b.size} breakpoints do not fit: "
                "n cells need n slopes, n offsets and n-1 breakpoints"
            )
        if not (np.all(np.isfinite(b)) and np.all(np.isfinite(k)) and np.all(np.isfinite(d))):
            raise PwaError("breakpoints, slopes and offsets must be finite")
        if np.any(np.diff(b) <= 0):
            raise PwaError(f"breakpoints {b.tolist()} must be strictly increasing")
        object.__setattr__(self, "breakpoints", read_only(b))
        object.__setattr__(self, "slopes", read_only(k))
        object.__setattr__(self, "offsets", read_only(d))

    @property
    def n_cells(self) -> int:
        """Number of cells."""
        return int(self.slopes.size)

    @classmethod
    def from_lines(cls, slopes, offsets) -> PiecewiseAffine:
        """Continuous PWA whose breakpoints are the intersections of neighbouring lines."""
        k = np.asarray(slopes, dtype=float)
        d = np.asarray(offsets, dtype=float)
        dk = k[1:] - k[:-1]
        if np.any(dk == 0):
            raise PwaError("neighbouring cells with equal slopes have no intersection")
        b = -(d[1:] - d[:-1]) / dk
        return cls(b, k, d)

    def cell(self, x):
        """Index of the active cell for x (array or float)."""
        return np.searchsorted(self.breakpoints, x, side="right")

    def __call__(self, x):
        i = self.cell(x)
        return self.slopes[i] * x + self.offsets[i]

    def jumps(self) -> np.ndarray:
        """Value jump at each breakpoint (right minus left limit); zero if continuous."""
        b = self.breakpoints
        return (self.slopes[1:] - self.slopes[:-1]) * b + (self.offsets[1:] - self.offsets[:-1])
