"""Exact normalization of the quadratic lobe, by symbolic integration (sympy).

For the lobe (k (c - 1) + 1)^2 in c = cos x, clamped to 0 below its zero crossing c0 = 1 - 1/k,
the energy it reflects when centred on the normal is 2 pi Int(k) with

    Int(k) = int_{max(c0, 0)}^{1} (k (c - 1) + 1)^2 c dc        (Phong form, cos x = R.V),

and the ideal normalization is coef = 1 / (2 pi Int). Where k < 1 the zero crossing lies below the
horizon (c0 < 0) and only the upper hemisphere reflects: the integral stops at c = 0. The paper's
gran(n) = arccos(c0) runs on to c0 < 0, which adds int_{c0}^{0} (...) c dc < 0 (light "reflected"
below the surface), so the paper's Int is smaller and its coef larger there.

For the Blinn form (cos x = N.H) with V = N, H halves the angle to L: with c = cos(theta_h),
cos(theta_o) = 2 c^2 - 1 and dw_o = 2 pi 4 c dc, so

    Int_B(k) = int_{max(c0, 1/sqrt 2)}^{1} (k (c - 1) + 1)^2 (2 c^2 - 1) 4 c dc,

where the lower limit switches at k = 2 + sqrt 2 (the zero crossing at theta_h = pi / 4).

Everything here is a sympy expression in the symbols below; `jax_function` turns one into the
generated code the stages evaluate.
"""

from __future__ import annotations

import functools
import inspect

import sympy as sp

k, c, n = sp.symbols("k c n", positive=True)
slope, intercept = sp.symbols("a b", real=True)
BLINN_SWITCH = 2 + sp.sqrt(2)


def lobe(c_, k_):
    """The unclamped quadratic lobe (k (c - 1) + 1)^2."""
    return (k_ * (c_ - 1) + 1) ** 2


@functools.cache
def phong_integral():
    """Int(k) over the upper hemisphere, piecewise in k (switch at k = 1)."""
    above = sp.factor(sp.integrate(lobe(c, k) * c, (c, 1 - 1 / k, 1)))
    below = sp.expand(sp.integrate(lobe(c, k) * c, (c, 0, 1)))
    return sp.Piecewise((above, k >= 1), (below, True))


@functools.cache
def phong_integral_gran():
    """The paper's Int(k): the integral up to gran, i.e. from c0 = 1 - 1/k even where c0 < 0."""
    return sp.factor(sp.integrate(lobe(c, k) * c, (c, 1 - 1 / k, 1)))


@functools.cache
def blinn_integral():
    """Int_B(k) of the Blinn form at normal view, piecewise in k (switch at k = 2 + sqrt 2)."""
    weight = (2 * c**2 - 1) * 4 * c
    above = sp.factor(sp.integrate(lobe(c, k) * weight, (c, 1 - 1 / k, 1)))
    below = sp.expand(sp.integrate(lobe(c, k) * weight, (c, 1 / sp.sqrt(2), 1)))
    return sp.Piecewise((above, k >= BLINN_SWITCH), (below, True))


def coef_of_k(integral):
    """The ideal normalization 1 / (2 pi Int) as a function of k."""
    return sp.piecewise_fold(1 / (2 * sp.pi * integral))


def coef_of_n(integral):
    """coef(n) for k = a n + b (symbols `slope`, `intercept`)."""
    return coef_of_k(integral).subs(k, slope * n + intercept)


@functools.cache
def large_k_expansion(which: str, order: int = 3):
    """The first `order` terms of coef(k) as k -> infinity: c_1 k + c_0 + c_-1 / k + ..."""
    integral = {"phong": phong_integral(), "blinn": blinn_integral()}[which]
    big = integral.args[0][0]            # the branch for large k
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


@functools.cache
def exact_coef_code(which: str):
    """(function of (n, a, b), generated source) for the exact coef(n) of the Phong or Blinn form."""
    integral = {"phong": phong_integral(), "blinn": blinn_integral()}[which]
    return jax_function(coef_of_n(integral), (n, slope, intercept))
