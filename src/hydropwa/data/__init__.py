"""Measurement data layer: runs, datasets, file formats, channel maps and validation.

Units are converted only here, where data enters or leaves the package; every
:class:`Run` holds SI units (``t`` [s], ``x`` [m], ``p_a`` [Pa], ...).
"""

from ._channel_map import ChannelMap, ChannelSpec, builtin_channel_map
from ._dataset import (
    MANIFEST,
    Dataset,
    check_dataset,
    contained_path,
    convert,
    manifest_problems,
    read_dataset,
    write_dataset,
)
from ._emps import load_emps
from ._faster import load_faster, uniform_clock
from ._formats import FORMATS, read_run, write_run
from ._import import ImportedRun, ImportResult, import_logs, read_plan
from ._run import Run
from ._units import CANONICAL_UNITS, convert_units, to_si
from ._validate import (
    PLAUSIBLE_RANGES,
    Issue,
    Plausible,
    ValidationReport,
    check_run,
    converter_limits,
    screen_runs,
    unusable,
    validate_run,
)

__all__ = [
    "CANONICAL_UNITS",
    "FORMATS",
    "PLAUSIBLE_RANGES",
    "MANIFEST",
    "ChannelMap",
    "Dataset",
    "ChannelSpec",
    "Issue",
    "ImportedRun",
    "ImportResult",
    "import_logs",
    "read_plan",
    "Plausible",
    "Run",
    "ValidationReport",
    "builtin_channel_map",
    "check_dataset",
    "check_run",
    "converter_limits",
    "unusable",
    "convert",
    "convert_units",
    "load_emps",
    "load_faster",
    "uniform_clock",
    "read_dataset",
    "read_run",
    "screen_runs",
    "to_si",
    "validate_run",
    "write_dataset",
    "write_run",
    "contained_path",
    "manifest_problems",
]
