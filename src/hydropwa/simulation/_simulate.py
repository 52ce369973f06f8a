"""One ``simulate`` for every model, and the result object it returns."""

from __future__ import annotations

import dataclasses
import math
import os
import threading
import time as _time
import warnings
from collections.abc import Callable, Iterator, Mapping, MutableMapping
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from .._display import channel_rows, html_table
from .._errors import ParameterError, SignalError, SimulationError
from .._layout import (
    CHAMBER_OUTPUT_CHANNELS,
    CONTROL_OUTPUT_CHANNELS,
    MODEL_KINDS,
    OUTPUT_CHANNELS,
    PWA_OUTPUT_CHANNELS,
)
from ..models import Model, as_model
from ..params import SystemParams
from . import _controller as C
from . import _kernel as K
from ._controller import eval_rates
from ._entries import SolverRun
from ._signals import Constant, Sampled, Signal, as_signal, check_supply_signal, pack_signals
from ._status import SolverStats, SolverStatus

if TYPE_CHECKING:
    import pandas as pd
    from matplotlib.figure import Figure

    from ..data import Run

#: Default relative tolerance. On the paper rig (10 s, 40 %, 1 Hz) it keeps the position
#: within 0.05 mm of a rtol-1e-9 reference (pressures within ~0.8 bar at sharp events such as
#: end-stop impacts); pass rtol=1e-5 or tighter for measurement-grade pressures.
DEFAULT_RTOL = 1e-3
#: Accepted relative tolerances of the integrator: tighter than 1e-12 is below what
#: float64 arithmetic resolves over a run; looser than 0.1 is not a solution any more.
RTOL_RANGE = (1e-12, 0.1)

__all__ = ["DEFAULT_RTOL", "simulate", "SimulationResult", "CHANNEL_UNITS"]

#: The kernel's right-hand side of each model kind (the model's ``name``): model kinds are
#: resolved here, where they are used, so the model layers need not import the kernel.
_KERNEL_KIND = {name: row.kernel for name, row in MODEL_KINDS.items()}

#: SI unit of every output channel (from the one layout table, :mod:`hydropwa._layout`).
CHANNEL_UNITS: dict[str, str] = {
    "t": "s",
    **dict(OUTPUT_CHANNELS),
    **dict(PWA_OUTPUT_CHANNELS),
    **dict(CHAMBER_OUTPUT_CHANNELS),
    **{name: unit for row in MODEL_KINDS.values() for name, unit in row.extra_outputs},
    **dict(CONTROL_OUTPUT_CHANNELS),
}
_OUT_COLS = tuple(name for name, _unit in OUTPUT_CHANNELS)
_PWA_COLS = tuple(name for name, _unit in PWA_OUTPUT_CHANNELS)
_CHAMBER_COLS = tuple(name for name, _unit in CHAMBER_OUTPUT_CHANNELS)
#: The active-cell channels of both PWA models, each once.
_CELL_CHANNELS = tuple(dict.fromkeys(_PWA_COLS + _CHAMBER_COLS))
#: Each kind's extra output rows (its registry row's ``extra_outputs``), by kernel id.
_EXTRA_COLS = tuple(tuple(name for name, _u in row.extra_outputs) for row in MODEL_KINDS.values())


class Channels(MutableMapping[str, np.ndarray]):
    """:class:`SimulationResult`'s channels: a dict whose derived rows are computed on first access.

    An open-loop :func:`simulate` holds ``t`` and a pending output pass (the compiled
    :func:`~._kernel.outputs` on the kernel's states, inputs and parameters). Any read of
    the mapping (a channel, ``in``, ``len``, iteration, pickling) runs the pass once and
    stores its rows, so every reader sees the numbers the eager pass gave (bit for bit: the
    same compiled pass on the same arrays), and a caller that reads only ``states`` never pays
    for it (~1.2 ms of the full model's 10 s benchmark run, 15 % of a warm call).
    Writes and deletions act on the filled dict, as on a plain one.
    """

    __slots__ = ("_data", "_pending")

    def __init__(
        self,
        data: dict[str, np.ndarray],
        pending: Callable[[], dict[str, np.ndarray]] | None = None,
    ) -> None:
        self._data = data
        self._pending = pending

    def _filled(self) -> dict[str, np.ndarray]:
        pending = self._pending
        if pending is not None:
            self._data.update(pending())
            self._pending = None
        return self._data

    def __getitem__(self, name: str) -> np.ndarray:
        return self._filled()[name]

    def __setitem__(self, name: str, value: np.ndarray) -> None:
        self._filled()[name] = value

    def __delitem__(self, name: str) -> None:
        del self._filled()[name]

    def __iter__(self) -> Iterator[str]:
        return iter(self._filled())

    def __len__(self) -> int:
        return len(self._filled())

    def __contains__(self, name: object) -> bool:
        return name in self._filled()

    def __repr__(self) -> str:
        return f"Channels({', '.join(self._filled())})"

    def __reduce__(self) -> tuple[Any, ...]:
        return (dict, (dict(self._filled()),))


