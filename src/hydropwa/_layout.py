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

This module is a leaf: it imports nothing from the package.
"""

from __future__ import annotations

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
#: States of the reduced and PWA models (Eqs. (12)–(23)): load pressure, velocity, position.
LOAD_STATES: tuple[tuple[str, str, float], ...] = (
    ("p_l", "Pa", 1e5),
    ("v", "m/s", 1e-2),
    ("x", "m", 1e-3),
)
#: The model kinds, declared once: name → (kernel kind, state table, what it is). ``simulate``
#: selects the compiled right-hand side by the name; the CLI, sweeps, warm-ups and evaluations
#: read their choices from here. ``pwa-chamber`` keeps the full model's state vector (spool,
#: chamber pressures, mechanics; P_S is its scheduled input).
MODEL_KINDS: dict[str, tuple[int, tuple[tuple[str, str, float], ...], str]] = {
    "full": (0, FULL_STATES, "full-order model, Eqs. (1)-(11)"),
    "reduced": (1, LOAD_STATES, "reduced load-pressure model, Eqs. (12)-(15)"),
    "pwa": (2, LOAD_STATES, "piecewise-affine load-pressure model, Eqs. (16)-(23)"),
    "pwa-chamber": (3, FULL_STATES, "piecewise-affine chamber-level model (spool, P_A, P_B)"),
}
#: Names of the model kinds, in kernel order.
MODEL_NAMES: tuple[str, ...] = tuple(MODEL_KINDS)
#: Model kinds built from parameters by ``hydropwa.linearize`` (not by name alone).
LINEARIZED_MODELS: tuple[str, ...] = ("pwa", "pwa-chamber")

#: A full-model state whose initial value is that of another state when the caller does not
#: give it (a component at rest with the node it hangs on).
FULL_STATE_TIES: dict[str, str] = {"p_acc": "p_a"}

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
