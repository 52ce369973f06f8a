"""Translate the compiled kernel's right-hand side and the component functions to C99.

The axis FMU (:func:`hydropwa.simulation.export_axis_fmu`) must compute the physics of the
compiled kernel without a second copy kept by hand. This emitter reads the *source* of the
numba functions (:func:`~hydropwa.simulation._kernel.rhs_full` and everything it calls in
:mod:`hydropwa.components._physics` and the kernel, found by walking the calls) with
Python's :mod:`ast` and writes each as a C function with the same statements:

- arguments are doubles; an argument that is subscripted (``p``, ``y``, ``dy``) is a pointer;
- a function that returns a tuple gets one output pointer per element, and ``a, b = f(...)``
  becomes ``f(..., &a, &b)``;
- module constants (``I_FC``, ``Y_PA``, ...) become their integer values; ``math.*`` and
  ``np.exp`` the C99 functions of ``<math.h>``; ``abs`` is ``fabs``;
- :func:`~hydropwa.components._physics.smooth_sign` and ``abs_power`` are the scalar bodies of
  their numba overloads (what the kernel runs), not their NumPy forms.

A construct outside this subset raises :class:`EmitError` naming the function and line, so a
change to the physics that the emitter cannot follow fails the export and its test, instead
of producing different C.
"""

from __future__ import annotations

import ast
import inspect
import math
import textwrap
from collections.abc import Callable
from types import ModuleType

from .._errors import HydropwaError

__all__ = ["EmitError", "emit_functions", "emit_many"]

_MATH = {
    "sqrt": "sqrt",
    "exp": "exp",
    "log": "log",
    "expm1": "expm1",
    "copysign": "copysign",
    "tanh": "tanh",
    "fabs": "fabs",
    "pow": "pow",
}


class EmitError(HydropwaError, RuntimeError):
    """A kernel function uses Python the C emitter does not translate."""


def _c_name(name: str) -> str:
    return "hp_" + name.lstrip("_")


def _literal(v: float | int | bool) -> str:
    if isinstance(v, bool):
        return "1" if v else "0"
    if isinstance(v, int):
        return f"{v}.0"
    if math.isinf(v):
        return "HUGE_VAL" if v > 0 else "(-HUGE_VAL)"
    s = repr(float(v))
    return s if ("." in s or "e" in s) else s + ".0"


