"""The expressions of the symbolic regression: built from fitted constants `c`, one variable `x`
and the operations +, -, *, /; enumerated up to a complexity, parsed, printed, evaluated. No JAX
here (`pipeline.symbolic.search` fits them), so that bad input is answered at once.

Complexity is TuringBot's, as the paper's table implies it: every constant, the variable, +, -
and * count 1 and / counts 2 (c x = 3, c (c + x) = 5, c x + c + c/x = 10,
c (c + c/(x - c) + x) = 12).

Expressions are nested tuples: ("x",), ("c",) or (op, left, right). Enumeration keeps one
representative of expressions that are equal for every value of the constants, or reduces them to
a cheaper one with the same family, by these rules (each removes only expressions that another
kept expression matches at equal or lower complexity):
- no operation between two constant-only operands (c op c is a constant);
- + and * chains are flattened left to right, their operands sorted, with at most one lone
  constant among them (c + c or c c is one constant);
- in a chain of + and -, every subtraction comes after every addition (a - b + c = a + c - b)
  and the subtracted operands are sorted; a - c is written a + c; a - a is 0;
- no quotient inside a product ((a/b) c = (a c)/b at the same cost), nor as numerator or
  denominator of a quotient ((a/b)/c = a/(b c) is cheaper); a/c is written c a (cheaper);
  a constant factor moves out of a quotient's operands to one numerator constant;
- like terms in a chain of + and - (a and a, or a and c a) are dropped (c a is cheaper), and so
  are common factors of a quotient's numerator and denominator.
"""

from __future__ import annotations

import re
from functools import lru_cache

import numpy as np

COST = {"+": 1, "-": 1, "*": 1, "/": 2}
X, C = ("x",), ("c",)
# Opcodes of the register programs the fitter runs.
NOP, VAR, CONST, ADD, SUB, MUL, DIV = range(7)
OPCODE = {"x": VAR, "c": CONST, "+": ADD, "-": SUB, "*": MUL, "/": DIV}


def complexity(e) -> int:
    if len(e) == 1:
        return 1
    return COST[e[0]] + complexity(e[1]) + complexity(e[2])


def constants(e) -> int:
    if len(e) == 1:
        return int(e == C)
    return constants(e[1]) + constants(e[2])


def _has_x(e) -> bool:
    return e == X or (len(e) == 3 and (_has_x(e[1]) or _has_x(e[2])))


def _chain(e, ops) -> list:
    """Operands of the left-to-right chain of `ops` rooted at e."""
    if e[0] in ops:
        return _chain(e[1], ops) + [e[2]]
    return [e]


def _key(e) -> str:
    return repr(e)


def _has_constant_factor(e) -> bool:
    return e[0] == "*" and C in _chain(e, "*")


def _without_constant_factor(e) -> str:
    """Key of e with a constant factor removed: two chain terms with equal keys are like terms."""
    if e[0] == "*":
        return _key([f for f in _chain(e, "*") if f != C])
    return _key([e])


def _canonical(op, a, b) -> bool:
    """Whether (op, a, b) is the representative the enumeration keeps (module docstring)."""
    if not (_has_x(a) or _has_x(b)):
        return False
    if op == "+":
        if b[0] in "+-" or a[0] == "-" or a == b:
            return False
        terms = _chain((op, a, b), "+")
        if sum(t == C for t in terms) > 1 or [_key(t) for t in terms] != sorted(_key(t) for t in terms):
            return False
    elif op == "-":
        if b == C or a == b or b[0] in "+-":
            return False
        if a[0] == "-" and _key(a[2]) > _key(b):
            return False
    if op in "+-":
        terms = [_without_constant_factor(t) for t in _chain((op, a, b), "+-")]
        if len(set(terms)) < len(terms):
            return False
    elif op == "*":
        if b[0] == "*" or a[0] == "/" or b[0] == "/":
            return False
        factors = _chain((op, a, b), "*")
        if sum(f == C for f in factors) > 1 or [_key(f) for f in factors] != sorted(_key(f) for f in factors):
            return False
    elif op == "/":
        if a == b or b == C or a[0] == "/" or b[0] == "/":
            return False
        if _has_constant_factor(b):
            return False
        numerator = {_key(f) for f in _chain(a, "*") if f != C}
        if numerator & {_key(f) for f in _chain(b, "*")}:
            return False
    return True


@lru_cache(maxsize=None)
def _forms_of(size: int, ops: str) -> tuple:
    if size == 1:
        return (X, C)
    out = []
    for op in ops:
        w = COST[op]
        for left in range(1, size - w):
            for a in _forms_of(left, ops):
                for b in _forms_of(size - w - left, ops):
                    if _canonical(op, a, b):
                        out.append((op, a, b))
    return tuple(out)


