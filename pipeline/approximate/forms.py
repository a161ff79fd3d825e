"""A derived form as a shader and a Python twin print it, and what its operations are predicted to
cost.

Every form is one sympy expression in the target's variable with its constants as numbers. Before
printing, exp(a) becomes exp2(a log2(e)) with the factor folded into a's constants (what a GPU
computes: its transcendental unit has exp2 and log2), and the numbers are evaluated to 17 digits.
The printers write 2^a as exp2(a), a^(1/2) as sqrt(a), a^(-1/2) as inversesqrt(a) (rsqrt in HLSL),
a^-1 as 1.0 / a, an integer power up to `SQUARINGS_MAX` by squarings and multiplies (x^5 =
((x x)(x x)) x: the repeated product is computed once by the compiler), any other power as
pow(a, b).

In a format (precision "fp32" or "fp16", `in_format`), every number is first rounded to the
format's nearest value, and printed as exactly that value: float32 in 9 significant digits (which
read back to the same float32; in the Python twin, a float64 program, its shortest float64 text),
float16 as its exact decimal. With no precision, the 17 digits.

`predicted_cycles(expr, table)` sums an architecture's cost table (`symbolic.gpu_costs`: cycles
of each of the grammar's ten operations) over the form's operations, each repeated subexpression
counted once: + and - as +, a product of k factors as k - 1 multiplies, exp2 and exp as exp, log2
and log as log, 1/a as /, squarings as multiplies, max and min as + (a compare and a select), a
general power as pow. None where the form calls a function the table does not cost (acos, erf).
"""

from __future__ import annotations

import math
from decimal import Decimal

import numpy as np
import sympy as sp
from sympy.printing.c import C99CodePrinter
from sympy.printing.glsl import GLSLPrinter
from sympy.printing.pycode import PythonCodePrinter

SQUARINGS_MAX = 64
DIGITS = 17


def free_numbers(*exprs) -> tuple[list, list, list]:
    """The expressions with each decimal number (a sympy Float; integers such as exponents stay)
    replaced by a symbol q_i, one symbol for a number they share: (the expressions, the symbols, the
    numbers as they were)."""
    numbers = sorted(set().union(*(e.atoms(sp.Float) for e in exprs)), key=sp.default_sort_key)
    q = [sp.Symbol(f"q_{i}", real=True) for i in range(len(numbers))]
    return [e.xreplace(dict(zip(numbers, q))) for e in exprs], q, numbers


def gpu_form(expr):
    """expr with exp(a) written exp2(a log2 e) (the factor folded into a's numbers), evaluated to
    numbers of 17 digits, pi and E among them wherever they stand (sympy's N leaves pi x inside a
    function as it is, which a shader language has no name for)."""
    log2e = sp.Float(1 / math.log(2), DIGITS)
    expr = expr.xreplace({s: sp.Float(s.evalf(DIGITS), DIGITS) for s in expr.atoms(sp.NumberSymbol)})
    # (the exponent held unevaluated: sympy would split 2^(a + b) into 2^b 2^a)
    expr = expr.replace(sp.exp, lambda a: sp.Pow(sp.Integer(2), sp.UnevaluatedExpr(sp.expand_mul(a * log2e)),
                                                 evaluate=False))
    expr = sp.N(expr, DIGITS)
    # (N leaves a number inside a function of the variable as it is: log(2) in sin(log(x) / log(2)))
    return expr.replace(lambda e: e.is_number and not e.is_Number and not e.is_Atom, lambda e: sp.N(e, DIGITS))


FORMATS = {"fp32": np.float32, "fp16": np.float16}


def in_format(expr, precision: str):
    """`gpu_form(expr)` with each number rounded to the format's nearest value (module docstring):
    the form a shader in that precision computes (its mathematics, before the arithmetic rounds)."""
    dtype = FORMATS[precision]
    expr = gpu_form(expr)
    with np.errstate(over="ignore"):            # (beyond the format's range: inf)
        return expr.xreplace({v: sp.Float(float(dtype(float(v))), DIGITS) for v in expr.atoms(sp.Float)})