class _Func:
    """One Python function being translated."""

    def __init__(self, node: ast.FunctionDef, module: ModuleType, name: str, emitter: _Emitter):
        self.node = node
        self.module = module
        self.name = name
        self.em = emitter
        self.args = [a.arg for a in node.args.args]
        subscripted = {
            n.value.id
            for n in ast.walk(node)
            if isinstance(n, ast.Subscript) and isinstance(n.value, ast.Name)
        }
        self.written = {
            t.value.id
            for n in ast.walk(node)
            if isinstance(n, ast.Assign)
            for t in n.targets
            if isinstance(t, ast.Subscript) and isinstance(t.value, ast.Name)
        }
        self.arrays = subscripted & set(self.args)
        returns = [n for n in ast.walk(node) if isinstance(n, ast.Return) and n.value is not None]
        sizes = {len(r.value.elts) if isinstance(r.value, ast.Tuple) else 1 for r in returns}
        if len(sizes) > 1:
            self.fail(node, "returns tuples of different sizes")
        self.n_out = sizes.pop() if sizes else 0
        self.locals: list[str] = []
        for n in ast.walk(node):
            targets: list[ast.expr] = []
            if isinstance(n, ast.Assign):
                targets = list(n.targets)
            elif isinstance(n, ast.AugAssign):
                targets = [n.target]
            for t in targets:
                for e in t.elts if isinstance(t, ast.Tuple) else [t]:
                    if (
                        isinstance(e, ast.Name)
                        and e.id not in self.args
                        and e.id not in self.locals
                    ):
                        self.locals.append(e.id)

    def fail(self, node: ast.AST, what: str):
        line = getattr(node, "lineno", "?")
        raise EmitError(
            f"cannot translate {self.module.__name__}.{self.name} to C (line {line} of the "
            f"function): {what}"
        )

    def signature(self) -> str:
        params = []
        for a in self.args:
            if a in self.arrays:
                params.append(f"{'' if a in self.written else 'const '}double *{a}")
            else:
                params.append(f"double {a}")
        if self.n_out > 1:
            params += [f"double *out{i}" for i in range(self.n_out)]
        ret = "double" if self.n_out == 1 else "void"
        return f"static {ret} {_c_name(self.name)}({', '.join(params) or 'void'})"

    def body(self) -> str:
        lines = [f"{self.signature()}\n{{"]
        if self.locals:
            lines.append(f"    double {', '.join(self.locals)};")
        for st in self.node.body:
            lines += self.stmt(st, 1)
        lines.append("}")
        return "\n".join(lines)

    # ---------------------------------------------------------------- statements
    def stmt(self, st: ast.stmt, depth: int) -> list[str]:  # noqa: C901 (one branch per Python statement kind the C emitter translates)
        ind = "    " * depth
        if isinstance(st, ast.Expr) and isinstance(st.value, ast.Constant):
            return []  # docstring
        if isinstance(st, ast.Pass):
            return []
        if isinstance(st, ast.Expr) and isinstance(st.value, ast.Call):  # a call of a void function
            f = self.callee(st.value)
            if f is None or f.n_out != 0:
                self.fail(st, "a call whose value is dropped")
            assert f is not None
            return [f"{ind}{_c_name(f.name)}({', '.join(self.call_args(st.value, f))});"]
        if isinstance(st, ast.Return):
            if st.value is None:
                return [f"{ind}return;"]
            if isinstance(st.value, ast.Tuple):
                out = [f"{ind}*out{i} = {self.expr(e)};" for i, e in enumerate(st.value.elts)]
                return [*out, f"{ind}return;"]
            return [f"{ind}return {self.expr(st.value)};"]
        if isinstance(st, ast.Assign):
            if len(st.targets) != 1:
                self.fail(st, "chained assignment")
            t = st.targets[0]
            if isinstance(t, ast.Tuple):
                if isinstance(st.value, ast.Call):
                    f = self.callee(st.value)
                    if f is not None and f.n_out == len(t.elts):
                        args = self.call_args(st.value, f)
                        outs = [f"&{self.target(e)}" for e in t.elts]
                        return [f"{ind}{_c_name(f.name)}({', '.join(args + outs)});"]
                if isinstance(st.value, ast.Tuple) and len(st.value.elts) == len(t.elts):
                    return [
                        f"{ind}{self.target(e)} = {self.expr(v)};"
                        for e, v in zip(t.elts, st.value.elts, strict=True)
                    ]
                self.fail(st, "tuple assignment from something other than a call or a tuple")
            return [f"{ind}{self.target(t)} = {self.expr(st.value)};"]
        if isinstance(st, ast.AugAssign):
            op = self.binop_symbol(st.op, st)
            return [f"{ind}{self.target(st.target)} {op}= {self.expr(st.value)};"]
        if isinstance(st, ast.If):
            out = [f"{ind}if ({self.expr(st.test)}) {{"]
            for s in st.body:
                out += self.stmt(s, depth + 1)
            if st.orelse:
                out.append(f"{ind}}} else {{")
                for s in st.orelse:
                    out += self.stmt(s, depth + 1)
            out.append(f"{ind}}}")
            return out
        self.fail(st, f"statement {type(st).__name__}")
        return []

    def target(self, e: ast.expr) -> str:
        if isinstance(e, ast.Name):
            return e.id
        if isinstance(e, ast.Subscript):
            return self.expr(e)
        self.fail(e, f"assignment target {type(e).__name__}")
        return ""

    # ---------------------------------------------------------------- expressions
    def binop_symbol(self, op: ast.operator, node: ast.AST) -> str:
        table = {ast.Add: "+", ast.Sub: "-", ast.Mult: "*", ast.Div: "/"}
        for k, v in table.items():
            if isinstance(op, k):
                return v
        self.fail(node, f"operator {type(op).__name__}")
        return ""

    def constant(self, name: str, node: ast.AST) -> str:
        v = self.module.__dict__.get(name)
        if isinstance(v, bool | int | float):
            return str(v) if isinstance(v, int) and not isinstance(v, bool) else _literal(v)
        self.fail(node, f"name {name!r} is neither an argument, a local nor a number constant")
        return ""

    def callee(self, call: ast.Call) -> _Func | None:
        if isinstance(call.func, ast.Name):
            return self.em.function(call.func.id, self.module)
        return None

    def call_args(self, call: ast.Call, f: _Func) -> list[str]:
        if call.keywords:
            self.fail(call, "keyword arguments")
        args = [self.expr(a) for a in call.args]
        defaults = f.node.args.defaults
        missing = len(f.args) - len(args)
        if missing > len(defaults) or missing < 0:
            self.fail(call, f"call of {f.name} with {len(args)} arguments")
        if missing:
            args += [self.expr_const(d, f) for d in defaults[len(defaults) - missing :]]
        return args

    def expr_const(self, d: ast.expr, f: _Func) -> str:
        if isinstance(d, ast.Constant) and isinstance(d.value, int | float):
            return _literal(d.value)
        f.fail(d, "a default argument that is not a number")
        return ""

    def expr(self, e: ast.expr) -> str:  # noqa: C901 (one branch per Python expression kind the C emitter translates)
        if isinstance(e, ast.Constant):
            if isinstance(e.value, bool | int | float):
                return _literal(e.value)
            self.fail(e, f"constant {e.value!r}")
        if isinstance(e, ast.Name):
            if e.id in self.args or e.id in self.locals:
                return e.id
            return self.constant(e.id, e)
        if isinstance(e, ast.Subscript):
            arr = e.value
            if not isinstance(arr, ast.Name) or arr.id not in self.arrays:
                self.fail(e, "subscript of something other than an array argument")
            assert isinstance(arr, ast.Name)
            idx = e.slice
            if isinstance(idx, ast.Name) and idx.id not in self.args and idx.id not in self.locals:
                v = self.module.__dict__.get(idx.id)
                if not isinstance(v, int):
                    self.fail(e, f"index {idx.id!r} is not an integer constant")
                return f"{arr.id}[{v}]"
            if isinstance(idx, ast.Constant) and isinstance(idx.value, int):
                return f"{arr.id}[{idx.value}]"
            self.fail(e, "an index that is not a constant")
        if isinstance(e, ast.BinOp):
            left, right = self.expr(e.left), self.expr(e.right)
            if isinstance(e.op, ast.Pow):
                return f"pow({left}, {right})"
            return f"({left} {self.binop_symbol(e.op, e)} {right})"
        if isinstance(e, ast.UnaryOp):
            if isinstance(e.op, ast.USub):
                return f"(-{self.expr(e.operand)})"
            if isinstance(e.op, ast.UAdd):
                return self.expr(e.operand)
            if isinstance(e.op, ast.Not):
                return f"(!{self.expr(e.operand)})"
            self.fail(e, "unary operator")
        if isinstance(e, ast.BoolOp):
            op = " && " if isinstance(e.op, ast.And) else " || "
            return "(" + op.join(self.expr(v) for v in e.values) + ")"
        if isinstance(e, ast.Compare):
            ops = {
                ast.Lt: "<",
                ast.LtE: "<=",
                ast.Gt: ">",
                ast.GtE: ">=",
                ast.Eq: "==",
                ast.NotEq: "!=",
            }
            parts = []
            lhs = e.left
            for cmp, rhs in zip(e.ops, e.comparators, strict=True):
                sym = next((v for k, v in ops.items() if isinstance(cmp, k)), None)
                if sym is None:
                    self.fail(e, f"comparison {type(cmp).__name__}")
                parts.append(f"({self.expr(lhs)} {sym} {self.expr(rhs)})")
                lhs = rhs
            return "(" + " && ".join(parts) + ")"
        if isinstance(e, ast.IfExp):
            return f"({self.expr(e.test)} ? {self.expr(e.body)} : {self.expr(e.orelse)})"
        if isinstance(e, ast.Attribute):
            if isinstance(e.value, ast.Name) and e.value.id == "math" and e.attr == "pi":
                return _literal(math.pi)
            self.fail(e, f"attribute {ast.unparse(e)}")
        if isinstance(e, ast.Call):
            return self.call(e)
        self.fail(e, f"expression {type(e).__name__}")
        return ""

    def call(self, e: ast.Call) -> str:
        fn = e.func
        if isinstance(fn, ast.Attribute) and isinstance(fn.value, ast.Name):
            if fn.value.id in ("math", "np") and fn.attr in _MATH:
                return f"{_MATH[fn.attr]}({', '.join(self.expr(a) for a in e.args)})"
            self.fail(e, f"call of {ast.unparse(fn)}")
        if isinstance(fn, ast.Name):
            if fn.id == "abs":
                return f"fabs({self.expr(e.args[0])})"
            if fn.id == "float":
                return self.expr(e.args[0])
            f = self.callee(e)
            if f is None:
                self.fail(e, f"call of {fn.id}")
            assert f is not None
            if f.n_out != 1:
                self.fail(e, f"{fn.id} returns a tuple; assign it to as many names")
            return f"{_c_name(f.name)}({', '.join(self.call_args(e, f))})"
        self.fail(e, "call")
        return ""


