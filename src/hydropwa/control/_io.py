"""Controller files (TOML or JSON, schema ``hydropwa.controller/2``) that a real-time target can read.

Schema 2 is schema 1 (below) plus ``conventions``, ``area_ratio``, ``velocity_filter``,
``[machine]``, ``[feedforward]``, ``[spool_model]``, per-cell ``k_nu``/``k_dnu``/``k_up`` and
``[verification]``; its specification is docs/controller_target.md and its JSON Schema
``schemas/controller-2.schema.json`` (:func:`controller_schema`). Schema-1 files are read as
they were.

Every dimensioned value is written as a string with its unit in the units a
hydraulics engineer reads (``"0.5 ms"``, ``"-54.17 bar"``, ``"0.2226 1/mm"``); the
reader accepts any unit of the right dimension (pint) or a plain number in SI.
Unbounded box sides are written ``"inf"`` / ``"-inf"``. Layout::

    schema = "hydropwa.controller/1"
    kind = "state_feedback"            # or "pi"
    sample_time = "0.5 ms"
    delay = false
    u_min = -1.0
    u_max = 1.0
    anti_windup = "clamp"
    tracking_gain = "0 1/s"
    pressure_washout = "100 ms"        # P_L high-pass for k_pl (0: plain P_L)
    law = "u = sat(DZinv(u_ff - k_pl*P_L - k_v*v + k_x*(r - x) + k_i*integral(r - x)))"
    [dead_zone_inverse]                # absent: no inverse
    offset = 0.1
    width = 0.004167
    hysteresis = 0.005                 # side band h (schema 2; absent: 0, none)
    quiet_band = 0.0083                # quiet band q (schema 2; absent: 0, none)
    integral_leak = "20 ms"            # integral leak where the band parks the valve (schema 2)
    integral_band = "0.085 mm"         # the integral runs only while |r - x| <= this (schema 2)
    quiet_at_rest = 1                  # 1: the quiet band only while r is at rest (schema 2)
    pre_open = "6 ms"                  # pre-opening look-ahead tau_o (schema 2; absent: 0, none)
    pressure_vent = "20 ms"            # low-pass T_p of the pressure vent at rest (schema 2)
    quiet_open = 12                    # the band opens after n samples beyond q (schema 2)
    [[cells]]                          # one per PWA cell; the first box holding
    label = "s=+1 o=0 w=5"             # [P_L, v, x, c_prev] selects the row
    lower = { p_l = "-100 bar", v = "14.56 mm/s", x = "-inf", c = 0.0 }
    upper = { p_l = "54.17 bar", v = "54.26 mm/s", x = "inf", c = "inf" }
    k_pl = "0.0978 1/bar"
    ...
    [design]                           # provenance, not read back into the loop
"""

from __future__ import annotations

import json
import math
import os
import tomllib
from importlib.resources import files
from pathlib import Path
from typing import Any

import tomli_w

from .._errors import HydropwaError
from .._io import atomic_write_text, check_output, overwrite_flag, read_text
from ..params import parse_quantity
from ._controllers import (
    DEAD_ZONE_V2,
    ControlError,
    DeadZoneInverse,
    FlowFeedForward,
    GainRow,
    PIController,
    SpoolModel,
    StateFeedbackController,
)
from ._estimator import CellEstimator

__all__ = [
    "save_controller",
    "load_controller",
    "controller_to_dict",
    "controller_from_dict",
    "SCHEMA",
    "SCHEMAS",
    "controller_schema",
    "CONVENTIONS",
]

