"""The API pages read right (issue 49, item 8): Sphinx roles become links, and every documented
parameter shows the default its signature has."""

from __future__ import annotations

import importlib.util
import logging
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def _hook():
    spec = importlib.util.spec_from_file_location(
        "sphinx_roles", ROOT / "docs/_hooks/sphinx_roles.py"
    )
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


@pytest.mark.parametrize(
    ("rendered", "identifier", "title"),
    [
        (
            ":class:<code>~hydropwa.params.SystemParams</code>",
            "hydropwa.params.SystemParams",
            "SystemParams",
        ),
        (":func:<code>hydropwa.simulate</code>", "hydropwa.simulate", "hydropwa.simulate"),
        (":meth:<code>~hydropwa.Rig.run()</code>", "hydropwa.Rig.run", "run()"),
        (
            ":py:data:<code>~hydropwa.params.PLAUSIBLE</code>",
            "hydropwa.params.PLAUSIBLE",
            "PLAUSIBLE",
        ),
    ],
)
def test_a_sphinx_role_becomes_an_optional_cross_reference(rendered, identifier, title):
    out = _hook().link_roles(f"<p>see {rendered}.</p>")
    assert out == (
        f'<p>see <autoref identifier="{identifier}" optional><code>{title}</code></autoref>.</p>'
    )
    assert ":class:" not in out and ":func:" not in out


def test_text_that_is_not_a_role_is_left_alone():
    text = "<p>ratio 1:2 and <code>x:y</code>, a :class: word</p>"
    assert _hook().link_roles(text) == text


def test_mkdocs_runs_the_hook():
    assert "docs/_hooks/sphinx_roles.py" in (ROOT / "mkdocs.yml").read_text()


def test_documented_defaults_are_the_signatures():
    """griffe (mkdocstrings) gives a grouped ``a, b, c`` entry without a type the first name's
    type and default (``sensor_noise: int = 1``), and the first choice of a ``{...}`` set as
    the default: every documented parameter of every function must show its own."""
    griffe = pytest.importorskip("griffe")
    logging.getLogger("griffe").setLevel(logging.ERROR)
    pkg = griffe.load(
        "hydropwa",
        search_paths=[str(ROOT / "src")],
        docstring_parser="numpy",
        resolve_aliases=False,
    )
    wrong: list[str] = []

    def norm(v: object) -> str:
        return str(v).replace('"', "'")

    def walk(obj) -> None:
        for m in list(obj.members.values()):
            if m.is_alias:
                continue
            if m.is_module or m.is_class:
                walk(m)
            if not (m.is_function and m.docstring):
                continue
            sig = {p.name: p for p in m.parameters}
            for section in m.docstring.parsed:
                if section.kind.value != "parameters":
                    continue
                for p in section.value:
                    q = sig.get(p.name)
                    if q is not None and norm(p.default) != norm(q.default):
                        wrong.append(f"{m.path}({p.name}): shown {p.default}, is {q.default}")

    walk(pkg)
    assert not wrong, "; ".join(wrong)