class _Emitter:
    """Collects the functions reachable from the entry points, in dependency order."""

    def __init__(self, overloads: dict[str, Callable]):
        self.done: dict[str, _Func] = {}
        self.order: list[str] = []
        self.overloads = overloads
        self.visiting: set[str] = set()

    def function(self, name: str, module: ModuleType, obj=None) -> _Func | None:
        if name in self.done:
            return self.done[name]
        if obj is None:
            obj = module.__dict__.get(name)
        if name in self.overloads:
            node = _overload_scalar(self.overloads[name])
            mod = inspect.getmodule(self.overloads[name])
        else:
            py = getattr(obj, "py_func", None)  # a numba dispatcher: its Python source
            if py is None:
                return None
            node = _def(py)
            mod = inspect.getmodule(py)
        assert mod is not None
        if name in self.visiting:
            raise EmitError(f"{name} is recursive; the C emitter translates call trees only")
        self.visiting.add(name)
        f = _Func(node, mod, name, self)
        # translate callees first (C needs them declared before use)
        for n in ast.walk(node):
            if isinstance(n, ast.Call) and isinstance(n.func, ast.Name):
                self.function(n.func.id, mod)
        text = f.body()
        self.visiting.discard(name)
        self.done[name] = f
        self.order.append(text)
        return f


