"""The one reader of expression text from outside the program (a target file, `--expr`, an anchor, a
formula kept in a cache): Python's own syntax tree (`ast.parse`, which runs nothing), walked by a
whitelist that builds the sympy tree directly. Nothing of the text is ever evaluated as code.

Accepted: numbers (decimal, integer), the declared names (variables, the parameter), the constants
`pi` and `E`, `+ - * / **` (and `^`, a power, as shaders and papers write it), unary minus and plus,
parentheses, calls of the functions of `FUNCTIONS` with their numbers of arguments, and a branch
as Python writes a conditional, `a if x < c else b` (a Piecewise; its test one comparison < <= > >=,
or `and`, `or`, `not` of them: a shader's ?: or if). Everything
else (attributes, subscripts, strings, lambdas, comprehensions, a comparison outside a conditional,
keyword arguments, names not declared) is refused before anything is built: `ExpressionError`, one line naming the
offending token and its column.

The work is bounded before sympy does it: a text of at most `MAX_LENGTH` characters, a tree at most
`MAX_DEPTH` deep, exact numbers of at most `MAX_DIGITS` digits (a power of exact numbers is refused
before it is computed: 9**9**9 would have 370 million), a number as an exponent at most
`MAX_EXPONENT` in magnitude (x**(10**100)) and in its denominator (50**(5**-52), a root of order
5**52), and an exact argument of a function at most
`MAX_ARGUMENT` in magnitude, of the gamma family at most `MAX_GAMMA_ARGUMENT` (gamma(10**6) would
compute a factorial of 5.6 million digits).

A number is read as sympy's `sympify` reads it (an integer exactly, a decimal as `Float(text)`, of
at least 15 digits): the same tree as before for every expression of the registries. `text` prints
an expression so that `parse(..., float64=True)` gives back the same tree exactly (each float64
constant as its shortest round-trip decimal): the caches' format.
"""

from __future__ import annotations

import ast
import decimal
import functools
import keyword
import math
import warnings

MAX_LENGTH = 4_000          # characters of one expression (its sums are built term by term: at most
                            # about 0.5 s of sympy here)
MAX_DEPTH = 100             # levels of its syntax tree (nested parentheses, calls, powers, signs)
MAX_DIGITS = 1_000          # decimal digits of an exact number it builds
MAX_EXPONENT = 10_000       # |exponent| of a power whose exponent is a number
MAX_ARGUMENT = 10 ** 6      # |exact number| given to a function
MAX_GAMMA_ARGUMENT = 100    # ... to the gamma family, which sympy evaluates exactly (gamma(n) = (n - 1)!,
                            # digamma(n) a harmonic sum, uppergamma(n, x) n terms)
GAMMA_FAMILY = ("gamma", "loggamma", "digamma", "beta", "uppergamma", "lowergamma")


class ExpressionError(ValueError):
    """Text refused by `parse` (one line: what, where, why)."""


@functools.cache
def _functions() -> dict:
    """name -> (sympy callable, fewest arguments, most arguments (None: any))."""
    import sympy as sp

    one = {name: (getattr(sp, name), 1, 1) for name in (
        "exp", "sqrt", "cbrt", "sin", "cos", "tan", "cot", "sec", "csc", "asin", "acos", "atan", "acot",
        "sinh", "cosh", "tanh", "asinh", "acosh", "atanh", "Abs", "sign", "floor", "ceiling", "Heaviside",
        "erf", "erfc", "erfinv", "erfcinv", "gamma", "loggamma", "digamma", "Ei", "Si", "Ci", "li",
        "elliptic_k", "elliptic_e")}
    two = {name: (getattr(sp, name), 2, 2) for name in ("atan2", "beta", "besselj", "bessely", "besseli",
                                                          "besselk", "uppergamma", "lowergamma")}
    return one | two | {
        "log": (sp.log, 1, 2), "Max": (sp.Max, 1, None), "Min": (sp.Min, 1, None),
        "abs": (sp.Abs, 1, 1), "max": (sp.Max, 1, None), "min": (sp.Min, 1, None), "pow": (sp.Pow, 2, 2),
        # as shaders write them
        "exp2": (lambda a: sp.Integer(2) ** a, 1, 1), "log2": (lambda a: sp.log(a) / sp.log(2), 1, 1),
        "rsqrt": (lambda a: 1 / sp.sqrt(a), 1, 1), "inversesqrt": (lambda a: 1 / sp.sqrt(a), 1, 1),
        "saturate": (lambda a: sp.Min(sp.Max(a, 0), 1), 1, 1),
        "clamp": (lambda a, lo, hi: sp.Min(sp.Max(a, lo), hi), 3, 3),
        "mix": (lambda a, b, s: a + (b - a) * s, 3, 3)}


