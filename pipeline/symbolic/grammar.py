"""The expressions of the symbolic regression: built from fitted constants `c`, the variables (`x`,
and `x1`, `x2` where there are several), the operations +, -, *, /, pow (a ^ b) and the functions
exp, log, sqrt, square, cube, sin, cos, abs and inv (1/a); enumerated up to a complexity, parsed,
printed, evaluated. No JAX here (`pipeline.symbolic.search` fits them), so that bad input is
answered at once.

Complexity is TuringBot's for + - * /, as the paper's table implies it: every constant, the
variable, +, - and * count 1 and / counts 2 (c x = 3, c (c + x) = 5, c x + c + c/x = 10,
c (c + c/(x - c) + x) = 12). A function counts as a division does, 2 (exp, log, sqrt, sin, cos,
abs, and pow: one call each; inv, 1/a, is the division it writes), and square and cube count 1,
as the product they stand for (so square(x) = 2 against x x = 3). `COST` holds it; a user's
table (`read_cost_table`) ranks the forms without changing which are enumerated: the enumeration
is by the default count (structure), the front by the table (cost).

Expressions are nested tuples: a variable ("x",), ("x1",), ..., a constant ("c",), a function
(name, a) or an operation (op, left, right), "pow" for a ^ b. Enumeration keeps one representative
of expressions that are equal for every value of the constants, or reduces them to a cheaper one
with the same family, by these rules (each removes only expressions that another kept expression
matches, wherever the removed one is defined, at equal or lower complexity):
- no operation or function of constant-only operands (c op c, exp(c) are constants);
- + and * chains are flattened left to right, their operands sorted, with at most one lone
  constant among them (c + c or c c is one constant);
- in a chain of + and -, every subtraction comes after every addition (a - b + c = a + c - b)
  and the subtracted operands are sorted; a - c is written a + c; a - a is 0;
- no quotient inside a product ((a/b) c = (a c)/b at the same cost), nor as numerator or
  denominator of a quotient ((a/b)/c = a/(b c) is cheaper); a/c is written c a (cheaper);
  a constant factor moves out of a quotient's operands to one numerator constant;
- like terms in a chain of + and - (a and a, or a and c a) are dropped (c a is cheaper), and so
  are common factors of a quotient's numerator and denominator;
- a function undone: exp(log a) and log(exp a) are a; square(sqrt a) is a;
- a constant moved out of a function at equal cost: exp(a + c) = c exp(a), square(c a) =
  c square(a), cube(c a) = c cube(a); c + log(a) = log(c a) (the kept forms reach every sign);
- a power of a power: log(sqrt a) = c log(a), log(a ^ b) = b log(a), sqrt, square or cube of a ^ c,
  and (sqrt a) ^ c, (cube a) ^ c, (a ^ c) ^ c, are one power (a ^ c) or c log(a);
  cube(square a) = square(cube a); (exp a) ^ b = exp(a b);
- two like functions joined where one does: exp(a) exp(b) = exp(a + b), exp(a)/exp(b) =
  exp(a - b), and so for sqrt, square and cube (sqrt(a) sqrt(b) = sqrt(a b), square(a)/square(b)
  = square(a/b)); log(a) + log(b) = log(a b), log(a) - log(b) = log(a/b);
- abs of what is never negative is that (abs of abs, exp, sqrt, square or a power a ^ b, which
  is real for a > 0 alone); abs(c a) = c abs(a); square(abs a) = square(a), cube(abs a) =
  abs(cube a), cos(abs a) = cos(a), and sqrt(square a) = abs(a) (cheaper); two abs factors
  join (abs(a) abs(b) = abs(a b));
- inv undone or moved: inv(inv a) = a, inv(c a) = c inv(a), inv(a ^ c) = a ^ c, inv(exp a) =
  exp(c a), inv(a / b) = b / a, log(inv a) = c log(a); sqrt, square, cube and abs of inv a are
  inv of sqrt, square, cube, abs of a; where / is given, inv is never a factor of a product
  (b inv(a) = b / a) nor, where * is given too, an operand of a quotient (inv(a) / b = inv(a b),
  a / inv(b) = a b), each at lower cost; two inv factors join where * is given (inv(a) inv(b)
  = inv(a b));
- cos of a sum with a constant term is a sine where sin is given (cos(a + c) = sin(a + c')).
Domain guards are the fit's: a form whose value or gradient is not finite at a data point (log or
sqrt of a value that reaches zero or below, a ^ b of a negative base, exp overflowing) is invalid
there and never enters the front.
"""

