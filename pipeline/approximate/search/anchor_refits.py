"""The anchors' forms refitted: the engines' own form at its own cost, its decimal numbers refitted by
minimax, over one variable's domain (`refitted_anchors`) or a parametric target's box
(`refitted_box_anchors`, which also refits each anchor with the numbers a back end gets for free
held: `offsets_free`); and constants at rounding's level dropped (`without_negligible`), each judged
by the form's float64 error over the domain (`measured`).
"""

from __future__ import annotations

import numpy as np

from ..measures import measure
from . import families, minimax
from ..forms import Form, free_numbers
from ..targets import numpy_function

NEGLIGIBLE = 1e-9               # a constant below this share of a form's largest is tried without it


def refitted_anchors(target, f, log) -> list[Form]:
    """Each anchor's form with its decimal numbers refitted together by minimax over the domain (from
    their own values, `minimax.slp`), where that lowers its error: the engines' own form at its own
    cost, with the numbers the exact function asks for. An anchor without decimal numbers has none."""
    import sympy as sp

    lo, hi = target.domain
    key = "max_abs_error" if target.metric == "abs" else "max_rel_error"
    weight = families.weight_of(target, f)
    symbol = target.symbol()
    out = []
    for anchor, expr in zip(target.anchors, target.anchor_expressions().values()):
        (free,), q, numbers = free_numbers(expr)
        if not numbers:
            continue
        g = sp.lambdify([q, symbol], free, "numpy")

        def model(c, s, g=g):
            with np.errstate(all="ignore"):
                return np.broadcast_to(np.asarray(g(c, s), dtype=np.float64), np.shape(s))

        c, _ = minimax.slp(model, minimax.numerical_jacobian(model), [float(v) for v in numbers], f, weight, lo, hi,
                           steps=40, exchanges=2)
        refit = Form(f"{anchor.name}_refitted", "found", "anchor_refit",
                     free.xreplace({qi: sp.Float(float(ci), 17) for qi, ci in zip(q, c)}),
                     f"{anchor.name}'s form, its numbers refitted by minimax")
        before, after = measured(Form(anchor.name, "anchor", "anchor", expr, ""), target, f)[key], \
            measured(refit, target, f)[key]
        if np.isfinite(after) and after < before * (1 - 1e-6):
            log(f"{anchor.name} refitted: error {before:.3g} -> {after:.3g}")
            out.append(refit)
    return out


def without_negligible(form: Form, target, f) -> Form:
    """`form` with its constants at rounding's level (below NEGLIGIBLE times its largest constant's
    magnitude, e.g. exp2(3.5e-18 - 1.44 x)) set to 0 where its float64 error does not rise; else the
    form as it is. Every output then writes the form without them."""
    import dataclasses

    import sympy as sp

    numbers = [a for a in form.expression.atoms(sp.Float) if a != 0]
    if len(numbers) < 2:
        return form
    largest = max(abs(float(a)) for a in numbers)
    tiny = {a: sp.Integer(0) for a in numbers if abs(float(a)) < NEGLIGIBLE * largest}
    if not tiny:
        return form
    key = "max_abs_error" if target.metric == "abs" else "max_rel_error"
    candidate = dataclasses.replace(form, expression=form.expression.xreplace(tiny))
    before, after = measured(form, target, f)[key], measured(candidate, target, f)[key]
    return candidate if after <= before else form


def measured(form: Form, target, f) -> dict:
    lo, hi = target.domain
    return measure.max_error(numpy_function(form.expression, target.symbol()), f, lo, hi, target.floor)


# The factors a back end multiplies by for free, held as they are by `offsets_free`: AMD's output
# modifiers halve, double or quadruple a result, and 0.5, 2 and 4 are among its inline constants.
FREE_FACTORS = (0.5, 2.0, 4.0)


