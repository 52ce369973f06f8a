"""JSON export of the PWA model for control design (MPT3-style polyhedral PWA systems).

Document (schema ``hydropwa.pwa/1``)::

    {"schema": "hydropwa.pwa/1", "time": "continuous" | "discrete", "sample_time": s | null,
     "form", "scheduled", "supply_pressure" [Pa], "input_range", "breakpoints",
     "state": [{"name": "p_l", "unit": "Pa"}, {"name": "v", "unit": "m/s"}, {"name": "x", "unit": "m"}],
     "input": [{"name": "u", "unit": "1"}],
     "params": SystemParams.to_dict() (SI),
     "cell_sets": {"dead_zone", "cq", "cqp", "friction": breakpoints, slopes, offsets, ...},
     "cells": [{"index": {g, s, o, n, w}, "H": [[...]], "h": [...], "A", "B", "f", "working_point"}]}

Each cell is the box H·[P_L, v, x, u] <= h of one cell combination at the document's supply
pressure. Because of the bilinear u·P_L term the dynamics are not affine inside a cell;
A, B, f are the Jacobian linearization of the PWA right-hand side at the cell's working
point (tangent point of the C_q cell, friction working point, middle of the command cell,
mid-stroke), so they are exact at that point and first-order accurate in the cell. End stops
are not part of the export. The model itself is rebuilt from ``params`` and ``cell_sets``.
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

import numpy as np

from .._display import channel_unit
from .._errors import HydropwaError, PwaError
from .._io import atomic_path, atomic_write_text, check_output, read_text
from .._layout import CHAMBER_KIND, FULL_STATES
from ..components import PiecewiseAffine
from ..params import params_from_dict
from ._chamber import CapacitanceCells, ChamberCellIndex, ChamberPwaModel, FlowCells
from ._fit import PwaFit
from ._model import PwaModel

__all__ = [
    "SCHEMA",
    "UNITS",
    "model_to_dict",
    "model_from_dict",
    "export_pwa",
    "save_pwa",
    "load_pwa",
    "pwa_statespaces",
    "save_pwa_mat",
]

SCHEMA = "hydropwa.pwa/1"
_STATE = [{"name": "p_l", "unit": "Pa"}, {"name": "v", "unit": "m/s"}, {"name": "x", "unit": "m"}]
_INPUT = [{"name": "u", "unit": "1"}]
_SETS = {
    "dead_zone": ("u", "1", "1"),
    "cq": ("p_tilde = sign(z) P_L / P_e", "1", "C_q / (K sqrt(P_e/(1 + alpha^3)))"),
    "cqp": ("p_tilde = sign(z) P_L / P_S", "1", "C_qp / (|z| K / (4 sqrt(P_S/2)))"),
    "friction": ("v", "m/s", "N"),
}


def _pwa_dict(pwa: PiecewiseAffine) -> dict[str, Any]:
    return {
        "breakpoints": pwa.breakpoints.tolist(),
        "slopes": pwa.slopes.tolist(),
        "offsets": pwa.offsets.tolist(),
    }


def _fit_dict(fit: PwaFit) -> dict[str, Any]:
    d = _pwa_dict(fit.pwa)
    d.update(
        interval=list(fit.interval),
        working_points=fit.working_points.tolist(),
        max_error=fit.max_error,
        rms_error=fit.rms_error,
        method=fit.method,
    )
    return d


def model_to_dict(model) -> dict[str, Any]:
    """Model → JSON-ready dict without the per-cell dynamics (see :func:`export_pwa`)."""
    sets: dict[str, Any] = {"dead_zone": _pwa_dict(model.dead_zone)}
    for key in ("cq", "cqp", "friction"):
        sets[key] = _fit_dict(getattr(model, key))
    for key, (var, unit, value) in _SETS.items():
        sets[key].update(variable=var, variable_unit=unit, value=value)
    return {
        "schema": SCHEMA,
        "form": model.form,
        "scheduled": model.scheduled,
        "supply_pressure": model.supply_pressure,
        "input_range": list(model.input_range),
        "breakpoints": model.breakpoints,
        "capacitance_position": model.capacitance_position,
        "area_ratio": model.area_ratio,
        "state": _STATE,
        "input": _INPUT,
        "params": model.params.to_dict(),
        "cell_sets": sets,
    }


#: Schema of the chamber-level model's document (``pwa-chamber``).
CHAMBER_SCHEMA = "hydropwa.pwa-chamber/1"
#: Most cell combinations of the chamber model exported without an explicit ``cells`` list.
MAX_CHAMBER_CELLS = 5000
_CHAMBER_STATE = [{"name": n, "unit": u} for n, u, _s in FULL_STATES]
_CHAMBER_SETS = {
    "dead_zone": ("spool", "1", "z [1]"),
    "flow": ("q = Delta P / P_S of a metering edge", "1", "Q / (z K sqrt(P_S))"),
    "capacitance": ("x", "m", "x_j at which V_A, V_B are evaluated [m]"),
    "friction": ("v", "m/s", "N"),
}


def chamber_to_dict(model) -> dict[str, Any]:
    """Chamber model → JSON-ready dict without per-cell dynamics (see :func:`export_pwa`)."""
    cap = model.capacitance
    fl = model.flow
    sets: dict[str, Any] = {
        "dead_zone": _pwa_dict(model.dead_zone),
        "flow": {
            **_pwa_dict(fl.pwa),
            "bounds": fl.bounds.tolist(),
            "interval": list(fl.interval),
            "eps": fl.eps,
            "tolerance": fl.tolerance,
        },
        "capacitance": {
            "breakpoints": cap.breakpoints.tolist(),
            "slopes": [0.0] * cap.n_cells,
            "offsets": cap.centres.tolist(),
            "bounds": cap.bounds.tolist(),
            "tolerance": cap.tolerance,
        },
        "friction": _fit_dict(model.friction),
    }
    for key, (var, unit, value) in _CHAMBER_SETS.items():
        sets[key].update(variable=var, variable_unit=unit, value=value)
    return {
        "schema": CHAMBER_SCHEMA,
        "form": "chamber",
        "scheduled": model.scheduled,
        "supply_pressure": model.supply_pressure,
        "state": _CHAMBER_STATE,
        "input": _INPUT,
        "params": model.params.to_dict(),
        "cell_sets": sets,
    }


def chamber_from_dict(data: dict[str, Any]):
    """Rebuild a :class:`~._chamber.ChamberPwaModel` from :func:`chamber_to_dict` output."""
    try:
        params = params_from_dict(
            _need(data, "params", "document"), source="PWA document", check_bare=False
        )
        sets = _need(data, "cell_sets", "document")
        f = _need(sets, "flow", "cell_sets")
        c = _need(sets, "capacitance", "cell_sets")
        iv = _need(f, "interval", "cell_sets.flow")
        flow = FlowCells(
            _pwa_from(f, "cell_sets.flow"),
            np.asarray(_need(f, "bounds", "cell_sets.flow"), dtype=float),
            (float(iv[0]), float(iv[1])),
            float(_need(f, "eps", "cell_sets.flow")),
            float(_need(f, "tolerance", "cell_sets.flow")),
        )
        cap = CapacitanceCells(
            np.asarray(_need(c, "breakpoints", "cell_sets.capacitance"), dtype=float),
            np.asarray(_need(c, "offsets", "cell_sets.capacitance"), dtype=float),
            np.asarray(_need(c, "bounds", "cell_sets.capacitance"), dtype=float),
            float(_need(c, "tolerance", "cell_sets.capacitance")),
        )
        return ChamberPwaModel(
            params=params,
            dead_zone=_pwa_from(_need(sets, "dead_zone", "cell_sets"), "cell_sets.dead_zone"),
            flow=flow,
            capacitance=cap,
            friction=_fit_from(_need(sets, "friction", "cell_sets"), "cell_sets.friction"),
            scheduled=bool(_need(data, "scheduled", "document")),
            supply_pressure=float(_need(data, "supply_pressure", "document")),
        )
    except PwaError:
        raise
    except HydropwaError as exc:
        raise PwaError(f"PWA document: {exc}") from None
    except (TypeError, ValueError, IndexError, KeyError) as exc:
        raise PwaError(f"PWA document does not match schema {CHAMBER_SCHEMA}: {exc}") from None


def _need(d: dict, key: str, where: str):
    if not isinstance(d, dict) or key not in d:
        raise PwaError(f"PWA document: {where} has no {key!r} (schema {SCHEMA})")
    return d[key]


def _pwa_from(d: dict, where: str) -> PiecewiseAffine:
    return PiecewiseAffine(
        _need(d, "breakpoints", where), _need(d, "slopes", where), _need(d, "offsets", where)
    )


def _fit_from(d: dict, where: str) -> PwaFit:
    pwa = _pwa_from(d, where)
    interval = _need(d, "interval", where)
    wp = np.asarray(_need(d, "working_points", where), dtype=float)
    if wp.shape != (pwa.n_cells,):
        raise PwaError(
            f"PWA document: {where} has {wp.size} working points for {pwa.n_cells} cells"
        )
    return PwaFit(
        pwa,
        (float(interval[0]), float(interval[1])),
        wp,
        float(_need(d, "max_error", where)),
        float(_need(d, "rms_error", where)),
        str(_need(d, "method", where)),
    )


def model_from_dict(data: dict[str, Any]):
    """Rebuild a :class:`PwaModel` from :func:`model_to_dict` / :func:`export_pwa` output.

    Raises
    ------
    PwaError
        Wrong schema, missing keys, malformed cells or parameters.
    """
    if not isinstance(data, dict):
        raise PwaError(f"PWA document must be a JSON object, got {type(data).__name__}")
    schema = data.get("schema")
    if schema == CHAMBER_SCHEMA:
        return chamber_from_dict(data)
    if schema != SCHEMA:
        raise PwaError(f"PWA document schema {schema!r} is not {SCHEMA!r} or {CHAMBER_SCHEMA!r}")
    try:
        params = params_from_dict(
            _need(data, "params", "document"), source="PWA document", check_bare=False
        )
        sets = _need(data, "cell_sets", "document")
        ir = _need(data, "input_range", "document")
        return PwaModel(
            params=params,
            dead_zone=_pwa_from(_need(sets, "dead_zone", "cell_sets"), "cell_sets.dead_zone"),
            cq=_fit_from(_need(sets, "cq", "cell_sets"), "cell_sets.cq"),
            cqp=_fit_from(_need(sets, "cqp", "cell_sets"), "cell_sets.cqp"),
            friction=_fit_from(_need(sets, "friction", "cell_sets"), "cell_sets.friction"),
            form=str(_need(data, "form", "document")),
            scheduled=bool(_need(data, "scheduled", "document")),
            supply_pressure=float(_need(data, "supply_pressure", "document")),
            input_range=(float(ir[0]), float(ir[1])),
            breakpoints=str(_need(data, "breakpoints", "document")),
            capacitance_position=data.get("capacitance_position"),
        )
    except PwaError:
        raise
    except HydropwaError as exc:
        raise PwaError(f"PWA document: {exc}") from None
    except (TypeError, ValueError, IndexError, KeyError) as exc:
        raise PwaError(f"PWA document does not match schema {SCHEMA}: {exc}") from None


def _box_rows(lower: np.ndarray, upper: np.ndarray) -> tuple[list, list]:
    n = lower.size
    H, h = [], []
    for i in range(n):
        e = np.zeros(n)
        e[i] = 1.0
        H.append(e.tolist())
        h.append(float(upper[i]))
        H.append((-e).tolist())
        h.append(float(-lower[i]))
    return H, h


#: Unit systems of the exported matrices: factor from SI to the unit, per variable of [P_L, v, x, u].
UNITS: dict[str, tuple[tuple[str, float], ...]] = {
    "si": (("Pa", 1.0), ("m/s", 1.0), ("m", 1.0), ("1", 1.0)),
    "engineering": tuple(channel_unit(u) for u in ("Pa", "m/s", "m", "1")),
}
#: Most bisections of one cell while refining it below ``refine_tol``.
MAX_REFINE_DEPTH = 12


def _state_doc(model, units: str) -> tuple[list, list]:
    (pu, _), (vu, _), (xu, _), (uu, _) = UNITS[units]
    al = model.area_ratio
    state = [
        {"name": "p_l", "unit": pu, "definition": f"P_A - alpha*P_B, alpha = {al:.6g}"},
        {"name": "v", "unit": vu, "definition": "rod velocity dx/dt"},
        {"name": "x", "unit": xu, "definition": "rod position"},
    ]
    return state, [{"name": "u", "unit": uu, "definition": "valve command (1 = 100 % opening)"}]


def _split(lower: np.ndarray, upper: np.ndarray, depth: int, model, idx, ps, tol, wp_v, poly):
    """Boxes (lower, upper, dynamics, bound) covering one cell, bisected until bound <= tol."""
    wp = {
        "p_l": 0.5 * (lower[0] + upper[0]),
        "v": float(np.clip(wp_v, lower[1], upper[1])),
        "x": model.x_capacitance,
        "u": 0.5 * (lower[3] + upper[3]),
    }
    dyn = model.state_space(wp, p_s=ps)
    bound = model.error_bound(idx, dyn, lower, upper, polynomial=poly)
    if tol is None or bound <= tol or depth >= MAX_REFINE_DEPTH:
        return [(lower, upper, dyn, bound)]
    # e = c·ΔP·Δu (bilinear): halve the side with the larger share of the error, P_L first
    k = 0 if depth % 2 == 0 else 3
    mid = 0.5 * (lower[k] + upper[k])
    up1, lo2 = upper.copy(), lower.copy()
    up1[k], lo2[k] = mid, mid
    return _split(lower, up1, depth + 1, model, idx, ps, tol, wp_v, poly) + _split(
        lo2, upper, depth + 1, model, idx, ps, tol, wp_v, poly
    )


def export_pwa(
    model,
    *,
    supply_pressure: float | None = None,
    sample_time: float | None = None,
    refine_tol: float | None = None,
    units: str = "si",
    cells=None,
    max_cells: int = MAX_CHAMBER_CELLS,
) -> dict[str, Any]:
    """The model with one affine system per cell, continuous or ZOH-discretised.

    Parameters
    ----------
    model : PwaModel
    supply_pressure : float, optional
        P_S [Pa] at which the cells are evaluated; default the model's fixed P_S.
    sample_time : float, optional
        If given, each cell is discretised with a zero-order hold of this period [s]
        (affine term included, see :meth:`AffineDynamics.discretize`).
    refine_tol : float, optional
        Bisect each cell (in P_L and u) until its guaranteed vector-field error bound is at
        most this many Pa/s of Ṗ_L (at most ``MAX_REFINE_DEPTH`` bisections per cell).
    units : {"si", "engineering"}
        ``si``: Pa, m/s, m, command in [1]; ``engineering``: bar, mm/s, mm, command in %,
        so that the matrices are well conditioned. The document names its units.
    cells : iterable of (g, s, a, b, j, w), optional
        Chamber model (``pwa-chamber``) only: the cell combinations to export (e.g.
        :meth:`~._chamber.ChamberPwaModel.visited_cells` of a run); default all of them,
        refused beyond ``max_cells`` (the product of its cell sets is large).
    max_cells : int
        Chamber model: most combinations exported without an explicit ``cells``.

    Returns
    -------
    dict
        JSON-ready document (module docstring); ``cells`` lists every non-empty cell (or
        refined piece of one) with A, B, f, the polyhedron H·[y; u] <= h, the working point
        and ``error_bound``: the guaranteed maximum of |Ṗ_L(PWA) − (A y + B u + f)₀| over
        the polyhedron (the other rows are exact), in the document's pressure unit per second.
        Chamber model: the state is the full model's, the bound covers Ṗ_A and Ṗ_B (the rows
        with the bilinear z·ΔP terms; the others are affine in a cell and exact).
    """
    if _is_chamber(model):
        if refine_tol is not None:
            raise PwaError(
                "refine_tol applies to the load-pressure forms; the chamber form's cells follow tolerances"
            )
        return _export_chamber(model, supply_pressure, sample_time, units, cells, max_cells)
    if cells is not None:
        raise PwaError("cells= selects cell combinations of the chamber form (pwa-chamber)")
    if units not in UNITS:
        raise PwaError(f"units {units!r} must be one of {', '.join(UNITS)}")
    if refine_tol is not None and not (isinstance(refine_tol, int | float) and refine_tol > 0):
        raise PwaError(f"refine tolerance {refine_tol!r} must be a positive number of Pa/s")
    ps = model.supply_pressure if supply_pressure is None else float(supply_pressure)
    doc = model_to_dict(model)
    doc["state"], doc["input"] = _state_doc(model, units)
    doc["units"] = units
    doc["variable_order"] = ["p_l", "v", "x", "u"]
    doc["export_supply_pressure"] = ps
    doc["time"] = "continuous" if sample_time is None else "discrete"
    doc["sample_time"] = None if sample_time is None else float(sample_time)
    doc["refine_tol"] = refine_tol
    doc["error_bound_note"] = (
        "error_bound: guaranteed max over the cell of |dP_L/dt of the PWA model - (A y + B u + f)[0]| "
        "of the continuous-time vector field, in the state's pressure unit per second; other rows exact"
    )
    sc = np.array([f for _u, f in UNITS[units]])
    T = np.diag(sc[:3])
    Ti = np.diag(1.0 / sc[:3])
    cells = []
    for idx, lower, upper in model.regions(ps):
        wp = model.working_point((idx.g, idx.s, idx.o, idx.w), ps)
        poly = model._row0_polynomial(idx, ps, model.params.load.force, (lower, upper))
        for lo, hi, dyn, bound in _split(
            lower, upper, 0, model, idx, ps, refine_tol, wp["v"], poly
        ):
            if sample_time is not None:
                dyn = dyn.discretize(sample_time)
            H, h = _box_rows(lo * sc, hi * sc)
            point = {
                k: float(dyn.point[k]) * f for k, f in zip(("p_l", "v", "x", "u"), sc, strict=True)
            }
            point["p_s"] = float(dyn.point["p_s"]) * sc[0]
            cells.append(
                {
                    "index": idx._asdict(),
                    "H": H,
                    "h": h,
                    "A": (T @ dyn.A @ Ti).tolist(),
                    "B": (T @ dyn.B / sc[3]).tolist(),
                    "f": (T @ dyn.f).tolist(),
                    "working_point": point,
                    "error_bound": bound * sc[0],
                }
            )
    doc["cells"] = cells
    doc["max_error_bound"] = max(c["error_bound"] for c in cells) if cells else 0.0
    return doc


def pwa_statespaces(
    model,
    *,
    supply_pressure: float | None = None,
    sample_time: float | None = None,
    refine_tol: float | None = None,
    units: str = "si",
    cells=None,
) -> list[dict[str, Any]]:
    """python-control ``StateSpace`` objects of all cells, with f as an extra input.

    Returns
    -------
    list of dict
        One entry per exported cell: ``sys`` (``control.StateSpace`` with inputs
        ``["u", "one"]``, ``B = [B, f]``: feed the constant 1 on the second input; outputs =
        states), ``H``, ``h`` (polyhedron over [y; u]), ``index``, ``working_point``,
        ``error_bound`` — in the units of :func:`export_pwa`.
    """
    import control  # deferred: python-control is only needed here

    doc = export_pwa(
        model,
        supply_pressure=supply_pressure,
        sample_time=sample_time,
        refine_tol=refine_tol,
        units=units,
        cells=cells,
    )
    names = [v["name"] for v in doc["state"]]
    n = len(names)
    out = []
    for c in doc["cells"]:
        A, B, f = np.array(c["A"]), np.array(c["B"]), np.array(c["f"])
        args: tuple[Any, ...] = (A, np.hstack((B, f[:, None])), np.eye(n), np.zeros((n, 2)))
        if doc["sample_time"] is not None:
            args = args + (doc["sample_time"],)
        sys = control.ss(*args, inputs=["u", "one"], outputs=names, states=names)
        out.append(
            {
                "sys": sys,
                "H": np.array(c["H"]),
                "h": np.array(c["h"]),
                "index": c["index"],
                "working_point": c["working_point"],
                "error_bound": c["error_bound"],
            }
        )
    return out


def save_pwa_mat(
    model,
    path: str | os.PathLike,
    *,
    supply_pressure: float | None = None,
    sample_time: float | None = None,
    refine_tol: float | None = None,
    units: str = "si",
    overwrite: bool = False,
    cells=None,
) -> Path:
    """MPT3-style MATLAB export: cell arrays A, B, f, H, h (regions H·[x; u] <= h).

    In MATLAB (MPT3)::

        d = load('pwa.mat');
        for i = 1:numel(d.A)
            sys(i) = LTISystem('A', d.A{i}, 'B', d.B{i}, 'f', d.f{i}, 'Ts', d.Ts);
            sys(i).setDomain('xu', Polyhedron('A', d.H{i}, 'b', d.h{i}));
        end
        pwa = PWASystem(sys);

    ``Ts`` is 0 for continuous time; ``state_names``, ``state_units``, ``error_bound`` and
    ``cell_index`` (g, s, o, n, w per row; chamber model: g, s, a, b, j, w) come along.
    """
    from scipy.io import savemat  # deferred: scipy submodules cost 0.1-0.5 s at import

    target = Path(path)
    if target.exists() and not overwrite:
        raise PwaError(f"{target} exists; pass overwrite=True (--force) to replace it")
    doc = export_pwa(
        model,
        supply_pressure=supply_pressure,
        sample_time=sample_time,
        refine_tol=refine_tol,
        units=units,
        cells=cells,
    )
    keys = tuple(doc["cells"][0]["index"]) if doc["cells"] else ("g", "s", "o", "n", "w")

    def cellarr(key):
        arr = np.empty((len(doc["cells"]), 1), dtype=object)
        for i, c in enumerate(doc["cells"]):
            v = np.array(c[key], dtype=float)
            arr[i, 0] = v[:, None] if v.ndim == 1 else v
        return arr

    data = {
        "A": cellarr("A"),
        "B": cellarr("B"),
        "f": cellarr("f"),
        "H": cellarr("H"),
        "h": cellarr("h"),
        "Ts": 0.0 if doc["sample_time"] is None else doc["sample_time"],
        "error_bound": np.array([c["error_bound"] for c in doc["cells"]]),
        "cell_index": np.array([[c["index"][k] for k in keys] for c in doc["cells"]], dtype=float),
        "state_names": np.array([v["name"] for v in doc["state"]], dtype=object),
        "state_units": np.array([v["unit"] for v in doc["state"]], dtype=object),
        "input_unit": doc["input"][0]["unit"],
        "supply_pressure_Pa": doc["export_supply_pressure"],
        "area_ratio": model.area_ratio if not _is_chamber(model) else 1.0,
    }
    try:
        with atomic_path(target, suffix=".mat") as tmp:
            savemat(tmp, data, do_compression=True)
    except OSError as exc:
        raise PwaError(f"cannot write {target}: {exc.strerror}") from None
    return target


def save_pwa(
    model,
    path: str | os.PathLike,
    *,
    supply_pressure: float | None = None,
    sample_time: float | None = None,
    refine_tol: float | None = None,
    units: str = "si",
    overwrite: bool = False,
    cells=None,
) -> Path:
    """Write :func:`export_pwa` as JSON (atomically) and return the path; an existing file
    raises :class:`~hydropwa.OutputExistsError` unless ``overwrite``."""
    check_output(path, overwrite)
    doc = export_pwa(
        model,
        supply_pressure=supply_pressure,
        sample_time=sample_time,
        refine_tol=refine_tol,
        units=units,
        cells=cells,
    )
    return atomic_write_text(path, json.dumps(doc, indent=1) + "\n", overwrite=overwrite)


def load_pwa(path: str | os.PathLike):
    """Read a PWA JSON document back into a :class:`PwaModel` (or, for a document of schema
    ``hydropwa.pwa-chamber/1``, a :class:`~._chamber.ChamberPwaModel`); PwaError on schema
    mismatch."""
    try:
        text = read_text(path, "PWA document", PwaError)
    except OSError as exc:
        raise PwaError(f"cannot read PWA document {path}: {exc.strerror}") from None
    return PwaModel.from_json(text)


# --- the chamber-level model (pwa-chamber) ----------------------------------------------
#: Chamber model: factor from SI to each unit system, per variable of [state..., u].
_CHAMBER_SI = tuple((unit, 1.0) for _name, unit, _scale in FULL_STATES) + (("1", 1.0),)
_CHAMBER_UNITS: dict[str, tuple[tuple[str, float], ...]] = {
    "si": _CHAMBER_SI,
    "engineering": tuple(channel_unit(unit) for unit, _ in _CHAMBER_SI),
}


def _is_chamber(model) -> bool:
    return getattr(model, "name", None) == CHAMBER_KIND.name


def chamber_regions(model, cells, ps: float):
    """Boxes over [state..., u] (SI) of chamber cell combinations (g, s, a, b, j, w).

    Spool: the dead-zone cell on the side of sign s; spool rate ±5 ω0; P_A, P_B: the
    pressures whose normalised edge drops lie in flow cells a, b (the covered interval); x:
    the capacitance cell within the stroke; ẋ: the friction cell within its fit interval; P_S
    the export's; P_acc with P_A; u within ±1.5.
    """
    e = model.flow.edges()
    cap = model.capacitance
    xb = np.concatenate(
        (
            [0.0],
            np.clip(cap.breakpoints, 0.0, model.params.cylinder.stroke),
            [model.params.cylinder.stroke],
        )
    )
    vlo, vhi = model.friction.interval
    vb = np.concatenate(([vlo], np.clip(model.friction.pwa.breakpoints, vlo, vhi), [vhi]))
    pt = model.params.supply.tank_pressure
    rate = 5.0 * model.params.valve.omega0
    out = []
    for c in cells:
        idx = ChamberCellIndex(*(int(i) for i in c))
        lo_nu, hi_nu = model._spool_bounds(idx.g, idx.s)
        qa, qb = (e[idx.a], e[idx.a + 1]), (e[idx.b], e[idx.b + 1])
        if idx.s > 0:
            pa, pb = (ps * (1.0 - qa[1]), ps * (1.0 - qa[0])), (pt + ps * qb[0], pt + ps * qb[1])
        else:
            pa, pb = (pt + ps * qa[0], pt + ps * qa[1]), (ps * (1.0 - qb[1]), ps * (1.0 - qb[0]))
        lower = np.array([lo_nu, -rate, pa[0], pb[0], xb[idx.j], vb[idx.w], ps, pa[0], -1.5])
        upper = np.array([hi_nu, rate, pa[1], pb[1], xb[idx.j + 1], vb[idx.w + 1], ps, pa[1], 1.5])
        out.append((idx, lower, upper))
    return out


def _chamber_bound(model, dyn, lower, upper, ps: float) -> float:
    """Guaranteed max of |Ṗ_A, Ṗ_B (PWA) − (A y + B u + f)| over a chamber cell's box [Pa/s].

    Inside a cell the pressure rows are bilinear in (ν, P_A) and (ν, P_B) and affine in the
    rest (constant bulk modulus above the release pressure: the box is clipped there), so the
    error of the tangent plane is extreme at the corners of the (ν, P_A, P_B) box.
    """
    prel = model.params.oil.release_pressure
    y0 = np.array([dyn.point[n] for n in model.state_names])
    u0 = float(dyn.point["u"])
    worst = 0.0
    for nu in (lower[0], upper[0]):
        for pa in (max(lower[2], prel), max(upper[2], prel)):
            for pb in (max(lower[3], prel), max(upper[3], prel)):
                y = y0.copy()
                y[0], y[2], y[3] = nu, pa, pb
                # the cell's own nonlinearity only: stay inside its cells (edges nudged inward)
                y[0] = min(max(nu, lower[0] + 1e-12), upper[0] - 1e-12)
                f = model.point(y, u0, ps)[0]
                lin = dyn.A @ y + dyn.B[:, 0] * u0 + dyn.f
                worst = max(worst, abs(f[2] - lin[2]), abs(f[3] - lin[3]))
    return float(worst)


def _export_chamber(model, supply_pressure, sample_time, units, cells, max_cells):
    """:func:`export_pwa` of the chamber model (one affine system per cell combination)."""
    if units not in _CHAMBER_UNITS:
        raise PwaError(f"units {units!r} must be one of {', '.join(_CHAMBER_UNITS)}")
    ps = model.supply_pressure if supply_pressure is None else float(supply_pressure)
    if cells is None:
        n = 0
        combos = []
        for g in range(model.dead_zone.n_cells):
            for s in (1, -1):
                lo, hi = model._spool_bounds(g, s)
                z = model.dead_zone.slopes[g] * 0.5 * (lo + hi) + model.dead_zone.offsets[g]
                if hi > lo and (1 if z >= 0 else -1) == s:
                    combos.append((g, s))
        nf, nx, nw = model.flow.n_cells, model.capacitance.n_cells, model.friction.n_cells
        n = len(combos) * nf * nf * nx * nw
        if n > max_cells:
            raise PwaError(
                f"the chamber model has {n} cell combinations (more than max_cells = {max_cells}); "
                "pass cells=model.visited_cells(result) for those a run visits, or raise max_cells"
            )
        cells = [
            ChamberCellIndex(g, s, a, b, j, w)
            for g, s in combos
            for a in range(nf)
            for b in range(nf)
            for j in range(nx)
            for w in range(nw)
        ]
    doc = chamber_to_dict(model)
    sc = np.array([f for _u, f in _CHAMBER_UNITS[units]])
    doc["state"] = [
        {"name": n, "unit": u}
        for n, (u, _f) in zip(model.state_names, _CHAMBER_UNITS[units], strict=False)
    ]
    doc["input"] = [
        {"name": "u", "unit": _CHAMBER_UNITS[units][-1][0], "definition": "valve command"}
    ]
    doc["units"] = units
    doc["variable_order"] = [*model.state_names, "u"]
    doc["export_supply_pressure"] = ps
    doc["time"] = "continuous" if sample_time is None else "discrete"
    doc["sample_time"] = None if sample_time is None else float(sample_time)
    doc["error_bound_note"] = (
        "error_bound: guaranteed max over the cell of |dP_A/dt, dP_B/dt of the PWA model - (A y + B u + f)| "
        "of the continuous-time vector field, in the state's pressure unit per second; other rows exact"
    )
    ns = len(model.state_names)
    T = np.diag(sc[:ns])
    Ti = np.diag(1.0 / sc[:ns])
    out = []
    for idx, lower, upper in chamber_regions(model, cells, ps):
        dyn = model.state_space(cells=idx, p_s=ps)
        bound = _chamber_bound(model, dyn, lower, upper, ps)
        if sample_time is not None:
            dyn = dyn.discretize(sample_time)
        H, h = _box_rows(lower * sc, upper * sc)
        point = {k: float(dyn.point[k]) * f for k, f in zip(doc["variable_order"], sc, strict=True)}
        out.append(
            {
                "index": {k: int(v) for k, v in idx._asdict().items()},
                "H": H,
                "h": h,
                "A": (T @ dyn.A @ Ti).tolist(),
                "B": (T @ dyn.B / sc[-1]).tolist(),
                "f": (T @ dyn.f).tolist(),
                "working_point": point,
                "error_bound": bound * sc[2],
            }
        )
    doc["cells"] = out
    doc["max_error_bound"] = max(c["error_bound"] for c in out) if out else 0.0
    return doc