from __future__ import annotations

import re
from functools import lru_cache

import numpy as np

BINARY = ("+", "-", "*", "/", "pow")
UNARY = ("exp", "log", "sqrt", "square", "cube", "sin", "cos", "abs", "inv")
# Every operation the grammar knows, in the order the enumeration takes them.
OPERATIONS = ("+", "-", "*", "/", "exp", "log", "sqrt", "square", "cube", "pow", "sin", "cos", "abs", "inv")
# The ten a user of pyoperon or TuringBot starts from: `pipeline regress`'s default `--ops`.
TEN = OPERATIONS[:10]
ARITHMETIC = ("+", "-", "*", "/")
# TuringBot's complexity for + - * / (the paper's table implies it), a function's as a division's,
# square and cube as a product's (module docstring); every leaf counts 1.
COST = {"+": 1, "-": 1, "*": 1, "/": 2, "pow": 2, "exp": 2, "log": 2, "sqrt": 2, "square": 1, "cube": 1,
        "sin": 2, "cos": 2, "abs": 2, "inv": 2}
LEAF_COST = 1
X, C = ("x",), ("c",)
VARIABLES_MAX = 3
# Opcodes of the register programs the fitter runs.
NOP, VAR, CONST, ADD, SUB, MUL, DIV, POW, EXP, LOG, SQRT, SQUARE, CUBE, SIN, COS, ABS, INV = range(17)
OPCODE = {"x": VAR, "c": CONST, "+": ADD, "-": SUB, "*": MUL, "/": DIV, "pow": POW, "exp": EXP, "log": LOG,
          "sqrt": SQRT, "square": SQUARE, "cube": CUBE, "sin": SIN, "cos": COS, "abs": ABS, "inv": INV}
# Never negative wherever defined (abs of them is themselves).
NONNEGATIVE = ("exp", "sqrt", "square", "abs", "pow")
# Names the parser also reads: pyoperon's and sympy's spellings.
ALIASES = {"add": "+", "sub": "-", "mul": "*", "div": "/", "^": "pow", "**": "pow", "sq": "square"}


def operations(spec) -> tuple:
    """The operations named by `spec`, in `OPERATIONS`' order: a string of characters from "+-*/"
    ("+-*/"), a comma- or space-separated list of names ("+,-,*,/,exp,pow"), or a sequence of names.
    Raises ValueError naming an unknown or repeated one."""
    if isinstance(spec, str):
        names = [t for t in re.split(r"[,\s]+", spec.strip()) if t]
        if len(names) == 1 and len(names[0]) > 1 and set(names[0]) <= set("+-*/"):
            names = list(names[0])
    else:
        names = list(spec)
    names = [ALIASES.get(n, n) for n in names]
    unknown = [n for n in names if n not in OPERATIONS]
    if unknown or not names:
        raise ValueError(f"unknown operation {unknown[0]!r}" if unknown else "no operation given")
    repeated = sorted({n for n in names if names.count(n) > 1})
    if repeated:
        raise ValueError(f"operation {repeated[0]!r} given twice")
    return tuple(op for op in OPERATIONS if op in names)


def variable_leaf(k: int) -> tuple:
    """The k-th variable's leaf: ("x",) for the first, ("x1",), ("x2",) for the others."""
    return X if k == 0 else (f"x{k}",)


def is_variable(e) -> bool:
    return len(e) == 1 and e != C


def variable_index(e) -> int:
    return 0 if e == X else int(e[0][1:])


def complexity(e, cost=None) -> float:
    """e's complexity under `cost` (an operation's cost by name, leaves under "constant" and
    "variable"; default `COST`, every leaf 1)."""
    table = COST if cost is None else cost
    if len(e) == 1:
        return table.get("constant" if e == C else "variable", LEAF_COST) if cost is not None else LEAF_COST
    return table[e[0]] + sum(complexity(a, cost) for a in e[1:])