def offsets_free(expr):
    """`expr` with each decimal factor of magnitude in FREE_FACTORS held as an exact number, and each
    integer term of a sum (the 1 of 1 - alpha) written as a decimal number: its decimal numbers are
    then those a refit frees. Filament's 0.5 / (NoV (NoL (1 - a) + a) + ...) refits its ones and keeps
    the 0.5 that RDNA3 applies as an output modifier (a refitted 0.5 costs a multiply there)."""
    import sympy as sp

    if expr.is_Atom:
        return expr
    args = [offsets_free(a) for a in expr.args]
    if expr.is_Add:
        args = [sp.Float(int(a), 17) if a.is_Integer else a for a in args]
    elif expr.is_Mul:
        args = [sp.Rational(float(a)) if a.is_Float and abs(float(a)) in FREE_FACTORS else a for a in args]
    return expr.func(*args)


def _held_as_decimal(expr):
    """`expr` with the exact factors `offsets_free` held (0.5, not an integer) decimal again."""
    import sympy as sp

    if expr.is_Atom:
        return expr
    args = [_held_as_decimal(a) for a in expr.args]
    if expr.is_Mul:
        args = [sp.Float(float(a), 17) if a.is_Rational and not a.is_Integer and abs(float(a)) in FREE_FACTORS
                else a for a in args]
    return expr.func(*args)


def _as_kept(expr, target):
    """`expr` as the derive cache keeps and reads it back (`engine.expressions.text`, then `parse`): the
    same numbers in the tree sympy builds from their text, where a number times a sum is distributed
    (c*(1 - r)*m, built by substitution, reads back as (c - c*r)*m), so that a rerun that reads the
    kept refit computes what this run did."""
    from ...engine import expressions
    from .templates import kept_symbols

    symbols = {s.name: s for s in kept_symbols(target)}
    return expressions.parse(expressions.text(expr), symbols, what="a refitted anchor", float64=True)


def refitted_box_anchors(target, f, log) -> tuple[list[dict], dict]:
    """Each anchor of a parametric target refitted by minimax on the box (`formulas._polished`, from
    its own numbers, at the parameter's grid and halfway values), as pixel forms, each kept where it
    lowers the anchor's error: `<anchor>_refitted`, its decimal numbers refitted (none without
    any); and `<anchor>_refitted_offsets`, its numbers as `offsets_free` leaves them to refit (the
    factors a back end gets for free held, the sums' integers refitted), where those are other
    numbers. Returns (the forms as the parametric search's records, the coverage)."""
    import sympy as sp

    from .formulas import _error_key, _polished, measure_box
    from ..targets import parameter_values

    values = None if target.parameter is None else np.sort(np.concatenate(parameter_values(target.parameter)))
    key = _error_key(target)
    out = []
    for anchor, expr in zip(target.anchors, target.anchor_expressions().values()):
        before = measure_box(expr, target, f)[key]
        free = offsets_free(expr)
        variants = []
        if expr.atoms(sp.Float):
            variants.append(("_refitted", expr, "its numbers refitted by minimax on the box"))
        if free.atoms(sp.Float) and sorted(map(float, free.atoms(sp.Float))) != sorted(map(float, expr.atoms(sp.Float))):
            variants.append(("_refitted_offsets", free, "its numbers and its sums' integers refitted by minimax on the "
                             f"box, its factors of {', '.join(f'{v:g}' for v in FREE_FACTORS)} held (free on AMD: "
                             "output modifiers)"))
        for suffix, start, source in variants:
            refit = _as_kept(_held_as_decimal(_polished(start, target, f, values)[0]), target)
            errors = measure_box(refit, target, f)
            if np.isfinite(errors[key]) and errors[key] < before * (1 - 1e-6):
                log(f"{anchor.name}{suffix}: error {before:.3g} -> {errors[key]:.3g}")
                out.append(dict(name=f"{anchor.name}{suffix}", family="anchor_refit", expression=refit,
                                source=f"{anchor.name}'s form, {source}", per="pixel", errors=errors))
    return out, dict(refitted_anchors=[r["name"] for r in out])
