"""The controller as dependency-free C99 code for a real-time target (issue 35).

:func:`export_c` writes ``hydropwa_ctrl.h``, ``hydropwa_ctrl.c`` and a README: the control
law of :mod:`hydropwa.simulation._controller` in C, reading the controller's packed float
vector (:meth:`~hydropwa.control.PIController.pack`) as one ``static const`` table.

How the C stays the package's law: it *is* the package's law, translated.

- the **law** is :func:`hydropwa.simulation._controller.law_step` and its stages, with the
  physics they call (the edge drop and the regularised root of Eqs. (5)/(6) in the flow
  feed-forward, :mod:`hydropwa.components._physics`), translated statement by statement from
  their numba source by :mod:`hydropwa.simulation._emit_c` (:data:`LAW_FUNCTIONS`), as the
  axis FMU's right-hand side is: the same floating-point operations in the same order, no
  hand-kept copy (``_c/hydropwa_ctrl_api.c`` only passes the header's structs to it);
- the **layout** (the indices ``C_*``, ``R_*``, ``X_*``, ``S_*``, ``RC_*``, ``L_*`` and the
  sizes) is emitted as ``#define HP_*`` lines from the tables of :mod:`hydropwa._layout_law`,
  and the header's memory and log arrays are sized from them;
- the tests step both in lockstep on closed-loop runs of two machines and require the same
  command within 1e-12 at every sample;
- a controller with a setting the export does not cover is refused, by name
  (:func:`check_expressible`).

The C needs no heap, no I/O and no global beyond the caller-owned state struct (the table is
``static const``); the worst-case cost of a step is a search over every gain row's box
(documented in the header, measured by ``benchmarks/target.py``).
"""

from __future__ import annotations

import math
import os
import re
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from .. import __version__
from .. import _layout_law as LL
from .._io import read_text, write_text_files
from .._layout_law import SIZES as LAW_SIZES
from ..simulation import _controller as C
from ..simulation._emit_c import emit_unit
from ..simulation._fmu import FmuVariable, build_fmu, fmi2_source, fmi3_source
from ._controllers import ControlError, PIController, StateFeedbackController

__all__ = ["export_c", "export_fmu", "c_sources", "c_structs", "check_expressible", "C_FILES"]

#: files written by :func:`export_c`
C_FILES = ("hydropwa_ctrl.h", "hydropwa_ctrl.c", "README.md")

#: names of the packed layout emitted as ``#define HP_<name>``: every index constant of the law
#: (generated from the tables of hydropwa/_layout_law.py), its sizes, and its numeric rules
_LAYOUT = (
    *sorted(n for n in vars(C) if re.fullmatch(r"(C|R|X|XR|E|AW|S|L|RC)_[A-Z]+", n)),
    *LAW_SIZES,
    "QUIET_HOLD",
    "QUIET_VENT",
    "REST_RATE",
    "REST_ACCELERATION",
)

