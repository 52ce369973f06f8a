"""Parameter sweeps: a grid or random sample of parameter sets, run in-process or on Dask.

``load_sweep("spec.toml")`` reads a :class:`SweepSpec`; :func:`run_sweep` runs
it with :func:`~hydropwa.simulation.simulate_batch` (threads) or on a Dask
cluster and returns one row of summary metrics per case.
"""

from ._run import SweepJournal, check_scheduler, run_case, run_sweep
from ._spec import SweepCase, SweepSpec, load_sweep, parse_sweep

__all__ = [
    "SweepCase",
    "SweepSpec",
    "load_sweep",
    "parse_sweep",
    "run_case",
    "run_sweep",
    "SweepJournal",
    "check_scheduler",
]
