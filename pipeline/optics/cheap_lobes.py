"""Cheap specular lobes used in engines, their usual normalizations, and what each costs to evaluate.

Every lobe is a function of t = cos x (R.V for the Phong form, N.H for the Blinn form) and of the
exponent n it stands in for; here it is written in u = 1 - t, as `lobe(u, n)`, with `u_end(n)`,
the u past which it is 0. Each also has a sympy expression in t and n, from which the operations
it costs are counted (`count_operations`).

Lobes compared (t = cos x):
- cos^n:            t^n (reference; Phong 1975, Blinn 1977)
- f_2:              ((n/2)(t - 1) + 1)^2 (Romanyuk & Lyashenko 2010; Lyon 1993 with exponent 2)
- f_Q, f_Q2:        the paper's lobes ((k (t - 1) + 1)^2 with k = k_Q(n) or a n + b)
- Schlick:          t / (n - n t + t) (Graphics Gems IV, 1994)
- SG:               exp(n (t - 1)) (a spherical Gaussian)
- SG (Lagarde):     exp((n + 0.775)(t - 1)) (Lagarde 2012, fitted to cos^n)
Normalizations: (n + 2) / (2 pi) (Phong form of cos^n, exact); Giesen's (n + 2)(n + 4) /
(8 pi (2^(-n/2) + n)) (Blinn form of cos^n, exact at normal incidence); (n + 8) / (8 pi) (its
common approximation); Gotanda's linear fit 0.0397436 n + 0.0856832 (2010); the paper's
0.214 (0.807 + n); and the exact ones of `pipeline.exact`.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import jax.numpy as jnp
import numpy as np
import sympy as sp

from . import integrals
from .lobes import SHAPES, k_Q

t, n_sym = sp.symbols("t n", positive=True)
_U = sp.UnevaluatedExpr   # marks a subexpression written as a unit (so its operations are counted once)
SG_LAGARDE_SHIFT = 0.775
GOTANDA = (0.0397436, 0.0856832)


@dataclasses.dataclass(frozen=True)
class Lobe:
    """A lobe: name, formula as text, its shape (a name of `lobes.SHAPES`) and that shape's parameter
    as a function of n, its support end u_end(n), and its sympy form in t and n."""

    name: str
    formula: str
    shape: str
    param: Callable
    u_end: Callable
    expr: sp.Expr

    def fn(self, u, n):
        """The lobe at u = 1 - cos x for exponent n."""
        return SHAPES[self.shape](u, self.param(n))


@dataclasses.dataclass(frozen=True)
class Normalization:
    """A normalization factor coef(n): name, formula as text, JAX function of n, sympy form."""

    name: str
    formula: str
    fn: Callable
    expr: sp.Expr


def giesen(n):
    """Giesen's normalization of the Blinn form of cos^n, exact at normal incidence."""
    return (n + 2.0) * (n + 4.0) / (8.0 * np.pi * (2.0 ** (-n / 2.0) + n))


def _quadratic_lobe(name: str, formula: str, k_of_n: Callable, k_expr: sp.Expr) -> Lobe:
    # Written as a shader would: k t + (1 - k), both constants of n (per material).
    kk = _U(k_expr)
    return Lobe(name, formula, "quadratic", k_of_n, lambda n: 1.0 / k_of_n(n),
                sp.Max(kk * t + _U(1 - k_expr), 0) ** 2)


def shape_lobes(Q_paper: float, Q_best: float, slope: float, intercept: float) -> list[Lobe]:
    """The lobes of the comparison, with the run's Q values and k_Q2 line."""
    n = n_sym

    def k_Q_expr(Q):
        return (sp.sqrt(sp.Float(Q)) - 1) / (sp.exp(sp.log(sp.Float(Q)) / n) - 1)

    return [
        Lobe("cos^n", "t^n", "power", lambda n: n, lambda n: jnp.ones_like(n), t**n),
        _quadratic_lobe("f_2", "((n/2)(t - 1) + 1)^2", lambda n: n / 2.0, n / 2),
        _quadratic_lobe(f"f_Q, Q = {Q_paper:g}", "(k_Q(n)(t - 1) + 1)^2",
                        lambda n: k_Q(n, Q_paper), k_Q_expr(Q_paper)),
        _quadratic_lobe(f"f_Q, Q = {Q_best:.4f}", "(k_Q(n)(t - 1) + 1)^2",
                        lambda n: k_Q(n, Q_best), k_Q_expr(Q_best)),
        _quadratic_lobe("f_Q2", f"(({slope:g} n + {intercept:g})(t - 1) + 1)^2",
                        lambda n: slope * n + intercept, sp.Float(slope) * n + sp.Float(intercept)),
        Lobe("Schlick", "t / (n - n t + t)", "schlick", lambda n: n,
             lambda n: jnp.ones_like(n), t / (_U(n) - _U(n - 1) * t)),
        Lobe("SG", "exp(n (t - 1))", "exp", lambda n: n, lambda n: jnp.ones_like(n),
             sp.exp(_U(n) * t - _U(n))),
        Lobe("SG (Lagarde)", f"exp((n + {SG_LAGARDE_SHIFT}) (t - 1))", "exp",
             lambda n: n + SG_LAGARDE_SHIFT, lambda n: jnp.ones_like(n),
             sp.exp(_U(n + SG_LAGARDE_SHIFT) * t - _U(n + SG_LAGARDE_SHIFT))),
    ]


