"""Sweep definitions read from TOML.

Example::

    base = "paper"                       # preset name or parameter TOML file
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
import itertools
import os
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .._errors import ParameterError
from ..params import FIELD_UNITS, SystemParams, get_preset, load_params, parse_quantity

__all__ = ["SweepCase", "SweepSpec", "load_sweep", "parse_sweep"]

_DISTRIBUTIONS = ("uniform", "loguniform", "normal")
_INPUT_KEYS = {"u", "duration", "model", "fs", "rtol", "supply_pressure", "load_force", "solver"}


def _field_unit(key: str) -> tuple[str, str, str]:
    """Split ``"group.field"`` and return (group, field, SI unit); names the valid choices on error."""
    group, _, name = key.partition(".")
    if group not in FIELD_UNITS or name not in FIELD_UNITS[group]:
        groups = ", ".join(FIELD_UNITS)
        raise ParameterError(
            f"unknown parameter {key!r} in sweep; use 'group.field' with group one of {groups}"
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
        ``"full"``, ``"reduced"`` or ``"pwa"``.
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
    model: str = "full"
    options: dict[str, Any] = field(default_factory=dict)

    def cases(self) -> list[SweepCase]:
        """All cases: each grid point combined with each random draw (draws reproducible from ``seed``)."""
        keys = list(self.grid)
        points = list(itertools.product(*(self.grid[k] for k in keys))) if keys else [()]
        draws: list[dict[str, float]] = [{}]
        if self.random and self.n_random > 0:
            rng = np.random.default_rng(self.seed)
            cols = {k: _draw(rng, *spec, self.n_random) for k, spec in self.random.items()}
            draws = [{k: float(cols[k][i]) for k in cols} for i in range(self.n_random)]
        out = []
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


def _parse_random(table: dict) -> tuple[int, int, dict[str, tuple[str, float, float]]]:
    n = int(table.get("n", 0))
    seed = int(table.get("seed", 0))
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
        out[key] = (dist, a, b)
    if out and n <= 0:
        raise ParameterError("[random] needs n ≥ 1 draws")
    return n, seed, out


def parse_sweep(data: dict, root: str | os.PathLike = ".") -> SweepSpec:
    """Build a :class:`SweepSpec` from a TOML document (already parsed to a dict)."""
    base_src = data.get("base", "paper")
    base_path = Path(root) / str(base_src)
    base = load_params(base_path) if str(base_src).endswith(".toml") else get_preset(str(base_src))
    grid = {}
    for key, values in data.get("grid", {}).items():
        _g, _f, unit = _field_unit(key)
        vals = values if isinstance(values, list) else [values]
        grid[key] = [parse_quantity(v, unit or "", key) for v in vals]
    n_random, seed, random = _parse_random(data.get("random", {}))
    inp = dict(data.get("input", {}))
    unknown = set(inp) - _INPUT_KEYS
    if unknown:
        raise ParameterError(
            f"unknown [input] keys {sorted(unknown)}; allowed: {sorted(_INPUT_KEYS)}"
        )
    duration = parse_quantity(inp.pop("duration", 1.0), "s", "input.duration")
    model = str(inp.pop("model", "full"))
    u = inp.pop("u", 0.0)
    options = {}
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
            options[key] = float(value)
        else:
            options[key] = value
    return SweepSpec(base, grid, random, n_random, seed, u, float(duration), model, options)


def _is_spec(value) -> bool:
    return isinstance(value, str) and ":" in value


def load_sweep(path: str | os.PathLike) -> SweepSpec:
    """Read a sweep definition from a TOML file (see the module docstring for the format)."""
    path = Path(path)
    with path.open("rb") as fh:
        data = tomllib.load(fh)
    return parse_sweep(data, root=path.parent)