@functools.cache
def _constants() -> dict:
    import sympy as sp

    return {"pi": sp.pi, "E": sp.E}


RESERVED = ("pi", "E")          # names of constants: not a variable's
# names the printed numpy and JAX code of an expression uses for its modules (`sympy.lambdify`)
MODULE_NAMES = ("numpy", "scipy", "math", "mpmath", "jax", "jnp", "builtins", "sympy")


def name_fault(name) -> str | None:
    """Why `name` cannot be declared (a variable's or a parameter's name), or None: it must be an
    ASCII identifier that is no Python keyword, no function or constant of the grammar, no module
    name of the printed code, and does not start with _."""
    if not (isinstance(name, str) and name.isascii() and name.isidentifier()):
        return "give a name of ASCII letters, digits and _ (not starting with a digit)"
    if keyword.iskeyword(name) or name.startswith("_"):
        return "a Python keyword or a name starting with _ cannot be a variable"
    if name in RESERVED or name in _functions() or name in MODULE_NAMES:
        return f"{name!r} names a constant, a function or a module of the grammar"
    return None


def parse(text, symbols, *, what: str = "expression", float64: bool = False):
    """The sympy expression of `text`. `symbols`: the declared names, {name: sympy Symbol}, or names
    (a str or a sequence of str; each becomes a real Symbol). `float64`: the caches' text (`text`): a
    decimal is the float64 it rounds to, not sympify's `Float(text)`, and Float(digits, bits) a
    constant of that precision. Raises ExpressionError (one line, naming `what`, the offending token
    and its column)."""
    import sympy as sp

    if isinstance(symbols, str):
        symbols = (symbols,)
    if not isinstance(symbols, dict):
        symbols = {name: sp.Symbol(name, real=True) for name in symbols}
    return _Reader(text, symbols, what, float64).read()


def _clip(text: str, most: int = 40) -> str:
    return text if len(text) <= most else text[:most - 3] + "..."


def _short(number) -> str:
    """A number as text of at most about 20 characters."""
    if number.is_Rational and _digits(number) > 20:
        return f"of {_digits(number) - (number.q == 1)} digits"
    return str(number) if number.is_Rational else f"{float(number):.6g}"


def _digits(value) -> int:
    """Decimal digits of an exact number (numerator and denominator together)."""
    return sum(len(str(abs(int(v)))) for v in (value.p, value.q))