def normalizations(slope: float, intercept: float, coef_scale: float, coef_offset: float):
    """The normalizations of the comparison, by name."""
    n = n_sym
    k_expr = sp.Float(slope) * n + sp.Float(intercept)
    exact_phong = integrals.coef_of_k(integrals.phong_integral()).args[0][0].subs(integrals.k, _U(k_expr))
    exact_blinn = integrals.coef_of_k(integrals.blinn_integral()).args[0][0].subs(integrals.k, _U(k_expr))
    phong_fn, _ = integrals.exact_coef_code("phong")
    blinn_fn, _ = integrals.exact_coef_code("blinn")
    items = [
        Normalization("(n+2)/(2pi)", "(n + 2) / (2 pi)", lambda n: (n + 2.0) / (2.0 * np.pi),
                      (n + 2) / (2 * sp.pi)),
        Normalization("Giesen", "(n + 2)(n + 4) / (8 pi (2^(-n/2) + n))",
                      giesen,
                      (n + 2) * (n + 4) / (8 * sp.pi * (2 ** (-n / 2) + n))),
        Normalization("(n+8)/(8pi)", "(n + 8) / (8 pi)", lambda n: (n + 8.0) / (8.0 * np.pi),
                      (n + 8) / (8 * sp.pi)),
        Normalization("Gotanda", f"{GOTANDA[0]} n + {GOTANDA[1]}",
                      lambda n: GOTANDA[0] * n + GOTANDA[1], GOTANDA[0] * n + GOTANDA[1]),
        Normalization("paper coef", f"{coef_scale:g} ({coef_offset:g} + n)",
                      lambda n: coef_scale * (coef_offset + n), coef_scale * (coef_offset + n)),
        Normalization("exact Phong coef", "6 k^2 / (pi (4 k - 1)), k = a n + b (k >= 1)",
                      lambda n: phong_fn(n, slope, intercept), exact_phong),
        Normalization("exact Blinn coef", "15 k^4 / (2 pi (20 k^3 - 25 k^2 + 12 k - 2)) (k >= 2 + sqrt 2)",
                      lambda n: blinn_fn(n, slope, intercept), exact_blinn),
        Normalization("asymptotic Phong coef", "(3 / (2 pi)) (k + 1/4)",
                      lambda n: 3.0 / (2.0 * np.pi) * (slope * n + intercept + 0.25),
                      3 / (2 * sp.pi) * (k_expr + sp.Rational(1, 4))),
        Normalization("asymptotic Blinn coef", "(3 / (8 pi)) (k + 5/4)",
                      lambda n: 3.0 / (8.0 * np.pi) * (slope * n + intercept + 1.25),
                      3 / (8 * sp.pi) * (k_expr + sp.Rational(5, 4))),
    ]
    return {item.name: item for item in items}


# ---- operation counts -------------------------------------------------------------------------

OPERATIONS = ("pow", "exp/log", "div", "sqrt", "madd")


def _is_constant(expr) -> bool:
    return not expr.free_symbols


def _node_operations(expr) -> dict[str, int]:
    """The operations of expr's top node alone (constant subexpressions are folded: free)."""
    ops = dict.fromkeys(OPERATIONS, 0)
    if _is_constant(expr):
        return ops
    if isinstance(expr, sp.Add | sp.Max | sp.Min | sp.Piecewise):
        terms = [a for a in expr.args if not _is_constant(a)]
        ops["madd"] += len(terms) - (0 if len(terms) < len(expr.args) else 1)
    elif isinstance(expr, sp.Mul):
        variable = [a for a in expr.args if not _is_constant(a)]
        constant = [a for a in expr.args if _is_constant(a) and a not in (1, -1)]  # negation is free
        divisions = [a for a in variable if a.is_Pow and a.exp == -1]
        ops["div"] += len(divisions)
        ops["madd"] += max(len(variable) + min(len(constant), 1) - 1 - len(divisions), 0)
    elif isinstance(expr, sp.Pow):
        e = expr.exp
        if e == -1:
            ops["div"] += 1
        elif e in (sp.Rational(1, 2), sp.Rational(-1, 2)):
            ops["sqrt"] += 1
        elif e.is_Integer and e > 1:     # by repeated squaring
            ops["madd"] += int(e).bit_length() - 1 + bin(int(e)).count("1") - 1
        elif expr.base.is_Number:
            ops["exp/log"] += 1          # c^x is an exp2 / exp
        else:
            ops["pow"] += 1
    elif isinstance(expr, sp.exp | sp.log):
        ops["exp/log"] += 1
    return ops


def _children(expr):
    if isinstance(expr, sp.Mul):   # a / b: the division is the Mul's; go on into b itself
        return [a.base if (a.is_Pow and a.exp == -1) else a for a in expr.args if a != -1]
    return expr.args


def _add(counts, ops):
    for key, v in ops.items():
        counts[key] += v


def _count(expr, counts, seen):
    if expr.is_Atom or expr in seen:     # a repeated subexpression is computed once
        return
    seen.add(expr)
    _add(counts, _node_operations(expr))
    for a in _children(expr):
        _count(a, counts, seen)


def count_operations(expr, variable=t):
    """(per_pixel, per_material): operation counts of expr, hoisting what does not depend on `variable`.

    Subexpressions free of the variable (functions of n only) are computed once per material, the
    rest once per pixel. A square counts as one multiply; x^-1 and a / b as one division; c^x as
    one exp; a general x^y as one pow; additions, multiplications and max as multiply-adds. Constant
    subexpressions are folded and a repeated subexpression is counted once, as a compiler would.
    The counts are those of the expressions as written here (after sympy's canonical form).
    """
    pixel = dict.fromkeys(OPERATIONS, 0)
    material = dict.fromkeys(OPERATIONS, 0)
    seen = set()

    def walk(e):
        if not e.has(variable):
            _count(e, material, seen)
        elif not e.is_Atom and e not in seen:
            seen.add(e)
            _add(pixel, _node_operations(e))
            for a in _children(e):
                walk(a)

    walk(expr)
    return pixel, material