@dataclass
class SimulationResult:
    """Trajectory of one simulation, resampled at the output rate.

    Attributes
    ----------
    t : ndarray
        Output times [s].
    channels : dict[str, ndarray]
        Named channels in SI (see :data:`CHANNEL_UNITS`): t, u, spool, z, p_a,
        p_b, p_l, p_s, f_l, x, v, friction, and for the PWA model the active
        cells cell_g, cell_o, cell_n, cell_w (the chamber PWA model: cell_g, cell_qa,
        cell_qb, cell_x, cell_w).
        From :func:`simulate` a :class:`Channels` mapping: the derived channels are
        computed from ``states`` on the first read of any channel.
    states : ndarray, shape (n, n_states)
        Raw model states; names in ``state_names``.
    state_names : tuple of str
    model : str
        ``"full"``, ``"reduced"``, ``"pwa"`` or ``"pwa-chamber"``.
    params : SystemParams
        The parameters used.
    inputs : dict[str, dict]
        Description of the input signals.
    stats : SolverStats
        Solver statistics (typed; also readable as a mapping, ``stats["steps"]``): steps,
        rejected, rhs_evaluations, jacobians, solver, wall_time [s] (the integration alone),
        compile_time [s] (loading or compiling the compiled solver in this call: non-zero
        only for a process's first run of a model), rtol, status, omega0 [rad/s].
    message : str
        How the integration ended: the status's fix-it message, and on failure the time,
        the state and a likely cause.
    control : dict
        Closed loop only: the controller's per-sample record (``t`` [s], ``u`` applied
        command [1], ``reference`` [m], ``error`` [m], ``command`` before the dead-zone
        inverse and saturation [1], ``row`` gain row, ``integral`` [m·s]), its
        ``sample_time`` [s], ``u_limits`` and ``description``; empty in open loop.
    """

    t: np.ndarray
    channels: MutableMapping[str, np.ndarray]
    states: np.ndarray
    state_names: tuple[str, ...]
    model: str
    params: SystemParams
    inputs: dict[str, dict] = field(default_factory=dict)
    stats: SolverStats = field(default_factory=SolverStats)
    control: dict[str, Any] = field(default_factory=dict)
    message: str = SolverStatus.SUCCESS.message

    @property
    def status(self) -> SolverStatus:
        """How the integration ended (:class:`SolverStatus`)."""
        return self.stats.status

    @property
    def success(self) -> bool:
        """True if the integration reached the final time."""
        return self.stats.status is SolverStatus.SUCCESS

    @property
    def units(self) -> dict[str, str]:
        """Unit of each channel."""
        return {k: CHANNEL_UNITS.get(k, "1") for k in self.channels}

    def __getitem__(self, name: str) -> np.ndarray:
        try:
            return self.channels[name]
        except KeyError:
            raise KeyError(f"no channel {name!r}; available: {', '.join(self.channels)}") from None

    def __repr__(self) -> str:
        t = f"t=[{self.t[0]:g}, {self.t[-1]:g}] s" if self.t.size else "empty"
        wall = self.stats.wall_time
        speed = f", {wall * 1e3:.3g} ms" if wall else ""
        status = "" if self.success else f", status={self.status.name}"
        return f"SimulationResult(model={self.model!r}, n={self.t.size}, {t}, steps={self.stats.steps}{speed}{status})"

    def _repr_html_(self) -> str:
        st = self.stats
        note = (
            f"{st.steps} steps, {st.wall_time * 1e3:.3g} ms"
            + (f" (+ {st.compile_time:.1f} s compiling, once)" if st.compile_time > 0.5 else "")
            + f", rtol {st.rtol}; values in engineering units"
            + ("" if self.success else f"; {self.status.name}: {self.message}")
        )
        title = f"SimulationResult: {self.model} model, {self.t.size} samples, {self.t[-1] - self.t[0] if self.t.size else 0:.4g} s"
        return html_table(
            title,
            ("channel", "unit", "min", "max"),
            channel_rows(self.channels, self.units),
            note=note,
        )

    def summary(self) -> str:
        """The run, the solver's outcome and each channel's range in engineering units."""
        lines = [repr(self), f"  {self.status.name}: {self.message}"]
        lines += [
            f"  {name}: {lo} … {hi} {unit}".rstrip()
            for name, unit, lo, hi in channel_rows(self.channels, self.units)
        ]
        return "\n".join(lines)

    def to_pandas(self) -> pd.DataFrame:
        """DataFrame with one column per channel, ``t`` [s] first (as :meth:`Run.to_pandas`).

        The index holds the same times (named ``time``) for ``df.plot()``; SI units are in
        ``df.attrs['units']``, the model name in ``df.attrs['model']``.
        """
        import pandas as pd  # deferred: pandas costs ~0.3 s at import

        df = pd.DataFrame(dict(self.channels), index=pd.Index(self.t, name="time"))
        df.attrs["units"] = self.units
        df.attrs["model"] = self.model
        return df

    def to_run(self, name: str | None = None, meta: dict | None = None) -> Run:
        """The result as a :class:`hydropwa.data.Run` (for the data layer's writers)."""
        from ..data import Run  # deferred: hydropwa.data loads pint (~0.3 s at import)

        m = {
            "source": "simulation",
            "model": self.model,
            "inputs": self.inputs,
            "stats": _plain(self.stats.as_dict()),
        }
        m.update(meta or {})
        fs = 1.0 / float(np.median(np.diff(self.t))) if self.t.size > 1 else 0.0
        return Run(
            name=name or f"sim-{self.model}",
            channels=dict(self.channels),
            units=self.units,
            fs=fs,
            meta=m,
        )

    def to_csv(self, path: str | os.PathLike, *, overwrite: bool = False) -> Path:
        """Write all channels to CSV (header ``name [unit]``), atomically; an existing file
        raises :class:`~hydropwa.OutputExistsError` unless ``overwrite``."""
        from ..data import write_run  # deferred: hydropwa.data loads pint (~0.3 s at import)

        return Path(write_run(self.to_run(), Path(path), format="csv", overwrite=overwrite))

    def to_parquet(self, path: str | os.PathLike, *, overwrite: bool = False) -> Path:
        """Write all channels to Parquet (units in the schema metadata), atomically; an existing
        file raises :class:`~hydropwa.OutputExistsError` unless ``overwrite``."""
        from ..data import write_run  # deferred: hydropwa.data loads pint (~0.3 s at import)

        return Path(write_run(self.to_run(), Path(path), format="parquet", overwrite=overwrite))

    def save(self, path: str | os.PathLike, *, overwrite: bool = False) -> Path:
        """Write the result as CSV or Parquet, by the suffix of ``path`` (see :meth:`to_csv`)."""
        suffix = Path(path).suffix.lower()
        if suffix == ".csv":
            return self.to_csv(path, overwrite=overwrite)
        if suffix == ".parquet":
            return self.to_parquet(path, overwrite=overwrite)
        raise SignalError(
            f"{path}: a simulation result is written as .csv or .parquet, not {suffix or 'no suffix'!r}"
        )

    def plot(
        self, channels: tuple[str, ...] = ("u", "x", "p_a", "p_b", "p_s"), *, ax: Any = None
    ) -> Figure:
        """Plot channels against time in engineering units (%, mm, bar); returns the figure.

        See :func:`hydropwa.plotting.plot_result` (one axes per display unit; ``ax`` to draw
        into given axes).
        """
        from ..plotting import plot_result  # deferred: matplotlib loads only when plotting

        return plot_result(self, channels=channels, ax=ax)

    def occupancy(self) -> dict[str, dict[int, float]]:
        """PWA only: fraction of time each cell of each nonlinearity is active."""
        out: dict[str, dict[int, float]] = {}
        for key in _CELL_CHANNELS:
            if key in self.channels:
                vals, counts = np.unique(self.channels[key].astype(int), return_counts=True)
                out[key[5:]] = {
                    int(v): float(c) / self.t.size for v, c in zip(vals, counts, strict=True)
                }
        return out

    def switches(self) -> dict[str, int]:
        """PWA only: number of cell changes of each nonlinearity between output samples."""
        return {
            key[5:]: int(np.count_nonzero(np.diff(self.channels[key]) != 0))
            for key in _CELL_CHANNELS
            if key in self.channels
        }


