"""Short text and HTML summaries of the package's objects for consoles and notebooks.

Every rich object (parameters, runs, datasets, simulation results, PWA models) prints as one
line and renders in Jupyter as a small table (``_repr_html_``) instead of a dump of its arrays.
Values are shown in engineering units (bar, mm, L, kN) where SI would be unreadable.
"""

from __future__ import annotations

import html
from collections.abc import Iterable, Mapping, Sequence

import numpy as np

#: display unit and factor from SI, per SI unit string: the package's one engineering-unit
#: table (consoles, notebooks, ``params show``, the figures' axes)
ENGINEERING_UNITS = {
    "Pa": ("bar", 1e-5),
    "m": ("mm", 1e3),
    "m/s": ("mm/s", 1e3),
    "1/s": ("%/s", 100.0),
    "m**2": ("cm²", 1e4),
    "m**3": ("L", 1e3),
    "m**3/s": ("L/min", 6e4),
    "N": ("N", 1.0),
    "1": ("%", 100.0),
    "": ("", 1.0),
}


def engineering(value: float, unit: str) -> str:
    """``value`` [SI ``unit``] as text in the engineering unit (``'95 bar'``, ``'0.7 L'``)."""
    shown, factor = ENGINEERING_UNITS.get(unit, (unit, 1.0))
    try:
        v = float(value) * factor
    except (TypeError, ValueError):
        return str(value)
    return f"{v:.4g} {shown}".rstrip()


def channel_unit(unit: str) -> tuple[str, float]:
    """Engineering unit and factor from SI for a channel's unit."""
    return ENGINEERING_UNITS.get(unit, (unit, 1.0))


def html_table(
    title: str, header: Sequence[str], rows: Iterable[Sequence[object]], note: str = ""
) -> str:
    """A small HTML table with a bold caption (escaped)."""
    esc = html.escape
    head = "".join(f"<th style='text-align:left'>{esc(str(h))}</th>" for h in header)
    body = "".join(
        "<tr>" + "".join(f"<td style='text-align:left'>{esc(str(c))}</td>" for c in row) + "</tr>"
        for row in rows
    )
    foot = f"<div style='font-size:smaller'>{esc(note)}</div>" if note else ""
    return f"<div><b>{esc(title)}</b><table><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>{foot}</div>"


def channel_rows(
    channels: Mapping[str, np.ndarray], units: dict[str, str]
) -> list[tuple[str, str, str, str]]:
    """(channel, unit, min, max) rows in engineering units, time excluded."""
    rows = []
    for name, values in channels.items():
        if name == "t":
            continue
        shown, factor = channel_unit(units.get(name, ""))
        a = np.asarray(values, dtype=float)
        if a.size == 0 or not np.any(np.isfinite(a)):
            rows.append((name, shown, "–", "–"))
            continue
        rows.append((name, shown, f"{np.nanmin(a) * factor:.4g}", f"{np.nanmax(a) * factor:.4g}"))
    return rows
