"""The compiled kernel's front: compile management and the calls into the compiled entries.

The compiled back end of every model is split on the solver's seams (as diffrax separates
terms, solvers, step-size controllers and outputs), one job per module:

=====================  ==========================================================================
``_kcommon``           model kinds, packed indices (from :mod:`hydropwa._layout`), input evaluation
``_rhs_full``          the full-order model, Eqs. (1)–(11): rhs, exact Jacobian, ∂f/∂t
``_rhs_load``          the reduced (12)–(15) and PWA (16)–(23) load-pressure models, PWA cells
``_rhs_chamber``       the chamber-level PWA model (``pwa-chamber``)
``_dispatch``          the model table: each kind's rhs and derivatives, chosen while typing
``_rosenbrock``        LU, ROS34PW2 / ROS4LS / ROS2(3) tableaus and steps, Jacobian refresh
``_stepcontrol``       error norm and step-size factors (Gustafsson's predictive controller)
``_outputs``           Hermite dense output and the per-model output passes
``_sampling``          controller sampling in the step loop (no code in open loop)
``_march``             the integration loop on its work arrays; open- and closed-loop drivers
``_entries``           the entry points, generated from ``MODEL_KINDS`` × methods × loop
``_kernel`` (here)     compile management (disk-cache probe, warm-ups, notices) and the calls
=====================  ==========================================================================

Every name of those modules is readable here too (``_kernel.rhs_full``, ``_kernel.I_AA``,
``_kernel._integrate_full``), so callers and tests keep one import. The names this module
defines itself (:func:`prepare`, :data:`NOTICE_AFTER_S`, :func:`_cached_on_disk`,
:func:`_interruptible`, :data:`compile_seconds`) are the ones to monkeypatch.

Model kinds and states
----------------------
``FULL`` (0), Eqs. (1)–(11): y = [ν, ν̇, P_A, P_B, x, ẋ, P_S, P_acc] (the order of
``hydropwa._layout.FULL_STATES``); P_S is a state only with the pump supply model,
otherwise its rate is zero and P_S(t) is the input signal; P_acc, the gas accumulator on
port A (not in the paper), is constant without one.
``REDUCED`` (1), Eqs. (12)–(15) generalised to the single-rod cylinder: y = [P_L, ẋ, x],
P_L = P_A − α P_B (α = 1 and the mean area in the paper form, p[I_RFORM] = 1; see
docs/reduced_asymmetric.md).
``PWA`` (2), Eqs. (16)–(23): y = [P_L, ẋ, x] with piecewise-affine cells.
``CHAMBER`` (3), the chamber-level PWA model (``pwa-chamber``): the full model's state vector,
PWA cells for the dead zone (over ν), the metering flows of Eqs. (5)–(6) (over each edge's
normalised drop), the chamber capacitances (over x) and friction (over ẋ); P_S is an input.

Parameter slots and output rows come from the one layout table, :mod:`hydropwa._layout`;
:func:`point_derivatives` gives every Python-side consumer (matrices, exports) this
assembly's right-hand side and exact derivatives.

Integrator
----------
Linearly implicit Rosenbrock methods with error control: ROS34PW2 (default), an
L-stable, stiffly accurate Rosenbrock-W method of order 3(2) that may reuse its
Jacobian, the L-stable ROS4LS of order 4(3) (a fresh Jacobian every step), and
Shampine & Reichelt's ROS2(3) (MATLAB's ``ode23s``). Exact Jacobians
and time derivatives for every model (:func:`jac_full`, :func:`jac_reduced`,
:func:`jac_pwa`; :func:`dfdt_full`, …), finite differences only for a full model with a
gas accumulator; Hermite dense output at the requested sample times.
They cope with the stiffness of the chambers (E/V), the tanh friction and the end
stops at a cost of a few right-hand-side calls per step.

Speed
-----
``integrate`` dispatches to one compiled entry point per model, in which the model
kind (and so the state count) is a compile-time constant; the input signals are one
packed vector (:func:`hydropwa.simulation.pack_signals`); the allocation-free helpers
skip numba's reference counting (``NO_REFCOUNT``); ``error_model="numpy"`` drops the
zero test numba puts before every division (non-finite results are caught per step);
the LU factors keep the reciprocals of their pivots, so the four solves of a step
multiply instead of divide. See docs/architecture_performance.md.
"""