def _plain(d: dict[str, Any]) -> dict[str, Any]:
    return {k: (v.item() if hasattr(v, "item") else v) for k, v in d.items()}


def _diagnose(params: SystemParams, state: dict[str, float]) -> str:
    """A likely cause of a failed integration, in the user's terms."""
    c, oil = params.cylinder, params.oil
    vmin = min(c.dead_volume_a, c.dead_volume_b)
    k_h = oil.bulk_modulus * c.area_a**2 / vmin
    hints = []
    if k_h / params.load.mass > 1e10:  # hydraulic eigenfrequency above 1e5 rad/s
        hints.append(
            f"dead volume {vmin:.3g} m³ makes the chamber stiffness {k_h:.3g} N/m "
            f"(eigenvalue ~{math.sqrt(k_h / params.load.mass):.3g} rad/s); check the chamber volumes"
        )
    if params.friction.smoothness * params.friction.static / params.load.mass > 1e12:
        hints.append(
            f"friction smoothness γ = {params.friction.smoothness:g} s/m with F_s = {params.friction.static:g} N "
            "makes the zero crossing extremely stiff; lower γ"
        )
    if params.cylinder.end_stop_stiffness / params.load.mass > 1e14:
        hints.append(
            "the end-stop stiffness is extreme for this mass; lower cylinder.end_stop_stiffness"
        )
    x = state.get("x")
    if x is not None and (x < -0.01 * c.stroke or x > 1.01 * c.stroke):
        hints.append(f"the piston left its stroke (x = {x:.4g} m)")
    return (
        "; ".join(hints)
        if hints
        else "no obvious parameter problem; try a smaller rtol or check the inputs"
    )


def _solver_args(
    kind, mdl, y0, t_out, p, sg, rtol, hmax, max_steps, solver
) -> tuple[int, SolverRun, int]:
    """The arguments :func:`~._kernel.integrate` and its closed-loop twin share, in order:
    the model kind, the :class:`~._entries.SolverRun` and the method."""
    run = SolverRun(y0, t_out, p, sg, float(rtol), mdl.state_scale(), 1e-5, float(hmax), max_steps)
    return kind, run, K.SOLVERS[solver]


def _output_channels(kind, t_out, Y, n_done, p, sg) -> dict[str, np.ndarray]:
    """The output pass of :func:`simulate`: channel name → rows of the done samples."""
    out = K.outputs(kind, t_out, Y, n_done, p, sg)
    channels = {name: out[i] for i, name in enumerate(_OUT_COLS)}  # contiguous rows
    for i, name in enumerate(_EXTRA_COLS[kind]):
        channels[name] = out[len(_OUT_COLS) + i]
    return channels


def _result_channels(kind, t_done, Y, n_done, p, sg, eager) -> Channels:
    """:func:`simulate`'s :class:`Channels`: ``t`` and the output pass, run at once when
    ``eager`` (the closed loop, whose own channels need ``x``) or else on the first read.

    The pass is loaded or compiled here either way, so its compilation counts in the
    result's ``compile_time``.
    """
    K.prepare_outputs(kind, t_done, Y, n_done, p, sg)
    if eager:
        return Channels({"t": t_done, **_output_channels(kind, t_done, Y, n_done, p, sg)})
    return Channels({"t": t_done}, partial(_output_channels, kind, t_done, Y, n_done, p, sg))


@dataclass(frozen=True)
class PackedInputs:
    """Inputs of :func:`simulate_packed`: the three signals packed once for many simulations.

    Built by :meth:`from_signals` from the same signals :func:`simulate` takes; a caller that
    simulates the same inputs with many parameter sets (the grey-box fit: every segment in
    every iteration) packs them once.
    """

    sg: np.ndarray
    hmax: float
    command_amplitude: float

    @classmethod
    def of(cls, sigs: list[Signal], duration: float) -> PackedInputs:
        """Pack ``[u, P_S, F_L]`` (signals); the step limit is the shortest sample interval
        of a sampled input (at most 10 ms), the command amplitude u's peak over ``duration``."""
        hmax = 0.01
        for sig in sigs:
            if isinstance(sig, Sampled) and sig.t.size > 1:
                hmax = min(hmax, float(np.min(np.diff(sig.t))))
        return cls(pack_signals(sigs), hmax, float(sigs[0].peak(duration)))

    @classmethod
    def from_signals(cls, u: Any, supply_pressure: Any, load_force: Any, t_out: np.ndarray):
        """Pack the inputs as :func:`simulate` takes them, for output times ``t_out``."""
        sigs = [
            as_signal(u, "", "u"),
            as_signal(supply_pressure, "Pa", "supply_pressure"),
            as_signal(load_force, "N", "load_force"),
        ]
        return cls.of(sigs, float(t_out[-1] - t_out[0]))