@lru_cache(maxsize=None)
def constants(e) -> int:
    """How many constants e holds (kept per form: the ladder asks it of every form it plans)."""
    if len(e) == 1:
        return int(e == C)
    return sum(constants(a) for a in e[1:])


def operations_of(e) -> set:
    """The operations e uses."""
    return set() if len(e) == 1 else {e[0]}.union(*(operations_of(a) for a in e[1:]))


def has_variable(e) -> bool:
    """Whether e reads a variable (a form of constants alone approximates nothing)."""
    return is_variable(e) or (len(e) > 1 and any(has_variable(a) for a in e[1:]))


def linear_constants(e) -> tuple:
    """Which constants (in order of appearance) the expression is jointly affine in: a largest set
    of constants none of which sits in a denominator, a function or a power, and no two of which
    are multiplied together (each constant appears once, so the expression is then affine in the
    set). The fit solves these exactly by linear least squares (variable projection) and iterates
    only the others."""
    paths = []

    def walk(node, path):
        if node == C:
            paths.append(path)
        elif len(node) > 1:
            for side, child in enumerate(node[1:]):
                walk(child, path + ((id(node), node[0], side),))

    walk(e, ())
    linear = [all(op in ARITHMETIC and not (op == "/" and side == 1) for _, op, side in path) for path in paths]

    def multiplied(i, j):       # the lowest common ancestor of constants i and j is a product
        a, b = paths[i], paths[j]
        k = 0
        while k < min(len(a), len(b)) and a[k] == b[k]:
            k += 1
        return a[k][1] in ("*", "/")

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


def _added(e) -> list:
    """The added terms of a chain of + and - (those not subtracted)."""
    if e[0] == "-":
        return _added(e[1])
    return _chain(e, ("+",))


def _key(e) -> str:
    return repr(e)


def _has_constant_factor(e) -> bool:
    return e[0] == "*" and C in _chain(e, ("*",))


def _without_constant_factor(e) -> str:
    """Key of e with a constant factor removed: two chain terms with equal keys are like terms."""
    if e[0] == "*":
        return _key([f for f in _chain(e, ("*",)) if f != C])
    return _key([e])


def _power_of_constant(e) -> bool:
    """e is a ^ c: a power with a constant exponent."""
    return e[0] == "pow" and e[2] == C


def _canonical(op, a, b, ops=frozenset(OPERATIONS)) -> bool:
    """Whether (op, a, b) is the representative the enumeration keeps (module docstring); `ops`,
    the operations enumerated (a rule applies only where its kept form can be written)."""
    if not (has_variable(a) or has_variable(b)):
        return False
    if op == "+":
        if b[0] in ("+", "-") or a[0] == "-" or a == b:
            return False
        terms = _chain((op, a, b), ("+",))
        if sum(t == C for t in terms) > 1 or [_key(t) for t in terms] != sorted(_key(t) for t in terms):
            return False
        if C in terms and "*" in ops and any(t[0] == "log" for t in terms):
            return False        # c + log(a) = log(c a)
    elif op == "-":
        if b == C or a == b or b[0] in ("+", "-"):
            return False
        if a[0] == "-" and _key(a[2]) > _key(b):
            return False
    if op in ("+", "-"):
        terms = _chain((op, a, b), ("+", "-"))
        keys = [_without_constant_factor(t) for t in terms]
        if len(set(keys)) < len(keys):
            return False
        if sum(t[0] == "log" for t in terms) > 1 and ({"*", "/"} <= ops):
            return False        # log a + log b = log(a b), log a - log b = log(a/b)
    elif op == "*":
        if b[0] == "*" or a[0] == "/" or b[0] == "/":
            return False
        if "/" in ops and (a[0] == "inv" or b[0] == "inv"):
            return False        # b inv(a) = b / a
        factors = _chain((op, a, b), ("*",))
        if sum(f == C for f in factors) > 1 or [_key(f) for f in factors] != sorted(_key(f) for f in factors):
            return False
        if not _one_of_each_function(factors, ops):
            return False
    elif op == "/":
        if a == b or b == C or a[0] == "/" or b[0] == "/":
            return False
        if "*" in ops and (a[0] == "inv" or b[0] == "inv"):
            return False        # inv(a) / b = inv(a b), a / inv(b) = a b
        if _has_constant_factor(b):
            return False
        numerator = {_key(f) for f in _chain(a, ("*",)) if f != C}
        if numerator & {_key(f) for f in _chain(b, ("*",))}:
            return False
        if not _one_of_each_function(_chain(a, ("*",)) + _chain(b, ("*",)), ops):
            return False
    elif op == "pow":
        if a[0] == "exp" and "*" in ops:
            return False        # (exp a) ^ b = exp(a b)
        if b == C and (_power_of_constant(a) or a[0] in ("sqrt", "cube")):
            return False        # (a ^ c) ^ c, (sqrt a) ^ c, (cube a) ^ c are a ^ c
    return True


