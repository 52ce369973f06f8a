"""What every kernel module shares: model kinds, packed indices, input evaluation.

The state (``Y_*``, ``L_*``), parameter-slot (``I_*``) and output-row (``O_*``) indices are
generated from the one layout table, :mod:`hydropwa._layout`; numba compiles them in as
constants. The three packed inputs u, P_S, F_L are read here for every model.
"""

from __future__ import annotations

import numpy as np
from numba import njit, types
from numba.extending import overload

from .. import _jitcache  # noqa: F401  (one cache stamp for all compiled modules)
from .._layout import (
    CHAMBER_OUTPUT_CHANNELS,
    MODEL_KINDS,
    N_SIGNALS,
    OUT,
    OUTPUT_CHANNELS,
    PWA_OUTPUT_CHANNELS,
    PWA_SLOT,
    PWA_SLOTS,
    SG,
    SG_VALUE,
    SLOT,
    SOLVER_STATS,
    STAT,
    Y_FULL,
    Y_LOAD,
)
from ..components._physics import (
    dead_zone,
    end_stop_force,
    end_stop_force_slope,
    load_pressure_gain,
    specimen_force,
    specimen_force_slope,
    stribeck_friction,
)
from ._signals import NO_REFCOUNT, eval_signal, eval_signal_rate

#: numba options of the solver's compiled parts: cached on disk, the GIL released, NumPy's
#: error model, and the fast-math flags that keep NaN/inf semantics (contraction, reciprocal,
#: no signed zero).
SOLVER_JIT: dict = {
    "cache": True,
    "nogil": True,
    "error_model": "numpy",
    "fastmath": {"contract", "arcp", "nsz"},
}
#: The same for helpers inlined into the step loop.
INLINE_JIT: dict = {**SOLVER_JIT, "inline": "always"}
#: ... that touch only arrays their caller owns (no reference counting, see ``NO_REFCOUNT``).
INLINE_NRT_JIT: dict = {**INLINE_JIT, **NO_REFCOUNT}

#: The registry rows (:data:`hydropwa._layout.MODEL_KINDS`) in kernel order: every per-kind
#: constant of the compiled code below is derived from them, indexed by the kind's kernel id.
KIND_ROWS = tuple(MODEL_KINDS.values())
#: The kernel ids under the names the physics modules use (the registry's rows, in order).
FULL, REDUCED, PWA, CHAMBER = (row.kernel for row in KIND_ROWS[:4])
_CBRT_1E4 = 1e-4 ** (1.0 / 3.0)
N_STATES = tuple(len(row.states) for row in KIND_ROWS)
_N_FULL = N_STATES[FULL]  # (the chamber model's loops over the full state)
# State indices: generated from the state tables in hydropwa._layout.
Y_NU, Y_DNU, Y_PA, Y_PB, Y_X, Y_V, Y_PS = (
    Y_FULL[k] for k in ("spool", "spool_rate", "p_a", "p_b", "x", "v", "p_s")
)
Y_PACC = Y_FULL["p_acc"]
L_PL, L_V, L_X = (Y_LOAD[k] for k in ("p_l", "v", "x"))

#: Per-kind flags of the registry rows (``CARRIES_SPOOL[kind]``, ...).
CARRIES_SPOOL = tuple(row.carries_spool for row in KIND_ROWS)
JAC_DEPENDS_ON_U = tuple(row.jacobian_depends_on_u for row in KIND_ROWS)
#: Inert trailing states of each kind (:attr:`~hydropwa._layout.ModelKind.inert_states`), padded
#: to ``N_INERT`` entries: state index (−1: none), parameter slot (−1: always inert), threshold.
N_INERT = max(len(row.inert_states) for row in KIND_ROWS)


def _inert_table(row, field):
    pad = ((-1, -1, 0.0),) * (N_INERT - len(row.inert_states))
    index = {name: i for i, (name, _u, _s) in enumerate(row.states)}
    entries = tuple(
        (index[state], -1 if slot is None else SLOT[slot], float(limit))
        for state, slot, limit in row.inert_states
    )
    return tuple(entry[field] for entry in entries + pad)


