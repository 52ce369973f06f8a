"""The full-order axis as a self-contained FMI 2.0 co-simulation FMU (issue 35).

Its equations are not written a second time: the right-hand side is the compiled kernel's
:func:`~hydropwa.simulation._kernel.rhs_full` and the component functions of
:mod:`hydropwa.components._physics` it calls, translated to C from their Python source by
:mod:`hydropwa.simulation._emit_c` when the FMU is built. Its variables, parameter slots and
state scales come from the layout table :mod:`hydropwa._layout`; its parameter values from
:meth:`hydropwa.models.FullOrderModel.pack`. Inside the FMU a Dormand–Prince 5(4) integrator
with the package's error norm steps from one communication point to the next (inputs held or,
with their derivatives, ramped: first-order hold).
"""

from __future__ import annotations

import math
import os
from importlib import resources
from pathlib import Path

import numpy as np

from .._errors import ParameterError
from .._layout import BASE_SLOTS, FULL_STATES, SLOT, Y_FULL
from ..components import _physics as P
from ..models import FullOrderModel
from ..params import SystemParams
from . import _kernel as K
from ._emit_c import emit_functions
from ._fmu import FmuVariable, build_fmu, fmi2_source
from ._simulate import RTOL_RANGE

__all__ = ["export_axis_fmu", "axis_rhs_c", "AXIS_OUTPUTS"]

#: states given as outputs (name, unit)
AXIS_OUTPUTS = (
    ("x", "m"),
    ("v", "m/s"),
    ("p_a", "Pa"),
    ("p_b", "Pa"),
    ("spool", ""),
    ("p_s", "Pa"),
)
_INPUTS = (
    ("u", "", "valve command [1] (+-1 full signal, > 0 extends)"),
    ("p_s", "Pa", "supply pressure (ignored with the pump supply model, where it is a state)"),
    ("f_l", "N", "load force on the rod (positive against extension)"),
)
_UNIT = {"1": "", "1/s": "", "Pa": "Pa", "m": "m", "m/s": "m/s"}


def axis_rhs_c() -> tuple[str, list[str]]:
    """C text of ``rhs_full`` and its callees (see :mod:`._emit_c`), and their Python names."""
    return emit_functions(
        K.rhs_full,
        {"smooth_sign": P._smooth_sign_compiled, "abs_power": P._abs_power_compiled},
    )


def _c_array(kind: str, name: str, values) -> str:
    if kind == "int":
        body = ", ".join(str(int(v)) for v in values)
    else:
        body = ", ".join(repr(float(v)) for v in values)
    return f"static const {kind} {name}[{len(values)}] = {{{body}}};"


def _check_fmu_start(params: SystemParams, initial_position: float | None, rtol: float) -> None:
    """The FMU's start values: a position on the stroke, rtol within ``RTOL_RANGE``."""
    lo, hi = RTOL_RANGE
    if not (isinstance(rtol, int | float) and math.isfinite(rtol) and lo <= rtol <= hi):
        raise ParameterError(
            f"rtol = {rtol!r} is outside [{lo:g}, {hi:g}]; 1e-6 (the default) is measurement grade"
        )
    stroke = params.cylinder.stroke
    if initial_position is not None and not (
        math.isfinite(initial_position) and 0.0 <= initial_position <= stroke
    ):
        raise ParameterError(
            f"initial_position = {initial_position:g} m is off the stroke [0, {stroke:g}] m; "
            "give a position on it (e.g. '100 mm')"
        )