def _def(fn: Callable) -> ast.FunctionDef:
    tree = ast.parse(textwrap.dedent(inspect.getsource(fn)))
    node = tree.body[0]
    assert isinstance(node, ast.FunctionDef)
    return node


def _overload_scalar(impl: Callable) -> ast.FunctionDef:
    """The nested ``def scalar`` of a numba ``@overload`` implementation (the compiled form)."""
    outer = _def(impl)
    for n in outer.body:
        if isinstance(n, ast.If):
            for m in n.body:
                if isinstance(m, ast.FunctionDef) and m.name == "scalar":
                    return m
    raise EmitError(f"{impl.__name__} has no scalar implementation to translate")


def emit_functions(entry: Callable, overloads: dict[str, Callable]) -> tuple[str, list[str]]:
    """C99 text of ``entry`` (a numba function) and every function it calls, callees first.

    Parameters
    ----------
    entry : numba dispatcher
        E.g. :func:`~hydropwa.simulation._kernel.rhs_full`.
    overloads : dict
        Name → numba ``@overload`` implementation whose nested ``scalar`` function is the
        compiled form (``smooth_sign``, ``abs_power``).

    Returns
    -------
    text : str
        The C functions (``static``), named ``hp_<name>``.
    names : list of str
        The Python functions translated.
    """
    module = inspect.getmodule(getattr(entry, "py_func", entry))
    assert module is not None
    em = _Emitter(overloads)
    em.function(entry.__name__, module, entry)
    return "\n\n".join(em.order) + "\n", list(em.done)


def emit_many(entries: list[Callable], overloads: dict[str, Callable]) -> tuple[str, list[str]]:
    """C99 text of several numba functions and their callees, each function once, callees first.

    As :func:`emit_functions` for a list of entry points (e.g. a residual generator's row and
    result functions, which share the component physics they call).
    """
    em = _Emitter(overloads)
    for entry in entries:
        module = inspect.getmodule(getattr(entry, "py_func", entry))
        assert module is not None
        em.function(entry.__name__, module, entry)
    return "\n\n".join(em.order) + "\n", list(em.done)
