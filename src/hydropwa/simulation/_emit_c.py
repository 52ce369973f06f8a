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
from collections.abc import Callable, Sequence
from types import ModuleType

from .._errors import HydropwaError

__all__ = ["EmitError", "emit_functions", "emit_unit"]

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
        # written in place (``a[i] += …``) or as an output of a call (``x, a[i] = f(…)``)
        stored: list[ast.expr] = []
        for n in ast.walk(node):
            if isinstance(n, ast.AugAssign):
                stored.append(n.target)
            elif isinstance(n, ast.Assign) and isinstance(n.targets[0], ast.Tuple):
                stored += n.targets[0].elts
        for st in stored:
            if isinstance(st, ast.Subscript) and isinstance(st.value, ast.Name):
                self.written.add(st.value.id)
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
            elif isinstance(n, ast.For):
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

    def resolve(self) -> None:
        """Arrays passed on: an argument handed to a callee's array (or written array) parameter
        is an array (written) here too; called once the callees are translated."""
        for n in ast.walk(self.node):
            if not isinstance(n, ast.Call):
                continue
            f = self.callee(n)
            if f is None:
                continue
            for a, param in zip(n.args, f.args, strict=False):
                if isinstance(a, ast.Name) and a.id in self.args and param in f.arrays:
                    self.arrays.add(a.id)
                    if param in f.written:
                        self.written.add(a.id)

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
        self.resolve()
        lines = [f"{self.signature()}\n{{"]
        if self.locals:  # all set to 0 first: no path reads one unset
            lines.append(f"    double {' = 0.0, '.join(self.locals)} = 0.0;")
        for st in self.node.body:
            lines += self.stmt(st, 1)
        lines.append("}")
        return "\n".join(lines)

    # ---------------------------------------------------------------- statements
    def stmt(self, st: ast.stmt, depth: int) -> list[str]:
        """C lines of one statement: the handler of its node type in :data:`_STATEMENTS`."""
        handler = _STATEMENTS.get(type(st))
        if handler is None:
            self.fail(st, f"statement {type(st).__name__}")
        assert handler is not None
        return handler(self, st, depth)

    def s_expr(self, st: ast.Expr, depth: int) -> list[str]:
        if isinstance(st.value, ast.Constant):
            return []  # docstring
        if not isinstance(st.value, ast.Call):
            self.fail(st, "statement Expr")
        assert isinstance(st.value, ast.Call)
        f = self.callee(st.value)  # a call of a void function
        if f is None or f.n_out != 0:
            self.fail(st, "a call whose value is dropped")
        assert f is not None
        return [f"{'    ' * depth}{_c_name(f.name)}({', '.join(self.call_args(st.value, f))});"]

    def s_pass(self, st: ast.Pass, depth: int) -> list[str]:
        return []

    def s_return(self, st: ast.Return, depth: int) -> list[str]:
        ind = "    " * depth
        if st.value is None:
            return [f"{ind}return;"]
        if isinstance(st.value, ast.Tuple):
            out = [f"{ind}*out{i} = {self.expr(e)};" for i, e in enumerate(st.value.elts)]
            return [*out, f"{ind}return;"]
        return [f"{ind}return {self.expr(st.value)};"]

    def s_assign(self, st: ast.Assign, depth: int) -> list[str]:
        ind = "    " * depth
        if len(st.targets) != 1:
            self.fail(st, "chained assignment")
        t = st.targets[0]
        if isinstance(t, ast.Tuple):
            return self.tuple_assign(st, t, ind)
        return [f"{ind}{self.target(t)} = {self.expr(st.value)};"]

    def tuple_assign(self, st: ast.Assign, t: ast.Tuple, ind: str) -> list[str]:
        """``a, b = f(...)`` (a call with as many outputs) or ``a, b = x, y``."""
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
        return []

    def s_augassign(self, st: ast.AugAssign, depth: int) -> list[str]:
        op = self.binop_symbol(st.op, st)
        return [f"{'    ' * depth}{self.target(st.target)} {op}= {self.expr(st.value)};"]

    def s_if(self, st: ast.If, depth: int) -> list[str]:
        ind = "    " * depth
        out = [f"{ind}if ({self.expr(st.test)}) {{"]
        for s in st.body:
            out += self.stmt(s, depth + 1)
        if st.orelse:
            out.append(f"{ind}}} else {{")
            for s in st.orelse:
                out += self.stmt(s, depth + 1)
        out.append(f"{ind}}}")
        return out

    def for_range(self, st: ast.For, depth: int) -> list[str]:
        """``for i in range([a,] b):`` as a C loop over a double counter (exact for integers)."""
        ind = "    " * depth
        it = st.iter
        if (
            not isinstance(st.target, ast.Name)
            or not isinstance(it, ast.Call)
            or not isinstance(it.func, ast.Name)
            or it.func.id != "range"
            or not 1 <= len(it.args) <= 2
            or st.orelse
        ):
            self.fail(st, "a for loop other than over range(a, b)")
        assert isinstance(st.target, ast.Name) and isinstance(it, ast.Call)
        i = st.target.id
        lo = self.expr(it.args[0]) if len(it.args) == 2 else "0.0"
        hi = self.expr(it.args[-1])
        out = [f"{ind}for ({i} = {lo}; {i} < {hi}; {i} += 1.0) {{"]
        for s in st.body:
            out += self.stmt(s, depth + 1)
        return [*out, f"{ind}}}"]

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

    def expr(self, e: ast.expr) -> str:
        """C text of one expression: the handler of its node type in :data:`_EXPRESSIONS`."""
        handler = _EXPRESSIONS.get(type(e))
        if handler is None:
            self.fail(e, f"expression {type(e).__name__}")
        assert handler is not None
        return handler(self, e)

    def e_constant(self, e: ast.Constant) -> str:
        if isinstance(e.value, bool | int | float):
            return _literal(e.value)
        self.fail(e, f"constant {e.value!r}")
        return ""

    def e_name(self, e: ast.Name) -> str:
        if e.id in self.args or e.id in self.locals:
            return e.id
        return self.constant(e.id, e)

    def e_subscript(self, e: ast.Subscript) -> str:
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
        if isinstance(idx, ast.Tuple | ast.Slice):
            self.fail(e, "a subscript of more than one index (pass a 1-d array)")
        return f"{arr.id}[(int)({self.expr(idx)})]"  # an integer-valued expression

    def e_binop(self, e: ast.BinOp) -> str:
        left, right = self.expr(e.left), self.expr(e.right)
        if isinstance(e.op, ast.Pow):
            return f"pow({left}, {right})"
        return f"({left} {self.binop_symbol(e.op, e)} {right})"

    def e_unaryop(self, e: ast.UnaryOp) -> str:
        if isinstance(e.op, ast.USub):
            return f"(-{self.expr(e.operand)})"
        if isinstance(e.op, ast.UAdd):
            return self.expr(e.operand)
        if isinstance(e.op, ast.Not):
            return f"(!{self.expr(e.operand)})"
        self.fail(e, "unary operator")
        return ""

    def e_boolop(self, e: ast.BoolOp) -> str:
        op = " && " if isinstance(e.op, ast.And) else " || "
        return "(" + op.join(self.expr(v) for v in e.values) + ")"

    def e_compare(self, e: ast.Compare) -> str:
        parts = []
        lhs = e.left
        for cmp, rhs in zip(e.ops, e.comparators, strict=True):
            sym = _COMPARISONS.get(type(cmp))
            if sym is None:
                self.fail(e, f"comparison {type(cmp).__name__}")
            parts.append(f"({self.expr(lhs)} {sym} {self.expr(rhs)})")
            lhs = rhs
        return "(" + " && ".join(parts) + ")"

    def e_ifexp(self, e: ast.IfExp) -> str:
        return f"({self.expr(e.test)} ? {self.expr(e.body)} : {self.expr(e.orelse)})"

    def e_attribute(self, e: ast.Attribute) -> str:
        if isinstance(e.value, ast.Name) and e.value.id == "math" and e.attr == "pi":
            return _literal(math.pi)
        if isinstance(e.value, ast.Name) and e.value.id == "math" and e.attr == "inf":
            return "HUGE_VAL"
        self.fail(e, f"attribute {ast.unparse(e)}")
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
            if fn.id == "int":  # truncation toward zero, as Python's
                return f"((double)(int)({self.expr(e.args[0])}))"
            if fn.id in ("min", "max") and len(e.args) == 2:
                a, b = (self.expr(x) for x in e.args)
                # Python's: the first argument unless the second is strictly smaller (larger)
                return f"({b} {'<' if fn.id == 'min' else '>'} {a} ? {b} : {a})"
            f = self.callee(e)
            if f is None:
                self.fail(e, f"call of {fn.id}")
            assert f is not None
            if f.n_out != 1:
                self.fail(e, f"{fn.id} returns a tuple; assign it to as many names")
            return f"{_c_name(f.name)}({', '.join(self.call_args(e, f))})"
        self.fail(e, "call")
        return ""


