"""Virtual test rig: the full-order model with the paper's sensors, supply and experiments.

``Rig`` (true parameters, sensors, rate, supply) + ``Campaign`` (experiments as data,
``load_campaign("paper")``) → ``run_campaign`` → one :class:`hydropwa.data.Dataset` per
experiment and ``true_params.toml``. ``measure`` applies the sensor chain to any
:class:`~hydropwa.SimulationResult`. See ``docs/architecture_rig.md``.
"""

from ._campaign import (
    EXPERIMENTS,
    BroadbandSweep,
    Campaign,
    DeadZoneExperiment,
    Experiment,
    FrfExperiment,
    FrfSweep,
    FrictionExperiment,
    LoadRuns,
    SineExperiment,
    builtin_campaigns,
    load_campaign,
    parse_campaign,
)
from ._experiments import (
    RunSpec,
    counter_force_signal,
    execute,
    load_profile,
    multisine,
    plan,
    run_seed,
)
from ._faults import (
    FAULT_KINDS,
    Fault,
    FaultKind,
    inject,
    parse_fault_spec,
    parse_faults,
    shift_command,
)
from ._plan import (
    LOG_COLUMNS,
    PLAN_MANIFEST,
    Envelope,
    Plan,
    PlanLimits,
    PlannedRun,
    RefusedRun,
    parse_limits,
    plan_campaign,
)
from ._rig import Rig, machine_supply, paper_supply
from ._runner import TRUE_PARAMS, run_campaign, run_experiment
from ._sensors import MEASURED_CHANNELS, SensorModel, machine_sensors, measure, paper_sensors
from ._sizing import SIZED, SizingRules, campaign_for, no_load_velocity, size_campaign

__all__ = [
    "EXPERIMENTS",
    "LOG_COLUMNS",
    "PLAN_MANIFEST",
    "SIZED",
    "Envelope",
    "Plan",
    "PlanLimits",
    "PlannedRun",
    "RefusedRun",
    "SizingRules",
    "campaign_for",
    "no_load_velocity",
    "parse_limits",
    "plan_campaign",
    "size_campaign",
    "FAULT_KINDS",
    "Fault",
    "FaultKind",
    "inject",
    "parse_fault_spec",
    "parse_faults",
    "shift_command",
    "MEASURED_CHANNELS",
    "TRUE_PARAMS",
    "BroadbandSweep",
    "Campaign",
    "DeadZoneExperiment",
    "Experiment",
    "FrfExperiment",
    "FrfSweep",
    "FrictionExperiment",
    "LoadRuns",
    "Rig",
    "RunSpec",
    "SensorModel",
    "SineExperiment",
    "builtin_campaigns",
    "counter_force_signal",
    "execute",
    "load_campaign",
    "load_profile",
    "machine_sensors",
    "machine_supply",
    "multisine",
    "measure",
    "paper_sensors",
    "paper_supply",
    "parse_campaign",
    "plan",
    "run_campaign",
    "run_experiment",
    "run_seed",
]