INERT_STATE, INERT_SLOT, INERT_LIMIT = (
    tuple(_inert_table(row, field) for row in KIND_ROWS) for field in range(3)
)
#: States each kind leaves out of the error norm when absent
#: (:attr:`~hydropwa._layout.ModelKind.norm_free_states`), padded to ``N_FREE`` entries like the
#: inert tables (at least one entry, so every kind's table has one type).
N_FREE = max(1, max(len(row.norm_free_states) for row in KIND_ROWS))


def _free_table(row, field):
    pad = ((-1, 0, 0.0),) * (N_FREE - len(row.norm_free_states))
    index = {name: i for i, (name, _u, _s) in enumerate(row.states)}
    entries = tuple(
        (index[state], SLOT[slot], float(limit)) for state, slot, limit in row.norm_free_states
    )
    return tuple(entry[field] for entry in entries + pad)


FREE_STATE, FREE_SLOT, FREE_LIMIT = (
    tuple(_free_table(row, field) for row in KIND_ROWS) for field in range(3)
)

# Packed parameter vector layout: generated from the one table in hydropwa._layout.
I_OMEGA0, I_ZETA, I_ALPHA, I_BETA, I_CREEP, I_OUTER = (
    SLOT[k] for k in ("omega0", "zeta", "alpha", "beta", "creep", "outer")
)
I_K, I_PTR, I_AA, I_AB, I_STROKE, I_VA, I_VB, I_CL, I_CEA, I_CEB = (
    SLOT[k] for k in ("K", "ptr", "aa", "ab", "stroke", "va", "vb", "cl", "cea", "ceb")
)
I_KSTOP, I_CSTOP, I_E, I_PVAP, I_PREL = (SLOT[k] for k in ("kstop", "cstop", "e", "pvap", "prel"))
I_FC, I_FS, I_SIGMA, I_CHI, I_DELTA, I_GAMMA = (
    SLOT[k] for k in ("fc", "fs", "sigma", "chi", "delta", "gamma")
)
I_PT, I_PUMP, I_PSET, I_QMAX, I_DROOP, I_VLINE, I_PRELIEF, I_GRELIEF, I_MASS = (
    SLOT[k] for k in ("pt", "pump", "pset", "qmax", "droop", "vline", "prelief", "grelief", "mass")
)
I_CLOAD = SLOT["cload"]  # viscous damping of the attached load (counter cylinder) [N·s/m]
I_KSPEC, I_CSPEC, I_XSPEC, I_FSPEC = (SLOT[k] for k in ("kspec", "cspec", "xspec", "fspec"))
I_RFORM = SLOT["rform"]  # reduced/PWA form: 0 asymmetric single-rod, 1 paper (mean area)
I_XCAP = SLOT["xcap"]  # PWA: rod position of the chamber capacitances [m]; < 0: the state x
I_ACCV, I_ACCP0, I_ACCN, I_HOSEL, I_HOSED, I_HOSEVOL, I_VISC = (
    SLOT[k] for k in ("accv", "accp0", "accn", "hosel", "hosed", "hosevol", "visc")
)
# hose lines of the full-lines model: volumes, conductances, wall modulus, orifice law
I_VLA, I_VLB, I_GLA, I_GLB, I_EHOSE, I_LORIF = (
    SLOT[k] for k in ("vla", "vlb", "gla", "glb", "ehose", "lorif")
)
# PWA section (written by hydropwa.linearization.pack_pwa)
I_SCHED, I_PSFIX, I_FORM, I_NG, I_NO, I_NN, I_NW = (PWA_SLOT[k] for k in PWA_SLOTS)
#: Output rows, named in the layout table.
O_U, O_SPOOL, O_Z, O_P_A, O_P_B, O_P_L, O_P_S, O_F_L, O_X, O_V, O_FRICTION = (
    OUT[k] for k in ("u", "spool", "z", "p_a", "p_b", "p_l", "p_s", "f_l", "x", "v", "friction")
)
O_F_SPEC = OUT["f_spec"]
#: Number of output rows of the full/reduced models and of the PWA model.
N_OUT, N_OUT_PWA = len(OUTPUT_CHANNELS), len(OUTPUT_CHANNELS) + len(PWA_OUTPUT_CHANNELS)
N_OUT_CHAMBER = len(OUTPUT_CHANNELS) + len(CHAMBER_OUTPUT_CHANNELS)

