"""Faults injected into the virtual rig: worn seals, rising friction, valve drift, a weak pump.

Each fault kind is one row of :data:`FAULT_KINDS`: its name, the unit its size is written in,
the machine parameters it moves and how (:class:`FaultKind`). A :class:`Fault` is a kind with
a size and an onset, abrupt (present from run ``start`` on) or growing (linearly from zero at
run ``start`` to the full size at the last run of the experiment). :func:`inject` turns the
faults into the rig and run of one run index; :func:`parse_faults` reads a campaign's
``[[faults]]`` tables and :func:`parse_fault_spec` the ``rig run --fault`` option.

No physics lives here: the leakage flows are the kernel's (Eq. (9) and
:func:`~hydropwa.components.external_leakage_flow`), the friction is Eq. (11) with its forces
scaled, the supply is the pump model with a lower set pressure.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from .._errors import ParameterError
from ..params import SystemParams, parse_quantity
from ..simulation import Chirp, Constant, Ramp, Sampled, Signal, Sine, Step

__all__ = [
    "FAULT_KINDS",
    "Fault",
    "FaultKind",
    "inject",
    "parse_fault_spec",
    "parse_faults",
    "shift_command",
]

ONSETS = ("abrupt", "growing")


def _add_conductance(value: float, size: float, at: float) -> float:
    """A leakage coefficient [m³/(s·Pa)] raised by ``size`` [m³/s] flowing at the drop ``at`` [Pa]."""
    return value + size / at


def _raise_by(value: float, size: float, at: float) -> float:
    """A value raised by the fraction ``size`` (friction +30 %: size = 0.3)."""
    return value * (1.0 + size)


def _lower_by(value: float, size: float, at: float) -> float:
    """A value lowered by the fraction ``size`` (supply −10 %: size = 0.1)."""
    return value * (1.0 - size)


@dataclass(frozen=True)
class FaultKind:
    """One kind of fault: what it is called, how its size is written, what it moves.

    Attributes
    ----------
    name : str
        Name in campaigns and on the command line (``internal_leakage``).
    unit : str
        Unit the size is written in (``"L/min"``, ``"%"``); sizes are SI inside (m³/s,
        fractions).
    moves : tuple of str
        Dotted :class:`~hydropwa.params.SystemParams` fields it changes, or ``("command",)``
        for the valve null (the spool's null shifted against the command).
    change : callable
        ``change(value, size, at)``: the moved field's new value from its healthy value, the
        SI size and the pressure drop ``at`` [Pa] a leakage is rated at.
    rated_drop : bool
        True when the size is a flow rated at a pressure drop (``at``).
    limit : float
        Largest size (SI) that still describes a running machine.
    description : str
        One line for ``hydropwa rig faults`` and the docs.
    """

    name: str
    unit: str
    moves: tuple[str, ...]
    change: Callable[[float, float, float], float]
    rated_drop: bool
    limit: float
    description: str


#: The fault kinds the rig can inject, by name (a new kind is one row here).
FAULT_KINDS: dict[str, FaultKind] = {
    k.name: k
    for k in (
        FaultKind(
            "internal_leakage",
            "L/min",
            ("cylinder.leakage",),
            _add_conductance,
            True,
            100e-3 / 60.0,
            "flow across the piston seal [L/min] at the chamber pressure difference `at`",
        ),
        FaultKind(
            "external_leakage_a",
            "L/min",
            ("cylinder.external_leakage_a",),
            _add_conductance,
            True,
            100e-3 / 60.0,
            "flow out of chamber A to the ambient [L/min] at its pressure `at`",
        ),
        FaultKind(
            "external_leakage_b",
            "L/min",
            ("cylinder.external_leakage_b",),
            _add_conductance,
            True,
            100e-3 / 60.0,
            "flow out of chamber B (rod seal) to the ambient [L/min] at its pressure `at`",
        ),
        FaultKind(
            "friction",
            "%",
            ("friction.coulomb", "friction.static", "friction.viscous"),
            _raise_by,
            False,
            10.0,
            "Coulomb, static and viscous friction raised by the percentage (seal wear)",
        ),
        FaultKind(
            "valve_null",
            "%",
            ("command",),
            _raise_by,  # not applied to a parameter: see shift_command
            False,
            0.5,
            "spool null shifted by the percentage of full opening (the valve opens at u = −x %)",
        ),
        FaultKind(
            "supply",
            "%",
            ("supply.pressure",),
            _lower_by,
            False,
            0.9,
            "supply (pump set) pressure lowered by the percentage",
        ),
        FaultKind(
            "bulk_modulus",
            "%",
            ("oil.bulk_modulus",),
            _lower_by,
            False,
            0.99,
            "oil bulk modulus lowered by the percentage (entrained air)",
        ),
    )
}


@dataclass(frozen=True)
class Fault:
    """A fault of one kind with its size and onset.

    Attributes
    ----------
    kind : str
        A name of :data:`FAULT_KINDS`.
    size : float
        Size in SI: leakage flow [m³/s] at ``at``, or a fraction (0.3 for +30 %; the valve
        null as a fraction of full opening, signed).
    at : float
        Pressure drop [Pa] the leakage flow is rated at (leakage kinds only; 50 bar default).
    onset : {"abrupt", "growing"}
        Abrupt: full size from run ``start`` on. Growing: linearly from 0 at run ``start``
        to the full size at the last run of the experiment.
    start : int
        Index of the first faulty run in the experiment's plan order.
    """

    kind: str
    size: float
    at: float = 50e5
    onset: str = "abrupt"
    start: int = 0

    def __post_init__(self) -> None:
        if self.kind not in FAULT_KINDS:
            raise ParameterError(
                f"fault kind {self.kind!r} is unknown; choose from {', '.join(FAULT_KINDS)}"
            )
        k = FAULT_KINDS[self.kind]
        signed = k.moves == ("command",)
        size = abs(self.size) if signed else self.size
        if not (math.isfinite(self.size) and 0.0 <= size <= k.limit):
            shown = size * (60e3 if k.unit == "L/min" else 100.0)
            lim = k.limit * (60e3 if k.unit == "L/min" else 100.0)
            raise ParameterError(
                f"fault {self.kind}: size {shown:g} {k.unit} must lie in 0…{lim:g} {k.unit}"
            )
        if not (math.isfinite(self.at) and 1e4 <= self.at <= 1e9):
            raise ParameterError(
                f"fault {self.kind}: rated pressure drop at = {self.at:g} Pa must lie in 0.1…10000 bar"
            )
        if self.onset not in ONSETS:
            raise ParameterError(
                f"fault {self.kind}: onset {self.onset!r} must be one of {', '.join(ONSETS)}"
            )
        if not (isinstance(self.start, int) and self.start >= 0):
            raise ParameterError(
                f"fault {self.kind}: start = {self.start!r} must be an integer >= 0"
            )

    def size_at(self, index: int, total: int) -> float:
        """Size (SI) at run ``index`` of ``total`` runs (0 before ``start``)."""
        if index < self.start:
            return 0.0
        if self.onset == "abrupt" or total - 1 <= self.start:
            return self.size
        return self.size * (index - self.start) / (total - 1 - self.start)

    def describe(self, size: float | None = None) -> dict[str, Any]:
        """Plain dict for a run's metadata: kind, size in the kind's unit, unit, onset."""
        k = FAULT_KINDS[self.kind]
        s = self.size if size is None else size
        shown = s * 60e3 if k.unit == "L/min" else s * 100.0
        d: dict[str, Any] = {"kind": self.kind, "size": shown, "unit": k.unit, "onset": self.onset}
        if k.rated_drop:
            d["at_bar"] = self.at / 1e5
        return d


#: Fields of each signal class that carry its level: a command offset shifts all of them.
_LEVEL_FIELDS: dict[type[Signal], tuple[str, ...]] = {
    Constant: ("value",),
    Step: ("before", "after"),
    Ramp: ("v0", "v1"),
    Sine: ("offset",),
    Chirp: ("offset",),
    Sampled: ("values",),
}


def shift_command(command: Signal, offset: float) -> Signal:
    """The command u(t) + ``offset`` [1], of the same signal class.

    A valve whose spool null has drifted by −offset opens as if the command were u + offset;
    the valve (Eq. (3)) is linear with unit static gain, so shifting the command is the same
    as shifting the spool's null once the spool has settled.
    """
    names = _LEVEL_FIELDS.get(type(command))
    if names is None:
        raise ParameterError(
            f"the valve null fault cannot shift a {type(command).__name__} command; "
            f"it shifts {', '.join(c.__name__ for c in _LEVEL_FIELDS)}"
        )
    return dataclasses.replace(command, **{n: getattr(command, n) + offset for n in names})


def inject(
    params: SystemParams, faults: Sequence[Fault], index: int, total: int
) -> tuple[SystemParams, float, list[dict[str, Any]]]:
    """The faulty machine of run ``index`` of ``total``.

    Returns
    -------
    params : SystemParams
        ``params`` with each fault's fields moved by its size at this run.
    command_offset : float
        Valve null shift [1] to add to the command inside the valve (:func:`shift_command`).
    applied : list of dict
        The faults present at this run (:meth:`Fault.describe`), for the run's metadata.
    """
    changes: dict[str, float] = {}
    offset = 0.0
    applied = []
    for f in faults:
        size = f.size_at(index, total)
        if size == 0.0:
            continue
        k = FAULT_KINDS[f.kind]
        applied.append(f.describe(size))
        if k.moves == ("command",):
            offset += size
            continue
        for path in k.moves:
            comp, fld = path.split(".")
            value = changes.get(path, getattr(getattr(params, comp), fld))
            changes[path] = k.change(value, size, f.at)
    return (params.replace(**changes) if changes else params), offset, applied


def _size(kind: FaultKind, value: Any, where: str) -> float:
    if isinstance(value, int | float) and not isinstance(value, bool) and kind.unit == "%":
        return float(value) / 100.0  # a bare number is a percentage
    if isinstance(value, str) and kind.unit == "%" and value.strip().endswith("%"):
        return parse_quantity(value.strip()[:-1], "", f"{where}: size") / 100.0
    return parse_quantity(value, "m**3/s" if kind.unit == "L/min" else "", f"{where}: size")


def parse_faults(tables: Any, source: str = "<dict>") -> tuple[Fault, ...]:
    """Faults from a campaign's ``[[faults]]`` tables (``kind``, ``size``, ``at``, ``onset``, ``start``).

    ``size`` carries its unit (``"0.1 L/min"``, ``"30 %"``; a bare number is a percentage),
    ``at`` a pressure (``"50 bar"``, leakage kinds only).

    Raises
    ------
    ParameterError
        Naming the file, the table and the key of a missing, unknown or invalid entry.
    """
    if isinstance(tables, Mapping):
        tables = [tables]
    if not isinstance(tables, list):
        raise ParameterError(f"{source}: [[faults]] must be an array of tables (write [[faults]])")
    out = []
    for i, t in enumerate(tables):
        where = f"{source}: [[faults]][{i}]"
        if not isinstance(t, Mapping):
            raise ParameterError(f"{where} must be a table with kind and size")
        extra = sorted(set(t) - {"kind", "size", "at", "onset", "start"})
        if extra:
            raise ParameterError(
                f"{where}: unknown key(s) {', '.join(extra)}; known: kind, size, at, onset, start"
            )
        if "kind" not in t or "size" not in t:
            raise ParameterError(
                f"{where}: needs kind and size (e.g. kind = 'friction', size = '30 %')"
            )
        name = str(t["kind"])
        if name not in FAULT_KINDS:
            raise ParameterError(
                f"{where}: kind {name!r} is unknown; choose from {', '.join(FAULT_KINDS)}"
            )
        kind = FAULT_KINDS[name]
        if "at" in t and not kind.rated_drop:
            raise ParameterError(f"{where}: 'at' is only for the leakage kinds, not {name}")
        at = parse_quantity(t["at"], "Pa", f"{where}: at") if "at" in t else 50e5
        try:
            out.append(
                Fault(
                    name,
                    _size(kind, t["size"], where),
                    at,
                    str(t.get("onset", "abrupt")),
                    t.get("start", 0),
                )
            )
        except ParameterError as exc:
            raise ParameterError(f"{where}: {exc}") from None
    return tuple(out)


def parse_fault_spec(spec: str) -> Fault:
    """A fault from the command line: ``KIND=SIZE[@AT][:growing]``.

    Examples: ``internal_leakage=0.1 L/min@50 bar``, ``friction=30 %:growing``,
    ``valve_null=0.5 %``.
    """
    head, _, onset = spec.partition(":")
    name, eq, rest = head.partition("=")
    if not eq:
        raise ParameterError(
            f"--fault {spec!r}: write KIND=SIZE[@AT][:growing], e.g. 'internal_leakage=0.1 L/min@50 bar'"
        )
    size, _, at = rest.partition("@")
    table: dict[str, Any] = {"kind": name.strip(), "size": size.strip()}
    if at:
        table["at"] = at.strip()
    if onset:
        table["onset"] = onset.strip()
    return parse_faults([table], f"--fault {spec!r}")[0]
