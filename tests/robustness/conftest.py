"""Hypothesis profiles for the robustness suite.

``ci`` (default): bounded example counts so the whole suite runs in well under 3 minutes.
``long``: thousands of examples per fuzz target; select with ``HYPOTHESIS_PROFILE=long``
(see ``docs/robustness.md``).

Fuzz targets use ``settings(max_examples=fuzz_examples(n))`` style scaling through
:data:`FUZZ_EXAMPLES` / :data:`PHYSICS_EXAMPLES`, which follow the active profile.
"""

from __future__ import annotations

from hypothesis import HealthCheck, settings

_COMMON = dict(
    suppress_health_check=[
        HealthCheck.too_slow,
        HealthCheck.function_scoped_fixture,
        HealthCheck.data_too_large,
        HealthCheck.filter_too_much,
    ],
    derandomize=False,
    print_blob=True,
)

# Per-example deadline for the fuzz targets: a parser that takes longer than this on a
# small input is treated as a hang. Physics tests override it with deadline=None.
settings.register_profile("ci", max_examples=100, deadline=2000, **_COMMON)
settings.register_profile("long", max_examples=3000, deadline=5000, **_COMMON)
settings.register_profile("dev", max_examples=20, deadline=None, **_COMMON)

from robust_support import PHYSICS_EXAMPLES, PROFILE  # noqa: E402,F401

settings.load_profile(PROFILE)


def pytest_terminal_summary(terminalreporter):
    """Print how many inputs each fuzz target tried (loaded / rejected)."""
    try:
        from _fuzzutil import COUNTS, DEFECTS
    except ImportError:  # pragma: no cover
        return
    if not COUNTS:
        return
    terminalreporter.section(f"fuzz input counts (profile {PROFILE!r})")
    for name in sorted(COUNTS):
        tried, ok, rejected, bad = COUNTS[name]
        terminalreporter.write_line(
            f"{name:40s} tried {tried:7d}  loaded {ok:7d}  rejected {rejected:7d}"
            + (f"  VIOLATIONS {bad:5d}" if bad else "")
        )
    total = [sum(v[i] for v in COUNTS.values()) for i in range(4)]
    terminalreporter.write_line(
        f"{'total':40s} tried {total[0]:7d}  loaded {total[1]:7d}  rejected {total[2]:7d}  "
        f"violations {total[3]}"
    )
    for (target, exc, site), (args, msg) in sorted(DEFECTS.items()):
        terminalreporter.write_line(f"DEFECT {target}: {exc} at {site}: {msg}\n    input {args}")