def export_axis_fmu(
    params: SystemParams,
    path: str | os.PathLike,
    *,
    initial_position: float | None = None,
    load_force: float | None = None,
    rtol: float = 1e-6,
    overwrite: bool = False,
) -> Path:
    """Build the full-order axis (valve, chambers, friction, end stops) as an FMI 2.0 CS FMU.

    Parameters
    ----------
    params : SystemParams
        The machine.
    path : path-like
        The ``.fmu`` file.
    initial_position : float, optional
        Rod position [m] of the initial rest state (default mid-stroke); the FMU's
        ``<state>_0`` parameters hold the whole initial state
        (:meth:`~hydropwa.models.FullOrderModel.initial_state`, balanced against
        ``load_force`` [N], default the parameter set's load).
    rtol : float
        Default relative tolerance of the FMU's integrator (parameter ``rtol``).
    overwrite : bool
        Replace an existing file.

    Returns
    -------
    Path

    Notes
    -----
    Inputs u [1], p_s [Pa], f_l [N]; outputs x, v, p_a, p_b, spool, p_s; parameters: every
    slot of the kernel's parameter vector under its ``component.field`` name (SI; ω0 is the
    valve's nominal value, ``valve.omega0``, as in the closed loop), the initial state and
    ``rtol``. Equations: Eqs. (1)–(11) as in :func:`hydropwa.simulate` with the full model.
    """
    if not isinstance(params, SystemParams):
        raise ParameterError(
            f"export_axis_fmu needs a SystemParams (load_params or get_preset), got {type(params).__name__}"
        )
    _check_fmu_start(params, initial_position, rtol)
    model = FullOrderModel(params)
    p = np.asarray(model.pack(), dtype=float)
    p[SLOT["omega0"]] = params.valve.omega0
    fl = params.load.force if load_force is None else float(load_force)
    y0 = model.initial_state(initial_position, load_force=fl)
    rhs, _names = axis_rhs_c()

    start_inputs = {"u": 0.0, "p_s": params.supply.pressure, "f_l": fl}
    variables = [
        FmuVariable(n, "input", "continuous", start_inputs[n], u, d) for n, u, d in _INPUTS
    ]
    variables += [
        FmuVariable(f"{n}_out" if n == "p_s" else n, "output", "continuous", None, u, f"state {n}")
        for n, u in AXIS_OUTPUTS
    ]
    par_slots = list(range(len(BASE_SLOTS)))
    variables += [
        FmuVariable(src or name, "parameter", "fixed", p[i], "", f"kernel slot {name} (SI)")
        for i, (name, src) in enumerate(BASE_SLOTS)
    ]
    variables += [
        FmuVariable(f"{n}_0", "parameter", "fixed", y0[i], _UNIT.get(u, ""), f"initial {n} [{u}]")
        for i, (n, u, _s) in enumerate(FULL_STATES)
    ]
    variables.append(FmuVariable("rtol", "parameter", "fixed", rtol, "", "relative tolerance"))
    n_in, n_out, n_par, n_y = len(_INPUTS), len(AXIS_OUTPUTS), len(par_slots), len(FULL_STATES)
    starts = [0.0 if v.start is None else v.start for v in variables]
    settable = [0 if v.causality == "output" else 1 for v in variables]
    defs = [
        f"#define HP_NVARS {len(variables)}",
        f"#define HP_NIN {n_in}",
        "#define HP_VR_U 0",
        "#define HP_VR_PS 1",
        "#define HP_VR_FL 2",
        f"#define HP_NOUT {n_out}",
        f"#define HP_VR_OUT {n_in}",
        f"#define HP_NPAR {n_par}",
        f"#define HP_VR_PAR {n_in + n_out}",
        f"#define HP_NY {n_y}",
        f"#define HP_VR_Y0 {n_in + n_out + n_par}",
        f"#define HP_VR_RTOL {n_in + n_out + n_par + n_y}",
        f"#define HP_NP {p.size}",
        _c_array("double", "hp_start", starts),
        _c_array("int", "hp_model_settable", settable),
        _c_array("int", "hp_out_state", [Y_FULL[n] for n, _u in AXIS_OUTPUTS]),
        _c_array("int", "hp_par_slot", par_slots),
        _c_array("double", "hp_p_default", p),
        _c_array("double", "hp_scale", [s for _n, _u, s in FULL_STATES]),
    ]
    template = (
        resources.files("hydropwa.simulation")
        .joinpath("_c", "hp_model_axis.c")
        .read_text(encoding="utf-8")
    )
    model_c = template.replace("@RHS@", rhs).replace("@VARS@", "\n".join(defs))
    return build_fmu(
        path,
        "hydropwa_axis",
        "hydropwa full-order valve-controlled cylinder (Eqs. (1)-(11))",
        variables,
        {"hydropwa_axis_fmi2.c": fmi2_source(model_c)},
        ["hydropwa_axis_fmi2.c"],
        step_size=1e-3,
        interpolate_inputs=True,
        overwrite=overwrite,
    )