SCHEMA = "hydropwa.controller/2"
#: schema 3 (issue 52): schema 2 plus ``output`` (force or pressure control),
#: ``feedforward_compliance`` and the gains per unit of that output; written only for a force or
#: pressure controller, so a position controller's file is schema 2 as before
SCHEMA3 = "hydropwa.controller/3"
#: The most gain rows a controller file may hold: the most cell combinations a PWA export
#: holds (``linearization.MAX_CHAMBER_CELLS``); a larger table is refused before it is read
#: (140 000 rows took minutes to load and to export as C).
MAX_GAIN_ROWS = 5000
#: schemas :func:`controller_from_dict` reads (schema 1: the law without the extension block)
SCHEMAS = ("hydropwa.controller/1", SCHEMA, SCHEMA3)
_LAW = {
    "pi": "u = sat(DZinv(k_p*e + k_i*integral(e) + k_ff*dr/dt - k_v*v - k_pl*(P_L - lowpass(P_L)) - k_dpl*dP_L/dt)), e = r - x",
    "state_feedback": "u = sat(DZinv(u_ff - k_pl*(P_L - lowpass(P_L)) - k_v*v + k_x*(r - x) + k_i*integral(r - x)))",
}
#: field → (display unit, factor from SI to display unit, SI unit for pint)
_PI_GAINS = {
    "kp": ("1/mm", 1e-3, "1/m"),
    "ki": ("1/(mm*s)", 1e-3, "1/(m*s)"),
    "kff": ("s/m", 1.0, "s/m"),
    "kv": ("s/m", 1.0, "s/m"),
    "kpl": ("1/bar", 1e5, "1/Pa"),
    "kdpl": ("s/bar", 1e5, "s/Pa"),
    "pressure_filter": ("ms", 1e3, "s"),
}
_ROW_GAINS = {
    "k_pl": ("1/bar", 1e5, "1/Pa"),
    "k_v": ("s/m", 1.0, "s/m"),
    "k_x": ("1/mm", 1e-3, "1/m"),
    "k_i": ("1/(mm*s)", 1e-3, "1/(m*s)"),
}
#: schema-2 elements: the extended law, every unit and sign convention a target needs
_LAW2 = (
    "c = c_fb + c_ff; u = sat(DZinv(c)); "
    "c_fb = k_p*e + k_i*integral(e) + k_ff*dr/dt - k_v*v - k_pl*(P_L - lowpass(P_L)) - k_dpl*dP_L/dt "
    "- k_nu*nu_hat - k_dnu*dnu_hat - k_up*c_pending (state feedback: k_p = k_x, k_ff = k_dpl = 0); "
    "c_ff = A_A*dr_ff/(K*rho(max(dp(sign(dr_ff), P_L, P_S), min_drop), transition_pressure)) "
    "+ [reference_state] (k_v*dr + k_pl*(P_ref - lowpass(P_ref)) + (k_nu + k_up)*c_flow), "
    "P_ref = (m*d2r + b*dr)/A_A, dr_ff = dr(t + lead) (required input), e = r - x; "
    "[position_observer] x, v := Kalman x_hat, v_hat driven by d2r; "
    "[spool_model] nu_hat, dnu_hat := Phi*[nu_hat, dnu_hat] + Gamma*c_apply, "
    "[measured] corrected first by gain*(nu_m - nu_hat); "
    "[hysteresis h] DZinv keeps its side until c leaves +-h; "
    "[quiet_band q, at rest: |dr|, |dr_ff| <= 1e-6 m/s, |d2r| <= 1e-3 m/s^2] c_o = 0 for |c| <= q, "
    "2(|c| - q)sign(c) to 2q, c beyond; held = c_o = 0 and |k_x e| < 8q; "
    "[quiet_open n] the band passes c only on the n-th sample in a row beyond q (at once for |e| > e_I); "
    "[pressure_vent T_p] p_low := a_p*p_low + (1 - a_p)*p_dev every sample before use, "
    "inside the band c_o = vent(-k_pl*p_low, 0.8q, q); "
    "[pre_open tau_o] at rest with dr(t + tau_o) moving: c_o = max(c_o, z_w) toward the move (required input); "
    "integral: [integral_leak] where the valve is parked (c_o = 0 or vent leak) I := a_l*I whatever held says, "
    "else no integration where held, k_i = 0 or [integral_band] |e| > e_I, else the anti-windup rule; "
    "[delay] u(t_k) is the command computed at t_(k-1) "
    "(docs/controller_target.md, 'The law, sample by sample')"
)
CONVENTIONS = {
    "command": "u in [u_min, u_max], +1 the full valve signal opening P->A (rod extends, +x), -1 opening P->B",
    "position": "x [m] from the retracted end stop, +x extending",
    "load_pressure": "P_L = P_A - area_ratio*P_B (asymmetric; mean-area: (P_A*A_A - P_B*A_B)/((A_A + A_B)/2)), positive pushes +x",
    "velocity": "v = dx/dt [m/s], +x extending; from velocity_filter if > 0, else a velocity sensor",
    "units": "every dimensioned value carries its unit; a bare number is SI",
}
#: units of the per-cell Kalman filter's numbers (all SI), written with them into the file
_EST_UNITS = {
    "states": "P_L [Pa], v [m/s], x [m], spool [1], spool_rate [1/s], d_acceleration [m/s^2], "
    "d_pressure_rate [Pa/s]",
    "phi": "per cell, 7 x 7 row-major, the ratios of the state units",
    "gamma": "per cell, 7 values, state units per unit opening command",
    "gain": "per cell, 7 x 2 row-major, columns: innovation of P_L [Pa], of x [m]",
    "affine": "per cell, 7 values in the state units: the cell's affine term over one sample",
    "init": "per cell, (a_vp [m/(s^2 Pa)], a_pp [1/s], f_a [m/s^2], f_p [Pa/s]): "
    "d_acceleration = -a_vp*P_L - f_a, d_pressure_rate = -a_pp*P_L - f_p at the first sample",
    "noise": "standard deviations: x [m], p_l [Pa], acceleration [m/s^2], force_drift "
    "[m/s^2 per sample], pressure_drift [Pa/s per sample]",
}
_FF = {
    "flow_coefficient": ("m**3/s/Pa**0.5", 1.0, "m**3/s/Pa**0.5"),
    "transition_pressure": ("bar", 1e-5, "Pa"),
    "area_a": ("cm**2", 1e4, "m**2"),
    "area_ratio": ("", 1.0, ""),
    "supply_pressure": ("bar", 1e-5, "Pa"),
    "tank_pressure": ("bar", 1e-5, "Pa"),
    "min_drop": ("bar", 1e-5, "Pa"),
    "lead": ("ms", 1e3, "s"),
    "mass": ("kg", 1.0, "kg"),
    "viscous": ("N*s/m", 1.0, "N*s/m"),
}
_MACHINE = {
    "area_a": ("cm**2", 1e4, "m**2"),
    "area_b": ("cm**2", 1e4, "m**2"),
    "stroke": ("mm", 1e3, "m"),
    "supply_pressure": ("bar", 1e-5, "Pa"),
}
_ROW_GAINS2 = {
    "k_nu": ("", 1.0, ""),
    "k_dnu": ("ms", 1e3, "s"),
    "k_up": ("", 1.0, ""),
}
#: the error-gain units of a force / pressure controller (schema 3): field → (unit, factor, SI)
_OUTPUT_GAINS = {
    "force": {
        "kp": ("1/kN", 1e3, "1/N"),
        "ki": ("1/(kN*s)", 1e3, "1/(N*s)"),
        "kff": ("s/kN", 1e3, "s/N"),
        "k_x": ("1/kN", 1e3, "1/N"),
        "k_i": ("1/(kN*s)", 1e3, "1/(N*s)"),
        "feedforward_compliance": ("mm/kN", 1e6, "m/N"),
    },
    "pressure": {
        "kp": ("1/bar", 1e5, "1/Pa"),
        "ki": ("1/(bar*s)", 1e5, "1/(Pa*s)"),
        "kff": ("s/bar", 1e5, "s/Pa"),
        "k_x": ("1/bar", 1e5, "1/Pa"),
        "k_i": ("1/(bar*s)", 1e5, "1/(Pa*s)"),
        "feedforward_compliance": ("mm/bar", 1e8, "m/Pa"),
    },
}