from __future__ import annotations

import json
import os
import time
import warnings
from collections.abc import Callable
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np
from numba._dispatcher import compute_fingerprint
from numba.core.errors import NumbaIRAssumptionWarning

from .. import _jitcache
from .._errors import interrupt_cause
from .._layout import MODEL_KINDS
from . import (
    _dispatch,
    _entries,
    _kcommon,
    _march,
    _outputs,
    _rhs_chamber,
    _rhs_full,
    _rhs_load,
    _rosenbrock,
    _sampling,
    _stepcontrol,
)
from ._dispatch import _POINT, _point_pwa, _point_reduced, pwa_load_flow_at
from ._entries import (
    _CLOSED,
    _ENTRY,
    ENTRIES,
    SolverRun,
    _closed_args,
    _open_args,
    _output_args,
    _point_args,
)
from ._kcommon import (
    CHAMBER,
    N_STATES,
    S_KIND_U,
)
from ._outputs import OUTPUTS
from ._rosenbrock import ROS34PW2

#: The kernel's modules, in the order :func:`__getattr__` searches them for a name.
_PARTS = (
    _kcommon,
    _rhs_full,
    _rhs_load,
    _rhs_chamber,
    _dispatch,
    _rosenbrock,
    _stepcontrol,
    _outputs,
    _sampling,
    _march,
    _entries,
)


def __getattr__(name: str) -> Any:
    """A name of one of the kernel's modules (:data:`_PARTS`), read through this front."""
    for part in _PARTS:
        if name in part.__dict__:
            return part.__dict__[name]
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def point_derivatives(kind, y, u, ps, fl, p):
    """Right-hand side and exact derivatives of the reduced, PWA or chamber PWA model at one point.

    The one assembly used by every Python-side consumer (matrices, exports, identification
    helpers): nothing outside this kernel re-derives the reduced or PWA dynamics.

    Parameters
    ----------
    kind : int
        The kernel kind: ``REDUCED``, ``PWA`` or ``CHAMBER``.
    y : array_like, shape (n,)
        State: [P_L (Pa), v (m/s), x (m)] (reduced, PWA) or the full model's eight states
        (chamber PWA, ``hydropwa._layout.FULL_STATES``).
    u, ps, fl : float
        Valve command [1], supply pressure [Pa], load force [N].
    p : ndarray
        Packed parameters (``model.pack()``).

    Returns
    -------
    f : ndarray, shape (n,)
        The state rates.
    J : ndarray, shape (n, n)
        ∂f/∂y (exact; inside the active cells for the PWA models).
    G : ndarray, shape (n, 3)
        ∂f/∂(u, P_S, F_L) (columns); G[:, 0] is the input matrix B.
    """
    if int(kind) not in _POINT:
        raise ValueError("point_derivatives serves the reduced and the PWA models")
    point = _POINT[int(kind)]
    args = _point_args(y, u, ps, fl, p)
    prepare(point, args, "linearization")
    point(*args)
    f, J, G = args[-3:]
    return f, J, np.ascontiguousarray(G)


def _check_run(kind, run) -> None:
    """One line if ``run``'s state or scale does not fit model ``kind``."""
    n = N_STATES[int(kind)]
    if len(run.y0) != n or len(run.scale) != n:
        raise ValueError(
            f"model kind {kind} has {n} states; got y0 of {len(run.y0)}, scale of {len(run.scale)}"
        )


def integrate_closed_loop(kind, run, method, ctl, ref, dref):
    """Closed-loop :func:`integrate`: the compiled controller ``ctl`` sets the valve command.

    ``run``: the :class:`~._entries.SolverRun`. Returns (Y, rows filled, status, t, y, stats,
    log); see :func:`_integrate_closed`.
    """
    _check_run(kind, run)
    if run.sg[S_KIND_U] != 0.0:
        raise ValueError("closed loop: the valve command must be packed as a constant signal")
    entry = ENTRIES[int(method)][1][int(kind)]
    args = _closed_args(run, ctl, ref, dref)
    # compile (or load) apart from the timed call, with numba's pedantic IR warning silenced as
    # for the open loop (pytest turns a stray compiler warning into a failure)
    prepare(entry, args, f"closed-loop {_KIND_NAMES[int(kind)]} model")
    with _interruptible():
        return entry(*args)


