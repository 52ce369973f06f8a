"""Sweep definitions read from TOML.

Example::

    base = "paper"                       # the machine: a preset or parameter TOML (required)
    [grid]                               # full factorial product
    "load.mass" = [1.0, 2.0]
    "supply.pressure" = ["80 bar", "100 bar"]
    [random]                             # n random draws (combined with every grid point)
    n = 100
    seed = 1
    "friction.coulomb" = {uniform = [10, 40]}
    [input]
    u = "sine:amplitude=0.4,frequency=1"
    duration = 5
    model = "full"                       # full, reduced or pwa
    fs = 2000
    rtol = 1e-3
"""

from __future__ import annotations

import dataclasses
import difflib
import itertools
import math
import os
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .._errors import HydropwaError, ParameterError
from .._io import read_text
from .._layout import DEFAULT_KIND, MODEL_NAMES
from .._limits import MAX_SWEEP_CASES, check_rtol, check_samples, check_supply_pressure
from ..params import FIELD_UNITS, SystemParams, get_preset, load_params, parse_quantity
from ..simulation import as_signal

__all__ = ["SweepCase", "SweepSpec", "load_sweep", "parse_sweep"]

_DISTRIBUTIONS = ("uniform", "loguniform", "normal")
_INPUT_KEYS = {"u", "duration", "model", "fs", "rtol", "supply_pressure", "load_force", "solver"}
_SECTIONS = ("base", "grid", "random", "input")
_MODELS = MODEL_NAMES


def _unknown(kind: str, name: str, allowed) -> ParameterError:
    """An unknown key, with the closest allowed one suggested."""
    close = difflib.get_close_matches(str(name), list(allowed), n=1)
    hint = f"; did you mean {close[0]!r}?" if close else ""
    return ParameterError(
        f"unknown {kind} {name!r} in the sweep{hint} (allowed: {', '.join(sorted(allowed))})"
    )


def _field_unit(key: str) -> tuple[str, str, str | None]:
    """Split ``"group.field"`` and return (group, field, SI unit); names the valid choices on error."""
    group, _, name = key.partition(".")
    if group not in FIELD_UNITS or name not in FIELD_UNITS[group]:
        groups = ", ".join(FIELD_UNITS)
        every = [f"{g}.{f}" for g, fields in FIELD_UNITS.items() for f in fields]
        close = difflib.get_close_matches(key, every, n=1)
        hint = f"; did you mean {close[0]!r}?" if close else ""
        raise ParameterError(
            f"unknown parameter {key!r} in sweep{hint}; use 'group.field' with group one of {groups}"
        )
    return group, name, FIELD_UNITS[group][name]


@dataclass(frozen=True)
class SweepCase:
    """One case of a sweep: its index and the parameter overrides (SI floats)."""

    index: int
    overrides: dict[str, float]


@dataclass(frozen=True)
class SweepSpec:
    """A parameter sweep: base parameters, varied fields, and the common input.

    Attributes
    ----------
    base : SystemParams
        Parameters every case starts from.
    grid : dict[str, list[float]]
        ``"group.field"`` → values (SI); all combinations are run.
    random : dict[str, tuple[str, float, float]]
        ``"group.field"`` → (distribution, a, b) in SI; ``n_random`` draws.
    n_random : int
    seed : int
    u : str
        Valve command spec (``hydropwa.simulation.parse_signal`` language).
    duration : float
        Simulated time per case [s].
    model : str
        ``"full"``, ``"reduced"``, ``"pwa"`` or ``"pwa-chamber"`` (``hydropwa._layout.MODEL_KINDS``).
    options : dict
        Further :func:`~hydropwa.simulation.simulate` keywords (fs, rtol, ...).
    """

    base: SystemParams
    grid: dict[str, list[float]] = field(default_factory=dict)
    random: dict[str, tuple[str, float, float]] = field(default_factory=dict)
    n_random: int = 0
    seed: int = 0
    u: Any = 0.0
    duration: float = 1.0
    model: str = DEFAULT_KIND.name
    options: dict[str, Any] = field(default_factory=dict)

    @property
    def n_cases(self) -> int:
        """Number of cases, without building them: grid points × random draws."""
        n = 1
        for values in self.grid.values():
            n *= len(values)
        return n * (self.n_random if self.random and self.n_random > 0 else 1)

    def cases(self) -> list[SweepCase]:
        """All cases: each grid point combined with each random draw (draws reproducible from ``seed``)."""
        keys = list(self.grid)
        points = list(itertools.product(*(self.grid[k] for k in keys))) if keys else [()]
        draws: list[dict[str, float]] = [{}]
        if self.random and self.n_random > 0:
            rng = np.random.default_rng(self.seed)
            cols = {k: _draw(rng, *spec, self.n_random) for k, spec in self.random.items()}
            draws = [{k: float(cols[k][i]) for k in cols} for i in range(self.n_random)]
        out: list[SweepCase] = []
        for point in points:
            for draw in draws:
                ov = dict(zip(keys, (float(v) for v in point), strict=True))
                ov.update(draw)
                out.append(SweepCase(len(out), ov))
        return out

    def params_for(self, case: SweepCase) -> SystemParams:
        """The base parameters with the case's overrides applied (validated)."""
        return apply_overrides(self.base, case.overrides)