#: settings of ``describe()`` the C law covers (any other one that is set is refused)
_COVERED = frozenset(
    {
        "kind",
        "sample_time",
        "delay",
        "u_min",
        "u_max",
        "anti_windup",
        "tracking_gain",
        "pressure_washout",
        "load_pressure",
        "dead_zone_inverse",
        # PI
        "kp",
        "ki",
        "kff",
        "kv",
        "kpl",
        "kdpl",
        "pressure_filter",
        # state feedback (per cell: box, k_pl, k_v, k_x, k_i, u_ff; design is provenance)
        "cells",
        "design",
        # schema 2 (the extension block)
        "feedforward",
        "velocity_filter",
        "position_observer",
        "spool_model",
        "estimator",
        # issue 52: the controlled output (position, force, load pressure) and its feed-forward
        "output",
        "feedforward_compliance",
    }
)
_CELL_COVERED = frozenset(
    {"label", "lower", "upper", "k_pl", "k_v", "k_x", "k_i", "u_ff", "k_nu", "k_dnu", "k_up"}
)
#: law elements the C covers (the README and the report list them)
LAW_ELEMENTS = (
    "PI with velocity feed-forward k_ff·ṙ, velocity feedback k_v, load-pressure feedback k_pl and its filtered rate k_dpl",
    "state feedback per PWA cell: gain rows with boxes over [P_L, ẋ, x, c_prev], the previous row tried first, then all in order, the nearest (scaled L1) outside all",
    "constant command u_ff per row",
    "dead-zone inverse with blend width, and with hysteresis of its side (schema 2)",
    "schema 2: quiet band of the command (closed valve and held integral while the sensor "
    "noise alone moves the command), with the integral's leak where the valve is parked and "
    "its band |e| <= e_I; optionally the band only while the reference is at rest",
    "schema 2: pre-opening: while r'(t_k) = 0 and r'(t_k + τ_o) != 0 an opening of at least "
    "the blend width z_w toward the coming move",
    "schema 2: pressure vent at rest: inside the quiet band the low-passed load-pressure share "
    "of the command opens the valve beyond 0.8 of the band, blended out over the band's ramp; "
    "the integral leaks wherever the command is within twice the band",
    "schema 2: the quiet band's opening delay: at rest the band opens the valve only on the n-th "
    "consecutive sample with the command beyond the band on one side (before, the command limited "
    "to the band; at once beyond the integral band), and the pressure vent does not push the rod "
    "away from the target while the position share is beyond the band",
    "saturation [u_min, u_max] with anti-windup none / clamping / back-calculation",
    "pressure washout (P_L − low-pass of P_L) for k_pl",
    "first-order filter of the backward difference Ṗ_L",
    "one-sample computation delay",
    "load pressure from the chamber pressures (asymmetric or mean-area form)",
    "schema 2: flow feed-forward per flow direction at the measured load pressure "
    "(Eqs. (5)/(6) inverted, on the look-ahead rate r'(t_k + τ))",
    "schema 2: reference state [P_ref, ṙ] in the k_v and k_pl feedback, P_ref = (m r̈ + b ṙ)/A_A "
    "washed out like P_L",
    "schema 2: velocity from the position samples (first-order filter of the backward difference)",
    "schema 2: spool estimate by the discrete (ZOH) valve model with per-row spool gains "
    "k_nu, k_dnu and pending-command gain k_up",
    "schema 2: the measured spool position as the spool estimate's measurement (steady-state "
    "Kalman gain [L_nu, L_dnu] on the model's prediction)",
    "schema 2: position observer (steady-state Kalman filter of [x, v] driven by r̈)",
    "schema 2: per-cell steady-state Kalman filter of [P_L, v, x, ν, ν̇, d_a, d_p] "
    "(the filter of the last sample's row, driven by the opening command the valve held)",
)


def _active(value: Any) -> bool:
    """Whether a setting of ``describe()`` switches something on (None, 0, False, empty: off)."""
    if value is None or value is False:
        return False
    if isinstance(value, int | float):
        return value != 0
    if isinstance(value, str | list | tuple | dict):
        return len(value) > 0
    return True


def check_expressible(controller) -> np.ndarray:
    """The packed vector of ``controller`` if the C law expresses it; else :class:`ControlError`.

    Refused (one line naming what): a controller that is neither a :class:`PIController` nor
    a :class:`StateFeedbackController`, a setting or cell field the C does not implement that is
    switched on, and a packed vector whose length does not match the layout.
    """
    if not isinstance(controller, PIController | StateFeedbackController):
        raise ControlError(
            f"cannot export a {type(controller).__name__} to C; the C law covers PIController and "
            "StateFeedbackController"
        )
    d = controller.describe()
    extra = sorted(k for k, v in d.items() if k not in _COVERED and _active(v))
    for cell in d.get("cells", []):
        extra += sorted(
            f"cells.{k}" for k, v in cell.items() if k not in _CELL_COVERED and _active(v)
        )
    if extra:
        raise ControlError(
            f"the C export does not implement {', '.join(sorted(set(extra)))} of this "
            f"{controller.kind} controller; simulate it in the package or drop the setting"
        )
    ctl = np.asarray(controller.pack(), dtype=float)
    n = int(ctl[C.C_NROWS])
    base = C.C_ROWS + C.ROW * n
    sizes = (
        base,
        base + C.N_EXT + C.XROW * n,
        base + C.N_EXT + (C.XROW + C.EROW) * n,
        base + C.N_EXT + (C.XROW + C.EROW + C.NZ) * n,
    )
    if ctl.shape[0] not in sizes:
        raise ControlError(
            f"the packed controller has {ctl.shape[0]} values, the C layout expects "
            f"{sizes[0]} (schema 1), {sizes[1]} (schema 2) or {sizes[2]} / {sizes[3]} (schema 2 "
            "with the Kalman filter, without / with the spool measured); the C export is older "
            "than this controller"
        )
    if np.isnan(ctl).any():
        raise ControlError("the packed controller holds NaN; the C export needs finite gains")
    return ctl