def _gain_units(table: dict, output: str) -> dict:
    """``table`` (field → unit, factor, SI) with the error gains in units of ``output``."""
    return table | {k: v for k, v in _OUTPUT_GAINS.get(output, {}).items() if k in table}


_BOX = (
    ("p_l", "bar", 1e-5, "Pa"),
    ("v", "mm/s", 1e3, "m/s"),
    ("x", "mm", 1e3, "m"),
    ("c", "", 1.0, ""),
)


def _q(value: float, unit: str, factor: float) -> str | float:
    if math.isinf(value):
        return "inf" if value > 0 else "-inf"
    v = float(value) * factor
    return f"{v:.10g} {unit}" if unit else float(f"{v:.10g}")


def _read(value: Any, si_unit: str, where: str) -> float:
    if isinstance(value, str) and value.strip().lower() in ("inf", "+inf", "-inf"):
        return -math.inf if value.strip().startswith("-") else math.inf
    try:
        return float(parse_quantity(value, si_unit, where))
    except HydropwaError as exc:
        raise ControlError(f"controller file: {exc}") from None


#: the file units of the schema-2 elements of ``[dead_zone_inverse]`` (``DEAD_ZONE_V2``):
#: name -> (unit, factor from SI, SI unit); the others are plain numbers
_DZ_UNITS = {
    "integral_leak": ("ms", 1e3, "s"),
    "integral_band": ("mm", 1e3, "m"),
    "pre_open": ("ms", 1e3, "s"),
    "pressure_vent": ("ms", 1e3, "s"),
}
_PLAIN = ("", 1.0, "")