class _Reader:
    def __init__(self, text, symbols: dict, what: str, float64: bool):
        self.what = what
        self.float64 = float64
        self.symbols = symbols
        self.functions = _functions()
        self.constants = _constants()
        if not isinstance(text, str):
            raise ExpressionError(f"{what}: {text!r} is not text")
        self.text = text

    def refuse(self, why: str, node=None, column: int | None = None):
        if node is not None:
            column = self._column(node)
        where = f" at column {column}" if column else ""
        shown = self.text if len(self.text) <= 80 else self.text[:77] + "..."
        raise ExpressionError(f"{self.what} {shown!r}: {why}{where}")

    def _column(self, node) -> int | None:
        offset = getattr(node, "col_offset", None)
        if offset is None:
            return None
        # ast's offsets count UTF-8 bytes; the message counts characters (the text is one line)
        return len(self.encoded[:offset].decode("utf-8", errors="ignore")) + 1

    def segment(self, node) -> str:
        """The text of a node (ast's offsets count UTF-8 bytes; the text is one line)."""
        return self.encoded[node.col_offset:node.end_col_offset].decode("utf-8", errors="replace")

    def read(self):
        import sympy as sp

        text = self.text
        if not text.strip():
            self.refuse("an empty expression")
        if len(text) > MAX_LENGTH:
            self.refuse(f"{len(text)} characters, more than {MAX_LENGTH}")
        for i, ch in enumerate(text):
            if ch in "\t\r\n":
                continue
            if not ch.isprintable():
                self.refuse(f"the control character {ch!r}", column=i + 1)
        text = text.replace("\t", " ").replace("\r", " ").replace("\n", " ")
        depth = 0
        for i, ch in enumerate(text):
            depth += (ch in "([{") - (ch in ")]}")
            if depth > MAX_DEPTH:
                self.refuse(f"parentheses nested deeper than {MAX_DEPTH}", column=i + 1)
        # ^ is a power (sympify's convert_xor); the columns named are those of the text with **
        self.text = text.replace("^", "**")
        self.encoded = self.text.encode("utf-8")
        try:
            with warnings.catch_warnings():         # (1if x: a SyntaxWarning before the error)
                warnings.simplefilter("ignore", SyntaxWarning)
                tree = ast.parse(self.text, mode="eval")
        except SyntaxError as e:
            self.refuse(f"does not parse ({e.msg})", column=e.offset)
        except (RecursionError, MemoryError):
            self.refuse("does not parse (too long a chain or too deep a nesting for Python's parser)")
        expr = self.build(tree.body, 1)
        if not isinstance(expr, sp.Expr):
            self.refuse("is not an expression")
        return expr

    def build(self, node, depth: int):
        if depth > MAX_DEPTH:
            self.refuse(f"nested deeper than {MAX_DEPTH}", node)
        if isinstance(node, ast.Constant):
            return self.number(node)
        if isinstance(node, ast.Name):
            if node.id in self.symbols:
                return self.symbols[node.id]
            if node.id in self.constants:
                return self.constants[node.id]
            if node.id in self.functions:
                self.refuse(f"the function {node.id!r} without its arguments", node)
            self.refuse(f"unknown name {node.id!r} (the declared: {', '.join(self.symbols) or 'none'}, pi, E)", node)
        if isinstance(node, ast.UnaryOp):
            if not isinstance(node.op, (ast.USub, ast.UAdd)):
                self.refuse(f"the operator {_OPERATORS.get(type(node.op), type(node.op).__name__)!r}", node)
            value = self.build(node.operand, depth + 1)
            return -value if isinstance(node.op, ast.USub) else value
        if isinstance(node, ast.BinOp):
            if type(node.op) not in (ast.Add, ast.Sub, ast.Mult, ast.Div, ast.Pow):
                self.refuse(f"the operator {_OPERATORS.get(type(node.op), type(node.op).__name__)!r}", node)
            if isinstance(node.op, ast.Pow):
                return self.arithmetic(node, self.power, self.build(node.left, depth + 1),
                                       self.build(node.right, depth + 1))
            # a chain a + b - c + ... (or a * b / c ...) is one level, not one per term: a long sum is as
            # deep as its deepest term
            spine = [node]
            while isinstance(spine[-1].left, ast.BinOp) and type(spine[-1].left.op) in _SAME[type(node.op)]:
                spine.append(spine[-1].left)
            first = self.build(spine[-1].left, depth + 1)
            rest = [(step, self.build(step.right, depth + 1)) for step in reversed(spine)]
            return self.arithmetic(node, self.chain, first, rest)
        if isinstance(node, ast.Call):
            return self.call(node, depth)
        if isinstance(node, ast.IfExp):             # a if c else b: a branch, as a shader's ?: (a Piecewise)
            import sympy as sp

            condition = self.condition(node.test, depth + 1, node)
            return sp.Piecewise((self.build(node.body, depth + 1), condition),
                                (self.build(node.orelse, depth + 1), True))
        if isinstance(node, ast.Attribute):
            at = len(self.encoded[:node.end_col_offset].decode("utf-8", errors="ignore")) - len(node.attr)
            self.refuse(f"the attribute {'.' + node.attr!r}", column=at)
        kind = _KINDS.get(type(node), type(node).__name__)
        self.refuse(f"{kind} {_clip(self.segment(node))!r} is not allowed", node)

    def condition(self, node, depth: int, branch):
        """A conditional's test: one comparison (< <= > >=) of two expressions, or `and`, `or` and `not`
        of such tests."""
        import sympy as sp

        if depth > MAX_DEPTH:
            self.refuse(f"nested deeper than {MAX_DEPTH}", node)
        if isinstance(node, ast.Compare) and len(node.ops) == 1 and type(node.ops[0]) in _comparisons():
            return _comparisons()[type(node.ops[0])](self.build(node.left, depth + 1),
                                                     self.build(node.comparators[0], depth + 1))
        if isinstance(node, ast.BoolOp):
            parts = [self.condition(v, depth + 1, branch) for v in node.values]
            return sp.And(*parts) if isinstance(node.op, ast.And) else sp.Or(*parts)
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.Not):
            return sp.Not(self.condition(node.operand, depth + 1, branch))
        self.refuse(f"a conditional whose test {_clip(self.segment(node))!r} is not one comparison (< <= > >=), "
                    "or and, or, not of them", branch)

    def number(self, node):
        import sympy as sp

        value = node.value
        token = self.segment(node) or repr(value)
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            kind = "a string" if isinstance(value, (str, bytes)) else f"the constant {token}"
            self.refuse(f"{kind} is not a number", node)
        if isinstance(value, int):
            if len(token.replace("_", "")) > MAX_DIGITS:
                self.refuse(f"an integer of more than {MAX_DIGITS} digits", node)
            return sp.Integer(value)
        digits = self.decimal(node)
        if self.float64:
            if not math.isfinite(value):
                self.refuse(f"the number {token} is not a finite float64", node)
            return sp.Float(value)
        return sp.Float(digits)

    def decimal(self, node) -> str:
        """A decimal literal's text, checked: at most MAX_DIGITS digits and a power of ten at most
        MAX_DIGITS (sympy's Float builds the integer of 1e88888888888888)."""
        digits = self.segment(node).replace("_", "")
        try:
            power_of_ten = abs(decimal.Decimal(digits).adjusted())
        except decimal.InvalidOperation:        # (an exponent beyond decimal's own range)
            power_of_ten = math.inf
        if power_of_ten > MAX_DIGITS or len(digits) > MAX_DIGITS:
            self.refuse(f"a decimal of more than {MAX_DIGITS} digits or a power of ten beyond {MAX_DIGITS}", node)
        return digits

    def arithmetic(self, node, operation, a, b):
        """operation(node, a, b), its failures (a division of a float by zero) a refusal."""
        try:
            return operation(node, a, b)
        except ExpressionError:
            raise
        except (ArithmeticError, ValueError, TypeError) as e:
            self.refuse(f"the arithmetic fails ({type(e).__name__})", node)

    def power(self, node, a, b):
        import sympy as sp

        if b.is_Number and (not b.is_finite or abs(b) > MAX_EXPONENT):
            self.refuse(f"the exponent {_short(b)} is beyond {MAX_EXPONENT}", node)
        if b.is_Rational and b.q > MAX_EXPONENT:       # (a root of that order of an exact number)
            self.refuse(f"the exponent's denominator {_short(sp.Integer(b.q))} is beyond {MAX_EXPONENT}", node)
        if b.is_Number and not a.free_symbols and abs(b) > 1:
            exact = [r for r in a.atoms(sp.Rational)] or [sp.Integer(2)]
            largest = max(max(abs(int(r.p)), abs(int(r.q))) for r in exact)
            if largest > 1 and float(abs(b)) * math.log10(largest) > MAX_DIGITS:
                self.refuse(f"the power would build a number of about {float(abs(b)) * math.log10(largest):.3g} "
                            f"digits, more than {MAX_DIGITS}", node)
        return a ** b

    def chain(self, node, first, rest):
        """first + b - c ... or first * b / c ..., its exact numbers' digits bounded first."""
        operands = [first] + [b for _, b in rest]
        exact = [v for v in operands if v.is_Rational]
        if isinstance(node.op, (ast.Add, ast.Sub)):
            digits = (max((len(str(abs(int(v.p)))) for v in exact), default=0) + len(str(len(exact)))
                      + sum(len(str(int(v.q))) for v in exact if v.q != 1))
        else:
            digits = sum(_digits(v) for v in exact)
        if len(exact) > 1 and digits > MAX_DIGITS:
            self.refuse(f"an exact number of more than {MAX_DIGITS} digits", node)
        # one operator at a time, as Python's operators on sympy's objects build it: sympify's tree
        # (a number times a sum is distributed where two factors meet; floats are summed in the
        # order sympy's Add collects them, which depends on the grouping)
        value = first
        for step, b in rest:
            value = {ast.Add: value.__add__, ast.Sub: value.__sub__, ast.Mult: value.__mul__,
                     ast.Div: value.__truediv__}[type(step.op)](b)
        return value

    def finer_float(self, node):
        """Float(digits, bits) of the caches' text: a constant finer (or coarser) than float64, its
        decimal digits read at that binary precision (`text`)."""
        import sympy as sp

        args = node.args
        if not (len(args) == 2 and not node.keywords and all(isinstance(a, ast.Constant) for a in args)
                and type(args[0].value) in (int, float) and type(args[1].value) is int and 2 <= args[1].value <= 4096):
            self.refuse("Float takes a decimal and its precision in bits (2 to 4096)", node)
        return sp.Float(self.decimal(args[0]), precision=args[1].value)

    def call(self, node, depth: int):
        if self.float64 and isinstance(node.func, ast.Name) and node.func.id == "Float":
            return self.finer_float(node)
        if not isinstance(node.func, ast.Name):
            self.build(node.func, depth + 1)        # (refuses what is not a name: an attribute, a lambda)
            self.refuse(f"a call of {_clip(self.segment(node.func))!r} (call functions by name)", node)
        name = node.func.id
        if name not in self.functions:
            self.refuse(f"unknown function {name!r}", node)
        if node.keywords:
            self.refuse(f"the keyword argument {node.keywords[0].arg or '**'!r} of {name}", node.keywords[0])
        if any(isinstance(a, ast.Starred) for a in node.args):
            self.refuse(f"a starred argument of {name}", node)
        function, fewest, most = self.functions[name]
        count = len(node.args)
        if count < fewest or (most is not None and count > most):
            wanted = f"{fewest}" if fewest == most else f"{fewest} or more" if most is None else f"{fewest} to {most}"
            self.refuse(f"{name} takes {wanted} argument{'s' if wanted != '1' else ''}, given {count}", node)
        arguments = [self.build(a, depth + 1) for a in node.args]
        most = MAX_GAMMA_ARGUMENT if name in GAMMA_FAMILY else MAX_ARGUMENT
        for a, argument in zip(node.args, arguments):
            if argument.is_Rational and abs(argument) > most:
                self.refuse(f"the exact argument of {name} is beyond {most:g}", a)
        try:
            return function(*arguments)
        except (TypeError, ValueError, ArithmeticError) as e:
            self.refuse(f"{name} of these arguments fails ({type(e).__name__})", node)