def simulate_packed(
    model: Model,
    inputs: PackedInputs,
    t_out: np.ndarray,
    initial_state: np.ndarray,
    *,
    rtol: float = DEFAULT_RTOL,
    max_steps: int = 5_000_000,
    packed_params: np.ndarray | None = None,
) -> tuple[dict[str, np.ndarray], int, int]:
    """:func:`simulate` of an open loop without its checks and result object.

    The same kernel call and output pass as :func:`simulate` (bit-for-bit the same channels),
    for callers that run thousands of short simulations of validated inputs: a grey-box
    fit's windows spend two thirds of a :func:`simulate` call outside the kernel.

    Parameters
    ----------
    model : Model
        A full, reduced or PWA model.
    inputs : PackedInputs
    t_out : ndarray
        Output times [s], strictly increasing (not checked).
    initial_state : ndarray
        State at ``t_out[0]`` (copied).
    rtol : float
        Relative tolerance [1], as in :func:`simulate`.
    max_steps : int
        Step budget, as in :func:`simulate`.
    packed_params : ndarray, optional
        ``model.pack(command_amplitude=inputs.command_amplitude)``, when the caller has it.

    Returns
    -------
    channels : dict
        Output channels (not ``t``) over the samples done.
    n_done : int
        Samples done (``t_out.size`` unless the integration failed).
    status : int
        :class:`SolverStatus` code (0: success).
    """
    kind = _KERNEL_KIND[model.name]
    p = (
        model.pack(command_amplitude=inputs.command_amplitude)
        if packed_params is None
        else packed_params
    )
    y0 = np.array(initial_state, dtype=float)
    args = _solver_args(
        kind, model, y0, t_out, p, inputs.sg, rtol, inputs.hmax, max_steps, "ros34pw2"
    )
    Y, n_done, status, _t_fail, _y_fail, _stats = K.integrate(*args, True, True)
    Y = Y[:n_done]
    return _output_channels(kind, t_out, Y, n_done, p, inputs.sg), int(n_done), int(status)


def simulate(
    model: Model | str,
    u: Any = 0.0,
    *,
    duration: float | None = None,
    timepts: np.ndarray | None = None,
    supply_pressure: Any = None,
    load_force: Any = None,
    initial_position: float | None = None,
    initial_state: np.ndarray | None = None,
    fs: float = 2000.0,
    rtol: float = DEFAULT_RTOL,
    params: SystemParams | None = None,
    max_steps: int = 5_000_000,
    hmax: float | None = None,
    raise_on_failure: bool = True,
    solver: str = "ros34pw2",
    controller: Any = None,
    reference: Any = None,
    t: np.ndarray | None = None,
    x0: float | None = None,
    sensor_noise: Mapping[str, float] | None = None,
    seed: int | None = None,
) -> SimulationResult:
    """Simulate any model (full, reduced or PWA) with time-varying inputs.

    Parameters
    ----------
    model : Model or {"full", "reduced"}
        Any :class:`~hydropwa.models.Model` (``FullOrderModel``, ``ReducedModel``,
        ``PwaModel``), or ``"full"``/``"reduced"`` with ``params`` (required with a name:
        there is no default machine); the PWA model is built by
        :func:`~hydropwa.linearization.linearize`.
    u : float, str, Signal or (t, values)
        Valve command [1] (fraction of full opening, ±1 = 100 %).
    duration : float, optional
        Simulated time [s] (from 0). Either this or ``timepts``.
    timepts : ndarray, optional
        Explicit output times [s] (increasing); overrides ``duration``/``fs``
        (python-control's name).
    supply_pressure : float, str, Signal or (t, values), optional
        P_S(t) [Pa]; default ``params.supply.pressure``. Ignored by the full
        model when ``supply.model == "pump"`` (P_S is then a state).
    load_force : float, str, Signal or (t, values), optional
        F_L(t) [N]; default ``params.load.force``.
    initial_position : float, optional
        Initial rod position [m] (default mid-stroke) for the default initial state.
    initial_state : ndarray, optional
        Full initial state vector (see the model's ``state_names``); overrides
        ``initial_position``.
    fs : float
        Output sampling rate [Hz] (default 2 kHz, as on the rig).
    rtol : float
        Relative tolerance (default :data:`DEFAULT_RTOL` = 1e-3); absolute tolerances are
        rtol × the model's state scale. See ``benchmarks/run.py`` for accuracy vs speed.
        1e-3 keeps the rod position of the paper rig within 0.1 mm of a tight-tolerance
        reference (see ``tests/performance``); pass 1e-5 or tighter for measurement-grade
        pressures at sharp events.
    max_steps : int
        Step budget of the integrator.
    hmax : float, optional
        Largest step [s]; default 10 ms, or the sample spacing of measured inputs.
    raise_on_failure : bool
        If False, a failed integration returns the partial result (``success`` False,
        ``status`` and ``message`` set) instead of raising.
    solver : {"ros34pw2", "ros4ls", "ros23"}
        Rosenbrock method: the third-order W-method ROS34PW2 (default, reuses
        its Jacobian across steps), the L-stable fourth-order ROS4LS (a fresh Jacobian
        every step, three right-hand sides per step instead of four) or the
        second-order ROS2(3) of ``ode23s``.
    controller : hydropwa.control controller, optional
        Close the loop: a discrete controller (anything with ``pack()`` returning the
        vector of :mod:`hydropwa.simulation._controller`, e.g.
        :class:`hydropwa.control.PIController`) sets the valve command at its sample
        instants (zero-order hold); ``u`` must then be left at 0.
    reference : float, str, Signal or (t, values), optional
        Closed loop: reference position r(t) [m] (a number, a signal spec such as
        ``"step:time=0.05,before=0.1,after=0.12"``, a Signal, e.g. a
        :class:`hydropwa.control.MotionProfile` from :func:`hydropwa.control.as_reference`,
        or samples). Required with ``controller``.
    t : ndarray, optional
        Deprecated alias of ``timepts``.
    x0 : float, optional
        Deprecated alias of ``initial_position`` (python-control's ``X0`` is the state
        vector, here ``initial_state``).
    sensor_noise : mapping, optional
        Closed loop: standard deviations of white Gaussian noise on the controller's
        measurements at its sample instants, ``{"x": m, "p_a": Pa, "p_b": Pa}`` (the
        load-state models take ``p_a`` as the noise on P_L), and ``"spool": 1`` on the spool
        position a controller that measures the spool reads (the full and chamber models);
        default exact sensors.
    seed : int, optional
        Seed of the sensor noise (``numpy.random.default_rng``).

    Returns
    -------
    SimulationResult
        With ``success``, ``status`` (:class:`SolverStatus`), ``message`` and ``stats``
        (:class:`SolverStats`).

    Raises
    ------
    SimulationError
        If the integration fails; names the time, the state and a likely cause,
        with the partial result in ``err.partial``.
    ParameterError
        For an unknown model name or solver.
    SignalError
        For malformed times, inputs or initial states.
    """
    timepts, initial_position = _resolve_aliases(timepts, t, initial_position, x0)
    _check_method(solver, rtol)
    mdl, kind = _resolve_model(model, params)
    t_out, duration = _time_grid(timepts, duration, fs)
    closed = _check_loop(u, controller, reference, sensor_noise)
    sigs = _input_signals(mdl, kind, 0.0 if closed else u, supply_pressure, load_force, t_out)
    inputs = PackedInputs.of(list(sigs), duration)
    p = _packed_params(mdl, inputs.command_amplitude)
    if closed:  # the command amplitude is not known beforehand: the valve's nominal ω0
        p[K.I_OMEGA0] = mdl.params.valve.omega0
    y0 = _initial_state(mdl, initial_state, initial_position, sigs, t_out[0])
    hmax = inputs.hmax if hmax is None else hmax
    loop = _closed_loop_setup(controller, reference, t_out, sensor_noise, seed) if closed else None
    args = _solver_args(kind, mdl, y0, t_out, p, inputs.sg, rtol, hmax, max_steps, solver)
    raw = _integrate(args, loop)
    n_done = raw.n_done
    Y = raw.Y[:n_done]
    sg = inputs.sg
    if loop is not None:  # derived channels see the held command of each sample interval
        sg = pack_signals([_held_command(raw.log, t_out[0]), sigs[1], sigs[2]])
    # the times are the caller's array when timepts was given: copy them then, not our own grid
    t_done = t_out[:n_done] if timepts is None else t_out[:n_done].copy()
    channels = _result_channels(kind, t_done, Y, n_done, p, sg, eager=closed)
    compile_time = K.compile_seconds - raw.compiled0
    control: dict[str, Any] = {}
    if loop is not None:
        control = _control_record(controller, loop[0], raw.log)
        _closed_loop_channels(channels, loop, raw.log, t_out[0], mdl.params.cylinder)
    status, message, state = _outcome(mdl, raw)
    result = SimulationResult(
        t=t_done,
        channels=channels,
        states=Y,
        state_names=tuple(mdl.state_names),
        model=mdl.name,
        params=mdl.params,
        inputs={"u": sigs[0].describe(), "p_s": sigs[1].describe(), "f_l": sigs[2].describe()},
        stats=_solver_stats(raw, solver, compile_time, rtol, status, float(p[K.I_OMEGA0])),
        control=control,
        message=message,
    )
    if not status.success and raise_on_failure:
        raise SimulationError(message, t=float(raw.t_fail), state=state, partial=result)
    return result


