"""hydropwa: valve-controlled hydraulic cylinders — full-order, reduced and piecewise-affine models,
identification from measurements, a virtual test rig and evaluation.

The public API is re-exported here; every module is private.
"""

from ._errors import (
    DataError,
    HydropwaError,
    IdentificationError,
    OutputExistsError,
    ParameterError,
    PwaError,
    SignalError,
    SimulationError,
)
from ._result import Result, ResultStatus, Status
from .models import FullOrderModel, Model, ReducedModel
from .params import (
    Cylinder,
    DeadZone,
    Friction,
    Load,
    Oil,
    ServoValve,
    Supply,
    SystemParams,
    ValveFlow,
    flow_coefficient_from_rating,
    get_preset,
    load_params,
    save_params,
)
from .simulation import (
    Chirp,
    Constant,
    Ramp,
    Sampled,
    SimulationResult,
    Sine,
    SolverStats,
    SolverStatus,
    Step,
    parse_signal,
    simulate,
    simulate_batch,
)

__version__ = "0.1.0"

__all__ = [
    "Chirp",
    "Constant",
    "Cylinder",
    "DataError",
    "DeadZone",
    "Friction",
    "FullOrderModel",
    "HydropwaError",
    "IdentificationError",
    "OutputExistsError",
    "Load",
    "Oil",
    "ParameterError",
    "PwaError",
    "Ramp",
    "ReducedModel",
    "Sampled",
    "ServoValve",
    "SignalError",
    "SimulationError",
    "SimulationResult",
    "Sine",
    "Step",
    "Supply",
    "SystemParams",
    "ValveFlow",
    "flow_coefficient_from_rating",
    "get_preset",
    "load_params",
    "parse_signal",
    "save_params",
    "simulate",
    "simulate_batch",
    "Model",
    "SolverStats",
    "SolverStatus",
    "Result",
    "ResultStatus",
    "Status",
]