def _dead_zone_to_dict(dz: DeadZoneInverse) -> dict[str, Any]:
    out: dict[str, Any] = {"offset": dz.offset, "width": dz.width}
    for k in DEAD_ZONE_V2:
        unit, f, _si = _DZ_UNITS.get(k, _PLAIN)
        v = getattr(dz, k)
        if v > 0.0:
            out[k] = _q(v, unit, f) if unit else v
    return out


def _dead_zone_from_dict(dzi: dict[str, Any]) -> DeadZoneInverse:
    """``[dead_zone_inverse]`` read back (schema-2 elements absent: 0)."""
    return DeadZoneInverse(
        offset=_read(dzi["offset"], "", "dead_zone_inverse.offset"),
        width=_read(dzi.get("width", 0.0), "", "dead_zone_inverse.width"),
        **{
            k: _read(dzi.get(k, 0.0), _DZ_UNITS.get(k, _PLAIN)[2], f"dead_zone_inverse.{k}")
            for k in DEAD_ZONE_V2
        },
    )


def controller_to_dict(ctrl) -> dict[str, Any]:
    """The controller as a TOML/JSON-ready dict with units, schema ``hydropwa.controller/2``.

    Every element of schema 1 (see the module docstring) and, for a target built from the
    file alone (docs/controller_target.md): the sign conventions, the area ratio of P_L,
    the machine (areas, stroke, design supply pressure), the feed-forward, the velocity
    filter, the spool model and per-cell spool gains, and the verification verdict.
    """
    if not isinstance(ctrl, PIController | StateFeedbackController):
        raise ControlError(
            f"cannot write a {type(ctrl).__name__}; give a PIController or StateFeedbackController"
        )
    output = ctrl.output
    d: dict[str, Any] = {
        "schema": SCHEMA if output == "position" else SCHEMA3,
        "kind": ctrl.kind,
        "sample_time": _q(ctrl.sample_time, "ms", 1e3),
        "sample_rate": _q(1.0 / ctrl.sample_time, "Hz", 1.0),
        "delay": ctrl.delay,
        "u_min": ctrl.u_min,
        "u_max": ctrl.u_max,
        "anti_windup": ctrl.anti_windup,
        "tracking_gain": _q(ctrl.tracking_gain, "1/s", 1.0),
        "pressure_washout": _q(ctrl.pressure_washout, "ms", 1e3),
        "load_pressure": ctrl.load_pressure,
        "law": _LAW[ctrl.kind] if not ctrl.extended else _LAW2,
        "conventions": dict(CONVENTIONS),
        "velocity_filter": _q(ctrl.velocity_filter, "ms", 1e3),
    }
    d |= _output_entries(ctrl)
    if ctrl.machine:
        m = ctrl.machine
        d["area_ratio"] = (
            float(m["area_b"] / m["area_a"]) if "area_a" in m and "area_b" in m else None
        )
        d["machine"] = {k: _q(m[k], *_MACHINE[k][:2]) for k in _MACHINE if k in m}
    if ctrl.dead_zone_inverse is not None:
        d["dead_zone_inverse"] = _dead_zone_to_dict(ctrl.dead_zone_inverse)
    if ctrl.feedforward is not None:
        ff = ctrl.feedforward.describe()
        d["feedforward"] = {k: _q(ff[k], *_FF[k][:2]) for k in _FF}
        d["feedforward"]["reference_state"] = bool(ff["reference_state"])
    if ctrl.position_observer is not None:
        d["position_observer"] = {
            "gain_x": ctrl.position_observer[0],
            "gain_v": _q(ctrl.position_observer[1], "1/s", 1.0),
        }
    if ctrl.spool_model is not None:
        d["spool_model"] = {
            "phi": list(ctrl.spool_model.phi),
            "gamma": list(ctrl.spool_model.gamma),
            "input": "the saturated opening command c the valve holds over the sample",
            "measured": ctrl.spool_model.measured,
        }
        if ctrl.spool_model.filtered:  # schema 2: the measured spool through a Kalman gain
            d["spool_model"]["gain"] = list(ctrl.spool_model.gain)
            d["spool_model"]["noise"] = dict(ctrl.spool_model.noise)
    if isinstance(ctrl, PIController):
        pig = _gain_units(_PI_GAINS, output)
        d["gains"] = {k: _q(getattr(ctrl, k), u, f) for k, (u, f, _si) in pig.items()}
    else:
        cells = []
        for r in ctrl.rows:
            c: dict[str, Any] = {"label": r.label}
            c["lower"] = {n: _q(v, u, f) for (n, u, f, _si), v in zip(_BOX, r.lower, strict=True)}
            c["upper"] = {n: _q(v, u, f) for (n, u, f, _si), v in zip(_BOX, r.upper, strict=True)}
            for k, (u, f, _si) in _gain_units(_ROW_GAINS, output).items():
                c[k] = _q(getattr(r, k), u, f)
            c["u_ff"] = r.u_ff
            if ctrl.spool_model is not None:
                for k, (u, f, _si) in _ROW_GAINS2.items():
                    c[k] = _q(getattr(r, k), u, f)
            cells.append(c)
        d["cells"] = cells
        d["design"] = _plain(ctrl.design)
        if ctrl.estimator is not None:  # schema 2: the per-cell Kalman filter (SI numbers)
            d["estimator"] = ctrl.estimator.describe() | {"units": dict(_EST_UNITS)}
    if ctrl.verification:
        d["verification"] = _plain(ctrl.verification)
    return _plain(d)