def _c_float(v: float) -> str:
    """A C double literal that reads back to exactly ``v`` (±HUGE_VAL for ±inf)."""
    if math.isinf(v):
        return "HUGE_VAL" if v > 0 else "-HUGE_VAL"
    s = repr(float(v))
    return s if ("." in s or "e" in s or "n" in s) else s + ".0"


def _c_rows(ctl: np.ndarray, start: int, n: int, width: int, label: str) -> list[str]:
    """Initialiser lines of ``n`` rows of ``width`` values from ``ctl[start]``, one per line."""
    return [
        f"    /* row {r}{label} */ "
        + ", ".join(_c_float(v) for v in ctl[start + width * r : start + width * (r + 1)])
        + ","
        for r in range(n)
    ]


def _table(ctl: np.ndarray) -> str:
    """The packed vector as C initialiser lines, rows of the gain table one per line."""
    lines = [
        "    /* header: T_s, delay, u_min, u_max, anti-windup, k_t, DZinv, offset, width, filter a,"
        " rows, washout a_w, P_L form, scales[4] */",
        "    " + ", ".join(_c_float(v) for v in ctl[: C.C_ROWS]) + ",",
    ]
    n = int(ctl[C.C_NROWS])
    lines += _c_rows(ctl, C.C_ROWS, n, C.ROW, "")
    e0 = C.C_ROWS + C.ROW * n
    if ctl.shape[0] > e0:
        lines.append(
            "    /* extension (schema 2): flow feed-forward K, p_tr, A_A, alpha, P_S, P_T, dp_min;"
            " reference state, m, b, lead; velocity filter a_v; spool model, Phi, Gamma;"
            " observer, L_x, L_v */"
        )
        lines.append("    " + ", ".join(_c_float(v) for v in ctl[e0 : e0 + C.N_EXT]) + ",")
        lines += _c_rows(ctl, e0 + C.N_EXT, n, C.XROW, ": k_nu, k_dnu, k_up")
        eb = e0 + C.N_EXT + C.XROW * n
        if ctl.shape[0] > eb:
            label = ": Kalman filter Phi (7x7), Gamma, phi0, L (7x2), init"
            lines += _c_rows(ctl, eb, n, C.EROW, label)
        sb = eb + C.EROW * n
        if ctl.shape[0] > sb:  # the measured spool's gain columns (e0+X_ESTNU)
            lines += _c_rows(ctl, sb, n, C.NZ, ": Kalman filter L, spool column")
    return "\n".join(lines)


#: the numba functions the exported C translates (with everything they call)
LAW_FUNCTIONS = (C.law_step, C.load_pressure)


def _read_template(name: str) -> str:
    """A file of ``control/_c``; the header with the law's sizes and log rows filled in."""
    text = resources.files("hydropwa.control").joinpath("_c", name).read_text(encoding="utf-8")
    return _fill_layout(text) if name == "hydropwa_ctrl.h" else text


def _fill_layout(header: str) -> str:
    """The header with the law's memory and log sizes and log rows of :mod:`hydropwa._layout_law`."""
    rows = "\n".join(
        f"#define HYDROPWA_CTRL_LOG_{n.upper()} {LL.LOG_ROW[n]} /* {what} [{unit}] */"
        for n, _w, unit, what in LL.LOG
    )
    header = header.replace("@LOG_ROWS@", rows)
    return header.replace("@N_CST@", str(LL.N_CST)).replace("@N_LOG@", str(LL.N_LOG))


