"""Parameters and bracketed expressions (RS274NGC §3.5), evaluated on a parameter table.

Expression trees come from ipr.syntax: a float is a constant; ("#", key) reads a
parameter (key an int, a lower-case name, or a tree giving the number); ("exists", name);
("neg", x);
(op, a, b) for the binary operators (+ - * / mod ** and or xor eq ne gt ge lt le);
(func, x) for the unary functions; ("atan", y, x). Trigonometry is in degrees.
"""
from __future__ import annotations

import math
import operator

from ipr.errors import BlockError
from ipr.parameters import MAX_PARAM
_EPS = 1e-12


def _check_number(key: float) -> int:
    n = round(key)
    if abs(key - n) > 1e-6 or not 1 <= n <= MAX_PARAM:
        raise BlockError("E-PARAM", f"parameter number {key:g} is not an integer in 1..{MAX_PARAM}")
    return n


def param_key(key, params: dict) -> int | str:
    """The table key of a parameter reference: an int 1..MAX_PARAM or a name."""
    if isinstance(key, str):
        return key
    if not isinstance(key, (int, float)):
        key = evaluate(key, params)
    return _check_number(key)


def read_param(key, params) -> float:
    """A parameter's value; `params` is an ipr.parameters.Parameters (unset ones, system values)."""
    return params[param_key(key, params)]


def _unary(name: str, x: float) -> float:
    if name == "abs":
        return abs(x)
    if name in ("acos", "asin"):
        if not -1.0 <= x <= 1.0:
            raise BlockError("E-EXPR", f"{name.upper()}[{x:g}]: argument outside -1..1")
        return math.degrees(math.acos(x) if name == "acos" else math.asin(x))
    if name in ("cos", "sin", "tan"):
        return getattr(math, name)(math.radians(x))
    if name == "exp":
        try:
            return math.exp(x)
        except OverflowError:
            raise BlockError("E-EXPR", f"EXP[{x:g}] overflows") from None
    if name == "fix":
        return float(math.floor(x))
    if name == "fup":
        return float(math.ceil(x))
    if name == "ln":
        if x <= 0.0:
            raise BlockError("E-EXPR", f"LN[{x:g}]: argument not positive")
        return math.log(x)
    if name == "round":
        return float(math.floor(abs(x) + 0.5)) * (1.0 if x >= 0 else -1.0)  # halves away from zero
    if name == "sqrt":
        if x < 0.0:
            raise BlockError("E-EXPR", f"SQRT[{x:g}]: negative argument")
        return math.sqrt(x)
    raise BlockError("E-EXPR", f"unknown function {name.upper()}")


def _divide(a: float, b: float) -> float:
    if b == 0.0:
        raise BlockError("E-EXPR", "division by zero")
    return a / b


def _modulo(a: float, b: float) -> float:
    if b == 0.0:
        raise BlockError("E-EXPR", "MOD by zero")
    r = math.fmod(a, b)
    return r + abs(b) if r < 0.0 else r   # never negative, as in RS274NGC


def _power(a: float, b: float) -> float:
    try:
        r = a ** b
    except (OverflowError, ZeroDivisionError):
        raise BlockError("E-EXPR", f"{a:g}**{b:g} has no value") from None
    if isinstance(r, complex):
        raise BlockError("E-EXPR", f"{a:g}**{b:g}: negative base with a fractional power")
    return float(r)


_BINARY = {
    "+": operator.add, "-": operator.sub, "*": operator.mul, "/": _divide, "mod": _modulo, "**": _power,
    "and": lambda a, b: float(a != 0.0 and b != 0.0),
    "or": lambda a, b: float(a != 0.0 or b != 0.0),
    "xor": lambda a, b: float((a != 0.0) != (b != 0.0)),
    "eq": lambda a, b: float(abs(a - b) < _EPS), "ne": lambda a, b: float(abs(a - b) >= _EPS),
    "gt": lambda a, b: float(a > b), "ge": lambda a, b: float(a >= b),
    "lt": lambda a, b: float(a < b), "le": lambda a, b: float(a <= b),
}


def _binary(op: str, a: float, b: float) -> float:
    return _BINARY[op](a, b)


def evaluate(node, params: dict) -> float:
    """The value of an expression tree; raises BlockError(E-EXPR / E-PARAM)."""
    if isinstance(node, float):
        return node
    value = _evaluate(node, params)
    if not math.isfinite(value):
        raise BlockError("E-EXPR", "expression has no finite value")
    return value


