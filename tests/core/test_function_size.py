"""No function over 80 lines of code and none with more than 10 parameters (issues 33 and 47,
"How we will know"), measured with ``ast`` over ``src/hydropwa``.

Lines of code: the non-blank, non-comment lines of a function's body after its docstring.
Parameters: the named ones (positional and keyword-only), without ``self``/``cls`` and
without ``*args``/``**kwargs``.

The line limit holds for every function: compiled kernels (the right-hand sides, the control
law's stages) and CLI commands included. :data:`LINE_EXCEPTIONS` lists the functions allowed
over it, each with its measured size as a ceiling and the reason: none today (the compiled step
loop ``_march``, 121 lines until 2026-12-02, is split into inlined named steps, bit for bit the
same on 386 arrays compiled for the same CPU; no right-hand side is over the limit).

The parameter limit is not measured for two kinds of function, because their parameters are
what they are by construction:

- compiled kernels (a decorator naming ``jit``, and everything in the kernel's modules
  :data:`KERNEL_FILES`): they pass the solver's work arrays and packed vectors explicitly,
  since a struct of arrays would cost reference counting in the allocation-free loop;
- CLI commands (``@….command(...)``): each typer option is a parameter.

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
#: Functions allowed over the line limit: (file, function) → (lines of code, why).
LINE_EXCEPTIONS: dict[tuple[str, str], tuple[int, str]] = {}
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
    """Exempt from the parameter limit (not from the line limit): compiled code, CLI commands."""
    decorators = [ast.unparse(d) for d in node.decorator_list]
    return (
        rel.startswith(KERNEL_FILES)
        or any("jit" in d for d in decorators)
        or any(".command(" in d for d in decorators)
    )


def measure() -> dict[tuple[str, str], tuple[int, int]]:
    """(file, function) → (lines of code, parameters) of every function; the parameters
    count as 0 where :func:`_exempt` (compiled code, CLI commands)."""
    out: dict[tuple[str, str], tuple[int, int]] = {}
    for path in sorted(ROOT.rglob("*.py")):
        rel = path.relative_to(ROOT).as_posix()
        src = path.read_text(encoding="utf-8")
        lines = src.splitlines()
        for node in ast.walk(ast.parse(src)):
            if not isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                continue
            a = node.args
            named = [
                x for x in a.posonlyargs + a.args + a.kwonlyargs if x.arg not in ("self", "cls")
            ]
            key = (rel, node.name)
            loc, n = _code_lines(lines, node), 0 if _exempt(rel, node) else len(named)
            old = out.get(key, (0, 0))
            out[key] = (max(loc, old[0]), max(n, old[1]))  # same-named methods: the largest
    return out


def test_no_function_over_80_lines_or_10_parameters_but_the_listed_ones():
    sizes = measure()
    grown_long = [k for k in LINE_EXCEPTIONS if sizes[k][0] > LINE_EXCEPTIONS[k][0]]
    assert not grown_long, f"grew past its ceiling: {grown_long}"
    stale_long = [k for k in LINE_EXCEPTIONS if sizes[k][0] <= MAX_LINES]
    assert not stale_long, f"within the line limit now; remove from LINE_EXCEPTIONS: {stale_long}"
    offenders = {
        k: v
        for k, v in sizes.items()
        if (v[0] > MAX_LINES and k not in LINE_EXCEPTIONS) or v[1] > MAX_PARAMS
    }
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


def test_compiled_code_and_cli_commands_are_measured_for_their_length():
    """The step loop, a right-hand side, a law stage and a CLI command are in the measure (their
    parameters are not: 0); the line-exempt list names compiled code only."""
    sizes = measure()
    for key in (
        ("simulation/_march.py", "_march"),
        ("simulation/_rhs_full.py", "rhs_full"),
        ("simulation/_controller.py", "law_step"),
        ("cli/_core.py", "simulate_command"),
    ):
        assert key in sizes and sizes[key][0] > 0 and sizes[key][1] == 0, key
    assert all(f.startswith("simulation/_") for f, _n in LINE_EXCEPTIONS)


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