def c_structs(header: str | Path | None = None) -> dict[str, type]:
    """ctypes mirrors of the C controller's structs, read from its header (one source, no drift).

    Parameters
    ----------
    header : str or Path, optional
        The text of ``hydropwa_ctrl.h`` (a string holding ``typedef``) or its path (an
        exported folder's); default the
        header shipped in the package, the one :func:`export_c` writes.

    Returns
    -------
    dict
        ``{"hydropwa_ctrl_meas": ..., "hydropwa_ctrl_ref": ..., "hydropwa_ctrl_state": ...}``:
        :class:`ctypes.Structure` subclasses with the header's fields in its order
        (``double`` → c_double, ``int`` → c_int, ``double z[7]`` → c_double × 7), to call
        the compiled controller from Python (``hydropwa_ctrl_step(&state, &meas, &ref)``).
    """
    import ctypes  # deferred: only a caller of the compiled C needs it

    if header is None:
        text = _read_template("hydropwa_ctrl.h")
    elif isinstance(header, Path) or "typedef" not in header:  # a path, as Path or str
        text = read_text(header, "C header", ControlError)
    else:
        text = header
    text = _fill_layout(text)  # a template's sizes (an exported header has them already)
    types: dict[str, Any] = {"double": ctypes.c_double, "int": ctypes.c_int}
    out: dict[str, type] = {}
    for body, name in re.findall(r"typedef struct \{(.*?)\}\s*(\w+);", text, flags=re.S):
        body = re.sub(r"/\*.*?\*/", "", body, flags=re.S)
        fields: list[tuple[str, Any]] = []
        for decl in filter(None, (d.strip() for d in body.split(";"))):
            m = re.fullmatch(r"(\w+)\s+(\w+)(?:\[(\d+)\])?", decl)
            if m is None or m.group(1) not in types:
                raise ControlError(f"c_structs: cannot mirror '{decl}' of struct {name}")
            ct = types[m.group(1)]
            fields.append((m.group(2), ct * int(m.group(3)) if m.group(3) else ct))
        out[name] = type(name, (ctypes.Structure,), {"_fields_": fields})
    return out


def _describe_line(controller) -> str:
    if isinstance(controller, StateFeedbackController):
        return f"state feedback, {len(controller.rows)} gain rows"
    return "PI (one gain row valid everywhere)"


def verdict_line(controller) -> str:
    """One line on the controller's verification verdict (:attr:`~hydropwa.control.
    StateFeedbackController.verdict`), as the exported C, its README and the FMU state it."""
    ver = controller.verification
    verdict = controller.verdict
    if verdict == "unverified":
        return (
            "NOT VERIFIED: the controller file records no verification on the full model "
            "(hydropwa control design verifies unless --no-verify)"
        )
    st = ver.get("settings", {})
    runs = f"{st.get('draws', '?')} parameter draws x {st.get('tasks', '?')} tasks"
    if verdict == "pass":
        return f"PASS: verified on the full model ({runs}, sensor noise, delay)"
    fails = list(ver.get("failures", []))
    first = f"; first: {fails[0]}" if fails else ""
    return f"FAIL: {len(fails)} failed checks of the verification on the full model ({runs}){first}"


def cost_per_step(
    n_rows: int, extended: bool = False, kalman: bool = False, kalman_spool: bool = False
) -> dict[str, int]:
    """Worst-case operation counts of one ``hydropwa_ctrl_step`` with ``n_rows`` gain rows.

    The row search evaluates at most n_rows + 1 box distances (the previous row, then all):
    per distance 4 coordinates × (2 comparisons, 1 subtraction, 1 division, 1 addition) and
    one comparison with the best so far. The rest of the schema-1 law is a fixed 40
    floating-point operations and 16 comparisons; the schema-2 block (``extended``: position
    observer, velocity filter, flow feed-forward with its two square roots, reference state,
    spool terms and the valve model's update) adds at most 76 operations (6 of them
    divisions, 2 square roots) and 14 comparisons, and its dead-zone rules (the quiet band
    with its at-rest test, the pre-opening, the hysteresis, the integral's band and leak;
    counted on their longest paths in the law's stages) at most 11 operations and 28
    comparisons; the per-cell Kalman filter (``kalman``)
    adds 7 × (2 + 2·7) for the prediction, 2 for the innovations and 7 × 4 for the update:
    142 operations, no division. The measured spool's filter (``spool_feedback``: the inverse
    of the dead-zone inverse, the innovation and two multiply-adds) adds at most 9 operations
    (1 division) and 6 comparisons to the schema-2 block; in the per-cell Kalman filter
    (``kalman_spool``) the spool's column adds 4 + 1 + 7 × 2 = 19 operations (1 division) and
    5 comparisons.
    """
    boxes = n_rows + 1 if n_rows > 1 else 0
    x = 1 if extended else 0
    ks = 1 if kalman_spool else 0
    kf = (142 if kalman else 0) + 19 * ks
    return {
        "box_distances": boxes,
        "divisions": 4 * boxes + 4 + (6 + 1) * x + ks,
        "flops": 12 * boxes + 40 + (76 + 11 + 9) * x + kf,
        "comparisons": 9 * boxes + 16 + (14 + 28 + 6) * x + 5 * ks,
    }