def _one_of_each_function(factors, ops) -> bool:
    """At most one factor of each of exp, sqrt, square, cube, abs and inv among a product's (or a
    quotient's numerator and denominator's) factors: two join into one (exp(a) exp(b) = exp(a + b))."""
    for name, needs in (("exp", {"+", "-"}), ("sqrt", {"*", "/"}), ("square", {"*", "/"}), ("cube", {"*", "/"}),
                        ("abs", {"*", "/"}), ("inv", {"*"})):
        if sum(f[0] == name for f in factors) > 1 and needs <= ops:
            return False
    return True


def _canonical_unary(name, a, ops=frozenset(OPERATIONS)) -> bool:
    """Whether (name, a) is the representative the enumeration keeps (module docstring)."""
    if not has_variable(a):
        return False
    if name == "exp":
        if a[0] == "log":
            return False
        if "*" in ops and a[0] in ("+", "-") and C in _added(a) and len(_added(a)) > 1:
            return False        # exp(a + c) = c exp(a)
    elif name == "log":
        if a[0] == "exp":
            return False
        if "*" in ops and a[0] in ("sqrt", "pow", "inv"):
            return False        # log(sqrt a) = c log(a), log(a ^ b) = b log(a), log(inv a) = c log(a)
    elif name == "sqrt":
        if _power_of_constant(a):
            return False
        if a[0] == "square" and "abs" in ops:
            return False        # sqrt(square a) = abs(a)
    elif name in ("square", "cube"):
        if (name == "square" and a[0] == "sqrt") or _power_of_constant(a) or _has_constant_factor(a):
            return False        # square(sqrt a) = a; (a ^ c)^2 = a ^ c; square(c a) = c square(a)
        if name == "cube" and a[0] == "square" and "square" in ops:
            return False        # cube(square a) = square(cube a)
        if a[0] == "abs":
            return False        # square(abs a) = square(a), cube(abs a) = abs(cube a)
    elif name == "abs":
        if a[0] in NONNEGATIVE or _has_constant_factor(a):
            return False        # abs(exp a) = exp(a), ...; abs(c a) = c abs(a)
    elif name == "inv":
        if a[0] == "inv" or _has_constant_factor(a) or _power_of_constant(a) or a[0] == "/":
            return False        # inv(inv a) = a; inv(c a) = c inv(a); inv(a ^ c) = a ^ c; inv(a / b) = b / a
        if a[0] == "exp" and "*" in ops:
            return False        # inv(exp a) = exp(c a)
    elif name == "cos":
        if a[0] == "abs":
            return False        # cos(abs a) = cos(a)
        if "sin" in ops and a[0] in ("+", "-") and C in _added(a) and len(_added(a)) > 1:
            return False        # cos(a + c) = sin(a + c')
    if name in ("sqrt", "square", "cube", "abs") and a[0] == "inv":
        return False            # sqrt(inv a) = inv(sqrt a), and so for square, cube and abs
    return True