def _output_entries(ctrl) -> dict[str, Any]:
    """Schema 3's ``output`` and ``feedforward_compliance`` (none for a position controller)."""
    if ctrl.output == "position":
        return {}
    unit, factor, _si = _OUTPUT_GAINS[ctrl.output]["feedforward_compliance"]
    return {
        "output": ctrl.output,
        "feedforward_compliance": _q(ctrl.feedforward_compliance, unit, factor),
    }


def _plain(obj):
    """Design provenance without None (TOML has no null) and with plain numbers."""
    if isinstance(obj, dict):
        return {str(k): _plain(v) for k, v in obj.items() if v is not None}
    if isinstance(obj, list | tuple):
        return [_plain(v) for v in obj]
    if isinstance(obj, float) and not math.isfinite(obj):
        return str(obj)
    if hasattr(obj, "item"):
        return obj.item()
    return obj


def _check_rows(cells: Any) -> None:
    """The ``cells`` table: a list of at most :data:`MAX_GAIN_ROWS` rows."""
    if not isinstance(cells, list):
        raise ControlError(
            f"controller file: 'cells' is a {type(cells).__name__}, expected a list of gain rows"
        )
    if len(cells) > MAX_GAIN_ROWS:
        raise ControlError(
            f"controller file: {len(cells)} gain rows, more than the {MAX_GAIN_ROWS} a PWA model "
            "has; check that it is the file you meant (a design writes one row per cell)"
        )