@contextmanager
def _interruptible():
    """Re-raise a Ctrl-C that a compiled call reported as ``SystemError`` as what it is.

    The signal handler may run while numba boxes a result; the dispatcher then returns
    a result with the ``KeyboardInterrupt`` set, which Python turns into a
    ``SystemError`` caused by it. Callers (and the CLI) expect a ``KeyboardInterrupt``.
    """
    try:
        yield
    except SystemError as exc:
        cause = interrupt_cause(exc)
        if cause is None:
            raise
        raise cause.with_traceback(None) from None


def integrate(kind, run, method=ROS34PW2, jac_reuse=True, gustafsson=True, exact_jac=True):
    """Integrate model ``kind``: :func:`_integrate` compiled for that model alone.

    ``run``: the problem and its tolerances, a :class:`~._entries.SolverRun` (y0, t_out, p, sg,
    rtol, scale, h0, hmax, max_steps). Each model has its own entry point in which ``kind`` is a
    compile-time constant, so its machine code holds only its own right-hand side (compiled on
    first use, cached on disk). Releases the GIL.
    """
    _check_run(kind, run)
    entry = ENTRIES[int(method)][0][int(kind)]
    args = _open_args(run, jac_reuse, gustafsson, exact_jac)
    prepare(entry, args, f"{_KIND_NAMES[int(kind)]} model")
    with _interruptible():
        return entry(*args)


#: Each kind's name in compile notices (its registry row's ``label``).
_KIND_NAMES = tuple(row.label for row in MODEL_KINDS.values())
_compile_notice = None
_noticed = False
#: Seconds this process spent loading or compiling kernels (read by ``simulate``).
compile_seconds = 0.0


#: Kernels in a warm-up's queue: dispatcher -> the :class:`~._warmup.WarmUp` whose
#: ``acquire(dispatcher)`` returns once this process may load or compile it.
_warming: dict = {}
#: Longest wait [s] for a warm-up process's kernel before compiling it here.
WARMUP_WAIT = 600.0
#: ``callback(dispatcher)`` run before a kernel missing from the disk cache compiles here
#: (:mod:`._warmup` starts compiling the other models' kernels in the background).
_cold_hook: Callable[[Any], None] | None = None


def warmup_calls(name):
    """The compiled kernels a warm-up of ``name`` compiles, as (dispatcher, args, what).

    ``name``: ``"full"``, ``"reduced"``, ``"pwa"`` (the open-loop solver with the default
    method and the model's output pass), ``"closed-<model>"`` (the closed-loop solver) or
    ``"point"`` (the linearization's point derivatives and the PWA load flow), ``"point-full"``
    (the chamber PWA model's point derivatives and the full model's, :mod:`._small_signal`) or
    ``"output-<model>"`` (the output pass alone: a first ``simulate`` compiles the solver
    while the background process compiles the output pass it needs next). The
    arguments are placeholders of exactly the types :func:`integrate`,
    :func:`integrate_closed_loop`, :func:`outputs` and :func:`point_derivatives` pass, so
    the compiled code is what they load.
    """
    z, zz = np.zeros(1), np.zeros((1, 1))
    kinds = {name: row.kernel for name, row in MODEL_KINDS.items()}
    if name == "point":
        args = _point_args(np.zeros(3), 0.0, 0.0, 0.0, z)
        return [
            (_point_pwa, args, "linearization"),
            (pwa_load_flow_at, (0.0, 0.0, 0.0, z), "linearization"),
            (_point_reduced, args, "linearization"),
        ]
    if name == "point-full":
        return [
            (
                _POINT[CHAMBER],
                _point_args(np.zeros(8), 0.0, 0.0, 0.0, z),
                "linearization",
            ),
            (_rhs_full.rhs_full, (z, 0.0, 0.0, 0.0, z, z), "small-signal"),
            (_rhs_full.jac_full, (z, 0.0, 0.0, 0.0, z, zz), "small-signal"),
            (_rhs_full.dfdt_full, (z, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, z, z), "small-signal"),
        ]
    model = name.removeprefix("closed-").removeprefix("output-")
    if model not in kinds:
        raise ValueError(f"unknown kernel {name!r}; choose from {', '.join(WARMUP_NAMES)}")
    kind = kinds[model]
    run = SolverRun(z, z, z, z, 0.0, z, 0.0, 0.0, 0)
    if name.startswith("closed-"):
        args = _closed_args(run, z, z, zz)
        return [(_CLOSED[kind], args, f"closed-loop {_KIND_NAMES[kind]} model")]
    output = (OUTPUTS[kind], _output_args(z, zz, 0, z, z), "output")
    if name.startswith("output-"):
        return [output]
    args = _open_args(run, True, True, True)
    return [(_ENTRY[kind], args, f"{_KIND_NAMES[kind]} model"), output]


