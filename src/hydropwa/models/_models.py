"""The three models, assembled from one :class:`~hydropwa.params.SystemParams`.

A model object knows its states, how to pack its parameters for the compiled
kernel, the typical magnitude of each state (for error control) and a default
initial state. The physics itself is in :mod:`hydropwa.components` and the
kernel right-hand sides in :mod:`hydropwa.simulation._kernel`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .._errors import ParameterError
from ..params import SystemParams, get_preset
from ..simulation import _kernel as K

__all__ = ["FullOrderModel", "ReducedModel", "Model", "pack_params", "as_model"]


def pack_params(params: SystemParams, omega0: float | None = None) -> np.ndarray:
    """Pack parameters into the kernel's float vector (layout in ``_kernel``).

    Parameters
    ----------
    params : SystemParams
    omega0 : float, optional
        Valve natural frequency [rad/s] to use (after the amplitude schedule);
        default ``params.valve.omega0``.
    """
    p = np.zeros(K.N_BASE)
    v, dz, fl, c, oil, fr, s, ld = (
        params.valve,
        params.dead_zone,
        params.flow,
        params.cylinder,
        params.oil,
        params.friction,
        params.supply,
        params.load,
    )
    p[K.I_OMEGA0] = v.omega0 if omega0 is None else omega0
    p[K.I_ZETA] = v.zeta
    p[K.I_ALPHA] = dz.alpha
    p[K.I_BETA] = dz.beta
    p[K.I_CREEP] = dz.creep_slope
    p[K.I_OUTER] = dz.outer_offset
    p[K.I_K] = fl.K
    p[K.I_PTR] = fl.transition_pressure
    p[K.I_AA] = c.area_a
    p[K.I_AB] = c.area_b
    p[K.I_STROKE] = c.stroke
    p[K.I_VA] = c.dead_volume_a
    p[K.I_VB] = c.dead_volume_b
    p[K.I_CL] = c.leakage
    p[K.I_KSTOP] = c.end_stop_stiffness
    p[K.I_CSTOP] = c.end_stop_damping
    p[K.I_E] = oil.bulk_modulus
    p[K.I_PVAP] = oil.vapour_pressure
    p[K.I_PREL] = oil.release_pressure
    p[K.I_FC] = fr.coulomb
    p[K.I_FS] = fr.static
    p[K.I_SIGMA] = fr.viscous
    p[K.I_CHI] = fr.stribeck_velocity
    p[K.I_DELTA] = fr.shape
    p[K.I_GAMMA] = fr.smoothness
    p[K.I_PT] = s.tank_pressure
    p[K.I_PUMP] = 1.0 if s.model == "pump" else 0.0
    p[K.I_PSET] = s.pressure
    p[K.I_QMAX] = s.pump_flow
    p[K.I_DROOP] = s.compensator_droop
    p[K.I_VLINE] = s.line_volume
    p[K.I_PRELIEF] = s.relief_pressure
    p[K.I_GRELIEF] = s.relief_gain
    p[K.I_MASS] = ld.mass
    p[K.I_CLOAD] = ld.damping
    return p


@dataclass(frozen=True)
class Model:
    """Base of the model objects; ``params`` is the one shared parameter set."""

    params: SystemParams = field(default_factory=lambda: get_preset("paper"))
    kind = -1
    name = "model"
    state_names: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        if not isinstance(self.params, SystemParams):
            raise ParameterError(f"{type(self).__name__} needs a SystemParams, got {type(self.params).__name__}")

    def pack(self, command_amplitude: float = 0.0) -> np.ndarray:
        """Kernel parameter vector; ω0 from the Table II schedule at the command amplitude [1]."""
        return pack_params(self.params, self.params.valve.omega0_at(command_amplitude))

    def state_scale(self) -> np.ndarray:  # pragma: no cover - overridden
        raise NotImplementedError

    def initial_state(self, x0: float | None = None, supply_pressure: float | None = None, load_force: float = 0.0) -> np.ndarray:
        raise NotImplementedError  # pragma: no cover


@dataclass(frozen=True)
class FullOrderModel(Model):
    """Full-order model, Eqs. (1)–(11): servo valve, dead-zone, orifices, chambers, mechanics.

    States: spool ν [1], spool velocity ν̇ [1/s], P_A [Pa], P_B [Pa], x [m], ẋ [m/s],
    and P_S [Pa] (a state only with ``supply.model = "pump"``).
    """

    kind = K.FULL
    name = "full"
    state_names: tuple[str, ...] = ("spool", "spool_rate", "p_a", "p_b", "x", "v", "p_s")

    def state_scale(self) -> np.ndarray:
        """Typical state magnitudes used as absolute tolerances (× rtol)."""
        return np.array([1.0, 10.0, 1e5, 1e5, 1e-3, 1e-2, 1e5])

    def initial_state(self, x0=None, supply_pressure=None, load_force=0.0) -> np.ndarray:
        """Rest at ``x0`` (default mid-stroke) with P_A + P_B = P_S and balanced forces."""
        c = self.params.cylinder
        ps = self.params.supply.pressure if supply_pressure is None else supply_pressure
        x = 0.5 * c.stroke if x0 is None else x0
        pa = (load_force + ps * c.area_b) / (c.area_a + c.area_b)
        pa = min(max(pa, 0.0), ps)
        return np.array([0.0, 0.0, pa, ps - pa, x, 0.0, ps])

    @staticmethod
    def state_from_measurement(x, v, p_a, p_b, p_s, spool=0.0) -> np.ndarray:
        """Initial state from measured quantities (SI)."""
        return np.array([spool, 0.0, p_a, p_b, x, v, p_s], dtype=float)


@dataclass(frozen=True)
class ReducedModel(Model):
    """Reduced model, Eqs. (12)–(15): load pressure P_L [Pa], ẋ [m/s], x [m] (integrated output)."""

    kind = K.REDUCED
    name = "reduced"
    state_names: tuple[str, ...] = ("p_l", "v", "x")

    def state_scale(self) -> np.ndarray:
        return np.array([1e5, 1e-2, 1e-3])

    def initial_state(self, x0=None, supply_pressure=None, load_force=0.0) -> np.ndarray:
        """Rest at ``x0`` (default mid-stroke) with Ā·P_L = F_L."""
        c = self.params.cylinder
        x = 0.5 * c.stroke if x0 is None else x0
        return np.array([load_force / c.mean_area, 0.0, x])

    @staticmethod
    def state_from_measurement(x, v, p_a, p_b, p_s=None, spool=0.0) -> np.ndarray:
        return np.array([p_a - p_b, v, x], dtype=float)


_BY_NAME = {"full": FullOrderModel, "reduced": ReducedModel}


def as_model(model, params: SystemParams | None = None) -> Model:
    """Return a model object from a model object or a name (``full``, ``reduced``, ``pwa``)."""
    if isinstance(model, Model) or hasattr(model, "pack") and hasattr(model, "kind"):
        return model
    if isinstance(model, str):
        name = model.strip().lower()
        params = params if params is not None else get_preset("paper")
        if name in _BY_NAME:
            return _BY_NAME[name](params)
        if name == "pwa":
            from ..linearization import linearize

            return linearize(params)
        raise ParameterError(f"unknown model {model!r}; choose full, reduced or pwa")
    raise ParameterError(f"cannot simulate a {type(model).__name__}; give a model object or 'full'/'reduced'/'pwa'")