def number_text(value: float, precision: str | None, exact: bool = False) -> str:
    """A number as the printers write it: the shortest float64 text (no precision), or the format's
    nearest value exactly (float32: 9 significant digits, which a shader compiler reads back as that
    float32, or with `exact` the shortest float64 text of it, for a float64 program such as the twin;
    float16: its exact decimal)."""
    if precision is None or not math.isfinite(value):
        return repr(float(value))
    with np.errstate(over="ignore"):            # (beyond the format's range: inf, as the shader reads it)
        v = float(FORMATS[precision](value))
    if not math.isfinite(v):
        return repr(v)
    if precision == "fp32":
        text = repr(v) if exact else f"{v:.9g}"
    else:
        text = format(Decimal(v), "f") if v != 0 else "0"
        text = text.rstrip("0").rstrip(".") if "." in text else text
    return text if any(c in text for c in ".eE") or "inf" in text or "nan" in text else text + ".0"


def _integer(e) -> int | None:
    if e.is_Integer or (e.is_Float and float(e).is_integer()):
        return int(e)
    return None


def _is(value, e) -> bool:
    return e.is_Number and float(e) == value


def _squarings(base: str, k: int) -> str:
    if k == 1:
        return base
    half = _squarings(base, k // 2)
    square = f"({half} * {half})"
    return square if k % 2 == 0 else f"({square} * {base})"


class _Powers:
    """The shared printing of powers (module docstring)."""

    exp2 = "exp2({})"
    rsqrt = "inversesqrt({})"
    one = "1.0"
    precision = None            # the format whose nearest values the numbers are printed as

    def _print_Pow(self, expr):
        base, e = expr.base, expr.exp
        if _is(2, base):
            return self.exp2.format(self._print(e))
        b = self.parenthesize(base, 100)
        if _is(0.5, e):
            return f"sqrt({self._print(base)})"
        if _is(-0.5, e):
            return self.rsqrt.format(self._print(base))
        k = _integer(e)
        if k is not None and 1 <= abs(k) <= SQUARINGS_MAX:
            product = _squarings(b, abs(k))
            return product if k > 0 else f"({self.one} / {product})"
        return f"pow({self._print(base)}, {self._print(e)})"

    def _print_Integer(self, expr):
        return f"{int(expr)}.0"

    infinity = "(1.0 / 0.0)"
    exact = False               # the numbers as a float64 program reads them (number_text)

    def _print_Float(self, expr):
        text = number_text(float(expr), self.precision, self.exact)
        return text if "inf" not in text else ("-" if text.startswith("-") else "") + self.infinity

    def _print_Rational(self, expr):
        return number_text(float(expr), self.precision, self.exact)

    def _print_Infinity(self, expr):
        return self.infinity

    def _print_NegativeInfinity(self, expr):
        return f"-{self.infinity}"

    def _min_max(self, expr, name):
        args = [self._print(a) for a in expr.args]
        text = args[0]
        for a in args[1:]:
            text = f"{name}({text}, {a})"
        return text

    def _print_Max(self, expr):
        return self._min_max(expr, "max")

    def _print_Min(self, expr):
        return self._min_max(expr, "min")


class NoShaderForm(ValueError):
    """A function the shader language has no form of (one line naming it)."""


class _Functions:
    """What every shader printer does with a function: its own name where the language has it
    (`NATIVE`), a rewrite in others (`REWRITTEN`), else NoShaderForm naming it."""

    language = "GLSL"
    NATIVE = ("sinh", "cosh", "tanh", "asinh", "acosh", "atanh")
    REWRITTEN: dict = {}

    def _print_Function(self, expr):
        name = type(expr).__name__
        if name in self.REWRITTEN:
            return self._print(self.REWRITTEN[name](*expr.args))
        if name in self.NATIVE:
            return f"{name}({', '.join(self._print(a) for a in expr.args)})"
        return super()._print_Function(expr)

    def _print_sinh(self, expr):
        return self._print_Function(expr)

    def _print_Piecewise(self, expr):
        """A branch as nested conditional expressions on one line, `(c ? a : b)` (sympy's printers
        break it over lines, which a function's body then holds)."""
        if expr.args[-1].cond != sp.true:
            raise NoShaderForm("a branch with no otherwise case has no value everywhere")
        out = self._print(expr.args[-1].expr)
        for piece in reversed(expr.args[:-1]):
            out = f"({self._print(piece.cond)} ? {self._print(piece.expr)} : {out})"
        return out

    _print_cosh = _print_tanh = _print_asinh = _print_acosh = _print_atanh = _print_sinh

    def _print(self, expr, **kwargs):
        from sympy.printing.codeprinter import PrintMethodNotImplementedError

        try:
            return super()._print(expr, **kwargs)
        except PrintMethodNotImplementedError:
            if expr in (sp.zoo, sp.nan):
                raise NoShaderForm(f"{expr} has no number: a constant of it does not evaluate (1/0, gamma(0))") from None
            name = type(expr).__name__
            raise NoShaderForm(f"{name} has no {self.language} form (no function of the language computes it)") \
                from None


def not_printed(error: Exception) -> str:
    """Why a form has no shader text, in one line: the function the language lacks (NoShaderForm), or
    the printer's failure."""
    return str(error) if isinstance(error, NoShaderForm) else f"no GLSL form ({type(error).__name__}: {error})"


class _GLSL(_Functions, _Powers, GLSLPrinter):
    pass


class _HLSL(_Functions, _Powers, C99CodePrinter):
    language = "HLSL"

    def __init__(self, settings=None):
        super().__init__(settings)
        self.math_macros = {}           # (C's M_LN2, M_PI: HLSL has none)
    rsqrt = "rsqrt({})"
    NATIVE = ("sinh", "cosh", "tanh")
    # (HLSL has no inverse hyperbolic functions: their logarithms)
    REWRITTEN = {"asinh": lambda x: sp.log(x + sp.sqrt(x * x + 1)), "acosh": lambda x: sp.log(x + sp.sqrt(x * x - 1)),
                 "atanh": lambda x: sp.log((1 + x) / (1 - x)) / 2, "sec": lambda x: 1 / sp.cos(x),
                 "csc": lambda x: 1 / sp.sin(x), "cot": lambda x: 1 / sp.tan(x), "acot": lambda x: sp.atan(1 / x),
                 "Heaviside": lambda x, at_zero=sp.Rational(1, 2): sp.Piecewise((0, x < 0), (at_zero, sp.Eq(x, 0)), (1, True))}

    def _print_Abs(self, expr):
        return f"abs({self._print(expr.args[0])})"

    # the C99 functions HLSL has too (C99's erf, tgamma, lgamma, ... it has not)
    INTRINSICS = ("sin", "cos", "tan", "asin", "acos", "atan", "atan2", "exp", "log", "sqrt", "floor", "ceiling")

    def _print_Function(self, expr):
        name = type(expr).__name__
        if name not in self.INTRINSICS and name not in self.NATIVE and name not in self.REWRITTEN:
            raise NoShaderForm(f"{name} has no {self.language} form (no function of the language computes it)")
        return super()._print_Function(expr)

    _print_gamma = _print_loggamma = _print_Function     # (C99 prints them as tgamma, lgamma)


class _Python(_Powers, PythonCodePrinter):
    infinity = "math.inf"
    exact = True
    exp2 = "2.0 ** ({})"
    rsqrt = "1.0 / math.sqrt({})"

    def _print_Pow(self, expr):
        base, e = expr.base, expr.exp
        if _is(0.5, e):
            return f"math.sqrt({self._print(base)})"
        return _Powers._print_Pow(self, expr)

    def _min_max(self, expr, name):
        return f"{name}({', '.join(self._print(a) for a in expr.args)})"


def _rename(expr, variable: str):
    (symbol,) = expr.free_symbols or {sp.Symbol(variable, real=True)}
    return expr.subs(symbol, sp.Symbol(variable, real=True))


def printed(printer, expr, precision: str | None = None) -> str:
    """`expr` in its symbols' own names by one of the printers (`_GLSL`, `_HLSL`, `_Python`), its
    numbers in `precision`'s format where given (`in_format`)."""
    printer.precision = precision
    try:
        numbered = gpu_form(expr) if precision is None else in_format(expr, precision)
    except (ValueError, ArithmeticError) as e:      # (a constant part outside its function's domain: erfinv(3))
        raise NoShaderForm(f"{sp.sstr(expr)[:80]} has no number: a constant of it does not evaluate ({e})") from None
    if numbered.has(sp.I):
        raise NoShaderForm(f"{sp.sstr(expr)[:80]} has no number: a constant of it is complex (asin(3), log(-2))")
    return printer.doprint(numbered)


def _printed(printer, expr, variable: str, precision: str | None) -> str:
    return printed(printer, _rename(expr, variable), precision)


def glsl(expr, variable: str = "x", precision: str | None = None) -> str:
    """The form as a GLSL expression in the float `variable` (module docstring), its numbers in
    `precision`'s format where given."""
    return _printed(_GLSL(), expr, variable, precision)


def hlsl(expr, variable: str = "x", precision: str | None = None) -> str:
    """The form as an HLSL expression in the float `variable`."""
    return _printed(_HLSL(), expr, variable, precision)


def python(expr, variable: str = "x", precision: str | None = None) -> str:
    """The form as a Python expression (the math module) in `variable`."""
    return _printed(_Python(), expr, variable, precision)


FUNCTION_OPERATIONS = {sp.exp: "exp", sp.log: "log"}


def operation_counts(expr) -> dict[str, int] | None:
    """How many of each of the grammar's ten operations the form computes (module docstring), or
    None where it calls a function outside them."""
    counts: dict[str, int] = {}
    seen: set = set()

    def add(op, k=1):
        counts[op] = counts.get(op, 0) + k

    def walk(e) -> bool:
        if e.is_Atom or e in seen:
            return True
        seen.add(e)
        if isinstance(e, sp.UnevaluatedExpr):
            pass
        elif isinstance(e, sp.Add):
            add("+", len(e.args) - 1)
        elif isinstance(e, sp.Mul):
            factors = [a for a in e.args if not _is(-1, a)]
            add("*", len(factors) - 1)
        elif isinstance(e, (sp.Max, sp.Min)):
            add("+", len(e.args) - 1)
        elif isinstance(e, sp.Pow):
            base, p = e.base, e.exp
            k = _integer(p)
            if _is(2, base):
                add("exp")
            elif _is(0.5, p):
                add("sqrt")
            elif _is(-0.5, p):
                add("sqrt")
                add("/")
            elif k == 2:
                add("square")
            elif k == 3:
                add("cube")
            elif k == -1:
                add("/")
            elif k is not None and 1 <= abs(k) <= SQUARINGS_MAX:
                add("*", abs(k).bit_length() - 1 + bin(abs(k)).count("1") - 1)
                if k < 0:
                    add("/")
            else:
                add("pow")
        elif type(e) in FUNCTION_OPERATIONS:
            add(FUNCTION_OPERATIONS[type(e)])
        else:
            return False
        return all(walk(a) for a in e.args)

    return counts if walk(gpu_form(expr)) else None


def predicted_cycles(expr, table: dict[str, float]) -> float | None:
    """The form's cycles predicted by an architecture's cost table (module docstring)."""
    counts = operation_counts(expr)
    if counts is None:
        return None
    return float(sum(table.get(op, math.nan) * k for op, k in counts.items()))


import dataclasses


@dataclasses.dataclass
class Form:
    """One approximation of a target: its `name` (polynomial_3, grammar_7, an anchor's name,
    exact), `kind` (found, anchor or exact), `family` (polynomial, polynomial_sqrt,
    exp2_polynomial, rational, grammar, anchor, exact), its sympy `expression` in the target's
    variable, where it comes from (`source`), and whether its fit converged."""

    name: str
    kind: str
    family: str
    expression: object
    source: str = ""
    converged: bool = True