#: The statements the emitter translates: node type → :class:`_Func` handler (lines of C).
_STATEMENTS: dict[type, Callable[..., list[str]]] = {
    ast.Expr: _Func.s_expr,
    ast.Pass: _Func.s_pass,
    ast.Return: _Func.s_return,
    ast.Assign: _Func.s_assign,
    ast.AugAssign: _Func.s_augassign,
    ast.If: _Func.s_if,
    ast.For: _Func.for_range,
}
#: The expressions it translates: node type → handler (C text).
_EXPRESSIONS: dict[type, Callable[..., str]] = {
    ast.Constant: _Func.e_constant,
    ast.Name: _Func.e_name,
    ast.Subscript: _Func.e_subscript,
    ast.BinOp: _Func.e_binop,
    ast.UnaryOp: _Func.e_unaryop,
    ast.BoolOp: _Func.e_boolop,
    ast.Compare: _Func.e_compare,
    ast.IfExp: _Func.e_ifexp,
    ast.Attribute: _Func.e_attribute,
    ast.Call: _Func.call,
}
#: Python's comparison operators in C.
_COMPARISONS: dict[type, str] = {
    ast.Lt: "<",
    ast.LtE: "<=",
    ast.Gt: ">",
    ast.GtE: ">=",
    ast.Eq: "==",
    ast.NotEq: "!=",
}


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


def emit_unit(
    entries: Sequence[Callable], overloads: dict[str, Callable] | None = None
) -> tuple[str, list[str]]:
    """One C99 unit of several numba functions and everything they call, each function once.

    The general form of :func:`emit_functions` (which the axis FMU uses for ``rhs_full``):
    the control law's C (:func:`hydropwa.control.c_sources`) is its sampling function and the
    load-pressure measurement; a residual generator's C would be its residual functions.

    Parameters
    ----------
    entries : sequence of numba dispatchers
        The functions a caller of the unit calls (named ``hp_<name>`` in the C, ``static``).
    overloads : dict, optional
        As for :func:`emit_functions`.

    Returns
    -------
    text : str
        The C functions, callees before callers.
    names : list of str
        The Python functions translated, in that order.
    """
    em = _Emitter(dict(overloads or {}))
    for entry in entries:
        module = inspect.getmodule(getattr(entry, "py_func", entry))
        assert module is not None
        em.function(entry.__name__, module, entry)
    return "\n\n".join(em.order) + "\n", list(em.done)