#: The names :func:`warmup_calls` takes.
WARMUP_NAMES = (
    *MODEL_KINDS,
    "point",
    "point-full",
    *(f"closed-{m}" for m in MODEL_KINDS),
    *(f"output-{m}" for m in MODEL_KINDS),
)


#: A compilation (or a wait for a warm-up) longer than this [s] ends with a "ready" notice.
NOTICE_AFTER_S = 2.0


def set_compile_notice(callback):
    """Call ``callback(message)`` before the first kernel is compiled, and after each wait.

    Once per process before the first compilation ("compiling the … solver"), then once for
    every kernel whose compilation (or wait for a background warm-up) took over 2 s ("… solver
    ready (8.1 s)"). The CLI passes a printer to stderr, so a user waiting on a fresh install
    is told why and sees each solver arrive. ``None`` (the library's default) stays silent;
    ``set_compile_notice(print)`` shows the same lines in Python. Returns the previous callback.
    """
    global _compile_notice, _noticed
    previous, _compile_notice, _noticed = _compile_notice, callback, False
    return previous


def _cached_on_disk(dispatcher) -> bool:
    """Whether numba's on-disk cache holds ``dispatcher`` compiled from the current sources."""
    try:
        if _jitcache.holds_prebuilt(dispatcher._cache):  # shipped with the package
            return True
        cache_file = dispatcher._cache._cache_file
        if not os.path.exists(cache_file._index_path):
            return False
        return bool(cache_file._load_index())  # {} where the index's stamp is stale
    except Exception:  # pragma: no cover - numba internals differ: assume compiled
        return True


#: Argument fingerprints each dispatcher was found ready for in this process (see :func:`prepare`).
_ready: dict[Any, set] = {}


def _fingerprint(args):
    """numba's own C-level type key of each argument (dtype, dimensions, layout, writability), or
    None where an argument has none.

    ``dispatcher.typeof_pyval`` builds numba type objects in Python (~20 µs per call of
    :func:`integrate`, and the garbage collector's work on them); the fingerprint is what
    numba's dispatcher itself computes in C to find a compiled overload.
    """
    try:
        return tuple(compute_fingerprint(a) for a in args)
    except Exception:  # pragma: no cover - an argument numba cannot fingerprint: type it
        return None