def controller_from_dict(d: dict[str, Any]):
    """Rebuild a controller from :func:`controller_to_dict` output (units converted to SI)."""
    if not isinstance(d, dict) or d.get("schema") not in SCHEMAS:
        raise ControlError(
            f"controller file schema {d.get('schema') if isinstance(d, dict) else None!r} is not one of "
            f"{', '.join(SCHEMAS)}"
        )
    v2 = d["schema"] in (SCHEMA, SCHEMA3)
    output = str(d.get("output", "position")) if d["schema"] == SCHEMA3 else "position"
    pi_gains, row_gains = _gain_units(_PI_GAINS, output), _gain_units(_ROW_GAINS, output)
    kind = d.get("kind")
    try:
        common: dict[str, Any] = {
            "sample_time": _read(d["sample_time"], "s", "sample_time"),
            "delay": d.get("delay", False),
            "u_min": _read(d.get("u_min", -1.0), "", "u_min"),
            "u_max": _read(d.get("u_max", 1.0), "", "u_max"),
            "anti_windup": d.get("anti_windup", "clamp"),
            "tracking_gain": _read(d.get("tracking_gain", 0.0), "1/s", "tracking_gain"),
            "pressure_washout": _read(d.get("pressure_washout", 0.0), "s", "pressure_washout"),
            "load_pressure": d.get("load_pressure", "asymmetric"),
        }
        dzi = d.get("dead_zone_inverse")
        if dzi is not None:
            common["dead_zone_inverse"] = _dead_zone_from_dict(dzi)
        if v2:
            common.update(_read_v2(d))
        if output != "position":
            si = _OUTPUT_GAINS.get(output, {}).get("feedforward_compliance", ("", 1.0, ""))[2]
            common["output"] = output
            common["feedforward_compliance"] = _read(
                d.get("feedforward_compliance", 0.0), si, "feedforward_compliance"
            )
        if kind == "pi":
            g = d.get("gains", {})
            unknown = set(g) - set(pi_gains)
            if unknown:
                raise ControlError(
                    f"controller file: unknown gains {sorted(unknown)}; known: {', '.join(pi_gains)}"
                )
            gains: dict[str, Any] = {
                k: _read(v, pi_gains[k][2], f"gains.{k}") for k, v in g.items()
            }
            return PIController(**common, **gains)
        if kind == "state_feedback":
            _check_rows(d["cells"])
            rows = []
            for i, c in enumerate(d["cells"]):
                lo = tuple(
                    _read(c["lower"][n], si, f"cells[{i}].lower.{n}") for n, _u, _f, si in _BOX
                )
                hi = tuple(
                    _read(c["upper"][n], si, f"cells[{i}].upper.{n}") for n, _u, _f, si in _BOX
                )
                g = {k: _read(c[k], row_gains[k][2], f"cells[{i}].{k}") for k in row_gains}
                if v2:
                    g |= {
                        k: _read(c.get(k, 0.0), _ROW_GAINS2[k][2], f"cells[{i}].{k}")
                        for k in _ROW_GAINS2
                    }
                rows.append(
                    GainRow(
                        lo,
                        hi,
                        **g,
                        u_ff=_read(c.get("u_ff", 0.0), "", f"cells[{i}].u_ff"),
                        label=str(c.get("label", "")),
                    )
                )
            est = d.get("estimator") if v2 else None
            return StateFeedbackController(
                rows=tuple(rows),
                design=dict(d.get("design", {})),
                estimator=None if est is None else CellEstimator.from_dict(est),
                **common,
            )
    except KeyError as exc:
        raise ControlError(f"controller file ({kind}) lacks {exc}") from None
    except (TypeError, AttributeError) as exc:
        raise ControlError(f"controller file does not match schema {SCHEMA}: {exc}") from None
    raise ControlError(f"controller file kind {kind!r} must be 'pi' or 'state_feedback'")