def _evaluate(node, params: dict) -> float:
    if isinstance(node, float):
        return node
    head = node[0]
    if head == "#":
        return read_param(node[1], params)
    if head == "neg":
        return -_evaluate(node[1], params)
    if head == "exists":
        return params.exists(node[1])
    if head == "atan":
        return math.degrees(math.atan2(_evaluate(node[1], params), _evaluate(node[2], params)))
    if len(node) == 2:
        return _unary(head, _evaluate(node[1], params))
    value = _binary(head, _evaluate(node[1], params), _evaluate(node[2], params))
    if not math.isfinite(value):
        raise BlockError("E-EXPR", f"{node[0].upper()} overflows")
    return value


def _finite(value: float) -> float:
    if not math.isfinite(value):
        raise BlockError("E-EXPR", "expression has no finite value")
    return value


def _param_at(number: float, params) -> float:
    """#[expr]: the parameter whose number an expression gives (param_key's rule)."""
    return params[_check_number(_finite(number))]


def _overflow(op: str):
    raise BlockError("E-EXPR", f"{op.upper()} overflows")


def _no_value():
    raise BlockError("E-EXPR", "expression has no finite value")


def _atan(y: float, x: float) -> float:
    return math.degrees(math.atan2(y, x))


_ARITHMETIC = {"+": "+", "-": "-", "*": "*"}   # Python's own operator, then the finiteness check
_CHECKED = {"/": "_divide", "mod": "_modulo", "**": "_power"}   # raise their own errors, then the check
_SCOPE = {"_param_at": _param_at, "_read": read_param, "_atan": _atan, "_unary": _unary, "_overflow": _overflow,
          "_no_value": _no_value, "_divide": _divide, "_modulo": _modulo, "_power": _power,
          **{f"_op_{op}": f for op, f in _BINARY.items() if op.isalpha()}}


class _Writer:
    """Straight-line Python computing _evaluate(node), step for step in the tree walk's order
    (left operand, right operand, operator; the same checks, so the same errors)."""

    def __init__(self):
        self.lines: list[str] = []

    def temp(self, source: str) -> str:
        name = f"t{len(self.lines)}"
        self.lines.append(f"    {name} = {source}")
        return name

    def check(self, name: str, error: str) -> None:
        self.lines.append(f"    if {name} - {name} != 0.0: {error}")   # inf and nan, not finite numbers

    def value(self, node) -> str:
        if node.__class__ is float:
            return repr(node) if math.isfinite(node) else f"float({repr(node)!r})"
        head = node[0]
        if head == "#":
            key = node[1]
            if key.__class__ is str:
                return self.temp(f"P[{key!r}]")
            if key.__class__ is int and 1 <= key <= MAX_PARAM:
                return self.temp(f"P[{key}]")
            if key.__class__ in (int, float):
                return self.temp(f"_read({key!r}, P)")   # raises E-PARAM when it is read, as evaluate does
            return self.temp(f"_param_at({self.value(key)}, P)")
        if head == "neg":
            return self.temp(f"-{self.value(node[1])}")
        if head == "exists":
            return self.temp(f"P.exists({node[1]!r})")
        if head == "atan":
            y = self.value(node[1])
            return self.temp(f"_atan({y}, {self.value(node[2])})")
        if len(node) == 2:
            return self.temp(f"_unary({head!r}, {self.value(node[1])})")
        a = self.value(node[1])
        b = self.value(node[2])
        if head in _ARITHMETIC:
            result = self.temp(f"{a} {head} {b}")
        elif head in _CHECKED:
            result = self.temp(f"{_CHECKED[head]}({a}, {b})")
        else:
            return self.temp(f"_op_{head}({a}, {b})")   # a comparison or logic: 0.0 or 1.0
        self.check(result, f"_overflow({head!r})")
        return result


def compile_expression(node):
    """A function of the parameter table giving evaluate(node, table): the same value and the
    same errors, without walking the tree each time (a loop body evaluates its lines millions
    of times): one statement per operation, so no depth of tree is too deep for Python's parser."""
    if node.__class__ is float:
        return lambda params: node
    writer = _Writer()
    result = writer.value(node)
    writer.check(result, "_no_value()")
    scope = dict(_SCOPE)
    exec("def value(P):\n" + "\n".join(writer.lines) + f"\n    return {result}\n", scope)
    return scope["value"]
