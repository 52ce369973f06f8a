"""No function over 80 lines of code and none with more than 10 parameters (issue 33, "How we
will know"), measured with ``ast`` over ``src/hydropwa``.

Lines of code: the non-blank, non-comment lines of a function's body after its docstring.
Parameters: the named ones (positional and keyword-only), without ``self``/``cls`` and
without ``*args``/``**kwargs``.

Not measured, because they are a different kind of function:

- compiled kernels (a decorator naming ``jit``, and everything in ``simulation/_kernel*``,
  the numba back end whose entry points pass the solver's work arrays explicitly); their
  split is the kernel issue's own work, timed against ``benchmarks/run.py``;
- CLI commands (``@….command(...)``): each typer option is a parameter by construction.

Every other function above a limit is listed in :data:`EXCEPTIONS` with its measured size as a
ceiling and the reason; a function that grows past its ceiling, a new offender, and an entry
that is no longer needed all fail, so the list only shrinks. ``python tests/core/test_function_size.py``
prints the table.
"""

from __future__ import annotations

import ast
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2] / "src" / "hydropwa"
MAX_LINES = 80
MAX_PARAMS = 10
#: the compiled back end (today one module; a split into a package keeps the prefix or the
#: ``kernel/`` folder of the design notes)
KERNEL_FILES = (
    "simulation/_kernel",
    "simulation/kernel/",
    # the kernel's modules behind its front (docs/architecture.md "Solver"; the same list as
    # the kernel-private import contract in pyproject.toml)
    "simulation/_kcommon",
    "simulation/_rhs_",
    "simulation/_dispatch",
    "simulation/_rosenbrock",
    "simulation/_stepcontrol",
    "simulation/_outputs",
    "simulation/_sampling",
    "simulation/_march",
    "simulation/_entries",
)

_API = (
    "public keyword options in the python-control/scipy style (every option keyword-only, "
    "documented, defaulted); an options object would break callers"
)
_SIGNALS = (
    "public function of measured signals: the channels (t, x, p_a, p_b, f_l) and the geometry "
    "are positional, the settings keywords; the friction method objects pass them through"
)
#: (file, function) → (lines of code, parameters, why): the measured sizes are ceilings.
EXCEPTIONS: dict[tuple[str, str], tuple[int, int, str]] = {
    ("control/_design.py", "design_state_feedback"): (46, 18, _API),
    ("control/_design.py", "design_pi"): (65, 14, _API),
    ("control/_verify.py", "design_controller"): (44, 13, _API),
    ("control/_metrics.py", "compare_models"): (43, 13, _API),
    ("simulation/_simulate.py", "simulate"): (
        43,
        21,
        _API + " (python-control's simulate: the one entry for every model, open and closed "
        "loop); its body is within the limits (checks, grid, signals, kernel call and result "
        "in helpers)",
    ),
    ("linearization/_model.py", "linearize"): (54, 11, _API),
    ("data/_validate.py", "check_run"): (23, 11, _API),
    ("rig/_runner.py", "run_experiment"): (
        32,
        11,
        _API + " (keyword-only faults; force is a deprecated alias)",
    ),
    ("rig/_runner.py", "run_campaign"): (
        23,
        11,
        _API + " (keyword-only faults; force is a deprecated alias)",
    ),
    ("cli/_linearize.py", "linearize_command"): (24, 14, "takes the command's options one to one"),
    ("cli/_control.py", "_compare"): (47, 12, "takes the command's options one to one"),
    ("identification/_friction_points.py", "friction_samples"): (17, 17, _SIGNALS),
    ("identification/_friction_points.py", "breakaway_peaks"): (27, 15, _SIGNALS),
    ("identification/_friction_points.py", "steady_window"): (25, 11, _SIGNALS),
}


def _code_lines(lines: list[str], node: ast.FunctionDef | ast.AsyncFunctionDef) -> int:
    body = node.body
    first = body[0]
    doc = isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant)
    if doc and isinstance(first.value.value, str):
        if len(body) == 1:
            return 0
        first = body[1]
    span = lines[first.lineno - 1 : node.end_lineno]
    return sum(1 for ln in span if ln.strip() and not ln.strip().startswith("#"))


