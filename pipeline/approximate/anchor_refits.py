"""The anchors' forms refitted (`refitted_anchors`: the engines' own form at its own cost, its decimal
numbers refitted by minimax) and constants at rounding's level dropped (`without_negligible`), each
judged by the form's float64 error over the domain (`measured`).
"""

from __future__ import annotations

import numpy as np

from . import families, measure, minimax
from .forms import Form, free_numbers
from .targets import numpy_function

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