def enumerate_forms(max_complexity: int, ops: str = "+-*/") -> list:
    """Every kept expression of complexity 1..max_complexity, by complexity."""
    return [e for size in range(1, max_complexity + 1) for e in _forms_of(size, ops)]


def show(e, variable: str = "x", constants=None) -> str:
    """Infix text, the variable named `variable`, every constant written c (or its value, from
    `constants` in the order the constants appear)."""
    values = iter(constants) if constants is not None else None

    def text(node, top):
        if node == X:
            return variable
        if node == C:
            return "c" if values is None else f"{next(values):.6g}"
        inner = f"{text(node[1], False)} {node[0]} {text(node[2], False)}"
        return inner if top else f"({inner})"

    return text(e, True)


def programs(forms, length: int) -> np.ndarray:
    """Register programs, one row per form: (opcode, left, right, constant index) per step, shape
    (forms, 4, length). Each step writes one register; the result is the last register. Forms
    shorter than `length` are padded at the front with no-ops."""
    out = np.zeros((len(forms), 4, length), dtype=np.int32)
    for row, e in enumerate(forms):
        steps = []

        def emit(node, count=[0]):
            if len(node) == 1:
                steps.append((OPCODE[node[0]], 0, 0, count[0] if node == C else 0))
                count[0] += node == C
            else:
                a = emit(node[1])
                b = emit(node[2])
                steps.append((OPCODE[node[0]], a, b, 0))
            return len(steps) - 1

        emit(e, count=[0])
        if len(steps) > length:
            raise ValueError(f"{show(e)} needs {len(steps)} steps, more than {length}")
        pad = length - len(steps)
        for i, (op, a, b, c) in enumerate(steps):
            out[row, :, pad + i] = (op, a + pad, b + pad, c)
    return out


def parse(text: str, variable: str = "x"):
    """An expression tree from infix text in the variable, c (or any number, read as a fitted
    constant), +, -, *, / and parentheses."""
    tokens = text.replace("(", " ( ").replace(")", " ) ")
    for op in "+-*/":
        tokens = tokens.replace(op, f" {op} ")
    tokens = tokens.split()
    position = [0]

    def peek():
        return tokens[position[0]] if position[0] < len(tokens) else None

    def take():
        if position[0] >= len(tokens):
            raise ValueError(f"{text!r} ends early (unbalanced parentheses or a missing operand)")
        position[0] += 1
        return tokens[position[0] - 1]

    def atom():
        t = take()
        if t == "(":
            e = chain()
            if take() != ")":
                raise ValueError(f"unbalanced parentheses in {text!r}")
            return e
        if t == variable:
            return X
        if t == "c":
            return C
        try:
            float(t)
        except ValueError:
            raise ValueError(f"unknown symbol {t!r} in {text!r} (use {variable}, c, numbers, + - * /)") from None
        return C

    def product():
        e = atom()
        while peek() in ("*", "/"):
            e = (take(), e, atom())
        return e

    def chain():
        e = product()
        while peek() in ("+", "-"):
            e = (take(), e, product())
        return e

    e = chain()
    if peek() is not None:
        raise ValueError(f"unexpected {peek()!r} in {text!r}")
    return e


def substitute(e, constants, variable):
    """e with its constants (in order of appearance) and the variable put in: numbers and a numpy
    array give its values, sympy Floats and a Symbol its sympy expression."""
    values = iter(constants)

    def build(node):
        if node == X:
            return variable
        if node == C:
            return next(values)
        a, b = build(node[1]), build(node[2])
        if node[0] == "+":
            return a + b
        if node[0] == "-":
            return a - b
        return a * b if node[0] == "*" else a / b

    return build(e)


def to_sympy(e, constants, symbol):
    """The sympy expression of e with its fitted constants."""
    import sympy as sp

    return substitute(e, [sp.Float(float(v), 15) for v in constants], symbol)


def canonical(expression, symbol) -> str:
    """sympy's canonical text of an expression in `symbol`: a polynomial part plus partial
    fractions, numbers to 6 significant digits."""
    import sympy as sp

    simplified = sp.apart(sp.cancel(sp.together(expression)), symbol)
    return re.sub(r"(?<![\d.])1\.0\*", "", str(simplified.evalf(6)))


def evaluate_numpy(e, c, x):
    """Value of e with constants c (in order of appearance) at x, in numpy."""
    with np.errstate(divide="ignore", invalid="ignore"):
        value = substitute(e, [float(v) for v in c], np.asarray(x, dtype=np.float64))
        return np.broadcast_to(value, np.shape(x)).astype(np.float64)
