"""Dense output and the output channels: Hermite interpolation, per-model output passes."""

from __future__ import annotations

import numpy as np
from numba import njit

from .. import _jitcache  # noqa: F401  (one cache stamp for all compiled modules)
from .._layout import LINES_KIND
from ..components._physics import (
    chamber_pressures_from_load,
)
from ._kcommon import (
    CHAMBER,
    FULL,
    I_CLOAD,
    I_PUMP,
    I_VLA,
    I_VLB,
    INLINE_NRT_JIT,
    L_PL,
    L_V,
    L_X,
    N_OUT,
    N_OUT_CHAMBER,
    N_OUT_PWA,
    O_F_L,
    O_F_SPEC,
    O_FRICTION,
    O_P_A,
    O_P_B,
    O_P_L,
    O_P_S,
    O_SPOOL,
    O_U,
    O_V,
    O_X,
    O_Z,
    PWA,
    REDUCED,
    Y_NU,
    Y_PA,
    Y_PB,
    Y_PS,
    Y_V,
    Y_X,
    _friction,
    _inputs,
    _opening,
    _specimen,
    n_states,
)
from ._rhs_chamber import chamber_terms
from ._rhs_load import _pwa_friction_cell, _reduced_terms, pwa_cells
from ._signals import NO_REFCOUNT


@njit(**INLINE_NRT_JIT)
def _dense_output(kind, Y, k_out, t_out, t, h, y, f0, ynew, fnew):
    """Fill output rows with t_out in (t, t + h] by cubic Hermite interpolation; returns the next row.

    The interpolant matches y and f at both ends, so it is third-order accurate
    and needs no extra right-hand-side calls.
    """
    n = n_states(kind)
    n_out = t_out.shape[0]
    t_new = t + h
    while k_out < n_out and t_out[k_out] <= t_new + 1e-12 * max(1.0, abs(t_new)):
        th = (t_out[k_out] - t) / h
        th2 = th * th
        h00 = 1.0 - 3.0 * th2 + 2.0 * th2 * th
        h10 = th - 2.0 * th2 + th2 * th
        h01 = 3.0 * th2 - 2.0 * th2 * th
        h11 = th2 * th - th2
        for i in range(n):
            Y[k_out, i] = h00 * y[i] + h01 * ynew[i] + h * (h10 * f0[i] + h11 * fnew[i])
        k_out += 1
    return k_out


# One compiled output pass per model: each holds only its own model's code, and a command
# compiles only the one it runs. Rows: the layout table's OUTPUT_CHANNELS (12), and for the PWA
# model the active cells g, o, n, w (PWA_OUTPUT_CHANNELS). The friction row of the full and
# reduced models is the Stribeck law at each sample's velocity, computed in the same pass.
@njit(cache=True, nogil=True, error_model="numpy")
def _outputs_full(t_out, Y, n_done, p, sg):
    out = np.empty((N_OUT, n_done))
    _fill_full(t_out, Y, n_done, p, sg, out)
    return out


@njit(cache=True, nogil=True, error_model="numpy")
def _outputs_reduced(t_out, Y, n_done, p, sg):
    out = np.empty((N_OUT, n_done))
    _fill_reduced(t_out, Y, n_done, p, sg, out)
    return out


@njit(cache=True, nogil=True, error_model="numpy")
def _outputs_pwa(t_out, Y, n_done, p, sg):
    out = np.empty((N_OUT_PWA, n_done))
    _fill_pwa(t_out, Y, n_done, p, sg, out)
    return out


@njit(cache=True, nogil=True, error_model="numpy")
def _outputs_chamber(t_out, Y, n_done, p, sg):
    out = np.empty((N_OUT_CHAMBER, n_done))
    _fill_chamber(t_out, Y, n_done, p, sg, out)
    return out


_LINES_ROW = LINES_KIND
LINES = _LINES_ROW.kernel
N_OUT_LINES = N_OUT + len(_LINES_ROW.extra_outputs)
_Y_PLA, _Y_PLB = (len(_LINES_ROW.states) - 2, len(_LINES_ROW.states) - 1)


@njit(cache=True, nogil=True, error_model="numpy")
def _outputs_lines(t_out, Y, n_done, p, sg):
    """Output pass of the full-lines model: the full model's rows, then P_line,A and P_line,B
    (a chamber's pressure where its port has no line)."""
    out = np.empty((N_OUT_LINES, n_done))
    _fill_full(t_out, Y, n_done, p, sg, out)
    for k in range(n_done):
        out[N_OUT, k] = Y[k, _Y_PLA] if p[I_VLA] > 0.0 else Y[k, Y_PA]
        out[N_OUT + 1, k] = Y[k, _Y_PLB] if p[I_VLB] > 0.0 else Y[k, Y_PB]
    return out