_SAME = {ast.Add: (ast.Add, ast.Sub), ast.Sub: (ast.Add, ast.Sub), ast.Mult: (ast.Mult, ast.Div),
         ast.Div: (ast.Mult, ast.Div)}
_OPERATORS = {ast.Mod: "%", ast.FloorDiv: "//", ast.MatMult: "@", ast.LShift: "<<", ast.RShift: ">>",
              ast.BitOr: "|", ast.BitAnd: "&", ast.BitXor: "^", ast.Invert: "~", ast.Not: "not"}
_KINDS = {ast.Attribute: "an attribute", ast.Subscript: "a subscript", ast.Lambda: "a lambda",
          ast.ListComp: "a comprehension", ast.SetComp: "a comprehension", ast.DictComp: "a comprehension",
          ast.GeneratorExp: "a comprehension", ast.Compare: "a comparison", ast.BoolOp: "a logical operator",
          ast.IfExp: "a conditional", ast.List: "a list", ast.Tuple: "a tuple", ast.Dict: "a dict", ast.Set: "a set",
          ast.NamedExpr: "an assignment", ast.JoinedStr: "a string", ast.Await: "await", ast.Yield: "yield",
          ast.YieldFrom: "yield", ast.Starred: "a starred expression", ast.Slice: "a slice"}


