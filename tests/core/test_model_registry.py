"""The model-kind registry (one ModelKind row per kind) and the method table (one Method row per
Rosenbrock method): every per-kind and per-method constant of the compiled code is derived from
a row, and every layer builds a model through ``build_model``."""

import math

import pytest

from hydropwa import _layout
from hydropwa._errors import ParameterError
from hydropwa.models import FullOrderModel, ReducedModel, as_model
from hydropwa.simulation import _dispatch, _kcommon, _rhs_chamber, _rhs_full, _rhs_load
from hydropwa.simulation import _rosenbrock as R
from hydropwa.simulation import _stepcontrol as SC


def test_rows_are_in_kernel_order_with_unique_entry_ids():
    rows = list(_layout.MODEL_KINDS.values())
    assert [r.kernel for r in rows] == list(range(len(rows)))
    assert len({r.entry_id for r in rows}) == len(rows)
    assert _layout.MODEL_NAMES == tuple(r.name for r in rows)
    assert _layout.LINEARIZED_MODELS == ("pwa", "pwa-chamber")


def test_compiled_tables_are_the_rows():
    """The step loop's per-kind flags and the inert-state table resolve the rows' names to the
    kernel's state and slot indices (the full model: P_acc without gas, P_S without the pump;
    the chamber model's P_S always)."""
    K = _kcommon
    assert K.CARRIES_SPOOL == (True, False, False, True, True)
    assert K.JAC_DEPENDS_ON_U == (False, True, True, False, False)
    pad = (-1,) * (K.N_INERT - 2)  # the tables are padded to the longest row (full-lines: 4)
    assert K.INERT_STATE[K.FULL] == (K.Y_PACC, K.Y_PS, *pad) == K.INERT_STATE[K.CHAMBER]
    assert K.INERT_SLOT[K.FULL] == (K.I_ACCV, K.I_PUMP, *pad)
    assert K.INERT_SLOT[K.CHAMBER] == (K.I_ACCV, -1, *pad)  # -1: always inert
    assert K.INERT_LIMIT[K.FULL][:2] == (0.0, 0.5)
    assert K.INERT_STATE[K.REDUCED] == K.INERT_STATE[K.PWA] == (-1,) * K.N_INERT
    # the trailing-run rule of n_solve needs the inert states last, the last state first
    assert K.INERT_STATE[K.FULL][0] == K.N_STATES[K.FULL] - 1
    # full-lines: the lines (absent at volume 0) before the full model's inert states; only the
    # lines leave the error norm, so without them it steps as the full model
    lines = _layout.MODEL_KINDS["full-lines"].kernel
    n = K.N_STATES[lines]
    assert n == K.N_STATES[K.FULL] + 2
    assert K.INERT_STATE[lines] == (n - 1, n - 2, K.Y_PACC, K.Y_PS)
    vla, vlb = _layout.SLOT["vla"], _layout.SLOT["vlb"]
    assert K.FREE_STATE[lines] == (n - 1, n - 2) and K.FREE_SLOT[lines] == (vlb, vla)
    assert all(K.FREE_STATE[k] == (-1,) * K.N_FREE for k in (K.FULL, K.REDUCED, K.PWA, K.CHAMBER))


def test_each_kind_finds_its_compiled_functions():
    fns = _dispatch.KIND_FUNCTIONS
    assert fns[_kcommon.FULL].rhs is _rhs_full.rhs_full
    assert fns[_kcommon.FULL].jac is _rhs_full.jac_full
    assert fns[_kcommon.REDUCED].dfdt is _rhs_load.dfdt_reduced
    assert fns[_kcommon.PWA].jac is _rhs_load.jac_pwa
    assert fns[_kcommon.CHAMBER].rhs is _rhs_chamber.rhs_chamber
    # finite differences of an exact-Jacobian kind go through a call wrapper (compile time)
    assert fns[_kcommon.REDUCED].rhs_call is not _rhs_load.rhs_reduced
    assert fns[_kcommon.FULL].rhs_call is _rhs_full.rhs_full


def test_build_model_builds_each_kind_of_this_layer(paper):
    full = _layout.build_model("full", paper)
    assert isinstance(full, FullOrderModel) and full.params is paper
    red = _layout.build_model(" Reduced ", paper, form="paper")
    assert isinstance(red, ReducedModel) and red.form == "paper"
    for row in _layout.MODEL_KINDS.values():
        module, _sep, attr = row.factory.partition(":")
        assert callable(getattr(__import__(module, fromlist=[attr]), attr))
        if not row.linearized:
            model = row.build(paper)
            assert model.name == row.name
            assert len(model.state_names) == len(row.states)


def test_unknown_or_linearized_names_are_refused_in_one_line(paper):
    with pytest.raises(ParameterError, match="unknown model 'ful'; choose full, reduced"):
        _layout.build_model("ful", paper)
    with pytest.raises(ParameterError, match=r"linearize\(params, form='chamber'\)"):
        as_model("pwa-chamber", paper)
    with pytest.raises(ParameterError, match="needs the machine"):
        as_model("full")