#: The output pass of each model kind: ``OUTPUTS[kind](t_out, Y, n_done, p, sg)``.
OUTPUTS = {
    FULL: _outputs_full,
    REDUCED: _outputs_reduced,
    PWA: _outputs_pwa,
    CHAMBER: _outputs_chamber,
    LINES: _outputs_lines,
}


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT, inline="always")
def _write_outputs(out, k, u, spool, z, pa, pb, pl, ps, fl, x, v, fr, p):
    """Output column k (rows from the layout table's OUTPUT_CHANNELS)."""
    out[O_U, k] = u
    out[O_SPOOL, k] = spool
    out[O_Z, k] = z
    out[O_P_A, k] = pa
    out[O_P_B, k] = pb
    out[O_P_L, k] = pl  # the model's load pressure: P_A − P_B (full, paper form), P_A − α P_B
    out[O_P_S, k] = ps
    out[O_F_L, k] = fl + p[I_CLOAD] * v  # the force sensor measures F_L(t) + c·ẋ
    out[O_X, k] = x
    out[O_V, k] = v
    out[O_FRICTION, k] = fr
    out[O_F_SPEC, k] = _specimen(x, v, p)


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def _fill_full(t_out, Y, n_done, p, sg, out):
    """Output pass of the full model (allocation-free), the Stribeck friction included."""
    for k in range(n_done):
        u, ps, fl = _inputs(t_out[k], sg)
        spool = Y[k, Y_NU]
        pa, pb = Y[k, Y_PA], Y[k, Y_PB]
        if p[I_PUMP] > 0.5:
            ps = Y[k, Y_PS]
        _write_outputs(
            out,
            k,
            u,
            spool,
            _opening(spool, p),
            pa,
            pb,
            pa - pb,
            ps,
            fl,
            Y[k, Y_X],
            Y[k, Y_V],
            _friction(Y[k, Y_V], p),
            p,
        )


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def _fill_reduced(t_out, Y, n_done, p, sg, out):
    """Output pass of the reduced model: P_A, P_B from P_L by Eq. (13), generalised."""
    for k in range(n_done):
        u, ps, fl = _inputs(t_out[k], sg)
        pl, v, x = Y[k, L_PL], Y[k, L_V], Y[k, L_X]
        z = _opening(u, p)
        al, pt, _a, _cq, _cl, _dcq, _dcl = _reduced_terms(x, p)
        pa, pb = chamber_pressures_from_load(z, pl, ps, al, pt)
        _write_outputs(out, k, u, u, z, pa, pb, pl, ps, fl, x, v, _friction(v, p), p)


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def _fill_pwa(t_out, Y, n_done, p, sg, out):
    """Output pass of the PWA model, with its active cells g, o, n, w in the extra rows."""
    for k in range(n_done):
        u, ps, fl = _inputs(t_out[k], sg)
        pl, v, x = Y[k, L_PL], Y[k, L_V], Y[k, L_X]
        g, o, nn, w, z, ps, _pn = pwa_cells(pl, v, u, ps, p)
        f_slope, f_offset = _pwa_friction_cell(p, w)
        out[N_OUT, k] = g
        out[N_OUT + 1, k] = o
        out[N_OUT + 2, k] = nn
        out[N_OUT + 3, k] = w
        al, pt, _a, _cq, _cl, _dcq, _dcl = _reduced_terms(x, p)
        pa, pb = chamber_pressures_from_load(z, pl, ps, al, pt)
        _write_outputs(out, k, u, u, z, pa, pb, pl, ps, fl, x, v, f_slope * v + f_offset, p)


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT)
def _fill_chamber(t_out, Y, n_done, p, sg, out):
    """Output pass of the chamber PWA model, with its active cells g, a, b, x, w in the extra rows."""
    for k in range(n_done):
        u, ps_in, fl = _inputs(t_out[k], sg)
        y = Y[k]
        terms = chamber_terms(y, ps_in, p)  # positions as chamber_terms returns them
        z, ps, fk, fd = terms[0], terms[2], terms[12], terms[13]
        g, ca, cb, j, w = terms[14], terms[15], terms[16], terms[17], terms[18]
        out[N_OUT, k] = g
        out[N_OUT + 1, k] = ca
        out[N_OUT + 2, k] = cb
        out[N_OUT + 3, k] = j
        out[N_OUT + 4, k] = w
        pa, pb, v = y[Y_PA], y[Y_PB], y[Y_V]
        _write_outputs(out, k, u, y[Y_NU], z, pa, pb, pa - pb, ps, fl, y[Y_X], v, fk * v + fd, p)
