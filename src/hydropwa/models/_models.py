"""The full-order and reduced models, assembled from one :class:`~hydropwa.params.SystemParams`.

A model object knows its states, how to pack its parameters for the compiled
kernel, the typical magnitude of each state (for error control) and a default
initial state: the :class:`Model` protocol, which the PWA model of
:mod:`hydropwa.linearization` satisfies as well. The physics itself is in
:mod:`hydropwa.components` and the kernel right-hand sides in
:mod:`hydropwa.simulation` (``_kernel``), which selects them by the model's ``name``;
this layer sits below both and imports neither.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import ClassVar, Protocol, runtime_checkable

import numpy as np

from .._channels import measured_values
from .._errors import ParameterError
from .._layout import (
    BASE_SLOTS,
    FULL_KIND,
    FULL_STATE_TIES,
    FULL_STATES,
    LINE_STATES,
    LINES_KIND,
    LOAD_STATES,
    MODEL_KINDS,
    MODEL_NAMES,
    N_BASE,
    REDUCED_KIND,
    SLOT,
    model_kind,
    state_vector,
)
from ..components import specimen_force
from ..params import SystemParams

__all__ = [
    "FullOrderModel",
    "FullLinesModel",
    "ReducedModel",
    "Model",
    "pack_params",
    "as_model",
    "machine_model",
    "REDUCED_FORMS",
    "MODEL_NAMES",
]

# MODEL_NAMES: the names of the model kinds (``hydropwa._layout.MODEL_KINDS``); ``simulate``
# selects the kernel's right-hand side by them.

#: Load-pressure forms of the reduced and PWA models: the single-rod model (default) and the
#: paper's mean-area model of Eqs. (12)–(15), kept so that Sec. VII stays reproducible.
REDUCED_FORMS = ("asymmetric", "paper")


def pack_params(
    params: SystemParams,
    omega0: float | None = None,
    *,
    form: str = "asymmetric",
    capacitance_position: float | None = None,
) -> np.ndarray:
    """Pack parameters into the kernel's float vector (layout table: :mod:`hydropwa._layout`).

    Parameters
    ----------
    params : SystemParams
    omega0 : float, optional
        Valve natural frequency [rad/s] to use (after the amplitude schedule);
        default ``params.valve.omega0``.
    form : {"asymmetric", "paper"}
        Load-pressure form of the reduced and PWA models (ignored by the full model).
    capacitance_position : float, optional
        Rod position [m] at which the chamber capacitances are frozen (the PWA model);
        None: they follow the state x (the reduced model).
    """
    if form not in REDUCED_FORMS:
        raise ParameterError(
            f"reduced-model form {form!r} must be one of {', '.join(REDUCED_FORMS)}"
        )
    p = np.zeros(N_BASE)
    for name, src in BASE_SLOTS:
        if src is not None:
            comp, fld = src.split(".")
            p[SLOT[name]] = getattr(getattr(params, comp), fld)
    if omega0 is not None:
        p[SLOT["omega0"]] = omega0
    p[SLOT["pump"]] = 1.0 if params.supply.model == "pump" else 0.0
    p[SLOT["rform"]] = 0.0 if form == "asymmetric" else 1.0
    p[SLOT["xcap"]] = -1.0 if capacitance_position is None else float(capacitance_position)
    return p


@runtime_checkable
class Model(Protocol):
    """What :func:`~hydropwa.simulate` needs of a model: every model satisfies it.

    :class:`FullOrderModel`, :class:`ReducedModel` and :class:`~hydropwa.linearization.PwaModel`
    are models by structure (no common base class), so a new model level needs no import of
    this layer; ``isinstance(obj, Model)`` checks the members below.

    Attributes
    ----------
    name : {"full", "reduced", "pwa"}
        Model kind; selects the compiled right-hand side.
    params : SystemParams
        The one parameter set the model was built from.
    state_names : tuple of str
        Names of the states, in the order of the state vector.
    """

    @property
    def name(self) -> str: ...

    @property
    def params(self) -> SystemParams: ...

    @property
    def state_names(self) -> tuple[str, ...]: ...

    def pack(self, command_amplitude: float = 0.0) -> np.ndarray:
        """Kernel parameter vector (float64) for a command of this amplitude [1]."""
        ...

    def state_scale(self) -> np.ndarray:
        """Typical magnitude of each state (absolute tolerance = rtol × scale)."""
        ...

    def initial_state(
        self,
        initial_position: float | None = None,
        supply_pressure: float | None = None,
        load_force: float = 0.0,
    ) -> np.ndarray:
        """State vector at rest at ``initial_position`` [m] (default mid-stroke)."""
        ...


class SmoothModelStates:
    """The states of a model that approximates a smooth one: its scales and its rest.

    A piecewise-affine model has the states of the smooth model it linearizes
    (:class:`~hydropwa.linearization.PwaModel` those of the reduced model,
    ``ChamberPwaModel`` those of the full one), so its tolerances and its rest state are that
    model's; the subclass names it in :attr:`smooth`.
    """

    @property
    def smooth(self) -> Model:
        """The smooth model whose states this model shares."""
        raise NotImplementedError

    def state_scale(self) -> np.ndarray:
        """Typical state magnitudes (the smooth model's) used as absolute tolerances (× rtol)."""
        return self.smooth.state_scale()

    def initial_state(
        self,
        initial_position: float | None = None,
        supply_pressure: float | None = None,
        load_force: float = 0.0,
    ) -> np.ndarray:
        """Rest at ``initial_position`` [m] (default mid-stroke), the smooth model's rest."""
        return self.smooth.initial_state(initial_position, supply_pressure, load_force)


def _specimen_at_rest(params: SystemParams, x: float) -> float:
    """Force [N] of the specimen on the rod at rest at x (:func:`~hydropwa.components.specimen_force`)."""
    ld = params.load
    # The same source run as Python: one scalar at set-up is not worth a compiled call's
    # dispatch (loading the entry and numba's target costs ~0.3 CPU-s in a fresh process).
    return float(
        specimen_force.py_func(
            x, 0.0, ld.specimen_stiffness, ld.specimen_damping, ld.contact_position, ld.preload
        )
    )


@dataclass(frozen=True)
class _ModelBase:
    """Shared fields of the full and reduced models; ``params`` is the one parameter set."""

    params: SystemParams  # the machine: required, there is no default machine (issue 37)
    name: ClassVar[str] = "model"
    state_names: ClassVar[tuple[str, ...]] = ()

    def __post_init__(self) -> None:
        if not isinstance(self.params, SystemParams):
            raise ParameterError(
                f"{type(self).__name__} needs a SystemParams, got {type(self.params).__name__}"
            )

    def pack(self, command_amplitude: float = 0.0) -> np.ndarray:
        """Kernel parameter vector; ω0 from the Table II schedule at the command amplitude [1]."""
        return pack_params(self.params, self.params.valve.omega0_at(command_amplitude))


@dataclass(frozen=True)
class FullOrderModel(_ModelBase):
    """Full-order model, Eqs. (1)–(11): servo valve, dead-zone, orifices, chambers, mechanics.

    States: spool ν [1], spool velocity ν̇ [1/s], P_A [Pa], P_B [Pa], x [m], ẋ [m/s],
    and P_S [Pa] (a state only with ``supply.model = "pump"``).
    """

    name: ClassVar[str] = FULL_KIND.name
    #: The state table (:mod:`hydropwa._layout`) the states, scales and initial states follow.
    states: ClassVar[tuple[tuple[str, str, float], ...]] = FULL_STATES
    state_names: ClassVar[tuple[str, ...]] = tuple(name for name, _u, _s in FULL_STATES)

    def state_scale(self) -> np.ndarray:
        """Typical state magnitudes used as absolute tolerances (× rtol)."""
        return np.array([scale for _n, _u, scale in self.states])

    def initial_state(
        self,
        initial_position: float | None = None,
        supply_pressure: float | None = None,
        load_force: float = 0.0,
    ) -> np.ndarray:
        """Rest at ``initial_position`` [m] (default mid-stroke) with P_A + P_B = P_S and
        balanced forces (the load and the specimen's force there)."""
        c = self.params.cylinder
        ps = self.params.supply.pressure if supply_pressure is None else supply_pressure
        x = 0.5 * c.stroke if initial_position is None else initial_position
        pa = (load_force + _specimen_at_rest(self.params, x) + ps * c.area_b) / (
            c.area_a + c.area_b
        )
        pa = min(max(pa, 0.0), ps)
        return self.state_from_measurement({"x": x, "p_a": pa, "p_b": ps - pa, "p_s": ps})

    def state_from_measurement(
        self, measured: Mapping[str, float], /, *positional: float
    ) -> np.ndarray:
        """Initial state from measured channels.

        Parameters
        ----------
        measured : Mapping[str, float]
            Channel name → value [SI] (:data:`hydropwa._channels.CHANNELS`): ``x`` [m], ``p_a``,
            ``p_b`` [Pa] required; ``v`` [m/s] and ``spool`` [1] default to rest (0), ``p_s``
            [Pa] to ``params.supply.pressure``. A state without a measured channel rests with
            the node it hangs on (:data:`~hydropwa._layout.FULL_STATE_TIES`).
        """
        defaults = {"v": 0.0, "spool": 0.0, "p_s": self.params.supply.pressure}
        values = measured_values(measured, self.state_names, defaults, positional)
        return np.array(state_vector(self.states, values, FULL_STATE_TIES), dtype=float)


@dataclass(frozen=True)
class FullLinesModel(FullOrderModel):
    """Full-order model with hose lines between the valve's ports and the chambers.

    The states of :class:`FullOrderModel`, then the line pressures P_line,A, P_line,B [Pa]
    (``params.lines``, :class:`~hydropwa.params.Lines`; a line of zero volume is no line, and
    the model is then the full model). At rest, and without a measured ``p_line_a``/``p_line_b``,
    a line holds its chamber's pressure.
    """

    name: ClassVar[str] = LINES_KIND.name
    states: ClassVar[tuple[tuple[str, str, float], ...]] = LINE_STATES
    state_names: ClassVar[tuple[str, ...]] = tuple(name for name, _u, _s in LINE_STATES)


@dataclass(frozen=True)
class ReducedModel(_ModelBase):
    """Reduced model: load pressure P_L [Pa], ẋ [m/s], x [m]; valve dynamics dropped (ν = u).

    Parameters
    ----------
    params : SystemParams
    form : {"asymmetric", "paper"}
        ``asymmetric`` (default): the single-rod load-pressure model, P_L = P_A − α P_B with
        α = A_B/A_A, flows from both orifice equations (5)–(6) under Q_B = α Q_A, force
        A_A P_L, position-dependent chamber capacitances; the rod drifts as a real
        single-rod axis does. ``paper``: Eqs. (12)–(15) with the mean area Ā (no drift).
        Derivation: docs/reduced_asymmetric.md.
    """

    form: str = "asymmetric"
    name: ClassVar[str] = REDUCED_KIND.name
    state_names: ClassVar[tuple[str, ...]] = tuple(name for name, _u, _s in LOAD_STATES)

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.form not in REDUCED_FORMS:
            raise ParameterError(
                f"reduced-model form {self.form!r} must be one of {', '.join(REDUCED_FORMS)}"
            )

    def pack(self, command_amplitude: float = 0.0) -> np.ndarray:
        """Kernel parameter vector (ω0 unused: the reduced model has no valve dynamics)."""
        return pack_params(self.params, form=self.form)

    @property
    def area_ratio(self) -> float:
        """α [1] of the load pressure P_L = P_A − α P_B: A_B/A_A, or 1 in the paper form."""
        c = self.params.cylinder
        return c.area_b / c.area_a if self.form == "asymmetric" else 1.0

    @property
    def force_area(self) -> float:
        """Area [m²] that turns P_L into the hydraulic force: A_A, or Ā in the paper form."""
        c = self.params.cylinder
        return c.area_a if self.form == "asymmetric" else c.mean_area

    def state_scale(self) -> np.ndarray:
        """Typical state magnitudes used as absolute tolerances (× rtol)."""
        return np.array([scale for _n, _u, scale in LOAD_STATES])

    def initial_state(
        self,
        initial_position: float | None = None,
        supply_pressure: float | None = None,
        load_force: float = 0.0,
    ) -> np.ndarray:
        """Rest at ``initial_position`` [m] (default mid-stroke) with A·P_L = F_L + F_spec (A = A_A,
        or Ā in the paper form; F_spec the specimen's force there)."""
        c = self.params.cylinder
        x = 0.5 * c.stroke if initial_position is None else initial_position
        f = load_force + _specimen_at_rest(self.params, x)
        return self.state_from_measurement({"x": x, "p_a": f / self.force_area, "p_b": 0.0})

    def state_from_measurement(
        self, measured: Mapping[str, float], /, *positional: float
    ) -> np.ndarray:
        """Initial state [P_A − α P_B, v, x] from measured channels.

        Parameters
        ----------
        measured : Mapping[str, float]
            Channel name → value [SI] (:data:`hydropwa._channels.CHANNELS`): ``x`` [m], ``p_a``,
            ``p_b`` [Pa] required, ``v`` [m/s] default 0; the other channels initialise no
            state of this model (ν = u, P_S an input).
        """
        m = measured_values(measured, ("x", "v", "p_a", "p_b"), {"v": 0.0}, positional)
        values = {"p_l": m["p_a"] - self.area_ratio * m["p_b"], "v": m["v"], "x": m["x"]}
        return np.array(state_vector(LOAD_STATES, values), dtype=float)


def as_model(model: Model | str, params: SystemParams | None = None) -> Model:
    """Return a model object from a model object or the name of a kind built in this layer.

    A name (``full``, ``reduced``: the registry rows whose factory is a class of this module,
    :data:`hydropwa._layout.MODEL_KINDS`) needs ``params`` (the machine); there is no default
    machine, so ``None`` with a name raises :class:`~hydropwa.ParameterError` saying how to give it.

    The PWA kinds are built from parameters by :func:`hydropwa.linearization.linearize` (a layer
    above this one); pass that object, or build it by name with
    :func:`hydropwa._layout.build_model` where it is used (the CLI, :mod:`hydropwa.sweep`).
    """
    if isinstance(model, Model):
        return model
    if not isinstance(model, str):
        raise ParameterError(
            f"cannot simulate a {type(model).__name__}; give a model object or a model name "
            f"({', '.join(_OWN_KINDS)}) with params"
        )
    row = model_kind(model)
    if row.linearized:
        options = "".join(f", {k}={v!r}" for k, v in row.factory_options)
        raise ParameterError(
            f"the {row.what} is built from parameters by linearize(params{options}); "
            f"pass hydropwa.linearize(params{options}) instead of {row.name!r}"
        )
    if params is None:  # no default machine (issue 37)
        raise ParameterError(
            f"model {model!r} needs the machine: pass params=load_params('machine.toml') "
            "(your machine) or params=get_preset('paper') (the paper's rig)"
        )
    built: Model = row.build(params)
    return built


def machine_model(params: SystemParams) -> FullOrderModel:
    """The full-order model of the machine ``params``: with its hose lines where it has them.

    :class:`FullLinesModel` when ``params.lines`` gives a line a volume
    (:attr:`~hydropwa.params.Lines.present`), else :class:`FullOrderModel`: what the virtual
    rig simulates, so a rig on a machine with hoses records the line pressures.
    """
    return FullLinesModel(params) if params.lines.present else FullOrderModel(params)


#: The kinds built in this layer (by :func:`as_model` from a name).
_OWN_KINDS = tuple(name for name, row in MODEL_KINDS.items() if not row.linearized)
