"""The exact coefs as a shader computes them: no pow, and nothing that overflows half precision.

The exact Phong- and Blinn-form coefs of the family are rational in k (`integrals.coef_of_k`):
P(k) / Q(k), e.g. 6 k^2 / (pi (4 k - 1)) and 15 k^4 / (2 pi (20 k^3 - 25 k^2 + 12 k - 2)) at m = 2.
Written as they stand, a shader computes k^4 (float16 overflows past 65504: k > 15.9, n > 35 on the
paper's line) and a printer writes pow(k, 4.0) (log and exp in machine code). `reciprocal_form`
writes them as k^(deg P - deg Q) P~(r) / Q~(r) with r = 1 / k, P~ and Q~ the polynomials with their
coefficients reversed, in Horner form: for k >= 1 (the branch's domain) every power of r is at most
1, so nothing overflows where the result itself does not; one reciprocal and multiply-adds.

`glsl` and `hlsl` print an expression with integer powers written as products (`b * b`), never pow.
"""

from __future__ import annotations

import sympy as sp
from sympy.printing.c import C99CodePrinter
from sympy.printing.glsl import GLSLPrinter

from . import integrals

r = sp.Symbol("r", positive=True)


def _reversed(poly: sp.Poly) -> sp.Expr:
    """A polynomial of degree d in k divided by k^d, as a polynomial in r = 1 / k, in Horner form."""
    d = poly.degree()
    return sp.horner(sum(c * r ** (d - i) for (i,), c in poly.terms()), r)


def reciprocal_form(expr_k, k_value) -> sp.Expr:
    """The rational coef `expr_k` (in `integrals.k`) at k = `k_value`, written in r = 1 / k (module
    docstring); k and r are kept as units, so that sympy does not fold the powers of r back into k."""
    num, den = sp.fraction(sp.cancel(sp.together(expr_k)))
    P, Q = sp.Poly(num, integrals.k), sp.Poly(den, integrals.k)
    unit = sp.UnevaluatedExpr
    k_unit, r_unit = unit(k_value), unit(1 / unit(k_value))
    lead = P.degree() - Q.degree()
    return k_unit ** lead * _reversed(P).subs(r, r_unit) / _reversed(Q).subs(r, r_unit)


def exact_coef_of_n(which: str, power: int, k_value) -> sp.Expr:
    """The exact coef of the Phong or Blinn form as a function of n through k = `k_value`: the
    piecewise coef of `integrals`, its large-k branch in `reciprocal_form` (the small-k branch keeps
    k < 1 or so: nothing to overflow)."""
    pieces = integrals.coef_of_k(integrals.integral(which, power)).args
    (big, condition), rest = pieces[0], pieces[1:]
    out = [(reciprocal_form(big, k_value), condition.subs(integrals.k, k_value))]
    out += [(expr.subs(integrals.k, k_value), cond if cond is sp.true else cond.subs(integrals.k, k_value))
            for expr, cond in rest]
    return sp.Piecewise(*out)


def _products(printer, expr) -> str | None:
    """`base * base * ...` for an integer power 2..8 (1.0 / (...) for -2..-8), else None."""
    if not (expr.exp.is_Integer and 2 <= abs(int(expr.exp)) <= 8):
        return None
    base = printer.parenthesize(expr.base, 100)
    product = " * ".join([base] * abs(int(expr.exp)))
    return product if expr.exp > 0 else f"1.0 / ({product})"


class _GLSL(GLSLPrinter):
    def _print_Pow(self, expr):
        return _products(self, expr) or super()._print_Pow(expr)


class _C(C99CodePrinter):
    def _print_Pow(self, expr):
        return _products(self, expr) or super()._print_Pow(expr)


def glsl(expr) -> str:
    """`expr` as GLSL, integer powers as products."""
    return _GLSL().doprint(expr)


def hlsl(expr) -> str:
    """`expr` as HLSL (C99's expression syntax, max for fmax), integer powers as products."""
    return _C().doprint(expr).replace("fmax(", "max(")