def _resolve_aliases(
    timepts: np.ndarray | None,
    t: np.ndarray | None,
    initial_position: float | None,
    x0: float | None,
) -> tuple[np.ndarray | None, float | None]:
    """``timepts`` and ``initial_position`` from their deprecated aliases ``t`` and ``x0``
    (each warns; an alias given beside its name is an error)."""
    if t is not None:
        warnings.warn(
            "simulate(t=...) is deprecated; use timepts=...", DeprecationWarning, stacklevel=3
        )
        if timepts is not None:
            raise SignalError("give either timepts or its deprecated alias t, not both")
        timepts = t
    if x0 is not None:
        warnings.warn(
            "simulate(x0=...) is deprecated; the rod position is initial_position=... "
            "(initial_state is the full state vector)",
            DeprecationWarning,
            stacklevel=3,
        )
        if initial_position is not None:
            raise SignalError("give either initial_position or its deprecated alias x0, not both")
        initial_position = x0
    return timepts, initial_position


def _check_method(solver: str, rtol: float) -> None:
    """The Rosenbrock method is one of the kernel's and ``rtol`` within :data:`RTOL_RANGE`."""
    if solver not in K.SOLVERS:
        raise ParameterError(f"unknown solver {solver!r}; choose {', '.join(K.SOLVERS)}")
    if not (isinstance(rtol, int | float) and RTOL_RANGE[0] <= rtol <= RTOL_RANGE[1]):
        raise ParameterError(
            f"rtol = {rtol!r} is outside [{RTOL_RANGE[0]:g}, {RTOL_RANGE[1]:g}]; the default "
            f"{DEFAULT_RTOL:g} keeps the position within 0.1 mm, 1e-5 gives measurement-grade "
            "pressures"
        )


def _resolve_model(model: Model | str, params: SystemParams | None) -> tuple[Model, int]:
    """The model object and the kernel's right-hand side for it (its kind)."""
    if not isinstance(model, str) and type(model) in _MODEL_CLASSES:
        mdl = model  # what as_model returns for it, without its runtime Protocol check
    else:
        mdl = as_model(model, params)
        if mdl is model and _frozen(type(mdl)):
            _MODEL_CLASSES.add(type(mdl))
    kind = _KERNEL_KIND.get(mdl.name)
    if kind is None:
        raise ParameterError(
            f"model {mdl.name!r} has no compiled right-hand side; choose {', '.join(_KERNEL_KIND)}"
        )
    return mdl, kind


#: Model classes that passed :func:`~hydropwa.models.as_model`'s ``isinstance(model, Model)``:
#: frozen dataclasses, whose instances all hold the same members, so that the runtime
#: Protocol check (~30 µs, a third of the Python around the kernel) runs once per class.
_MODEL_CLASSES: set[type] = set()
#: ``pack`` of the last few frozen models without writeable arrays (every model ``linearize``
#: and ``as_model`` build: the PWA cell tables are read-only; a model holding a writeable
#: array, e.g. a deep copy, packs on every call): (id, command amplitude) → (model, vector).
#: Such a model's vector is a function of its fields and the amplitude; ~30–60 µs a call.
_PACKED: dict[tuple[int, float], tuple[Model, np.ndarray]] = {}
_PACKED_SIZE = 16
_PACKED_LOCK = threading.Lock()