@lru_cache(maxsize=None)
def _forms_of(size: int, ops: tuple, variables: int) -> tuple:
    if size == 1:
        return tuple(variable_leaf(k) for k in range(variables)) + (C,)
    present = frozenset(ops)
    out = []
    for op in ops:
        w = COST[op]
        if op in UNARY:
            if size - w >= 1:
                out.extend((op, a) for a in _forms_of(size - w, ops, variables) if _canonical_unary(op, a, present))
            continue
        for left in range(1, size - w):
            for a in _forms_of(left, ops, variables):
                for b in _forms_of(size - w - left, ops, variables):
                    if _canonical(op, a, b, present):
                        out.append((op, a, b))
    return tuple(out)


def forms_of(size: int, ops="+-*/", variables: int = 1) -> tuple:
    """Every kept expression of complexity exactly `size` (the default count)."""
    return _forms_of(size, operations(ops), variables)


def enumerate_forms(max_complexity: int, ops="+-*/", variables: int = 1) -> list:
    """Every kept expression of complexity 1..max_complexity in `variables` variables, by complexity."""
    if not 1 <= variables <= VARIABLES_MAX:
        raise ValueError(f"{variables} variables: the grammar takes 1 to {VARIABLES_MAX}")
    ops = operations(ops)
    return [e for size in range(1, max_complexity + 1) for e in _forms_of(size, ops, variables)]


def read_cost_table(path, ops) -> dict:
    """A cost table from a TOML file: a `[cost]` table (or top-level keys) giving each operation of
    `ops` a cost > 0, and optionally "constant" and "variable" (default 1). Raises ValueError naming
    a missing operation, an unknown key or a bad value."""
    from pathlib import Path

    from ..engine.toml_files import read_toml

    path = Path(path)
    data = read_toml(path, "cost file")
    table = data.get("cost", data)
    if not isinstance(table, dict):
        raise ValueError(f"{path}: [cost] must be a table of operation = cost")
    out = {}
    for key, value in table.items():
        name = ALIASES.get(key, key)
        if name not in OPERATIONS and name not in ("constant", "variable"):
            raise ValueError(f"{path}: unknown key {key!r} (give costs of {', '.join(OPERATIONS)}, constant, variable)")
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not np.isfinite(value) or value < 0:
            raise ValueError(f"{path}: {key} = {value!r}: give a finite number >= 0")
        out[name] = float(value)
    missing = [op for op in ops if op not in out]
    if missing:
        raise ValueError(f"{path}: no cost for {', '.join(missing)} (an operation of --ops)")
    return out


def _names(variable) -> list:
    """One name (or symbol) per variable, from a name or a sequence of names."""
    return list(variable) if isinstance(variable, (list, tuple)) else [variable]


def show(e, variable="x", constants=None) -> str:
    """Infix text, the variables named `variable` (a name, or one name per variable), every
    constant written c (or its value, from `constants` in the order the constants appear); a
    function as name(a), pow as a ^ b."""
    values = iter(constants) if constants is not None else None
    names = _names(variable)

    def text(node, top):
        if is_variable(node):
            return names[variable_index(node)]
        if node == C:
            return "c" if values is None else f"{next(values):.6g}"
        if len(node) == 2:
            return f"{node[0]}({text(node[1], True)})"
        inner = f"{text(node[1], False)} {'^' if node[0] == 'pow' else node[0]} {text(node[2], False)}"
        return inner if top else f"({inner})"

    return text(e, True)


def programs(forms, length: int) -> np.ndarray:
    """Register programs, one row per form: (opcode, left, right, index) per step, shape (forms, 4,
    length), the index a constant's (in order of appearance) or a variable's; a function reads its
    left register. Each step writes one register; the result is the last register. Forms shorter
    than `length` are padded at the front with no-ops."""
    out = np.zeros((len(forms), 4, length), dtype=np.int32)
    for row, e in enumerate(forms):
        steps = []

        def emit(node, count=[0]):
            if len(node) == 1:
                steps.append((CONST, 0, 0, count[0]) if node == C else (VAR, 0, 0, variable_index(node)))
                count[0] += node == C
            elif len(node) == 2:
                a = emit(node[1])
                steps.append((OPCODE[node[0]], a, a, 0))
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