def _draw(rng, dist: str, a: float, b: float, n: int) -> np.ndarray:
    if dist == "uniform":
        return rng.uniform(a, b, n)
    if dist == "loguniform":
        return np.exp(rng.uniform(np.log(a), np.log(b), n))
    return rng.normal(a, b, n)


def apply_overrides(base: SystemParams, overrides: dict[str, float]) -> SystemParams:
    """Replace ``"group.field"`` values (SI) in a parameter set; validation runs on construction."""
    groups: dict[str, dict[str, float]] = {}
    for key, value in overrides.items():
        group, name, _unit = _field_unit(key)
        groups.setdefault(group, {})[name] = value
    changes = {g: dataclasses.replace(getattr(base, g), **vals) for g, vals in groups.items()}
    return dataclasses.replace(base, **changes)


def _count(table: dict, key: str, default: int) -> int:
    v = table.get(key, default)
    if isinstance(v, bool) or not isinstance(v, int) or v < 0:
        raise ParameterError(f"[random] {key} = {v!r} must be a whole number ≥ 0")
    return v


def _parse_random(table: dict) -> tuple[int, int, dict[str, tuple[str, float, float]]]:
    if not isinstance(table, dict):
        raise ParameterError(
            "[random] must be a table: n, seed and 'group.field' = {uniform = [a, b]}"
        )
    n = _count(table, "n", 0)
    seed = _count(table, "seed", 0)
    out = {}
    for key, spec in table.items():
        if key in ("n", "seed"):
            continue
        _g, _f, unit = _field_unit(key)
        if not isinstance(spec, dict) or len(spec) != 1 or next(iter(spec)) not in _DISTRIBUTIONS:
            raise ParameterError(
                f"random parameter {key!r} needs one distribution, e.g. {{uniform = [10, 40]}}; "
                f"choose {', '.join(_DISTRIBUTIONS)}"
            )
        dist, bounds = next(iter(spec.items()))
        if not isinstance(bounds, list) or len(bounds) != 2:
            raise ParameterError(f"random parameter {key!r}: {dist} needs two values [a, b]")
        a, b = (parse_quantity(v, unit or "", key) for v in bounds)
        if not (math.isfinite(a) and math.isfinite(b)):
            raise ParameterError(f"random parameter {key!r}: {dist} bounds must be finite")
        if dist == "uniform" and not a < b:
            raise ParameterError(
                f"random parameter {key!r}: uniform [{a:g}, {b:g}] needs a < b; swap the bounds"
            )
        if dist == "loguniform" and not 0 < a < b:
            raise ParameterError(
                f"random parameter {key!r}: loguniform [{a:g}, {b:g}] needs 0 < a < b"
            )
        if dist == "normal" and not b > 0:
            raise ParameterError(
                f"random parameter {key!r}: normal [mean, std] needs std > 0, got {b:g}"
            )
        out[key] = (dist, a, b)
    if out and n <= 0:
        raise ParameterError("[random] needs n ≥ 1 draws")
    if n > 0 and not out:
        raise ParameterError(
            "[random] has n draws but no parameter to draw; add 'group.field' = {uniform = [a, b]}"
        )
    return n, seed, out