def _frozen(cls: type) -> bool:
    """Whether instances of ``cls`` are frozen dataclasses (their fields cannot be reassigned)."""
    params = getattr(cls, "__dataclass_params__", None)
    return dataclasses.is_dataclass(cls) and bool(getattr(params, "frozen", False))


def _writeable_arrays(obj: Any, depth: int = 0) -> bool:
    """Whether ``obj`` holds a writeable NumPy array in its dataclass fields, tuples, lists or
    dicts (to a depth of 8; deeper counts as holding one)."""
    if isinstance(obj, np.ndarray):
        return bool(obj.flags.writeable)
    if isinstance(obj, SystemParams):  # floats and tuples, frozen all the way down
        return False
    if depth > 8:
        return True
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        items: Any = (getattr(obj, f.name) for f in dataclasses.fields(obj))
    elif isinstance(obj, tuple | list):
        items = obj
    elif isinstance(obj, dict):
        items = obj.values()
    else:
        return False
    return any(_writeable_arrays(x, depth + 1) for x in items)


def _packed_params(mdl: Model, command_amplitude: float) -> np.ndarray:
    """``mdl.pack(command_amplitude=...)``, remembered for the last few frozen models that
    hold no writeable array (a fresh copy each call: the closed loop writes ω0 into it)."""
    if not _frozen(type(mdl)):
        return mdl.pack(command_amplitude=command_amplitude)
    key = (id(mdl), command_amplitude)
    with _PACKED_LOCK:
        hit = _PACKED.get(key)
    if hit is None:  # (the entry holds its model: no other object takes its id meanwhile)
        hit = (mdl, mdl.pack(command_amplitude=command_amplitude))
        if _writeable_arrays(mdl):
            return hit[1]
        with _PACKED_LOCK:
            if len(_PACKED) >= _PACKED_SIZE:
                del _PACKED[next(iter(_PACKED))]  # the oldest
            _PACKED[key] = hit
    return hit[1].copy()


def _time_grid(
    timepts: np.ndarray | None, duration: float | None, fs: float
) -> tuple[np.ndarray, float]:
    """The output times [s] and the simulated span [s]: ``timepts`` checked, or a grid of
    ``duration`` at ``fs``."""
    if timepts is None:
        if duration is None or not (duration > 0) or not math.isfinite(duration):
            raise SignalError(f"duration must be a positive number of seconds, got {duration!r}")
        if not (fs > 0) or not math.isfinite(fs):
            raise SignalError(f"output rate fs must be a positive number of Hz, got {fs!r}")
        n = int(round(duration * fs)) + 1
        return np.linspace(0.0, duration, n), duration
    t_out = np.ascontiguousarray(timepts, dtype=float).ravel()
    if t_out.size < 2 or not np.all(np.isfinite(t_out)) or np.any(np.diff(t_out) <= 0):
        raise SignalError("timepts must hold at least two finite, strictly increasing times [s]")
    return t_out, float(t_out[-1] - t_out[0])


def _check_loop(
    u: Any, controller: Any, reference: Any, sensor_noise: Mapping[str, float] | None
) -> bool:
    """Whether the loop is closed; the closed loop's arguments only with a controller, and
    no valve command beside it."""
    if controller is not None:
        if not (isinstance(u, int | float) and u == 0.0):
            raise SignalError("give either a valve command u or a controller, not both")
        if reference is None:
            raise SignalError("a controller needs a reference position (reference=...)")
        return True
    if reference is not None:
        raise SignalError("reference is the set point of a controller; pass controller=... as well")
    if sensor_noise:
        raise SignalError(
            "sensor_noise is the noise of a controller's sensors; pass controller=... as well"
        )
    return False


def _input_signals(
    mdl: Model, kind: int, u: Any, supply_pressure: Any, load_force: Any, t_out: np.ndarray
) -> tuple[Signal, Signal, Signal]:
    """The valve command, P_S and F_L as signals (P_S and F_L default to the parameters'),
    a given P_S checked against the supply's bounds and the model."""
    prm = mdl.params
    u_sig = as_signal(u, "", "u")
    ps_sig = as_signal(
        prm.supply.pressure if supply_pressure is None else supply_pressure, "Pa", "supply_pressure"
    )
    fl_sig = as_signal(prm.load.force if load_force is None else load_force, "N", "load_force")
    if supply_pressure is not None:  # the parameters' own P_S was validated with them
        check_supply_signal(ps_sig, prm.supply, float(t_out[-1]))
        if MODEL_KINDS[mdl.name].linearized and not getattr(mdl, "scheduled", True):
            _check_fixed_supply(mdl, ps_sig)
    return u_sig, ps_sig, fl_sig


def _check_fixed_supply(mdl: Model, ps_sig: Signal) -> None:
    """A PWA model linearized at one P_S takes no other supply pressure."""
    fixed = float(getattr(mdl, "supply_pressure", np.nan))
    if not (isinstance(ps_sig, Constant) and math.isclose(float(ps_sig(0.0)), fixed, rel_tol=1e-9)):
        raise SignalError(
            f"this PWA model's cells are fixed at P_S = {fixed / 1e5:g} bar and would ignore the "
            "supply_pressure input; build it with linearize(params, ..., scheduled=True) to follow P_S(t), "
            "or linearize(params, supply_pressure=...) for another constant P_S"
        )


