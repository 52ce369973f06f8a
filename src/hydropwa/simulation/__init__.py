"""Simulation: input signals, the compiled stiff integrator and ``simulate``."""

from ._axis_fmu import export_axis_fmu
from ._batch import SUMMARY_COLUMNS, simulate_batch, summarize
from ._fmu import FmuBuildError
from ._kernel import set_compile_notice
from ._notice import ENV_NOTICE, default_compile_notice, install_default_notice
from ._signals import (
    Chirp,
    Constant,
    Ramp,
    Sampled,
    Signal,
    Sine,
    Step,
    as_signal,
    pack_signals,
    parse_signal,
)
from ._simulate import CHANNEL_UNITS, DEFAULT_RTOL, SimulationResult, law_inputs, simulate
from ._small_signal import FullSmallSignal, full_point_derivatives, full_small_signal
from ._status import SolverStats, SolverStatus
from ._warmup import WarmUp, set_auto_warmup, warm_up

__all__ = [
    "CHANNEL_UNITS",
    "Chirp",
    "DEFAULT_RTOL",
    "FmuBuildError",
    "FullSmallSignal",
    "Constant",
    "Ramp",
    "SUMMARY_COLUMNS",
    "Sampled",
    "Signal",
    "SimulationResult",
    "Sine",
    "SolverStats",
    "SolverStatus",
    "Step",
    "WarmUp",
    "as_signal",
    "export_axis_fmu",
    "full_point_derivatives",
    "full_small_signal",
    "law_inputs",
    "pack_signals",
    "parse_signal",
    "set_compile_notice",
    "default_compile_notice",
    "ENV_NOTICE",
    "simulate",
    "simulate_batch",
    "set_auto_warmup",
    "summarize",
    "warm_up",
]

# a first simulate on a fresh installation says that it compiles (docs/performance.md)
install_default_notice()