#: Packed input signals (``sg``): the slots of each input's kind and constant value, from the layout.
S_KIND_U, S_KIND_PS, S_KIND_FL = (SG["kind"] + i for i in range(N_SIGNALS))
S_U, S_PS, S_FL = (SG_VALUE[k] for k in ("u", "p_s", "f_l"))
#: The integrator's statistics array, from the layout (SOLVER_STATS).
ST_STEPS, ST_REJECTED, ST_RHS, ST_JAC = (
    STAT[k] for k in ("steps", "rejected", "rhs_evaluations", "jacobians")
)
N_STATS = len(SOLVER_STATS)

# Status codes of integrate()
OK, MAX_STEPS, STEP_COLLAPSE, NON_FINITE = 0, 1, 2, 3


def literal_kind(kind):
    """The value of a literal integer type (a model kind or a method), or None if not literal."""
    return kind.literal_value if isinstance(kind, types.IntegerLiteral) else None


def per_kind(table, name):
    """A compiled function ``f(kind)`` returning ``table[kind]``; callable from compiled code only.

    With a literal ``kind`` (one entry point per kind) the value is a compile-time constant of
    the caller's code (loops over n states unroll, flags fold away); otherwise a table look-up.
    """

    def fn(kind):
        raise NotImplementedError(f"{name} is called from compiled code only")

    fn.__name__ = fn.__qualname__ = name

    @overload(fn, prefer_literal=True, inline="always")
    def _ol(kind):
        k = literal_kind(kind)
        if k is None:
            return lambda kind: table[kind]
        value = table[k]
        return lambda kind: value

    return fn


#: Number of states of model ``kind``; a compile-time constant where ``kind`` is (small loops unroll).
n_states = per_kind(N_STATES, "n_states")
#: Whether the state of model ``kind`` holds the spool (ν, ν̇).
carries_spool = per_kind(CARRIES_SPOOL, "carries_spool")
#: Whether ∂f/∂y of model ``kind`` depends on the valve command u.
jac_depends_on_u = per_kind(JAC_DEPENDS_ON_U, "jac_depends_on_u")
_inert_states = per_kind(INERT_STATE, "inert_states")
_inert_slots = per_kind(INERT_SLOT, "inert_slots")
_inert_limits = per_kind(INERT_LIMIT, "inert_limits")
_free_states = per_kind(FREE_STATE, "free_states")
_free_slots = per_kind(FREE_SLOT, "free_slots")
_free_limits = per_kind(FREE_LIMIT, "free_limits")


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def inert_state(kind, j, p):
    """State j of model ``kind`` is constant for the parameters p (a zero column and row of ∂f/∂y).

    From the registry row's ``inert_states``: the full model's P_S without the pump model and
    P_acc without an accumulator; the chamber model's P_S always (its input).
    """
    states, slots, limits = _inert_states(kind), _inert_slots(kind), _inert_limits(kind)
    for i in range(N_INERT):
        if states[i] == j:
            return slots[i] < 0 or p[slots[i]] <= limits[i]
    return False


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def n_solve(kind, p):
    """Number of leading states of model ``kind`` left after its trailing inert states (:func:`inert_state`)."""
    n = n_states(kind)
    states = _inert_states(kind)
    for i in range(N_INERT):
        if states[i] != n - 1 or not inert_state(kind, states[i], p):
            break
        n -= 1
    return n


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def n_norm(kind, p):
    """Number of leading states of model ``kind`` in the step's error norm (the RMS).

    All its states but a trailing run of absent ones (the registry row's ``norm_free_states``:
    a hose line of zero volume), so a kind with an absent component steps as the kind without
    it; every other kind's norm runs over all its states.
    """
    n = n_states(kind)
    states, slots, limits = _free_states(kind), _free_slots(kind), _free_limits(kind)
    for i in range(N_FREE):
        if states[i] != n - 1 or p[slots[i]] > limits[i]:
            break
        n -= 1
    return n