def _initial_state(
    mdl: Model,
    initial_state: np.ndarray | None,
    initial_position: float | None,
    sigs: tuple[Signal, Signal, Signal],
    t0: float,
) -> np.ndarray:
    """The state at ``t0``: ``initial_state`` checked, or the model's rest at
    ``initial_position`` under the inputs' P_S and F_L at ``t0``."""
    ps0 = sigs[1](t0)
    fl0 = sigs[2](t0)
    if initial_state is None:
        return mdl.initial_state(initial_position, supply_pressure=ps0, load_force=fl0)
    y0 = np.asarray(initial_state, dtype=float).ravel().copy()
    if y0.size != len(mdl.state_names) or not np.all(np.isfinite(y0)):
        raise SignalError(
            f"initial_state needs {len(mdl.state_names)} finite values ({', '.join(mdl.state_names)}), got {y0.size}"
        )
    return y0


@dataclass(frozen=True)
class _KernelRun:
    """What one kernel call of :func:`simulate` returned (``log`` the controller's, closed
    loop only), its wall time without compilation [s] and the compile clock before it [s]."""

    Y: np.ndarray
    n_done: int
    status: int
    t_fail: float
    y_fail: np.ndarray
    stats: np.ndarray
    log: np.ndarray
    wall: float
    compiled0: float


def _integrate(
    args: tuple[int, SolverRun, int],
    loop: tuple[np.ndarray, Signal, np.ndarray, np.ndarray] | None,
) -> _KernelRun:
    """The open- or closed-loop kernel call (``loop`` from :func:`_closed_loop_setup`), timed."""
    compiled0 = K.compile_seconds
    t0 = _time.perf_counter()
    if loop is None:
        Y, n_done, status, t_fail, y_fail, stats = K.integrate(*args, True, True)
        log = np.empty((0, 0))
    else:
        ctl, _ref_sig, ref, dref = loop
        Y, n_done, status, t_fail, y_fail, stats, log = K.integrate_closed_loop(
            *args, ctl, ref, dref
        )
    wall = _time.perf_counter() - t0
    wall -= min(wall, K.compile_seconds - compiled0)  # the kernel's first load or compile
    return _KernelRun(Y, n_done, status, t_fail, y_fail, stats, log, wall, compiled0)


def _closed_loop_channels(
    channels: Channels,
    loop: tuple[np.ndarray, Signal, np.ndarray, np.ndarray],
    log: np.ndarray,
    t0: float,
    cylinder: Any,
) -> None:
    """Add the reference, the tracking error, the controller's command and its gain row
    (held over each sample interval) to a closed loop's channels.

    A force or pressure controller (e0+X_OUT > 0) adds ``force`` (A_A·P_A − A_B·P_B [N]),
    ``force_reference`` and ``force_error`` [N] (a pressure controller's reference in Pa is
    shown as the force A_A·P_L it asks for) instead of ``reference`` and ``error`` [m]."""
    ctl, ref_sig = loop[0], loop[1]
    tt = channels["t"]
    j = np.clip(np.floor((tt - t0) / ctl[C.C_TS] + 1e-6).astype(int), 0, log.shape[1] - 1)
    e0 = C.C_ROWS + C.ROW * int(ctl[C.C_NROWS])
    out = float(ctl[e0 + C.X_OUT]) if ctl.size >= e0 + C.N_EXT else 0.0
    if out > 0.5:
        per = 1.0 if out < 1.5 else cylinder.area_a  # N per unit of the reference
        channels["force"] = cylinder.area_a * channels["p_a"] - cylinder.area_b * channels["p_b"]
        channels["force_reference"] = per * np.asarray(ref_sig(tt), dtype=float)
        channels["force_error"] = channels["force_reference"] - channels["force"]
    else:
        channels["reference"] = np.asarray(ref_sig(tt), dtype=float)
        channels["error"] = channels["reference"] - channels["x"]
    channels["command"] = log[C.L_C, j]
    channels["cell_ctl"] = log[C.L_ROW, j]


def _outcome(mdl: Model, raw: _KernelRun) -> tuple[SolverStatus, str, dict[str, float]]:
    """How the run ended: the status, its message (on failure with the time, the state and a
    likely cause) and the state at the failure (empty on success)."""
    status = SolverStatus(int(raw.status))
    if status.success:
        return status, status.message, {}
    state = {name: float(v) for name, v in zip(mdl.state_names, raw.y_fail, strict=True)}
    state_txt = ", ".join(f"{k}={v:.6g}" for k, v in state.items())
    message = (
        f"{mdl.name} model integration failed at t = {raw.t_fail:.6g} s: {status.message}. "
        f"State: {state_txt}. Likely cause: {_diagnose(mdl.params, state)}"
    )
    return status, message, state


def _solver_stats(
    raw: _KernelRun,
    solver: str,
    compile_time: float,
    rtol: float,
    status: SolverStatus,
    omega0: float,
) -> SolverStats:
    """The result's :class:`SolverStats` from the kernel's statistics array."""
    stats = raw.stats
    return SolverStats(
        steps=int(stats[K.ST_STEPS]),
        rejected=int(stats[K.ST_REJECTED]),
        rhs_evaluations=int(stats[K.ST_RHS]),
        jacobians=int(stats[K.ST_JAC]),
        solver=solver,
        wall_time=raw.wall,
        compile_time=compile_time,
        rtol=float(rtol),
        status=status,
        omega0=omega0,
    )