def opcodes(forms) -> tuple:
    """The sorted opcodes the forms' programs use (the fitter evaluates only these)."""
    used = set().union(*(operations_of(e) for e in forms)) if forms else set()
    return tuple(sorted({VAR, CONST} | {OPCODE[op] for op in used}))


def operation_codes(ops) -> tuple:
    """The sorted opcodes of every program over these operations (searches over narrower ones
    compiled for them share one compiled fit)."""
    return tuple(sorted({VAR, CONST} | {OPCODE[op] for op in operations(ops)}))


_TOKEN = re.compile(r"\s*(\d+\.?\d*(?:[eE][-+]?\d+)?|\.\d+(?:[eE][-+]?\d+)?|[A-Za-z_][A-Za-z0-9_]*|\*\*|[-+*/^(),])")


def parse(text: str, variable="x", values=None):
    """An expression tree from infix text in the variable (a name, or one name per variable), c (or
    any number, read as a fitted constant; a number after an opening parenthesis, a comma or an
    operator may carry a minus sign), + - * / ^ (or **), the functions exp, log, sqrt, square,
    cube, sin, cos, abs, inv, pow(a, b), and parentheses. `values`, a list, receives each constant's number in order
    of appearance (nan for c)."""
    names = _names(variable)
    values = [] if values is None else values
    tokens, position = [], 0
    while position < len(text.rstrip()):
        match = _TOKEN.match(text, position)
        if not match:
            raise ValueError(f"unknown symbol {text[position:].split()[0]!r} in {text!r}")
        tokens.append(match.group(1))
        position = match.end()
    at = [0]

    def peek():
        return tokens[at[0]] if at[0] < len(tokens) else None

    def take():
        if at[0] >= len(tokens):
            raise ValueError(f"{text!r} ends early (unbalanced parentheses or a missing operand)")
        at[0] += 1
        return tokens[at[0] - 1]

    def expect(token):
        if take() != token:
            raise ValueError(f"unbalanced parentheses in {text!r}" if token == ")" else f"expected {token!r} in {text!r}")

    def atom():
        t = take()
        if t == "(":
            e = chain()
            expect(")")
            return e
        if t in names:
            return variable_leaf(names.index(t))
        if t == "c":
            values.append(float("nan"))
            return C
        name = ALIASES.get(t, t)
        if name in UNARY or name == "pow":
            expect("(")
            a = chain()
            if name == "pow":
                expect(",")
                b = chain()
                expect(")")
                return ("pow", a, b)
            expect(")")
            return (name, a)
        sign = 1.0
        if t == "-" and peek() is not None:
            sign, t = -1.0, take()
        try:
            values.append(sign * float(t))
        except ValueError:
            raise ValueError(f"unknown symbol {t!r} in {text!r} (use {', '.join(names)}, c, numbers, "
                             f"+ - * / ^ and {', '.join(UNARY)}, pow)") from None
        return C

    def power():
        e = atom()
        if peek() in ("^", "**"):
            take()
            return ("pow", e, power())
        return e

    def product():
        e = power()
        while peek() in ("*", "/"):
            e = (take(), e, power())
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


_NUMPY = {"exp": np.exp, "log": np.log, "sqrt": np.sqrt, "sin": np.sin, "cos": np.cos, "abs": np.abs}


def apply(name, args, functions):
    """Operation `name` on its operands `args` (numbers, numpy or JAX arrays, sympy expressions);
    `functions` gives exp, log, sqrt, sin, cos and abs for the kind of operand."""
    if name == "+":
        return args[0] + args[1]
    if name == "-":
        return args[0] - args[1]
    if name == "*":
        return args[0] * args[1]
    if name == "/":
        return args[0] / args[1]
    if name == "pow":
        return args[0] ** args[1]
    if name == "square":
        return args[0] ** 2
    if name == "cube":
        return args[0] ** 3
    if name == "inv":
        return 1 / args[0]
    return functions[name](args[0])


