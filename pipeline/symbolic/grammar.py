"""The expressions of the symbolic regression: built from fitted constants `c`, the variables (`x`,
and `x1`, `x2` where there are several) and the operations +, -, *, /; enumerated up to a
complexity, parsed, printed, evaluated. No JAX here (`pipeline.symbolic.search` fits them), so that
bad input is answered at once.

Complexity is TuringBot's, as the paper's table implies it: every constant, the variable, +, -
and * count 1 and / counts 2 (c x = 3, c (c + x) = 5, c x + c + c/x = 10,
c (c + c/(x - c) + x) = 12).

Expressions are nested tuples: a variable ("x",), ("x1",), ..., a constant ("c",) or (op, left,
right). Enumeration keeps one
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
VARIABLES_MAX = 3
# Opcodes of the register programs the fitter runs.
NOP, VAR, CONST, ADD, SUB, MUL, DIV = range(7)
OPCODE = {"x": VAR, "c": CONST, "+": ADD, "-": SUB, "*": MUL, "/": DIV}


def variable_leaf(k: int) -> tuple:
    """The k-th variable's leaf: ("x",) for the first, ("x1",), ("x2",) for the others."""
    return X if k == 0 else (f"x{k}",)


def is_variable(e) -> bool:
    return len(e) == 1 and e != C


def variable_index(e) -> int:
    return 0 if e == X else int(e[0][1:])


def complexity(e) -> int:
    if len(e) == 1:
        return 1
    return COST[e[0]] + complexity(e[1]) + complexity(e[2])


def constants(e) -> int:
    if len(e) == 1:
        return int(e == C)
    return constants(e[1]) + constants(e[2])


def _has_x(e) -> bool:
    return is_variable(e) or (len(e) == 3 and (_has_x(e[1]) or _has_x(e[2])))


def linear_constants(e) -> tuple:
    """Which constants (in order of appearance) the expression is jointly affine in: a largest set
    of constants none of which sits in a denominator and no two of which are multiplied together
    (each constant appears once, so the expression is then affine in the set). The fit solves
    these exactly by linear least squares (variable projection) and iterates only the others."""
    paths = []

    def walk(node, path):
        if node == C:
            paths.append(path)
        elif len(node) == 3:
            walk(node[1], path + ((id(node), node[0], 0),))
            walk(node[2], path + ((id(node), node[0], 1),))

    walk(e, ())
    linear = [all(not (op == "/" and side == 1) for _, op, side in path) for path in paths]

    def multiplied(i, j):       # the lowest common ancestor of constants i and j is a product
        a, b = paths[i], paths[j]
        k = 0
        while k < min(len(a), len(b)) and a[k] == b[k]:
            k += 1
        return a[k][1] in "*/"

    candidates = [i for i, ok in enumerate(linear) if ok]
    best = ()
    for mask in range(1 << len(candidates)):
        chosen = tuple(candidates[b] for b in range(len(candidates)) if mask >> b & 1)
        if len(chosen) > len(best) and not any(multiplied(i, j) for i in chosen for j in chosen if i < j):
            best = chosen
    return tuple(i in best for i in range(len(paths)))


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
def _forms_of(size: int, ops: str, variables: int) -> tuple:
    if size == 1:
        return tuple(variable_leaf(k) for k in range(variables)) + (C,)
    out = []
    for op in ops:
        w = COST[op]
        for left in range(1, size - w):
            for a in _forms_of(left, ops, variables):
                for b in _forms_of(size - w - left, ops, variables):
                    if _canonical(op, a, b):
                        out.append((op, a, b))
    return tuple(out)


def enumerate_forms(max_complexity: int, ops: str = "+-*/", variables: int = 1) -> list:
    """Every kept expression of complexity 1..max_complexity in `variables` variables, by complexity."""
    if not 1 <= variables <= VARIABLES_MAX:
        raise ValueError(f"{variables} variables: the grammar takes 1 to {VARIABLES_MAX}")
    return [e for size in range(1, max_complexity + 1) for e in _forms_of(size, ops, variables)]


def _names(variable) -> list:
    """One name (or symbol) per variable, from a name or a sequence of names."""
    return list(variable) if isinstance(variable, (list, tuple)) else [variable]