# the input channels as int64 values, not literals: a literal argument would compile
# eval_signal once per channel
_CH0, _CH1, _CH2 = np.int64(0), np.int64(1), np.int64(2)


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT, inline="always")
def _inputs(t, sg):
    """Evaluate the three packed input signals u, P_S, F_L at time t.

    Inlined into its callers; constant signals (kind 0, value at ``sg[S_U]``, …) are read
    here without a call to :func:`eval_signal`.
    """
    u = sg[S_U] if sg[S_KIND_U] == 0.0 else eval_signal(sg, _CH0, t)
    ps = sg[S_PS] if sg[S_KIND_PS] == 0.0 else eval_signal(sg, _CH1, t)
    fl = sg[S_FL] if sg[S_KIND_FL] == 0.0 else eval_signal(sg, _CH2, t)
    return u, ps, fl


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT, inline="always")
def _input_rates(t, sg):
    """Time derivatives of the three packed inputs at t (:func:`~hydropwa.simulation.eval_signal_rate`)."""
    du = 0.0 if sg[S_KIND_U] == 0.0 else eval_signal_rate(sg, _CH0, t)
    dps = 0.0 if sg[S_KIND_PS] == 0.0 else eval_signal_rate(sg, _CH1, t)
    dfl = 0.0 if sg[S_KIND_FL] == 0.0 else eval_signal_rate(sg, _CH2, t)
    return du, dps, dfl


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT, inline="always")
def _friction(v, p):
    return stribeck_friction(v, p[I_FC], p[I_FS], p[I_SIGMA], p[I_CHI], p[I_DELTA], p[I_GAMMA])


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT, inline="always")
def _opening(nu, p):
    return dead_zone(nu, p[I_ALPHA], p[I_BETA], p[I_CREEP], p[I_OUTER])


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT, inline="always")
def _mean_area(p):
    """Ā = (A_A + A_B)/2 [m²] of the reduced and PWA models, Eqs. (14)–(15)."""
    return 0.5 * (p[I_AA] + p[I_AB])


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT, inline="always")
def _load_gain(p):
    """4E/V_t [Pa/m³] of Eq. (14) (:func:`~hydropwa.components.load_pressure_gain`)."""
    return load_pressure_gain(p[I_E], p[I_VA] + p[I_VB])


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT, inline="always")
def _specimen(x, v, p):
    """Force of the specimen on the rod [N], opposing extension (:func:`~hydropwa.components.specimen_force`)."""
    return specimen_force(x, v, p[I_KSPEC], p[I_CSPEC], p[I_XSPEC], p[I_FSPEC])


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT, inline="always")
def _contact_force(x, v, p):
    """Contact force on the piston [N], positive towards +x: the end stops minus the specimen.

    Every model's Newton's law (Eqs. (10), (15)) takes it as its ``stop`` term.
    """
    return end_stop_force(x, v, p[I_STROKE], p[I_KSTOP], p[I_CSTOP]) - _specimen(x, v, p)


@njit(cache=True, nogil=True, error_model="numpy", **NO_REFCOUNT, inline="always")
def _contact_force_slope(x, v, p):
    """(∂F/∂x [N/m], ∂F/∂ẋ [N·s/m]) of :func:`_contact_force`."""
    kx, kv = end_stop_force_slope(x, v, p[I_STROKE], p[I_KSTOP], p[I_CSTOP])
    sx, sv = specimen_force_slope(x, v, p[I_KSPEC], p[I_CSPEC], p[I_XSPEC], p[I_FSPEC])
    return kx - sx, kv - sv