@functools.cache
def _comparisons() -> dict:
    """A conditional's comparisons: Python's operator -> sympy's relation."""
    import sympy as sp

    return {ast.Lt: sp.StrictLessThan, ast.LtE: sp.LessThan, ast.Gt: sp.StrictGreaterThan, ast.GtE: sp.GreaterThan}


def text(expr, symbols: dict | None = None) -> str:
    """An expression as text that `parse(text, ..., float64=True)` reads back to the same tree: sympy's
    printing (`sstr`), each Float as the shortest decimal of its float64 (a Float of another
    precision as Float(its digits, its bits), which only that reading takes). With `symbols` ({name:
    Symbol}), the reading back is checked: raises ExpressionError where the tree differs (a Float
    finer than float64, a construct outside the grammar)."""
    import sympy as sp
    from mpmath.libmp import repr_dps, to_str as mlib_to_str
    from sympy.printing.str import StrPrinter

    class Exact(StrPrinter):
        def _print_Float(self, f):
            value = float(f)
            if not math.isfinite(value):
                raise ExpressionError(f"the constant {f} is not a finite float64")
            if f._prec == 53:
                return repr(value)
            digits = mlib_to_str(abs(f)._mpf_, repr_dps(f._prec))
            return f"{'-' if value < 0 else ''}Float({digits}, {f._prec})"

        def _print_Piecewise(self, e):          # (a if c else b, as the reader takes a branch)
            if e.args[-1].cond != sp.true:
                raise ExpressionError("a branch with no otherwise case has no text")
            out = self._print(e.args[-1].expr)
            for piece in reversed(e.args[:-1]):
                out = f"({self._print(piece.expr)} if {self._print(piece.cond)} else {out})"
            return out

        def _print_And(self, e):
            return "(" + " and ".join(f"({self._print(a)})" for a in e.args) + ")"

        def _print_Or(self, e):
            return "(" + " or ".join(f"({self._print(a)})" for a in e.args) + ")"

        def _print_Not(self, e):
            return f"(not ({self._print(e.args[0])}))"

    printed = Exact().doprint(expr)
    if symbols is not None:
        back = parse(printed, symbols, what="a printed expression", float64=True)
        if sp.srepr(back) != sp.srepr(expr):
            raise ExpressionError(f"a printed expression {printed[:80]!r} does not read back to the same tree")
    return printed