def show(e, variable="x", constants=None) -> str:
    """Infix text, the variables named `variable` (a name, or one name per variable), every
    constant written c (or its value, from `constants` in the order the constants appear)."""
    values = iter(constants) if constants is not None else None
    names = _names(variable)

    def text(node, top):
        if is_variable(node):
            return names[variable_index(node)]
        if node == C:
            return "c" if values is None else f"{next(values):.6g}"
        inner = f"{text(node[1], False)} {node[0]} {text(node[2], False)}"
        return inner if top else f"({inner})"

    return text(e, True)


def programs(forms, length: int) -> np.ndarray:
    """Register programs, one row per form: (opcode, left, right, index) per step, shape (forms, 4,
    length), the index a constant's (in order of appearance) or a variable's. Each step writes one
    register; the result is the last register. Forms shorter than `length` are padded at the front
    with no-ops."""
    out = np.zeros((len(forms), 4, length), dtype=np.int32)
    for row, e in enumerate(forms):
        steps = []

        def emit(node, count=[0]):
            if len(node) == 1:
                steps.append((CONST, 0, 0, count[0]) if node == C else (VAR, 0, 0, variable_index(node)))
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


def parse(text: str, variable="x", values=None):
    """An expression tree from infix text in the variable (a name, or one name per variable), c (or
    any number, read as a fitted constant; a number after an opening parenthesis or an operator may
    carry a minus sign), +, -, *, / and parentheses. `values`, a list, receives each constant's
    number in order of appearance (nan for c)."""
    names = _names(variable)
    values = [] if values is None else values
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
        if t in names:
            return variable_leaf(names.index(t))
        if t == "c":
            values.append(float("nan"))
            return C
        sign = 1.0
        if t == "-" and peek() is not None:
            sign, t = -1.0, take()
        try:
            values.append(sign * float(t))
        except ValueError:
            raise ValueError(f"unknown symbol {t!r} in {text!r} (use {', '.join(names)}, c, numbers, "
                             f"+ - * /)") from None
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


def fold_constants(e, values):
    """(e, values) with every subtree free of variables (c op c, as another engine may write it)
    replaced by one constant of its value: the complexity of what the expression is."""
    values = iter(values)

    def build(node):
        if node == C:
            return C, [next(values)]
        if len(node) == 1:
            return node, []
        (a, va), (b, vb) = build(node[1]), build(node[2])
        if a == C and b == C:
            x, y = va[0], vb[0]
            with np.errstate(all="ignore"):
                v = {"+": x + y, "-": x - y, "*": x * y}.get(node[0], x / y if y != 0 else np.inf)
            return C, [float(v)]
        return (node[0], a, b), va + vb

    return build(e)


def substitute(e, constants, variables):
    """e with its constants (in order of appearance) and its variables (a list, one per variable)
    put in: numbers and numpy arrays give its values, sympy Floats and Symbols its sympy expression."""
    values = iter(constants)

    def build(node):
        if is_variable(node):
            return variables[variable_index(node)]
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
    """The sympy expression of e with its fitted constants, in `symbol` (or a list of symbols, one
    per variable)."""
    import sympy as sp

    return substitute(e, [sp.Float(float(v), 15) for v in constants], _names(symbol))


def canonical(expression, symbol) -> str:
    """sympy's canonical text of an expression in `symbol`: a polynomial part plus partial
    fractions (in several variables, given as a list: one cancelled fraction), numbers to 6
    significant digits."""
    import sympy as sp

    simplified = sp.cancel(sp.together(expression))
    symbols = _names(symbol)
    if len(symbols) == 1:
        simplified = sp.apart(simplified, symbols[0])
    return re.sub(r"(?<![\d.])1\.0\*", "", str(simplified.evalf(6)))


def evaluate_numpy(e, c, x):
    """Value of e with constants c (in order of appearance) at x (the points of one variable, or an
    array (variables, points)), in numpy."""
    x = np.asarray(x, dtype=np.float64)
    columns = x[None] if x.ndim == 1 else x
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        value = substitute(e, [float(v) for v in c], list(columns))
        return np.broadcast_to(value, columns.shape[1:]).astype(np.float64)
