"""The closed-loop verification verdict in the report: the design beside the textbook PI baseline.

Reads ``tables/closed_loop_verification.csv`` (written by the paper study's control stage from
:func:`hydropwa.control.closed_loop_verification`) and renders it as one table with a sentence
that states the task set and the criteria it was judged on.
"""

from __future__ import annotations

import html
from pathlib import Path

__all__ = ["closed_loop_verification_html"]

_COLUMNS = {
    "hold_peak_to_peak_mm": "hold p-p [mm]",
    "hold_mean_error_mm": "mean hold error [mm]",
    "following_error_mm": "trapezoid peak error [mm]",
    "saturation_percent": "saturation [%]",
    "sign_changes_per_s": "sign changes at holds [1/s]",
    "limit_cycles": "limit cycles",
    "failed_checks": "failed checks",
    "first_failure": "first failed check",
}


def closed_loop_verification_html(out: Path) -> str:
    """HTML of the verification verdicts (empty when the table is not there)."""
    import pandas as pd  # deferred: pandas costs ~0.3 s at import

    from ._report import _table  # deferred: _report imports this module

    f = Path(out) / "tables" / "closed_loop_verification.csv"
    if not f.is_file():
        return ""
    df = pd.read_csv(f, keep_default_na=False).rename(columns=_COLUMNS)
    verdicts = ", ".join(
        f"{html.escape(str(c))}: <b>{html.escape(str(v)).upper()}</b>"
        for c, v in zip(df["controller"], df["verdict"], strict=True)
    )
    return f"""<p>Verification before use ({verdicts}): both controllers on the full model over
the same task set (steps 5 → 95 → 50 % of the stroke against ±50 % of the maximum force and
their holds, a trapezoid at half the maximum velocity) with sensor noise (20 µm, 0.1 bar on
each chamber), the computation delay of the design, and the parameter draws stated in the
controller file. Limits: hold ≤ 0.1 mm peak to peak without a limit cycle, peak following
error ≤ 0.5 % of the move, saturation ≤ 10 %, ≤ 100 command sign changes per second at the
holds; the worst value over tasks and draws.</p>
{_table(df, "verification verdict: the design and the textbook PI + feed-forward baseline")}"""
