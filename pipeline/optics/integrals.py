"""Exact normalization of the family's lobe, by symbolic integration (sympy), for any power m.

For the lobe (k (c - 1) + 1)^m in c = cos x (m = 2 in the paper), clamped to 0 below its zero
crossing c0 = 1 - 1/k, the energy it reflects when centred on the normal is 2 pi Int(k) with

    Int(k) = int_{max(c0, 0)}^{1} (k (c - 1) + 1)^m c dc        (Phong form, cos x = R.V),

which for k >= 1 is ((m + 2) k - 1) / ((m + 1)(m + 2) k^2) (at m = 2: (4k - 1) / (12 k^2)).

and the ideal normalization is coef = 1 / (2 pi Int). Where k < 1 the zero crossing lies below the
horizon (c0 < 0) and only the upper hemisphere reflects: the integral stops at c = 0. The paper's
gran(n) = arccos(c0) runs on to c0 < 0, which adds int_{c0}^{0} (...) c dc < 0 (light "reflected"
below the surface), so the paper's Int is smaller and its coef larger there.

For the Blinn form (cos x = N.H) with V = N, H halves the angle to L: with c = cos(theta_h),
cos(theta_o) = 2 c^2 - 1 and dw_o = 2 pi 4 c dc, so

    Int_B(k) = int_{max(c0, 1/sqrt 2)}^{1} (k (c - 1) + 1)^m (2 c^2 - 1) 4 c dc,

where the lower limit switches at k = 2 + sqrt 2 (the zero crossing at theta_h = pi / 4), for
every m.

Everything here is a sympy expression in the symbols below, integrated for the integer power
given (each function takes `power`, default 2); `jax_function` turns one into the generated code
the stages evaluate.
"""

from __future__ import annotations

import functools
import inspect

import sympy as sp

k, c, n = sp.symbols("k c n", positive=True)
slope, intercept = sp.symbols("a b", real=True)
BLINN_SWITCH = 2 + sp.sqrt(2)


def lobe(c_, k_, power: int = 2):
    """The unclamped lobe (k (c - 1) + 1)^m."""
    return (k_ * (c_ - 1) + 1) ** int(power)


@functools.cache
def phong_integral(power: int = 2):
    """Int(k) over the upper hemisphere, piecewise in k (switch at k = 1)."""
    above = sp.factor(sp.integrate(lobe(c, k, power) * c, (c, 1 - 1 / k, 1)))
    below = sp.expand(sp.integrate(lobe(c, k, power) * c, (c, 0, 1)))
    return sp.Piecewise((above, k >= 1), (below, True))


@functools.cache
def phong_integral_gran(power: int = 2):
    """The paper's Int(k): the integral up to gran, i.e. from c0 = 1 - 1/k even where c0 < 0."""
    return sp.factor(sp.integrate(lobe(c, k, power) * c, (c, 1 - 1 / k, 1)))


@functools.cache
def blinn_integral(power: int = 2):
    """Int_B(k) of the Blinn form at normal view, piecewise in k (switch at k = 2 + sqrt 2)."""
    weight = (2 * c**2 - 1) * 4 * c
    above = sp.factor(sp.integrate(lobe(c, k, power) * weight, (c, 1 - 1 / k, 1)))
    below = sp.expand(sp.integrate(lobe(c, k, power) * weight, (c, 1 / sp.sqrt(2), 1)))
    return sp.Piecewise((above, k >= BLINN_SWITCH), (below, True))


def integral(which: str, power: int = 2):
    """Int(k) of the Phong or the Blinn form."""
    return {"phong": phong_integral, "blinn": blinn_integral}[which](int(power))


def coef_of_k(integral):
    """The ideal normalization 1 / (2 pi Int) as a function of k."""
    return sp.piecewise_fold(1 / (2 * sp.pi * integral))


def coef_of_n(integral):
    """coef(n) for k = a n + b (symbols `slope`, `intercept`)."""
    return coef_of_k(integral).subs(k, slope * n + intercept)


@functools.cache
def large_k_expansion(which: str, order: int = 3, power: int = 2):
    """The first `order` terms of coef(k) as k -> infinity: c_1 k + c_0 + c_-1 / k + ..."""
    big = integral(which, power).args[0][0]            # the branch for large k
    e = sp.symbols("e", positive=True)
    series = sp.series(sp.simplify(coef_of_k(big).subs(k, 1 / e)), e, 0, order - 1).removeO()
    return sp.expand(series.subs(e, 1 / k))


def expansion_in_n(expr_k):
    """An expansion in k rewritten for k = a n + b and expanded in powers of n (to O(1/n))."""
    e = sp.symbols("e", positive=True)
    inner = expr_k.subs(k, slope * n + intercept).subs(n, 1 / e)
    series = sp.series(inner, e, 0, 2).removeO()
    return sp.expand(series.subs(e, 1 / n))


def jax_function(expr, args):
    """(function, source): `expr` compiled by sympy's code generator for jax.numpy, then jitted."""
    from .numerics import jax
    fn = sp.lambdify(args, expr, modules="jax")
    return jax.jit(fn), inspect.getsource(fn)


def asymptote(which: str, power: int = 2) -> tuple[float, float]:
    """(c_1, c_0) of the two-term large-k form c_1 k + c_0 of coef(k): at m = 2, (3 / (2 pi)) (k + 1/4)
    (Phong) and (3 / (8 pi)) (k + 5/4) (Blinn)."""
    series = large_k_expansion(which, 3, int(power))
    return float(series.coeff(k, 1)), float(series.coeff(k, 0))


@functools.cache
def exact_coef_code(which: str, power: int = 2):
    """(function of (n, a, b), generated source) for the exact coef(n) of the Phong or Blinn form."""
    return jax_function(coef_of_n(integral(which, power)), (n, slope, intercept))
