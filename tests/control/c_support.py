"""Helpers of the C-target tests: compile the generated controller, replay measured samples.

The package's compiled law (:func:`hydropwa.simulation._controller.controller_sample`) and the
generated C are driven with the same measurement sequence; both give the command, the
command before the inverse and limits, and the gain row at every sample.
"""

from __future__ import annotations

import ctypes
import shutil
import subprocess
from pathlib import Path

import numpy as np

from hydropwa._layout import Y_FULL, Y_LOAD
from hydropwa.control import c_structs
from hydropwa.simulation import _controller as C

#: the flags the issue requires the generated C to compile cleanly with
STRICT = ("-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic", "-O2", "-ffp-contract=off")

GCC = shutil.which("gcc")


#: ctypes mirrors of the C structs, read from the shipped header (``c_structs``)
_STRUCTS = c_structs()
Meas = _STRUCTS["hydropwa_ctrl_meas"]
State = _STRUCTS["hydropwa_ctrl_state"]
Ref = _STRUCTS["hydropwa_ctrl_ref"]


def compile_shared(src: Path, out: Path, extra: tuple[str, ...] = ()) -> ctypes.CDLL:
    """Compile ``src/hydropwa_ctrl.c`` with :data:`STRICT` into a shared library and load it."""
    cmd = [GCC, *STRICT, *extra, "-shared", "-fPIC", "-o", str(out), str(src / "hydropwa_ctrl.c")]
    cmd.append("-lm")
    proc = subprocess.run(cmd, capture_output=True, text=True, check=False)
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr == "", proc.stderr  # no warning at all
    lib = ctypes.CDLL(str(out))
    lib.hydropwa_ctrl_step.restype = ctypes.c_double
    lib.hydropwa_ctrl_step.argtypes = [
        ctypes.POINTER(State),
        ctypes.POINTER(Meas),
        ctypes.POINTER(Ref),
    ]
    lib.hydropwa_ctrl_load_pressure.restype = ctypes.c_double
    lib.hydropwa_ctrl_load_pressure.argtypes = [ctypes.c_double] * 4
    return lib


def reference_channels(controller, reference, tk: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The reference r and channels (ṙ, ṙ(t + τ), r̈; no noise) the package's loop samples at
    ``tk`` (``simulate``'s own set-up of a closed-loop run)."""
    from hydropwa.simulation._simulate import _closed_loop_setup

    _ctl, _sig, r, rch = _closed_loop_setup(controller, reference, np.asarray(tk, dtype=float))
    return r, rch


def replay_c(lib: ctypes.CDLL, x, v, pl, r, rch) -> dict[str, np.ndarray]:
    """Step the compiled C controller over the samples; command, c and row per sample.

    ``rch``: the reference channels (rows ``RC_*`` of the compiled law) at the samples.
    """
    n = len(x)
    s = State()
    m = Meas()
    rf = Ref()
    lib.hydropwa_ctrl_init(ctypes.byref(s))
    u, c, row = np.empty(n), np.empty(n), np.empty(n, dtype=np.int64)
    for k in range(n):
        m.x, m.v, m.p_l = float(x[k]), float(v[k]), float(pl[k])
        rf.r, rf.r_rate = float(r[k]), float(rch[C.RC_DR, k])
        rf.r_rate_ff, rf.r_acc = float(rch[C.RC_DRFF, k]), float(rch[C.RC_DDR, k])
        rf.r_rate_pre = float(rch[C.RC_DRPO, k])
        u[k] = lib.hydropwa_ctrl_step(ctypes.byref(s), ctypes.byref(m), ctypes.byref(rf))
        c[k], row[k] = s.c_raw, s.row
    return {"u": u, "c": c, "row": row}


def replay_package(ctl: np.ndarray, x, v, pl, r, rch, a_a, a_b) -> dict[str, np.ndarray]:
    """Step the package's compiled law (the reduced-model measurement: y = [P_L, v, x]).

    ``rch``: the reference channels at the samples (the noise rows are not used: the noise
    is in the measurements); ``a_a``, ``a_b``: the piston areas [m²] the loop passes.
    """
    n = len(x)
    cst = np.zeros(C.N_CST)
    log = np.zeros((C.N_LOG, n))
    sg = np.zeros(32)
    y = np.zeros(len(Y_LOAD))
    ts = float(ctl[C.C_TS])
    r = np.ascontiguousarray(r, dtype=float)
    ch = np.zeros((C.N_RCH, n))
    ch[: C.RC_NX] = np.asarray(rch, dtype=float)[: C.RC_NX]
    ch[C.RC_DRPO] = np.asarray(rch, dtype=float)[C.RC_DRPO]
    for k in range(n):
        y[Y_LOAD["x"]], y[Y_LOAD["v"]], y[Y_LOAD["p_l"]] = x[k], v[k], pl[k]
        C.controller_sample(1, k, k * ts, y, a_a, a_b, ctl, cst, r, ch, sg, log)
    return {"u": log[C.L_U].copy(), "c": log[C.L_C].copy(), "row": log[C.L_ROW].astype(np.int64)}


def package_load_pressure(ctl, p_a, p_b, a_a, a_b) -> np.ndarray:
    """P_L the package's loop measures on the full model (:func:`~._controller.measure`)."""
    y = np.zeros(len(Y_FULL))
    out = np.empty(len(p_a))
    for k in range(len(p_a)):
        y[Y_FULL["p_a"]], y[Y_FULL["p_b"]] = p_a[k], p_b[k]
        out[k] = C.measure(0, y, a_a, a_b, ctl[C.C_PLMEAN])[2]
    return out


#: a stand-alone program for the sanitizer run: reads n and the areas, then
#: n × (x, v, p_a, p_b, r, ṙ, ṙ(t + τ), r̈, ṙ(t + τ_o)) from stdin (binary doubles), writes n × (u, c, row) to stdout
DRIVER = r"""
#include <stdio.h>
#include <stdlib.h>
#include "hydropwa_ctrl.h"

int main(void)
{
    double head[3];
    long n, k;
    hydropwa_ctrl_state s;
    hydropwa_ctrl_ref ref;
    if (fread(head, sizeof(double), 3, stdin) != 3) return 2;
    n = (long)head[0];
    hydropwa_ctrl_init(&s);
    for (k = 0; k < n; ++k) {
        double in[9], out[3];
        hydropwa_ctrl_meas m;
        if (fread(in, sizeof(double), 9, stdin) != 9) return 3;
        m.x = in[0];
        m.v = in[1];
        m.p_l = hydropwa_ctrl_load_pressure(in[2], in[3], head[1], head[2]);
        ref.r = in[4];
        ref.r_rate = in[5];
        ref.r_rate_ff = in[6];
        ref.r_acc = in[7];
        ref.r_rate_pre = in[8];
        out[0] = hydropwa_ctrl_step(&s, &m, &ref);
        out[1] = s.c_raw;
        out[2] = (double)s.row;
        if (fwrite(out, sizeof(double), 3, stdout) != 3) return 4;
    }
    hydropwa_ctrl_reset(&s);
    return 0;
}
"""