def _closed_loop_setup(
    controller: Any,
    reference: Any,
    t_out: np.ndarray,
    sensor_noise: Mapping[str, float] | None = None,
    seed: int | None = None,
) -> tuple[np.ndarray, Signal, np.ndarray, np.ndarray]:
    """Packed controller, reference signal, reference samples and the reference channels.

    The channels (rows ``RC_*`` of :mod:`._controller`) at the sample instants t_k: ṙ(t_k),
    ṙ(t_k + τ) (τ the controller's feed-forward look-ahead), r̈(t_k), and the sensor noise.
    Rates and accelerations are the reference's analytic ones (``rate``, ``acceleration``)
    where it has them, else differences of the packed signal over one sample.
    """
    try:
        ctl = np.ascontiguousarray(controller.pack(), dtype=float)
    except AttributeError:
        raise SignalError(
            f"cannot use a {type(controller).__name__} as a controller; give one of hydropwa.control's controllers"
        ) from None
    ts = float(ctl[C.C_TS]) if ctl.size else 0.0
    if ctl.size < C.C_ROWS or not (ts > 0) or not math.isfinite(ts):
        raise SignalError(
            "controller vector is malformed (sample time must be a positive number of seconds)"
        )
    try:
        ref_sig = as_signal(reference, "m", "reference")
    except SignalError as exc:
        if not isinstance(reference, str):
            raise
        # simulation knows no motion-profile names: those are the control layer's
        raise SignalError(
            f"{exc}; a motion profile is made into a Signal by the control layer: pass "
            "hydropwa.control.as_reference(...) as the reference"
        ) from None
    span = float(t_out[-1] - t_out[0])
    n_smp = int(math.floor(span / ts + 1e-9)) + 1
    tk = t_out[0] + ts * np.arange(n_smp)
    ref = np.ascontiguousarray(ref_sig(tk), dtype=float)
    e0 = C.C_ROWS + C.ROW * int(ctl[C.C_NROWS])
    lead = float(ctl[e0 + C.X_LEAD]) if ctl.size >= e0 + C.N_EXT else 0.0

    def rate(tt):
        if hasattr(ref_sig, "rate"):
            return np.asarray(ref_sig.rate(tt), dtype=float)
        return eval_rates(pack_signals([ref_sig]), 0, tt)

    rch = np.zeros((C.N_RCH, n_smp))
    rch[C.RC_DR] = rate(tk)
    rch[C.RC_DRFF] = rate(tk + lead) if lead > 0.0 else rch[C.RC_DR]
    pre = float(ctl[e0 + C.X_DZPO]) if ctl.size >= e0 + C.N_EXT else 0.0
    if pre > 0.0:  # the pre-opening's look-ahead of the direction
        rch[C.RC_DRPO] = rate(tk + pre)
    if hasattr(ref_sig, "acceleration"):
        rch[C.RC_DDR] = np.asarray(ref_sig.acceleration(tk), dtype=float)
    else:
        rch[C.RC_DDR] = (rate(tk + 0.5 * ts) - rate(tk - 0.5 * ts)) / ts
    if not (np.all(np.isfinite(ref)) and np.all(np.isfinite(rch))):
        raise SignalError("reference is not finite at every sample instant")
    if sensor_noise:
        rng = np.random.default_rng(seed)
        # drawn in this order (the spool last), so adding a spool noise leaves the others' draws
        for key, row in (
            ("x", C.RC_NX),
            ("p_a", C.RC_NPA),
            ("p_b", C.RC_NPB),
            ("spool", C.RC_NNU),
        ):
            sd = sensor_noise.get(key, 0.0)
            if not (isinstance(sd, int | float) and math.isfinite(sd) and sd >= 0.0):
                raise SignalError(
                    f"sensor_noise[{key!r}] = {sd!r} must be a standard deviation >= 0 in SI units"
                )
            if sd > 0.0:
                rch[row] = rng.normal(0.0, float(sd), n_smp)
        unknown = set(sensor_noise) - {"x", "p_a", "p_b", "spool"}
        if unknown:
            raise SignalError(
                f"sensor_noise has unknown channels {sorted(unknown)}; use x, p_a, p_b, spool"
            )
    return ctl, ref_sig, ref, rch


def law_inputs(
    controller: Any,
    reference: Any,
    duration: float,
    *,
    sensor_noise: Mapping[str, float] | None = None,
    seed: int | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """What the compiled law of a closed-loop :func:`simulate` run reads at its sample instants.

    The reference samples r(t_k) and the reference channels (rows ``RC_*`` of the law's layout:
    ṙ, the look-ahead rates, r̈ and the sensor noise draws) of a run of ``duration`` [s] from
    t = 0, exactly as ``simulate(..., controller=controller, reference=reference,
    duration=duration, sensor_noise=sensor_noise, seed=seed)`` builds them: column k is sample
    k. A law replayed on them (one sample of a transfer, a lockstep test) sees what the run's
    law sees.
    """
    _ctl, _sig, ref, rch = _closed_loop_setup(
        controller, reference, np.array([0.0, float(duration)]), sensor_noise, seed
    )
    return ref, rch


def _held_command(log: np.ndarray, t0: float) -> Sampled:
    """The applied command of every sample interval as a staircase signal (zero-order hold)."""
    tk, uk = _done(log, C.L_T), _done(log, C.L_U)
    if tk.size < 2:
        u0 = float(uk[0]) if uk.size else 0.0
        return Sampled(np.array([t0, t0 + 1.0]), np.array([u0, u0]))
    d = 1e-7 * float(np.min(np.diff(tk)))
    tt = np.empty(2 * tk.size - 1)
    vv = np.empty_like(tt)
    tt[0], vv[0] = tk[0], uk[0]
    tt[1::2], vv[1::2] = tk[1:] - 2.0 * d, uk[:-1]
    tt[2::2], vv[2::2] = tk[1:] - d, uk[1:]
    return Sampled(tt, vv)


def _done(log: np.ndarray, row: int) -> np.ndarray:
    """Row ``row`` of the log over the samples reached (a failed run stops early; no copy otherwise)."""
    n = log.shape[1]
    if n and not np.isfinite(log[C.L_T, n - 1]):
        n = int(np.count_nonzero(np.isfinite(log[C.L_T])))
    return log[row, :n]


def _control_record(controller: Any, ctl: np.ndarray, log: np.ndarray) -> dict[str, Any]:
    """The controller's per-sample log as named arrays (see ``SimulationResult.control``)."""
    rec: dict[str, Any] = {
        "t": _done(log, C.L_T),
        "u": _done(log, C.L_U),
        "reference": _done(log, C.L_R),
        "error": _done(log, C.L_E),
        "command": _done(log, C.L_C),
        "row": _done(log, C.L_ROW).astype(np.int64),
        "integral": _done(log, C.L_INT),
        "feedforward": _done(log, C.L_UFF),
        "sample_time": float(ctl[C.C_TS]),
        "u_limits": (float(ctl[C.C_UMIN]), float(ctl[C.C_UMAX])),
    }
    describe = getattr(controller, "describe", None)
    rec["description"] = describe() if callable(describe) else {"kind": type(controller).__name__}
    return rec