def prepare(dispatcher, args, what="solver"):
    """Load ``dispatcher`` from the cache or compile it for ``args`` before the timed call.

    A no-op once it is ready in this process. The seconds spent are added to
    :data:`compile_seconds`, so ``simulate`` reports compilation apart from simulation.
    """
    global compile_seconds, _noticed
    if not hasattr(dispatcher, "typeof_pyval"):  # not a numba dispatcher (a test's stand-in)
        return 0.0
    key = _fingerprint(args)
    ready = _ready.setdefault(dispatcher, set())
    if key is not None and key in ready:  # seen ready in this process: no typing needed
        return 0.0
    sig = tuple(dispatcher.typeof_pyval(a) for a in args)
    if sig in dispatcher.signatures:  # ready for exactly these argument types
        if key is not None:
            ready.add(key)
        return 0.0
    # (a read-only or differently laid-out array is a new signature: compile it here too, with
    # the warning filter below, not at the call)

    t0 = time.perf_counter()
    cold = False
    warming = _warming.get(dispatcher)
    if warming is not None:
        # a warm-up (see ._warmup) has this kernel in its queue: load it once that process has
        # cached it (meanwhile compiling its later kernels here), or compile it here if that
        # process has not started it
        warming.acquire(dispatcher)
    elif not _cached_on_disk(dispatcher):
        cold = True
        if _compile_notice is not None and not _noticed:
            _noticed = True
            _compile_notice(
                f"compiling the {what} solver ({_expected_compile(dispatcher)}; once, later runs"
                " load it from the cache)"
            )
        if _cold_hook is not None:
            _cold_hook(dispatcher)

    with warnings.catch_warnings():
        # numba's pedantic scope check after inlining the PWA model's code through an overload
        # (a variable set on both branches of an if); the IR is valid and the results are tested.
        warnings.simplefilter("ignore", NumbaIRAssumptionWarning)
        dispatcher.compile(sig)
    dt = time.perf_counter() - t0
    compile_seconds += dt
    if cold:
        _record_compile(dispatcher, dt)
    if key is not None:
        ready.add(key)
    if _compile_notice is not None and dt > NOTICE_AFTER_S and (cold or warming is not None):
        # each long wait ends with a line, so a user sees the compiler progress, not silence
        _compile_notice(f"  {what} solver ready ({dt:.1f} s)")
    return dt


#: The file beside a kernel's cache entries that keeps how long it took to compile here [s].
COMPILE_TIMES = "hydropwa-compile-seconds.json"


def _record_compile(dispatcher, seconds: float) -> None:
    """Keep the wall time ``dispatcher`` took to compile on this machine (for the next notice)."""
    try:
        path = Path(dispatcher._cache.cache_path, COMPILE_TIMES)
        times = json.loads(path.read_text()) if path.exists() else {}
        times[dispatcher._cache._impl.filename_base] = round(seconds, 1)
        path.write_text(json.dumps(times))
    except Exception:  # a read-only cache folder, numba internals differ: nothing to keep
        pass


def _expected_compile(dispatcher) -> str:
    """How long compiling ``dispatcher`` takes, as the notice says it: measured here, or the build's.

    The last compile on this machine (:func:`_record_compile`) where there was one; otherwise the
    CPU time it took when the shipped entries were built (``_prebuilt/BUILD.json``), which a busy
    or slower machine exceeds.
    """
    try:
        base = dispatcher._cache._impl.filename_base
        here = Path(dispatcher._cache.cache_path, COMPILE_TIMES)
        if here.exists():
            seconds = json.loads(here.read_text()).get(base)
            if seconds is not None:
                return f"~{seconds:.0f} s, as it took on this machine last time"
        build = json.loads((_jitcache.PREBUILT_DIR / "BUILD.json").read_text())
        cpu = build["compile_cpu_seconds"][base]
        return f"~{cpu:.0f} s of one idle core; longer while other work runs"
    except Exception:  # no record of this kernel
        return "tens of seconds of one core"


def prepare_outputs(kind, t_out, Y, n_done, p, sg):
    """Load or compile :func:`outputs`' compiled pass for these arguments without running it.

    :func:`~hydropwa.simulation.simulate` calls it at once, so a first call's compilation is
    counted in its ``compile_time`` even though the pass runs on the first channel read.
    """
    prepare(OUTPUTS[kind], _output_args(t_out, Y, n_done, p, sg), "output")


def outputs(kind, t_out, Y, n_done, p, sg):
    """Derived channels per output sample (see :mod:`._outputs`), in one compiled pass.

    The Stribeck friction channel of the full and reduced models is computed in that pass by
    the compiled :func:`~hydropwa.components.stribeck_friction` (its scalar sign and power
    forms, ~29 ns per sample), which measured 0.58 ms against 0.70 ms for the same law run as
    NumPy on the whole velocity row afterwards (20 001 samples, thread time, loaded machine).
    """
    args = _output_args(t_out, Y, n_done, p, sg)
    prepare(OUTPUTS[kind], args, "output")  # load or compile (a no-op once ready), timed apart
    with _interruptible():
        return OUTPUTS[kind](*args)
