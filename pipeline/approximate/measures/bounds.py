"""A form's error bound on a GPU: its error as executed (`executed`) plus, propagated to first order
through the form, what each special function it calls may err on that GPU's architectures
(`isa.special_functions`: Vulkan's minimum, or the vendor's own figure) beyond what lavapipe's did.

Each special call s_i of the form as a shader computes it (`forms.gpu_form`: exp2, log, sqrt,
inversesqrt, a reciprocal 1/b, pow, acos, asin, atan, sin, cos) is given an error e_i; the bound's
second term is the largest over the measuring grid (`measure.grid`) of sum_i |dF/de_i| delta_i(x),
delta_i the absolute error allowed at the call's argument and value (pow inherits from
exp2(y log2 x), and is exact where it is 0), over max(|f|, floor) for a relative measure. A form without special calls is
bounded by its executed error.
"""

from __future__ import annotations

import math

import numpy as np
import sympy as sp

from ...isa import special_functions
from . import measure
from ..forms import gpu_form

LN2 = math.log(2.0)


def _kind(node) -> str | None:
    """The special function a node of a gpu_form computes, or None (arithmetic, min, max)."""
    if isinstance(node, sp.Pow):
        base, e = node.base, node.exp
        if base.is_Number and float(base) == 2.0:
            return "exp2"
        if e.is_Number:
            value = float(e)
            if value == 0.5:
                return "sqrt"
            if value == -0.5:
                return "inversesqrt"
            if value.is_integer() and value < 0:
                return "division"
            if value.is_integer():
                return None
        return "pow"
    return {sp.log: "log2", sp.acos: "acos", sp.asin: "asin", sp.atan: "atan", sp.sin: "sin", sp.cos: "cos"}.get(
        type(node))


def special_calls(expression):
    """(the form with each special call s_i replaced by s_i + e_i, [(e_i, the call, its kind)])."""
    calls = []

    def rebuild(node):
        if node.is_Atom:
            return node
        args = [rebuild(a) for a in node.args]
        built = node.func(*args, evaluate=False) if isinstance(node, (sp.Add, sp.Mul, sp.Pow)) else node.func(*args)
        kind = _kind(node)
        if kind is None:
            return built
        e = sp.Symbol(f"e_{len(calls)}", real=True)
        calls.append((e, node, kind))
        return built + e

    return rebuild(gpu_form(expression)), calls


def sensitivities(expression, symbol, x: np.ndarray) -> list[dict]:
    """For each special call: its kind, |dF/de| at x, its argument(s) and value at x (float64)."""
    perturbed, calls = special_calls(expression)
    zero = {e: 0 for e, _, _ in calls}
    out = []
    with np.errstate(all="ignore"):
        for e, node, kind in calls:
            slope = sp.lambdify(symbol, sp.diff(perturbed, e).xreplace(zero), "numpy")
            value = sp.lambdify(symbol, node, "numpy")
            arguments = [sp.lambdify(symbol, a, "numpy") for a in node.args]
            out.append(dict(kind=kind, slope=np.abs(np.broadcast_to(np.asarray(slope(x), dtype=np.float64), x.shape)),
                            value=np.broadcast_to(np.asarray(value(x), dtype=np.float64), x.shape),
                            arguments=[np.broadcast_to(np.asarray(a(x), dtype=np.float64), x.shape) for a in arguments]))
    return out


def allowed(call: dict, vendor: str, precision: str) -> np.ndarray:
    """The absolute error a call may have on `vendor`'s architectures (`isa.special_functions`)."""
    kind, value, arguments = call["kind"], call["value"], call["arguments"]
    if kind == "pow":              # inherited from exp2(y log2 x)
        base, exponent = arguments
        with np.errstate(all="ignore"):
            logarithm = np.log2(base)
            from_log = np.abs(value) * LN2 * np.abs(exponent) * special_functions.allowed(
                special_functions.accuracy("log2", vendor, precision), base, logarithm, precision)
            total = from_log + special_functions.allowed(special_functions.accuracy("exp2", vendor, precision), exponent * logarithm,
                                                value, precision)
        return np.where(value == 0, 0.0, total)       # (0^y = exp2(-inf): exact)
    argument = arguments[0] if kind != "exp2" else arguments[1]
    return special_functions.allowed(special_functions.accuracy(kind, vendor, precision), argument, value, precision)


def functions_used(expression) -> list[str]:
    """The special functions a form calls, in order, once each."""
    return list(dict.fromkeys(kind for _, _, kind in special_calls(expression)[1]))


def propagated(calls: list[dict], vendor: str, precision: str, scale: np.ndarray) -> float:
    """The largest over the grid of sum_i |dF/de_i| delta_i / scale (module docstring)."""
    if not calls:
        return 0.0
    with np.errstate(all="ignore"):
        total = sum(c["slope"] * allowed(c, vendor, precision) for c in calls) / scale
    total = np.where(np.isnan(total), np.inf, total)
    return float(np.max(total))


def scale_of(target, f, x) -> np.ndarray:
    """The measure's divisor at x: 1 (abs), max(|f|, floor) (rel)."""
    return np.ones_like(x) if target.metric == "abs" else np.maximum(np.abs(f(x)), target.floor)


def grid(target) -> np.ndarray:
    return measure.grid(*target.domain)