def test_methods_are_rows():
    assert R.SOLVERS == {"ros23": 0, "ros34pw2": 1, "ros4ls": 2}
    assert [m.id for m in R.METHODS] == [0, 1, 2]
    by = {m.name: m for m in R.METHODS}
    assert by["ros23"].gamma == pytest.approx(1.0 / (2.0 + math.sqrt(2.0)), rel=1e-15)
    assert [by[n].error_order for n in ("ros23", "ros34pw2", "ros4ls")] == [2, 2, 3]
    assert [m.name for m in R.METHODS if m.w_method] == ["ros34pw2"]
    assert [m.name for m in R.METHODS if m.fsal] == ["ros23"]
    assert len(R.STEPPERS) == len(R.METHODS)


@pytest.mark.parametrize("order", [2, 3, 4])
def test_step_factor_root_is_the_error_orders(order):
    """The step controller's root is err^(1/(q + 1)) for the method's error order q (the fast
    paths for q = 2, 3 within rounding of pow; q = 4 by pow), its floor the root of 1e-4."""
    for err in (1e-6, 0.3, 1.0, 7.5):
        assert SC._err_root(err, order) == pytest.approx(err ** (1.0 / (order + 1)), rel=4e-16)
    assert SC._err_root_floor(order) == pytest.approx(1e-4 ** (1.0 / (order + 1)), rel=4e-16)


#: Literal model-kind names allowed in library code outside the registry and the CLI's help.
KIND_NAME_LIMIT = 5


def literal_kind_names() -> list[str]:
    """Where library code spells a model kind's name instead of asking the registry.

    Counted over every module of ``src/hydropwa`` except ``_layout.py`` (the registry), on the
    parsed source (so comments do not count): each string constant equal to a kind name
    (``"pwa"``, also as an f-string piece), and each quoted kind name (``'full'``, ``"full"``)
    inside another string, such as an error message. Not counted: docstrings (the
    documentation, as the CLI's help is) and strings passed as ``help=`` (the CLI's help text).
    Composite names that only begin with a kind's (``"pwa-scheduled"``, ``"closed-full"``) are
    other names and do not count.
    """
    import ast
    from pathlib import Path

    kinds = set(_layout.MODEL_NAMES)
    quoted = [f"{q}{k}{q}" for k in kinds for q in "'\""]
    root = Path(_layout.__file__).parent
    hits = []
    for path in sorted(root.rglob("*.py")):
        if path.name == "_layout.py" and path.parent == root:
            continue
        tree = ast.parse(path.read_text(encoding="utf-8"))
        skip: set[int] = set()
        for node in ast.walk(tree):
            body = getattr(node, "body", None)
            if isinstance(body, list) and body and isinstance(body[0], ast.Expr):
                if isinstance(body[0].value, ast.Constant):
                    skip.add(id(body[0].value))  # a docstring
            if isinstance(node, ast.keyword) and node.arg == "help":
                skip.update(id(n) for n in ast.walk(node.value))
        for node in ast.walk(tree):
            if not isinstance(node, ast.Constant) or not isinstance(node.value, str):
                continue
            if id(node) in skip:
                continue
            if node.value in kinds or any(q in node.value for q in quoted):
                hits.append(f"{path.relative_to(root)}:{node.lineno}: {node.value!r}")
    return hits


def test_library_code_names_kinds_through_the_registry():
    """Fewer than 5 literal kind names outside the registry and the CLI's help (92 by grep,
    docstrings included, at the last stop); see :func:`literal_kind_names` for what counts."""
    hits = literal_kind_names()
    assert len(hits) < KIND_NAME_LIMIT, "\n".join(hits)


def test_the_kind_name_count_sees_a_literal(tmp_path, monkeypatch):
    """The counter is not blind: a module with one literal name and one quoted name in a
    message is two hits; the same names in a docstring, a comment or ``help=`` are none."""
    pkg = tmp_path / "pkg"
    pkg.mkdir()
    (pkg / "_layout.py").write_text('MODEL = "full"\n')  # the registry itself: not counted
    (pkg / "m.py").write_text(
        '"""Module doc naming "full"."""\n'
        "# a comment naming 'pwa'\n"
        "def f(model='reduced'):\n"
        '    """Docstring: "pwa"."""\n'
        "    opt(help=\"full or 'pwa'\")\n"
        "    raise ValueError(f\"{model}: fit 'full' instead\")\n"
    )
    monkeypatch.setattr(_layout, "__file__", str(pkg / "_layout.py"))
    hits = literal_kind_names()
    assert [h.split(":")[1] for h in hits] == ["3", "6"], hits


def test_optional_parts_decide_which_kinds_apply():
    """A kind with an optional part (``component``) applies only where the parameters carry
    it: the hose-line kind on a machine with lines, not on the paper's rig."""
    from hydropwa._layout import BASE_MODELS, MODEL_KINDS, kinds_for
    from hydropwa.params import Lines, get_preset

    paper = get_preset("paper")
    hosed = paper.replace(lines=Lines(volume_b=7.85e-5, conductance_b=6e-9))
    optional = {r.name for r in MODEL_KINDS.values() if r.component is not None}
    assert optional == {"full-lines"}
    assert kinds_for(paper) == BASE_MODELS == tuple(n for n in MODEL_KINDS if n not in optional)
    assert kinds_for(hosed) == tuple(MODEL_KINDS)
    assert paper.carries(None) and not paper.carries("lines") and hosed.carries("lines")
    with pytest.raises(ParameterError, match="not an optional part"):
        paper.carries("valve")