def _exempt(rel: str, node: ast.FunctionDef | ast.AsyncFunctionDef) -> bool:
    decorators = [ast.unparse(d) for d in node.decorator_list]
    return (
        rel.startswith(KERNEL_FILES)
        or any("jit" in d for d in decorators)
        or any(".command(" in d for d in decorators)
    )


def measure() -> dict[tuple[str, str], tuple[int, int]]:
    """(file, function) → (lines of code, parameters) of every function not exempt."""
    out: dict[tuple[str, str], tuple[int, int]] = {}
    for path in sorted(ROOT.rglob("*.py")):
        rel = path.relative_to(ROOT).as_posix()
        src = path.read_text(encoding="utf-8")
        lines = src.splitlines()
        for node in ast.walk(ast.parse(src)):
            if not isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef) or _exempt(rel, node):
                continue
            a = node.args
            named = [
                x for x in a.posonlyargs + a.args + a.kwonlyargs if x.arg not in ("self", "cls")
            ]
            key = (rel, node.name)
            loc, n = _code_lines(lines, node), len(named)
            old = out.get(key, (0, 0))
            out[key] = (max(loc, old[0]), max(n, old[1]))  # same-named methods: the largest
    return out


def test_no_function_over_80_lines_or_10_parameters_but_the_listed_ones():
    sizes = measure()
    offenders = {k: v for k, v in sizes.items() if v[0] > MAX_LINES or v[1] > MAX_PARAMS}
    new = sorted(
        f"{f}::{n} {v[0]} lines, {v[1]} parameters"
        for (f, n), v in offenders.items()
        if (f, n) not in EXCEPTIONS
    )
    assert not new, "over the limits (split it, or list it with a reason):\n" + "\n".join(new)
    grown = sorted(
        f"{f}::{n} {sizes[f, n]} > ceiling {EXCEPTIONS[f, n][:2]}"
        for (f, n) in offenders
        if (f, n) in EXCEPTIONS
        and (sizes[f, n][0] > EXCEPTIONS[f, n][0] or sizes[f, n][1] > EXCEPTIONS[f, n][1])
    )
    assert not grown, "an excepted function grew:\n" + "\n".join(grown)
    stale = sorted(f"{f}::{n}" for (f, n) in EXCEPTIONS if (f, n) not in offenders)
    assert not stale, "within the limits now; remove from EXCEPTIONS:\n" + "\n".join(stale)


#: compiled modules whose functions are measured for their length all the same: the control
#: law's stages (issue 47; their parameters are the law's vectors and slots, passed explicitly)
COMPILED_MEASURED = ("simulation/_controller.py",)


def test_the_compiled_control_law_is_stages_of_at_most_80_lines():
    too_long = []
    for rel in COMPILED_MEASURED:
        src = (ROOT / rel).read_text(encoding="utf-8")
        lines = src.splitlines()
        for node in ast.walk(ast.parse(src)):
            if isinstance(node, ast.FunctionDef) and _code_lines(lines, node) > MAX_LINES:
                too_long.append(f"{rel}::{node.name} {_code_lines(lines, node)} lines")
    assert not too_long, "split the stage:\n" + "\n".join(too_long)


def test_the_measure_counts_code_lines_and_named_parameters():
    src = '''
def f(a, b, /, c, *args, d, e=1, **kw):
    """Doc
    string."""
    # a comment
    x = 1

    return x
'''
    node = ast.parse(src).body[0]
    assert isinstance(node, ast.FunctionDef)
    assert _code_lines(src.splitlines(), node) == 2
    a = node.args
    assert len(a.posonlyargs + a.args + a.kwonlyargs) == 5


if __name__ == "__main__":
    for (f, n), (loc, par) in sorted(measure().items(), key=lambda kv: -kv[1][0]):
        if loc > MAX_LINES or par > MAX_PARAMS:
            sys.stdout.write(f"{f}::{n}: {loc} lines, {par} parameters\n")