def parse_sweep(data: dict, root: str | os.PathLike = ".") -> SweepSpec:
    """Build a :class:`SweepSpec` from a TOML document (already parsed to a dict).

    Everything is checked here, before any case runs: unknown sections and keys (with the
    closest valid name suggested), empty grid lists, bounds of random draws, the input
    quantities (with the bounds of the parameter files), and the sweep's size.
    """
    if not isinstance(data, dict):
        raise ParameterError("a sweep file is a TOML table with [grid], [random] and [input]")
    for key in data:
        if key not in _SECTIONS:
            raise _unknown("section" if isinstance(data[key], dict) else "key", key, _SECTIONS)
    if "base" not in data:  # no default machine (issue 37)
        raise ParameterError(
            'the sweep file names no machine: add base = "paper" (the paper\'s rig) or '
            'base = "machine.toml" (your parameter file) at its top'
        )
    base_src = data["base"]
    if not isinstance(base_src, str) or not base_src.strip():
        raise ParameterError(f"base = {base_src!r} must be a preset name or a parameter TOML file")
    base_path = Path(root) / str(base_src)
    base = load_params(base_path) if str(base_src).endswith(".toml") else get_preset(str(base_src))
    grid = _parse_grid(data.get("grid", {}), base)
    n_random, seed, random = _parse_random(data.get("random", {}))
    both = sorted(set(grid) & set(random))
    if both:
        raise ParameterError(f"{both} are in both [grid] and [random]; vary each parameter in one")
    duration, model, u, options = _parse_input(data.get("input", {}))
    check_samples(float(duration), float(options.get("fs", 2000.0)), "input.duration")
    as_signal(u, "", "u")  # a malformed command spec fails here, not in every case
    if "load_force" in options:
        as_signal(options["load_force"], "N", "load_force")
    check_supply_pressure(
        options.get("supply_pressure"), base, float(duration), "input.supply_pressure"
    )
    if not grid and not random:
        raise ParameterError(
            "nothing to sweep: no [grid] values and no [random] draws; add e.g. [grid] "
            "'supply.pressure' = ['60 bar', '100 bar'] (one run: hydropwa simulate)"
        )
    spec = SweepSpec(base, grid, random, n_random, seed, u, float(duration), model, options)
    if spec.n_cases > MAX_SWEEP_CASES:
        sizes = " × ".join(
            [str(len(v)) for v in grid.values()] + ([str(n_random)] if random else [])
        )
        raise ParameterError(
            f"the sweep has {spec.n_cases:.3g} cases ({sizes}); at most {MAX_SWEEP_CASES:,} are "
            "run in one sweep: split it, or draw fewer random cases"
        )
    return spec


def _parse_grid(grid_table: Any, base: SystemParams) -> dict[str, list[float]]:
    """[grid]: 'group.field' = [values] in SI, each value checked against ``base``."""
    grid = {}
    if not isinstance(grid_table, dict):
        raise ParameterError("[grid] must be a table of 'group.field' = [values]")
    for key, values in grid_table.items():
        _g, _f, unit = _field_unit(key)
        vals = values if isinstance(values, list) else [values]
        if not vals:
            raise ParameterError(f"[grid] {key!r} is an empty list; give at least one value")
        grid[key] = [parse_quantity(v, unit or "", key) for v in vals]
        for v in grid[key]:  # each value must make valid parameters on its own
            try:
                apply_overrides(base, {key: v})
            except ParameterError as exc:
                raise ParameterError(f"[grid] {key!r}: {exc}") from None
    return grid


def _parse_input(inp_table: Any) -> tuple[float, str, Any, dict[str, Any]]:
    """[input]: (duration [s], model, command u, the other simulate options in SI)."""
    if not isinstance(inp_table, dict):
        raise ParameterError("[input] must be a table (u, duration, model, fs, rtol, ...)")
    inp = dict(inp_table)
    for key in inp:
        if key not in _INPUT_KEYS:
            raise _unknown("[input] key", key, _INPUT_KEYS)
    duration = parse_quantity(inp.pop("duration", 1.0), "s", "input.duration")
    model = inp.pop("model", DEFAULT_KIND.name)
    if model not in _MODELS:
        raise ParameterError(f"input.model = {model!r} is unknown; choose {', '.join(_MODELS)}")
    u = inp.pop("u", 0.0)
    options: dict[str, Any] = {}
    for key, value in inp.items():
        if key == "supply_pressure":
            options[key] = (
                parse_quantity(value, "Pa", "input.supply_pressure")
                if not _is_spec(value)
                else value
            )
        elif key == "load_force":
            options[key] = (
                parse_quantity(value, "N", "input.load_force") if not _is_spec(value) else value
            )
        elif key == "fs":
            options[key] = parse_quantity(value, "Hz", "input.fs")
        elif key == "rtol":
            options[key] = check_rtol(value, "input.rtol")
        elif key == "solver":
            if not isinstance(value, str):
                raise ParameterError(f"input.solver = {value!r} must be a solver name")
            options[key] = value
        else:
            options[key] = value
    return duration, model, u, options


def _is_spec(value) -> bool:
    return isinstance(value, str) and ":" in value


def load_sweep(path: str | os.PathLike) -> SweepSpec:
    """Read a sweep definition from a TOML file (see the module docstring for the format)."""
    path = Path(path)
    if not path.is_file():
        what = "is a folder, not a sweep file" if path.is_dir() else "does not exist"
        raise ParameterError(f"sweep file {path} {what}; give a TOML file")
    try:
        data = tomllib.loads(read_text(path, "sweep file", ParameterError))
    except tomllib.TOMLDecodeError as exc:
        raise ParameterError(
            f"sweep file {path}: not valid TOML ({exc}); fix the line it names"
        ) from None
    except RecursionError:
        raise ParameterError(f"sweep file {path}: nested too deeply to be a sweep file") from None
    try:
        return parse_sweep(data, root=path.parent)
    except HydropwaError as exc:
        raise ParameterError(f"sweep file {path}: {exc}") from None
