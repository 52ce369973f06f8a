"""The one layout table of the compiled kernel's packed parameter vector and output channels.

The kernel (:mod:`hydropwa.simulation._kernel`) reads its parameters from one float vector.
Every slot is declared here once: its name, and where its value comes from in a
:class:`~hydropwa.params.SystemParams` (a dotted ``component.field`` path, or ``None`` for
slots that the model object sets itself, such as the reduced model's form). The kernel's
``I_*`` indices, :func:`hydropwa.models.pack_params` and the PWA packing are generated from
this table, and so are the names of the output channels. Adding a parameter is one line here.

The states of each model are declared here too (:data:`FULL_STATES`, :data:`LOAD_STATES`):
name, unit, typical magnitude (the integrator's absolute tolerance is ``rtol`` times it) and
how the default and measured initial states fill it. The kernel's ``Y_*`` indices, the
models' ``state_names``, ``state_scale`` and initial states are generated from them, so a
new state (see the gas accumulator) is one row here plus its rate in the kernel.

The model kinds are rows here too (:class:`ModelKind`, :data:`MODEL_KINDS`): what each kind
is and does, read by the compiled side's per-kind tables and by every layer that builds a model
(:func:`build_model`, whose factories are resolved lazily by name).

This module imports nothing from the package but its error types.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass
from typing import Any

from ._errors import ParameterError

#: (slot name, source in SystemParams or None) in kernel order. Slots with ``None`` are
#: written by the model object (see ``hydropwa.models``).
BASE_SLOTS: tuple[tuple[str, str | None], ...] = (
    ("omega0", "valve.omega0"),
    ("zeta", "valve.zeta"),
    ("alpha", "dead_zone.alpha"),
    ("beta", "dead_zone.beta"),
    ("creep", "dead_zone.creep_slope"),
    ("outer", "dead_zone.outer_offset"),
    ("K", "flow.K"),
    ("ptr", "flow.transition_pressure"),
    ("aa", "cylinder.area_a"),
    ("ab", "cylinder.area_b"),
    ("stroke", "cylinder.stroke"),
    ("va", "cylinder.dead_volume_a"),
    ("vb", "cylinder.dead_volume_b"),
    ("cl", "cylinder.leakage"),
    ("kstop", "cylinder.end_stop_stiffness"),
    ("cstop", "cylinder.end_stop_damping"),
    ("e", "oil.bulk_modulus"),
    ("pvap", "oil.vapour_pressure"),
    ("prel", "oil.release_pressure"),
    ("fc", "friction.coulomb"),
    ("fs", "friction.static"),
    ("sigma", "friction.viscous"),
    ("chi", "friction.stribeck_velocity"),
    ("delta", "friction.shape"),
    ("gamma", "friction.smoothness"),
    ("pt", "supply.tank_pressure"),
    ("pump", None),  # 1.0 with the pump supply model (P_S a state), else 0.0
    ("pset", "supply.pressure"),
    ("qmax", "supply.pump_flow"),
    ("droop", "supply.compensator_droop"),
    ("vline", "supply.line_volume"),
    ("prelief", "supply.relief_pressure"),
    ("grelief", "supply.relief_gain"),
    ("mass", "load.mass"),
    ("cload", "load.damping"),
    # specimen / tool / spring the rod meets (components.specimen_force; stiffness 0: none)
    ("kspec", "load.specimen_stiffness"),
    ("cspec", "load.specimen_damping"),
    ("xspec", "load.contact_position"),
    ("fspec", "load.preload"),
    # reduced / PWA load-pressure form: 0 asymmetric single-rod model, 1 the paper's mean area
    ("rform", None),
    # rod position [m] at which the PWA model evaluates its chamber capacitances; < 0: the state x
    ("xcap", None),
    # gas accumulator on port A (full model only; gas volume 0: none)
    ("accv", "accumulator.gas_volume"),
    ("accp0", "accumulator.precharge_pressure"),
    ("accn", "accumulator.polytropic_index"),
    ("hosel", "accumulator.hose_length"),
    ("hosed", "accumulator.hose_diameter"),
    ("hosevol", "accumulator.hose_volume"),
    ("visc", "accumulator.viscosity"),
    # external leakage of each chamber to the ambient, C_eA, C_eB [m³/(s·Pa)]
    ("cea", "cylinder.external_leakage_a"),
    ("ceb", "cylinder.external_leakage_b"),
    # hose lines between the valve's ports and the chambers (the full-lines model; volume 0: none)
    ("vla", "lines.volume_a"),
    ("vlb", "lines.volume_b"),
    ("gla", "lines.conductance_a"),
    ("glb", "lines.conductance_b"),
    ("ehose", "lines.bulk_modulus"),
    ("lorif", "lines.orifice"),
)

#: Index of each base slot.
SLOT: dict[str, int] = {name: i for i, (name, _src) in enumerate(BASE_SLOTS)}
#: Size of the base block (room for a few more slots before the PWA section).
N_BASE = 56
assert len(BASE_SLOTS) <= N_BASE

#: PWA section (after the base block): flags and cell counts, then the cell table from I_CELLS.
PWA_SLOTS: tuple[str, ...] = ("sched", "psfix", "form", "ng", "no", "nn", "nw")
PWA_SLOT: dict[str, int] = {name: N_BASE + i for i, name in enumerate(PWA_SLOTS)}
I_CELLS = N_BASE + len(PWA_SLOTS) + 3

#: The cell table of the PWA models from ``I_CELLS``: one section per PWA slot ``ng``, ``no``,
#: ``nn``, ``nw`` (in that order; the load-pressure model's dead zone over u, flow cells over the
#: supply and load drops, friction over ẋ; the chamber model's dead zone over ν, metering flow over
#: the normalised edge drop, capacitance position over x, friction over ẋ). A section of n cells
#: holds these fields one after the other: n − 1 breakpoints, n slopes, n offsets.
CELL_FIELDS: tuple[str, ...] = ("breakpoints", "slopes", "offsets")


def cell_sections(counts: tuple[int, ...]) -> list[int]:
    """Start index in the packed vector of each cell section, given the cell counts (ng, no, nn, nw).

    A section of n cells is 3n − 1 long (:data:`CELL_FIELDS`); the first starts at ``I_CELLS``.
    The list ends with the index one past the last section (the packed vector's length).
    """
    starts = [I_CELLS]
    for n in counts:
        starts.append(starts[-1] + len(CELL_FIELDS) * int(n) - 1)
    return starts


#: The packed input signals of every model, in the order of the packed signal vector ``sg``
#: (:func:`hydropwa.simulation.pack_signals`): name, SI unit.
INPUT_SIGNALS: tuple[tuple[str, str], ...] = (("u", "1"), ("p_s", "Pa"), ("f_l", "N"))
N_SIGNALS = len(INPUT_SIGNALS)
#: Header blocks of ``sg``, one slot per signal each: the signal's kind (0: constant), and the
#: first index and count of a sampled signal's samples. Signal i's kind is ``sg[SG["kind"] + i]``.
SIGNAL_HEADER: tuple[str, ...] = ("kind", "first", "count")
SG: dict[str, int] = {name: j * N_SIGNALS for j, name in enumerate(SIGNAL_HEADER)}
#: Parameters of signal i: ``sg[SG_PARAMS + SIGNAL_PARAMS * i :][:SIGNAL_PARAMS]``, a constant's
#: value first; the sampled signals' times and values follow from ``SG_DATA``.
SG_PARAMS = 16
SIGNAL_PARAMS = 8
SG_DATA = SG_PARAMS + SIGNAL_PARAMS * N_SIGNALS
assert len(SIGNAL_HEADER) * N_SIGNALS <= SG_PARAMS
#: Slot of each input's constant value (in closed loop the controller writes the command there).
SG_VALUE: dict[str, int] = {
    name: SG_PARAMS + SIGNAL_PARAMS * i for i, (name, _u) in enumerate(INPUT_SIGNALS)
}

#: The compiled integrator's statistics array, in order (``SolverStats`` fields of the same names).
SOLVER_STATS: tuple[str, ...] = ("steps", "rejected", "rhs_evaluations", "jacobians")
STAT: dict[str, int] = {name: i for i, name in enumerate(SOLVER_STATS)}

#: Output channels of every model, in the kernel's row order, with their SI units.
OUTPUT_CHANNELS: tuple[tuple[str, str], ...] = (
    ("u", "1"),
    ("spool", "1"),
    ("z", "1"),
    ("p_a", "Pa"),
    ("p_b", "Pa"),
    ("p_l", "Pa"),
    ("p_s", "Pa"),
    ("f_l", "N"),
    ("x", "m"),
    ("v", "m/s"),
    ("friction", "N"),
    ("f_spec", "N"),  # force of the specimen on the rod (components.specimen_force)
)
#: Extra output rows of the PWA model (active cells), after :data:`OUTPUT_CHANNELS`.
PWA_OUTPUT_CHANNELS: tuple[tuple[str, str], ...] = (
    ("cell_g", "1"),
    ("cell_o", "1"),
    ("cell_n", "1"),
    ("cell_w", "1"),
)
#: Extra output rows of the chamber-level PWA model (``pwa-chamber``, active cells): dead zone over
#: the spool ν, metering-flow cells of the edges A and B (over their normalised pressure drop),
#: capacitance cell over x, friction cell over ẋ.
CHAMBER_OUTPUT_CHANNELS: tuple[tuple[str, str], ...] = (
    ("cell_g", "1"),
    ("cell_qa", "1"),
    ("cell_qb", "1"),
    ("cell_x", "1"),
    ("cell_w", "1"),
)
#: Channels added in closed loop (``simulate(..., controller=...)``), filled from the controller log.
CONTROL_OUTPUT_CHANNELS: tuple[tuple[str, str], ...] = (
    ("reference", "m"),
    ("error", "m"),
    ("command", "1"),
    ("cell_ctl", "1"),
    ("force", "N"),
    ("force_reference", "N"),
    ("force_error", "N"),
)
OUT: dict[str, int] = {
    name: i for i, (name, _u) in enumerate(OUTPUT_CHANNELS + PWA_OUTPUT_CHANNELS)
}


#: States of the full-order model in kernel order: (name, SI unit, typical magnitude).
#: The typical magnitude sets the absolute tolerance (``rtol`` × it) and the finite-difference
#: step of the Jacobian column.
FULL_STATES: tuple[tuple[str, str, float], ...] = (
    ("spool", "1", 1.0),  # valve spool position ν, Eq. (1)
    ("spool_rate", "1/s", 10.0),  # ν̇
    ("p_a", "Pa", 1e5),  # chamber pressures, Eq. (9)
    ("p_b", "Pa", 1e5),
    ("x", "m", 1e-3),  # rod position and velocity, Eq. (10)
    ("v", "m/s", 1e-2),
    ("p_s", "Pa", 1e5),  # supply pressure: a state only with the pump supply model
    ("p_acc", "Pa", 1e5),  # gas accumulator on port A (constant without one)
)
#: States of the full model with hose lines (``full-lines``): the full model's, then the
#: pressure of the line on each valve port (a line of zero volume holds its chamber's pressure).
LINE_STATES: tuple[tuple[str, str, float], ...] = FULL_STATES + (
    ("p_line_a", "Pa", 1e5),
    ("p_line_b", "Pa", 1e5),
)
#: Extra output rows of the full-lines model: the line pressures (a chamber's where it has none).
LINE_OUTPUT_CHANNELS: tuple[tuple[str, str], ...] = (("p_line_a", "Pa"), ("p_line_b", "Pa"))
#: States of the reduced and PWA models (Eqs. (12)–(23)): load pressure, velocity, position.
LOAD_STATES: tuple[tuple[str, str, float], ...] = (
    ("p_l", "Pa", 1e5),
    ("v", "m/s", 1e-2),
    ("x", "m", 1e-3),
)


@dataclass(frozen=True)
class ModelKind:
    """One model kind: everything a layer asks of it, declared once (a row of :data:`MODEL_KINDS`).

    The compiled side reads the fields below through per-kind constant tables indexed by
    :attr:`kernel` (``simulation._kcommon``); Python layers build the model by
    :func:`build_model`. A new kind is one row here plus its right-hand-side module
    (docs/architecture.md, "Adding a model kind").

    Attributes
    ----------
    name : str
        The kind's name (``simulate``, the CLI's ``--model``, sweeps, evaluations).
    kernel : int
        Its index in every compiled per-kind table (its position in :data:`MODEL_KINDS`).
    entry_id : str
        Its part of the compiled entry points' names (``_integrate_<entry_id>``).
    states : tuple of (name, SI unit, typical magnitude)
        The state vector in kernel order.
    extra_outputs : tuple of (name, SI unit)
        Output rows after :data:`OUTPUT_CHANNELS` (the PWA models' active cells).
    what : str
        What it is, with the paper's equations.
    label : str
        Its name in compile notices ("compiling the chamber PWA model solver").
    carries_spool : bool
        The state holds the spool (ν, ν̇): the controller reads the spool from the state.
    jacobian_depends_on_u : bool
        ∂f/∂y changes with the valve command u: a new command refreshes the Jacobian.
    inert_states : tuple of (state, slot or None, threshold)
        Trailing states that are constant (zero row and column of ∂f/∂y), last state first:
        inert when the slot is None, or when the packed parameter ``p[slot] <= threshold``.
        The linear solves skip a trailing run of them (bit for bit the same solution).
    lu_blocks : tuple of int
        Ends of the diagonal blocks of W = I − hγJ when it is block lower triangular over its
        full solved size (the last entry): factorised block by block; () a dense LU.
    rhs_module : str
        The compiled module holding its ``rhs_<entry_id>``, ``jac_<entry_id>`` (exact ∂f/∂y) and
        ``dfdt_<entry_id>`` (∂f/∂t) (``hydropwa.simulation._rhs_*``); resolved by the kernel.
    exact_jacobian_always : bool
        Its ``jac_`` always fills the exact ∂f/∂y (else it returns False where it cannot, e.g.
        with a gas accumulator, and the solver takes differences).
    factory : str
        ``"module:callable"`` building the model as ``callable(params, **options)``; resolved
        by :func:`build_model` on first use, so this layer imports nothing above it.
    factory_options : tuple of (keyword, value)
        Keywords the factory always gets for this kind (``form="chamber"``).
    style : (colour, line style, label)
        How plots draw it.
    norm_free_states : tuple of (state, slot, threshold)
        Trailing states left out of the step's error norm (its RMS) where ``p[slot] <=
        threshold``, last state first: the held state of an absent optional component (a hose
        line of zero volume), so the kind then steps exactly as the kind without it. () for
        every kind whose norm runs over all its states.
    component : str or None
        The optional part of the parameters the kind adds (``"lines"``,
        ``SystemParams.carries``): the kind is among a machine's default model sets (the
        closed-loop comparison, :func:`kinds_for`) only where its parameters carry that part.
        None: a kind every machine has.
    """

    name: str
    kernel: int
    entry_id: str
    states: tuple[tuple[str, str, float], ...]
    extra_outputs: tuple[tuple[str, str], ...]
    what: str
    label: str
    carries_spool: bool
    jacobian_depends_on_u: bool
    inert_states: tuple[tuple[str, str | None, float], ...]
    lu_blocks: tuple[int, ...]
    rhs_module: str
    exact_jacobian_always: bool
    factory: str
    factory_options: tuple[tuple[str, object], ...]
    style: tuple[str, str, str]
    norm_free_states: tuple[tuple[str, str, float], ...] = ()
    component: str | None = None

    @property
    def linearized(self) -> bool:
        """Built from parameters by :func:`hydropwa.linearization.linearize` (not by name alone)."""
        return self.factory.startswith("hydropwa.linearization")

    def build(self, params: Any, **options: Any) -> Any:
        """The model of this kind for ``params`` (SystemParams), ``options`` passed to its factory."""
        module, _sep, attr = self.factory.partition(":")
        factory = getattr(importlib.import_module(module), attr)
        return factory(params, **dict(self.factory_options), **options)


#: The full model's inert trailing states: the gas accumulator without gas volume, P_S without
#: the pump model (then an input).
_FULL_INERT: tuple[tuple[str, str | None, float], ...] = (
    ("p_acc", "accv", 0.0),
    ("p_s", "pump", 0.5),
)
#: The model kinds, one row each, in kernel order (:attr:`ModelKind.kernel`). ``pwa-chamber``
#: keeps the full model's state vector (spool, chamber pressures, mechanics; P_S is its
#: scheduled input, so always inert).
MODEL_KINDS: dict[str, ModelKind] = {
    row.name: row
    for row in (
        ModelKind(
            "full", 0, "full", FULL_STATES, (), "full-order model, Eqs. (1)-(11)", "full",
            carries_spool=True, jacobian_depends_on_u=False, inert_states=_FULL_INERT,
            rhs_module="hydropwa.simulation._rhs_full", exact_jacobian_always=False,
            lu_blocks=(2, 6), factory="hydropwa.models:FullOrderModel", factory_options=(),
            style=("tab:blue", "-", "full-order"),
        ),
        ModelKind(
            "reduced", 1, "reduced", LOAD_STATES, (),
            "reduced load-pressure model, Eqs. (12)-(15)", "reduced",
            carries_spool=False, jacobian_depends_on_u=True, inert_states=(), lu_blocks=(),
            rhs_module="hydropwa.simulation._rhs_load", exact_jacobian_always=True,
            factory="hydropwa.models:ReducedModel", factory_options=(),
            style=("tab:green", "--", "reduced (mean P_S)"),
        ),
        ModelKind(
            "pwa", 2, "pwa", LOAD_STATES, PWA_OUTPUT_CHANNELS,
            "piecewise-affine load-pressure model, Eqs. (16)-(23)", "PWA",
            carries_spool=False, jacobian_depends_on_u=True, inert_states=(), lu_blocks=(),
            rhs_module="hydropwa.simulation._rhs_load", exact_jacobian_always=True,
            factory="hydropwa.linearization:linearize", factory_options=(),
            style=("tab:red", "-.", "PWA (mean P_S)"),
        ),
        ModelKind(
            "pwa-chamber", 3, "chamber", FULL_STATES, CHAMBER_OUTPUT_CHANNELS,
            "piecewise-affine chamber-level model (spool, P_A, P_B)", "chamber PWA",
            carries_spool=True, jacobian_depends_on_u=False,
            inert_states=(("p_acc", "accv", 0.0), ("p_s", None, 0.0)), lu_blocks=(),
            rhs_module="hydropwa.simulation._rhs_chamber", exact_jacobian_always=False,
            factory="hydropwa.linearization:linearize", factory_options=(("form", "chamber"),),
            style=("tab:orange", "-.", "PWA chamber-level (P_S(t))"),
        ),
        ModelKind(
            "full-lines", 4, "lines", LINE_STATES, LINE_OUTPUT_CHANNELS,
            "full-order model with hose lines between valve and chambers", "full (hose lines)",
            carries_spool=True, jacobian_depends_on_u=False,
            inert_states=(("p_line_b", "vlb", 0.0), ("p_line_a", "vla", 0.0), *_FULL_INERT),
            rhs_module="hydropwa.simulation._rhs_lines", exact_jacobian_always=False,
            lu_blocks=(2, 6), factory="hydropwa.models:FullLinesModel", factory_options=(),
            style=("tab:purple", "-", "full-order, hose lines"),
            norm_free_states=(("p_line_b", "vlb", 0.0), ("p_line_a", "vla", 0.0)),
            component="lines",
        ),
    )
}  # fmt: skip
assert [row.kernel for row in MODEL_KINDS.values()] == list(range(len(MODEL_KINDS)))
#: Names of the model kinds, in kernel order.
MODEL_NAMES: tuple[str, ...] = tuple(MODEL_KINDS)
#: Model kinds built from parameters by ``hydropwa.linearize`` (not by name alone).
LINEARIZED_MODELS: tuple[str, ...] = tuple(r.name for r in MODEL_KINDS.values() if r.linearized)
#: The rows by name, for code that means one kind: ``FULL_KIND.name``, not a literal name (a test
#: holds literal kind names outside this module and the CLI's help text below 5).
FULL_KIND = MODEL_KINDS["full"]
REDUCED_KIND = MODEL_KINDS["reduced"]
PWA_KIND = MODEL_KINDS["pwa"]
CHAMBER_KIND = MODEL_KINDS["pwa-chamber"]
LINES_KIND = MODEL_KINDS["full-lines"]
#: The kind simulated when none is named (``simulate`` by name, sweeps, batches, the CLI).
DEFAULT_KIND = FULL_KIND
#: The kind a controller is designed on unless told otherwise (``control design``).
DESIGN_KIND = PWA_KIND
#: Kinds without the valve and the two chambers: one load-pressure state (Eqs. (12)-(23)).
LOAD_PRESSURE_MODELS: tuple[str, ...] = tuple(
    r.name for r in MODEL_KINDS.values() if r.states == LOAD_STATES
)
#: Kinds built from parameters alone, so a grey-box fit can start one from measurements.
MEASURABLE_MODELS: tuple[str, ...] = tuple(r.name for r in MODEL_KINDS.values() if not r.linearized)


#: Kinds every machine has (no optional part: :attr:`ModelKind.component` None).
BASE_MODELS: tuple[str, ...] = tuple(r.name for r in MODEL_KINDS.values() if r.component is None)


def kinds_for(params: Any) -> tuple[str, ...]:
    """Names of the kinds that apply to a machine, in kernel order: every kind without an
    optional part, and those whose part ``params`` carries (``SystemParams.carries``)."""
    return tuple(r.name for r in MODEL_KINDS.values() if params.carries(r.component))


def model_kind(name: str) -> ModelKind:
    """The registry row of the model kind ``name`` (case and surrounding blanks ignored).

    Raises
    ------
    ParameterError
        For an unknown name, listing the known ones.
    """
    row = MODEL_KINDS.get(str(name).strip().lower())
    if row is None:
        raise ParameterError(f"unknown model {name!r}; choose {', '.join(MODEL_NAMES)}")
    return row


def build_model(name: str, params: Any, **options: Any) -> Any:
    """The model of kind ``name`` for ``params`` (a SystemParams): the one way a layer builds one.

    ``options`` go to the kind's factory (:attr:`ModelKind.factory`), e.g. ``supply_pressure``,
    ``scheduled`` for the PWA kinds or ``form="paper"`` for the reduced model.
    """
    return model_kind(name).build(params, **options)


#: A full-model state whose initial value is that of another state when the caller does not
#: give it (a component at rest with the node it hangs on).
FULL_STATE_TIES: dict[str, str] = {"p_acc": "p_a", "p_line_a": "p_a", "p_line_b": "p_b"}

#: Index of each state in the kernel's state vector.
Y_FULL: dict[str, int] = {name: i for i, (name, _u, _s) in enumerate(FULL_STATES)}
Y_LOAD: dict[str, int] = {name: i for i, (name, _u, _s) in enumerate(LOAD_STATES)}


def state_vector(
    states: tuple[tuple[str, str, float], ...],
    values: dict[str, float],
    ties: dict[str, str] | None = None,
) -> list[float]:
    """A state vector in kernel order from named values.

    A state missing from ``values`` takes the value of the state it is tied to in ``ties``
    (if that one is given), else 0.
    """
    ties = ties or {}
    names = {name for name, _u, _s in states}
    unknown = set(values) - names
    if unknown:
        raise KeyError(f"unknown state(s) {', '.join(sorted(unknown))}; known: {', '.join(names)}")
    out = []
    for name, _u, _s in states:
        if name in values:
            out.append(float(values[name]))
        elif name in ties and ties[name] in values:
            out.append(float(values[ties[name]]))
        else:
            out.append(0.0)
    return out