def c_sources(controller) -> dict[str, str]:
    """The texts of ``hydropwa_ctrl.h``, ``hydropwa_ctrl.c`` and ``README.md`` for ``controller``.

    Raises
    ------
    ControlError
        The controller has a law element the C does not implement (:func:`check_expressible`).
    """
    ctl = check_expressible(controller)
    n = int(ctl[C.C_NROWS])
    e0 = C.C_ROWS + C.ROW * n
    ext = ctl.shape[0] > e0
    eb = e0 + C.N_EXT + C.XROW * n
    cost = cost_per_step(n, ext, ctl.shape[0] > eb, ctl.shape[0] > eb + C.EROW * n)
    subs = {
        "@VERSION@": __version__,
        "@KIND@": _describe_line(controller),
        "@N_ROWS@": str(n),
        "@N_TABLE@": str(ctl.shape[0]),
        "@SAMPLE_TIME@": _c_float(controller.sample_time),
        "@LEAD@": _c_float(float(ctl[e0 + C.X_LEAD]) if ext else 0.0),
        "@PRE_OPEN@": _c_float(float(ctl[e0 + C.X_DZPO]) if ext else 0.0),
        "@LOAD_PRESSURE@": controller.load_pressure,
        "@BOXES@": str(cost["box_distances"]),
        "@DIVS@": str(cost["divisions"]),
        "@FLOPS@": str(cost["flops"]),
        "@CMPS@": str(cost["comparisons"]),
        "@DELAY@": "one sample (the command computed at t_k is returned at t_{k+1})"
        if controller.delay
        else "none (the command computed at t_k is meant for t_k)",
        "@ELEMENTS@": "\n".join(f"- {e}" for e in LAW_ELEMENTS),
        "@VERDICT@": verdict_line(controller).replace("*/", "* /"),
        "@VERIFIED@": "1" if controller.verdict == "pass" else "0",
    }
    header = _read_template("hydropwa_ctrl.h")
    readme = _read_template("README.md")
    for k, v in subs.items():
        header = header.replace(k, v)
        readme = readme.replace(k, v)
    layout = "\n".join(f"#define HP_{name} {getattr(C, name)}" for name in _LAYOUT)
    # the areas of the flow feed-forward's mean-area conversion: the design's (schema 2)
    a_a = float(ctl[e0 + C.X_AA]) if ext else 1.0
    a_b = float(ctl[e0 + C.X_ALPHA]) * a_a if ext else 1.0
    law, _names = emit_unit(LAW_FUNCTIONS)
    source = (
        f"/* hydropwa_ctrl.c: {subs['@KIND@']}, generated by hydropwa {__version__}.\n"
        f" * Verification: {subs['@VERDICT@']}\n"
        " * Do not edit: regenerate with `hydropwa control export CTRL --c DIR`.\n"
        " * C99, no heap, no I/O; the only data is the constant table T below. */\n"
        '#include "hydropwa_ctrl.h"\n\n'
        "#include <math.h> /* HUGE_VAL, fabs, sqrt (link with -lm where libm is separate) */\n\n"
        "/* Packed layout of hydropwa/_layout_law.py (generated from its tables) */\n"
        f"{layout}\n"
        f"#define HP_AREA_A {_c_float(a_a)}\n#define HP_AREA_B {_c_float(a_b)}\n\n"
        "/* The controller's packed vector (SI units; layout above) */\n"
        f"static const double T[{ctl.shape[0]}] = {{\n{_table(ctl)}\n}};\n\n"
        "/* The law: hydropwa/simulation/_controller.py's law_step and its stages and the\n"
        " * physics they call (components/_physics.py), translated by simulation/_emit_c.py */\n"
        f"{law}\n" + _read_template("hydropwa_ctrl_api.c")
    )
    return {"hydropwa_ctrl.h": header, "hydropwa_ctrl.c": source, "README.md": readme}


def export_c(controller, directory: str | os.PathLike, *, overwrite: bool = False) -> Path:
    """Write the controller as C99 (``hydropwa_ctrl.h``, ``hydropwa_ctrl.c``, ``README.md``).

    Parameters
    ----------
    controller : PIController or StateFeedbackController
        The controller (e.g. from :func:`load_controller` or a design).
    directory : path-like
        Folder to write into; created if missing.
    overwrite : bool
        Write into a folder that already holds files (default: refuse).

    Returns
    -------
    Path
        The folder.

    Raises
    ------
    ControlError
        The controller has a law element the C does not implement.
    OutputExistsError
        The folder exists and is not empty, and ``overwrite`` is False.

    Notes
    -----
    The law is the one of :mod:`hydropwa.simulation._controller` (docs/control.md), with the
    packed vector as a constant table; see the README written beside the sources for the call
    sequence, units and sign conventions.
    """
    return write_text_files(directory, c_sources(controller), overwrite=overwrite)


