"""A form's constants chosen among the values of the format its shader computes in: the fpminimax
problem (Brisebarre & Chevillard, ARITH 2007; Sollya's `fpminimax`), by an integer search around
the rounded values rather than Sollya's lattice reduction.

A fitted form's constants (the numbers `forms.gpu_form` prints: exp folded into exp2) are rounded
to the format's nearest values; the search then moves them by whole steps of the format (its
representable neighbours, `executed.ordinals`), one constant by up to `RADIUS` steps either way and
every pair and triple by one step each, keeping a move that lowers the form's largest error on the measuring
grid (`measure.grid`, the form's mathematics in float64 with those constants), round after round
until no move helps or `ROUNDS` have run. The choice is measured on the whole domain
(`measure.max_error`) against the rounded values', and kept only where it is lower; the caller
keeps it only where the error as executed drops too. Where rounding costs less than `NEGLIGIBLE` of
the error, no search runs (float32's rounding of most forms).
"""

from __future__ import annotations

import itertools

import numpy as np
import sympy as sp

from ..measures import measure
from ..measures.executed import from_ordinals, ordinals
from ..forms import DIGITS, FORMATS, free_numbers, gpu_form

RADIUS = 3
ROUNDS = 16
NEGLIGIBLE = 1e-3


def _error_of(g, x, fx, metric: str, floor: float):
    def error(c) -> float:
        with np.errstate(all="ignore"):
            values = np.broadcast_to(np.asarray(g(list(c), x), dtype=np.float64), x.shape)
            diff = np.abs(values - fx)
            if metric == "rel":
                diff = np.where(diff == 0, 0.0, diff / np.maximum(np.abs(fx), floor))
        worst = float(np.max(diff))
        return worst if np.isfinite(worst) else np.inf
    return error


def choose(expression, target, f, precision: str) -> tuple[object, dict]:
    """(the form with its constants chosen in `precision`'s format (module docstring), what the
    search did: dict(searched, moves, rounded_error, chosen_error) on the whole domain in float64,
    the target's measure). The form returned has every constant a value of the format; it is the
    rounded one where the search found nothing better."""
    dtype = FORMATS[precision]
    expr = gpu_form(expression)
    (free,), q, numbers = free_numbers(expr)
    key = "max_abs_error" if target.metric == "abs" else "max_rel_error"
    lo, hi = target.domain
    floor = target.floor if target.metric == "rel" else 0.0
    with np.errstate(over="ignore"):
        rounded = np.array([dtype(float(v)) for v in numbers], dtype=dtype)

    def form_of(c):
        return free.xreplace({qi: sp.Float(float(ci), DIGITS) for qi, ci in zip(q, c)})

    def whole(c) -> float:
        from ..targets import numpy_function

        return measure.max_error(numpy_function(form_of(c), target.symbol()), f, lo, hi, floor)[key]

    rounded_error = whole(rounded) if len(numbers) else whole([])
    out = dict(searched=False, moves=0, rounded_error=rounded_error, chosen_error=rounded_error)
    if not len(numbers) or not np.all(np.isfinite(rounded.astype(np.float64))):
        return form_of(rounded), out
    fitted_error = whole(np.array([float(v) for v in numbers]))
    if rounded_error <= fitted_error * (1 + NEGLIGIBLE):
        return form_of(rounded), out
    g = sp.lambdify([q, target.symbol()], free, "numpy")
    x = measure.grid(lo, hi)
    error = _error_of(g, x, f(x), target.metric, floor)
    places = ordinals(rounded, precision)
    best_places, best = places.copy(), error(from_ordinals(places, precision).astype(np.float64))
    moves = [(i, s) for i in range(len(places)) for s in range(-RADIUS, RADIUS + 1) if s]
    pairs = [tuple(zip(chosen, steps)) for size in (2, 3) for chosen in itertools.combinations(range(len(places)), size)
             for steps in itertools.product((-1, 1), repeat=size)]
    count = 0
    for _ in range(ROUNDS):
        improved = False
        for move in [(m,) for m in moves] + pairs:
            trial = best_places.copy()
            for i, s in move:
                trial[i] += s
            value = error(from_ordinals(trial, precision).astype(np.float64))
            if value < best * (1 - 1e-12):
                best_places, best, improved = trial, value, True
                count += 1
        if not improved:
            break
    chosen = from_ordinals(best_places, precision).astype(np.float64)
    chosen_error = whole(chosen)
    out = dict(searched=True, moves=count, rounded_error=rounded_error, chosen_error=min(chosen_error, rounded_error))
    if chosen_error < rounded_error:
        return form_of(chosen), out
    return form_of(rounded), out