def _read_v2(d: dict[str, Any]) -> dict[str, Any]:
    """The schema-2 elements of a controller file as :class:`_Discrete` keyword arguments (SI)."""
    out: dict[str, Any] = {
        "velocity_filter": _read(d.get("velocity_filter", 0.0), "s", "velocity_filter")
    }
    m = d.get("machine")
    if m:
        out["machine"] = {
            k: _read(v, _MACHINE[k][2], f"machine.{k}") for k, v in m.items() if k in _MACHINE
        }
    ff = d.get("feedforward")
    if ff is not None:
        kw: dict[str, Any] = {
            k: _read(ff[k], _FF[k][2], f"feedforward.{k}") for k in _FF if k in ff
        }
        kw["reference_state"] = bool(ff.get("reference_state", True))
        # optional: the regularised root's transition (absent: 0, the plain root √Δp)
        kw.setdefault("transition_pressure", 0.0)
        out["feedforward"] = FlowFeedForward(**kw)
    po = d.get("position_observer")
    if po is not None:
        out["position_observer"] = (
            _read(po["gain_x"], "", "position_observer.gain_x"),
            _read(po["gain_v"], "1/s", "position_observer.gain_v"),
        )
    sm = d.get("spool_model")
    if sm is not None:
        out["spool_model"] = SpoolModel(
            tuple(sm["phi"]),
            tuple(sm["gamma"]),
            measured=bool(sm.get("measured", False)),
            gain=tuple(sm.get("gain", (0.0, 0.0))),
            noise=dict(sm.get("noise", {})),
        )
    ver = d.get("verification")
    if ver:
        out["verification"] = dict(ver)
    return out


def controller_schema(version: int = 2) -> dict[str, Any]:
    """The JSON Schema (draft 2020-12) of ``hydropwa.controller/<version>`` files (2, or 3: a force
    or pressure controller), shipped in the package."""
    text = (
        files("hydropwa.control")
        .joinpath(f"schemas/controller-{int(version)}.schema.json")
        .read_text("utf-8")
    )
    return json.loads(text)


def save_controller(
    ctrl,
    path: str | os.PathLike,
    *,
    overwrite: bool = False,
    force: bool | None = None,
    machine_parameters=None,
) -> Path:
    """Write a controller to ``.toml`` or ``.json`` atomically; refuses to overwrite without ``overwrite``.

    ``machine_parameters`` (a :class:`~hydropwa.params.SystemParams`, optional): the machine
    the controller was designed for, written as ``[machine.parameters]`` (SI), so that
    ``hydropwa control simulate`` runs it on that machine without ``--params``.
    """
    path = Path(path)
    overwrite = overwrite_flag(overwrite, force, "save_controller")
    check_output(path, overwrite)
    d = controller_to_dict(ctrl)
    if machine_parameters is not None:
        d.setdefault("machine", {})["parameters"] = machine_parameters.to_dict()
    if path.suffix.lower() == ".json":
        return atomic_write_text(path, json.dumps(d, indent=2) + "\n")
    if path.suffix.lower() == ".toml":
        return atomic_write_text(path, tomli_w.dumps(d))
    raise ControlError(f"controller file {path} must end in .toml or .json")


def load_controller(path: str | os.PathLike):
    """Read a controller file written by :func:`save_controller` (or by hand, same schema)."""
    path = Path(path)
    if not path.is_file():
        raise ControlError(f"controller file {path} does not exist")
    text = read_text(path, "controller file", ControlError)
    try:
        if path.suffix.lower() == ".json":
            d = json.loads(text)
        else:
            d = tomllib.loads(text)
    except (json.JSONDecodeError, tomllib.TOMLDecodeError) as exc:
        raise ControlError(f"controller file {path} cannot be parsed: {exc}") from None
    except RecursionError:
        raise ControlError(f"controller file {path} is nested too deeply to be one") from None
    return controller_from_dict(d)