#: the controller FMU's variables (value references in this order; hp_model_ctrl.c's VR_*)
FMU_VARIABLES = [
    FmuVariable("x", "input", "continuous", 0.0, "m", "piston position (+ extends)"),
    FmuVariable("v", "input", "continuous", 0.0, "m/s", "piston velocity"),
    FmuVariable("p_l", "input", "continuous", 0.0, "Pa", "load pressure in the controller's form"),
    FmuVariable("r", "input", "continuous", 0.0, "m", "reference position"),
    FmuVariable("r_rate", "input", "continuous", 0.0, "m/s", "reference velocity"),
    FmuVariable(
        "r_rate_ff",
        "input",
        "continuous",
        0.0,
        "m/s",
        "reference velocity at t + lead (feed-forward)",
    ),
    FmuVariable("r_acc", "input", "continuous", 0.0, "m/s2", "reference acceleration"),
    FmuVariable(
        "r_rate_pre",
        "input",
        "continuous",
        0.0,
        "m/s",
        "reference velocity at t + pre-open look-ahead (0 without)",
    ),
    FmuVariable(
        "u", "output", "discrete", None, "", "valve command [1] of the last sample (+-1 full)"
    ),
    FmuVariable(
        "spool",
        "input",
        "continuous",
        0.0,
        "",
        "reported spool position [1] (sign of u; read only with the spool measured)",
    ),
]


def export_fmu(
    controller, path: str | os.PathLike, *, fmi_version: str = "2.0", overwrite: bool = False
) -> Path:
    """Build the controller as an FMI 2.0 (or 3.0) co-simulation FMU from the C of :func:`export_c`.

    The FMU holds the platform binary of this machine and the sources (``hydropwa_ctrl.h``,
    ``hydropwa_ctrl.c``, ``hydropwa_ctrl_fmi2.c``, README), so a user or a tool that compiles
    source-code FMUs rebuilds it for another platform.

    Parameters
    ----------
    controller : PIController or StateFeedbackController
    path : path-like
        The ``.fmu`` file.
    fmi_version : str
        ``"2.0"`` (default) or ``"3.0"`` (co-simulation; the same C, the FMI 3.0 interface
        and ``sources/buildDescription.xml``).
    overwrite : bool
        Replace an existing file (default: refuse).

    Returns
    -------
    Path

    Raises
    ------
    ControlError
        The controller has a law element the C does not implement.
    FmuBuildError
        No C compiler (``$CC``, gcc, cc or clang) on PATH, or it failed.

    Notes
    -----
    Inputs x [m], v [m/s], p_l [Pa], r [m], r_rate [m/s], r_rate_ff [m/s] (the rate at
    t + the feed-forward's look-ahead), r_acc [m/s²], r_rate_pre [m/s] (the rate at t + the
    pre-opening's look-ahead; 0 without it), spool [1] (the spool position the valve reports,
    in units of the opening with the sign of u, read only by a controller designed with
    ``spool="measured"``; value reference 9, after u, so that the earlier ones stay); output
    u [1]. ``doStep(t, h)``
    evaluates the law at every sample instant t_0 + k·T_s in [t, t + h) with the inputs set
    at t, and u is the command of the last of them from then on (no direct feedthrough):
    a master that sets the inputs at t_k, steps the controller, then reads u and passes it to
    the plant's step from t_k reproduces the package's loop.
    """
    sources = c_sources(controller)
    model = _read_template("hp_model_ctrl.c")
    if fmi_version == "3.0":
        interface = "hydropwa_ctrl_fmi3.c"
        sources[interface] = fmi3_source(model)
    else:
        interface = "hydropwa_ctrl_fmi2.c"
        sources[interface] = fmi2_source(model)
    return build_fmu(
        path,
        "hydropwa_ctrl",
        f"hydropwa position controller: {_describe_line(controller)}, "
        f"T_s = {controller.sample_time * 1e3:g} ms; verification {verdict_line(controller)}",
        FMU_VARIABLES,
        sources,
        [interface, "hydropwa_ctrl.c"],
        step_size=controller.sample_time,
        fmi_version=fmi_version,
        overwrite=overwrite,
    )
