"""`hydropwa.evaluation` is a library that knows nothing of the paper study.

The study lives in `hydropwa.studies.paper` (the `studies` layer above `evaluation`); the old
imports from `hydropwa.evaluation` stay working as deprecated aliases, the one deliberate upward
reference (docs/architecture.md, "Layers").
"""

from __future__ import annotations

import subprocess
import sys

import pytest

MOVED = ("run_paper_study", "write_report", "StudyResult", "StudyError")


def test_importing_evaluation_loads_nothing_of_the_studies():
    # a fresh interpreter: this session's other tests may already have imported the study
    code = (
        "import sys, hydropwa.evaluation as ev; "
        "bad = sorted(m for m in sys.modules if m.startswith('hydropwa.studies')); "
        "print(bad); "
        f"assert not set({MOVED!r}) & set(ev.__all__), ev.__all__; "
        "sys.exit(1 if bad else 0)"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stdout + done.stderr


@pytest.mark.parametrize("name", MOVED)
def test_the_old_import_is_the_new_object_with_a_deprecation_warning(name):
    import hydropwa.evaluation as ev
    import hydropwa.studies.paper as paper

    with pytest.warns(DeprecationWarning, match=rf"hydropwa\.studies\.paper\.{name}"):
        old = getattr(ev, name)
    assert old is getattr(paper, name)


def test_the_from_import_form_warns_too():
    with pytest.warns(DeprecationWarning, match="moved to hydropwa.studies.paper"):
        from hydropwa.evaluation import run_paper_study
    from hydropwa.studies.paper import run_paper_study as new

    assert run_paper_study is new


def test_an_unknown_name_is_still_an_attribute_error():
    import hydropwa.evaluation as ev

    with pytest.raises(AttributeError, match="has no attribute 'no_such_name'"):
        ev.no_such_name  # noqa: B018
    assert not hasattr(ev, "also_missing")