def fold_constants(e, values):
    """(e, values) with every subtree free of variables (c op c, exp(c), as another engine may write
    it) replaced by one constant of its value: the complexity of what the expression is."""
    values = iter(values)

    def build(node):
        if node == C:
            return C, [next(values)]
        if len(node) == 1:
            return node, []
        parts = [build(a) for a in node[1:]]
        if all(a == C for a, _ in parts):
            with np.errstate(all="ignore"):
                v = apply(node[0], [np.float64(v[0]) for _, v in parts], _NUMPY)
            return C, [float(v)]
        return (node[0],) + tuple(a for a, _ in parts), [v for _, vs in parts for v in vs]

    return build(e)


def substitute(e, constants, variables, functions=None):
    """e with its constants (in order of appearance) and its variables (a list, one per variable)
    put in: numbers and numpy arrays give its values (numpy's functions), sympy Floats and Symbols
    its sympy expression (`functions`: sympy's exp, log, sqrt, sin, cos and Abs)."""
    values = iter(constants)
    functions = _NUMPY if functions is None else functions

    def build(node):
        if is_variable(node):
            return variables[variable_index(node)]
        if node == C:
            return next(values)
        return apply(node[0], [build(a) for a in node[1:]], functions)

    return build(e)


def glsl(e, constants, variable="t", uniforms: str = "") -> str:
    """e as a GLSL expression in the float `variable`, its constants written as numbers (as a shader
    specialized to one material has them), or, with `uniforms` (an array's name), read from that
    array in order (`c[0]`, `c[1]`, ...: per-material values the compiler cannot fold): pow as
    pow(a, b), square and cube as products, inv a as 1.0 / a."""
    values = iter(constants)
    index = iter(range(10**6))

    def text(node):
        if is_variable(node):
            return variable
        if node == C and uniforms:
            return f"{uniforms}[{next(index)}]"
        if node == C:
            v = float(next(values))
            return f"({v!r})" if v < 0 else repr(v)
        if len(node) == 2:
            a = text(node[1])
            if node[0] in ("square", "cube"):
                return f"({a} * {a}" + (f" * {a})" if node[0] == "cube" else ")")
            if node[0] == "inv":
                return f"(1.0 / {a})"
            return f"{node[0]}({a})"
        a, b = text(node[1]), text(node[2])
        return f"pow({a}, {b})" if node[0] == "pow" else f"({a} {node[0]} {b})"

    return text(e)


def to_sympy(e, constants, symbol):
    """The sympy expression of e with its fitted constants, in `symbol` (or a list of symbols, one
    per variable)."""
    import sympy as sp

    return substitute(e, [sp.Float(float(v), 15) for v in constants], _names(symbol),
                      {"exp": sp.exp, "log": sp.log, "sqrt": sp.sqrt, "sin": sp.sin, "cos": sp.cos, "abs": sp.Abs})


def canonical(expression, symbol) -> str:
    """sympy's canonical text of an expression in `symbol`: a rational function as a polynomial part
    plus partial fractions (in several variables, given as a list: one cancelled fraction), any
    other as sympy simplifies it, or the expression as built where that is less than half as long;
    numbers to 6 significant digits."""
    import sympy as sp

    symbols = _names(symbol)
    rational = all(expression.is_rational_function(s) for s in symbols)
    simplified = sp.cancel(sp.together(expression)) if rational else sp.powsimp(expression)
    if rational and len(symbols) == 1:
        simplified = sp.apart(simplified, symbols[0])
    text = re.sub(r"(?<![\d.])1\.0\*", "", str(simplified.evalf(6)))
    # (a power of a sum expands into many terms, (c - t^3)^3 into a polynomial of degree 9: where the
    # expression as built is less than half as long, it is the one shown)
    built = re.sub(r"(?<![\d.])1\.0\*", "", str(expression.evalf(6)))
    return built if 2 * len(built) < len(text) else text


def evaluate_numpy(e, c, x):
    """Value of e with constants c (in order of appearance) at x (the points of one variable, or an
    array (variables, points)), in numpy (nan outside its domain)."""
    x = np.asarray(x, dtype=np.float64)
    columns = x[None] if x.ndim == 1 else x
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        value = substitute(e, [np.float64(v) for v in c], list(columns))
        return np.broadcast_to(value, columns.shape[1:]).astype(np.float64)
