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

from .._errors import HydropwaError, PwaError
from .._io import atomic_write_text
from ..components import PiecewiseAffine
from ._fit import PwaFit

__all__ = ["SCHEMA", "model_to_dict", "model_from_dict", "export_pwa", "save_pwa", "load_pwa"]

SCHEMA = "hydropwa.pwa/1"
_STATE = [{"name": "p_l", "unit": "Pa"}, {"name": "v", "unit": "m/s"}, {"name": "x", "unit": "m"}]
_INPUT = [{"name": "u", "unit": "1"}]
_SETS = {
    "dead_zone": ("u", "1", "1"),
    "cq": ("p_tilde = sign(z) P_L / P_S", "1", "C_q / (K sqrt(P_S/2))"),
    "cqp": ("p_tilde = sign(z) P_L / P_S", "1", "C_qp / (|z| K / (4 sqrt(P_S/2)))"),
    "friction": ("v", "m/s", "N"),
}


def _pwa_dict(pwa: PiecewiseAffine) -> dict[str, Any]:
    return {"breakpoints": pwa.breakpoints.tolist(), "slopes": pwa.slopes.tolist(), "offsets": pwa.offsets.tolist()}


def _fit_dict(fit: PwaFit) -> dict[str, Any]:
    d = _pwa_dict(fit.pwa)
    d.update(interval=list(fit.interval), working_points=fit.working_points.tolist(), max_error=fit.max_error,
             rms_error=fit.rms_error, method=fit.method)
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
        "state": _STATE,
        "input": _INPUT,
        "params": model.params.to_dict(),
        "cell_sets": sets,
    }


def _need(d: dict, key: str, where: str):
    if not isinstance(d, dict) or key not in d:
        raise PwaError(f"PWA document: {where} has no {key!r} (schema {SCHEMA})")
    return d[key]


def _pwa_from(d: dict, where: str) -> PiecewiseAffine:
    return PiecewiseAffine(_need(d, "breakpoints", where), _need(d, "slopes", where), _need(d, "offsets", where))


def _fit_from(d: dict, where: str) -> PwaFit:
    pwa = _pwa_from(d, where)
    interval = _need(d, "interval", where)
    wp = np.asarray(_need(d, "working_points", where), dtype=float)
    if wp.shape != (pwa.n_cells,):
        raise PwaError(f"PWA document: {where} has {wp.size} working points for {pwa.n_cells} cells")
    return PwaFit(pwa, (float(interval[0]), float(interval[1])), wp, float(_need(d, "max_error", where)),
                  float(_need(d, "rms_error", where)), str(_need(d, "method", where)))


def model_from_dict(data: dict[str, Any]):
    """Rebuild a :class:`PwaModel` from :func:`model_to_dict` / :func:`export_pwa` output.

    Raises
    ------
    PwaError
        Wrong schema, missing keys, malformed cells or parameters.
    """
    from ..params import params_from_dict
    from ._model import PwaModel

    if not isinstance(data, dict):
        raise PwaError(f"PWA document must be a JSON object, got {type(data).__name__}")
    schema = data.get("schema")
    if schema != SCHEMA:
        raise PwaError(f"PWA document schema {schema!r} is not {SCHEMA!r}")
    try:
        params = params_from_dict(_need(data, "params", "document"), source="PWA document")
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


def export_pwa(model, *, supply_pressure: float | None = None, sample_time: float | None = None) -> dict[str, Any]:
    """The model with one affine system per cell, continuous or ZOH-discretised.

    Parameters
    ----------
    model : PwaModel
    supply_pressure : float, optional
        P_S [Pa] at which the cells are evaluated; default the model's fixed P_S.
    sample_time : float, optional
        If given, each cell is discretised with a zero-order hold of this period [s]
        (affine term included, see :meth:`AffineDynamics.discretize`).

    Returns
    -------
    dict
        JSON-ready document (module docstring); ``cells`` lists every non-empty cell.
    """
    ps = model.supply_pressure if supply_pressure is None else float(supply_pressure)
    doc = model_to_dict(model)
    doc["export_supply_pressure"] = ps
    doc["time"] = "continuous" if sample_time is None else "discrete"
    doc["sample_time"] = None if sample_time is None else float(sample_time)
    cells = []
    for idx, lower, upper in model.regions(ps):
        wp = model.working_point((idx.g, idx.s, idx.o, idx.w), ps)
        wp["p_l"] = float(np.clip(wp["p_l"], lower[0], upper[0]))
        wp["v"] = float(np.clip(wp["v"], lower[1], upper[1]))
        if model.form == "paper":
            wp["p_l"] = 0.5 * (lower[0] + upper[0]) if not lower[0] <= wp["p_l"] < upper[0] else wp["p_l"]
        dyn = model.state_space(wp, p_s=ps)
        if sample_time is not None:
            dyn = dyn.discretize(sample_time)
        H, h = _box_rows(lower, upper)
        cells.append({
            "index": idx._asdict(),
            "H": H,
            "h": h,
            "A": dyn.A.tolist(),
            "B": dyn.B.tolist(),
            "f": dyn.f.tolist(),
            "working_point": dyn.point,
        })
    doc["cells"] = cells
    return doc


def save_pwa(model, path: str | os.PathLike, *, supply_pressure: float | None = None,
             sample_time: float | None = None) -> Path:
    """Write :func:`export_pwa` as JSON (atomically) and return the path."""
    doc = export_pwa(model, supply_pressure=supply_pressure, sample_time=sample_time)
    return atomic_write_text(path, json.dumps(doc, indent=1) + "\n")


def load_pwa(path: str | os.PathLike):
    """Read a PWA JSON document back into a :class:`PwaModel` (PwaError on schema mismatch)."""
    from ._model import PwaModel

    try:
        text = Path(path).read_text(encoding="utf-8")
    except OSError as exc:
        raise PwaError(f"cannot read PWA document {path}: {exc.strerror}") from None
    return PwaModel.from_json(text)
