"""Minimax fits on a whole interval: Remez's exchange for the families linear in their coefficients
(a polynomial, a polynomial times sqrt(1 - x)), and sequential linear programming with exchange
points for the others (a rational, exp2 of a polynomial, a grammar form's constants).

`remez(basis, target, weight, lo, hi)` finds the coefficients a of sum_k a_k phi_k(x) that minimize
max |w(x) (sum_k a_k phi_k(x) - f(x))| over [lo, hi]: for a Haar system of m functions (the
monomials; the monomials times sqrt(1 - x) on [lo, 1)), the best approximation is the one whose
weighted error equioscillates, reaching +-E with alternating signs at m + 1 points (Chebyshev's
theorem), which the exchange converges to: solve for the m + 1 reference points, move them to the
error's alternating extrema, until the extrema's levels agree within `LEVELS` (relative).

`slp(model, jacobian, c0, ...)` minimizes max |w (model(c, x) - f)| over points by sequential linear
programs (`optics.minimax_lp`: HiGHS on a working set of points): each step minimizes the largest
linearized error within a trust region,
kept where the true error falls; after it settles, the error's maximum over the whole interval
(`measure.largest`) joins the points and it goes on (`EXCHANGES` times), so that the fit is
minimax on the interval, not on the points. Each linear program has its step and its error in
units of the current largest error (HiGHS's tolerances are absolute: a small error would be below
them; the matrix is left as it is, since scaling it stalls exact fits), and the steps end where the
program finds no gain with its step inside the trust region (a stationary point of the minimax).

`along(problems, start, own)` fits one form at each value of a parameter in order, each from its
neighbour's optimum (`pipeline derive`'s targets with a parameter, and the lobe search's families
at each n).
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import minimize_scalar

from ...optics.minimax_lp import linear_minimax
from ..measures import measure
from ..targets.box import chebyshev_points

EXACT = 1e-13           # an error below this (relative to the largest |w f|) is rounding: the fit is exact
LEVELS = 1e-9           # the exchange stops where the extrema's levels agree to this (relative)
ITERATIONS = 60         # exchange steps at most
GRID = 8192             # cells of the grid the exchange reads the error's extrema from
SLP_STEPS = 80
EXCHANGES = 4
POINTS = 400            # the slp's first points (Chebyshev-Lobatto on the interval)
STATIONARY = 1e-9       # a linear program that gains less than this (relative), its step inside the region: done
GROWTH = 1.25           # an error this much above the previous value's calls for the form's own start too


class MinimaxFailed(RuntimeError):
    """The exchange found fewer alternating extrema than the reference needs (not a Haar system on
    the interval, or the error vanished)."""


def _alternating_extrema(x, e):
    """Per run of one sign of e, the index of its largest |e|: alternating in sign, in order."""
    sign = np.sign(e)
    nonzero = np.flatnonzero(sign != 0)
    if nonzero.size == 0:
        return np.array([], dtype=int)
    runs, start = [], nonzero[0]
    for i, j in zip(nonzero[:-1], nonzero[1:]):
        if sign[j] != sign[i]:
            runs.append((start, i + 1))
            start = j
    runs.append((start, nonzero[-1] + 1))
    return np.array([a + int(np.argmax(np.abs(e[a:b]))) for a, b in runs])


def _refine(e, x, j):
    a, b = x[max(j - 1, 0)], x[min(j + 1, x.size - 1)]
    if b <= a:
        return x[j]
    found = minimize_scalar(lambda s: -abs(float(e(np.array([s]))[0])), bounds=(a, b), method="bounded",
                            options=dict(xatol=1e-15 * max(1.0, abs(a), abs(b))))
    return found.x if abs(float(e(np.array([found.x]))[0])) > abs(float(e(x[j:j + 1])[0])) else x[j]


def remez(basis, target, weight, lo: float, hi: float) -> dict:
    """The weighted minimax coefficients of `basis` (callables phi_k of x) for `target` with
    `weight` (callables of x) on [lo, hi] (module docstring). Returns dict(coefficients, level
    (|E|, the equioscillation's level), error (the largest weighted error, measured), reference
    (the m + 1 points), signs (the error's sign there), iterations, exact (the basis holds the
    target to rounding: no equioscillation)). Raises MinimaxFailed."""
    m = len(basis)
    x = measure.grid(lo, hi)
    x = np.unique(np.concatenate([x, np.linspace(lo, hi, GRID + 1)]))
    phi = np.stack([f(x) for f in basis], axis=1)
    usable = np.max(np.abs(phi), axis=1) > 1e-14          # a point where every phi vanishes is no reference
    f_x, w_x = target(x), weight(x)
    reference = chebyshev_points(lo, hi, m + 1)
    # (the reference on usable points: nearest usable grid point)
    candidates = x[usable]
    reference = candidates[np.clip(np.searchsorted(candidates, reference), 0, candidates.size - 1)]
    reference = np.unique(reference)
    if reference.size < m + 1:
        reference = candidates[np.linspace(0, candidates.size - 1, m + 1).astype(int)]
    best = None
    for iteration in range(1, ITERATIONS + 1):
        A = np.stack([f(reference) for f in basis], axis=1)
        signs = (-1.0) ** np.arange(m + 1)
        system = np.column_stack([A, signs / weight(reference)])
        try:
            solution = np.linalg.solve(system, target(reference))
        except np.linalg.LinAlgError:
            raise MinimaxFailed("a singular reference (the basis is not a Haar system here)") from None
        a = solution[:m]

        def e(s, a=a):
            s = np.asarray(s, dtype=np.float64)
            with np.errstate(all="ignore"):
                return weight(s) * (np.stack([f(s) for f in basis], axis=1) @ a - target(s))

        values = w_x * (phi @ a - f_x)
        largest = float(np.max(np.abs(values)))
        if best is None or largest < best["error"]:
            best = dict(coefficients=a, level=abs(float(solution[m])), error=largest, reference=reference,
                        signs=np.sign(e(reference)), iterations=iteration, exact=False)
        if largest <= EXACT * np.max(np.abs(w_x * f_x)):
            return best | dict(exact=True, converged=True)        # the basis holds the target: nothing to equioscillate
        extrema = _alternating_extrema(x, np.where(usable, values, 0.0))
        if extrema.size < m + 1:
            raise MinimaxFailed(f"{extrema.size} alternating extrema, {m + 1} needed")
        # the window of m + 1 consecutive extrema holding the largest, with the largest smallest level
        top = int(np.argmax(np.abs(values[extrema])))
        windows = [w for w in range(extrema.size - m) if w <= top <= w + m]
        chosen = max(windows, key=lambda w: np.min(np.abs(values[extrema[w:w + m + 1]])))
        points = extrema[chosen:chosen + m + 1]
        reference = np.array([_refine(e, x, j) for j in points])
        levels = np.abs(e(reference))
        if (np.max(levels) - np.min(levels)) <= LEVELS * np.max(levels):
            return dict(coefficients=a, level=float(np.mean(levels)), error=float(np.max(levels)), reference=reference,
                        signs=np.sign(e(reference)), iterations=iteration, exact=False, converged=True)
    return best | dict(exact=False, converged=False)


def slp_points(model, jacobian, c0, target_values, weights, x, steps: int = SLP_STEPS) -> tuple[np.ndarray, float]:
    """Minimax constants of `model(c, x)` on fixed points `x` (an array of points of one variable, or
    (variables, points)): sequential linear programs (module docstring) from c0, each step minimizing
    the largest linearized weighted error within a trust region, kept where the true error falls.
    Returns (constants, the largest weighted error on the points; inf where never finite)."""
    c = np.asarray(c0, dtype=np.float64)
    y = np.asarray(target_values, dtype=np.float64)
    w = np.asarray(weights, dtype=np.float64)

    def residual(c_):
        with np.errstate(all="ignore"):
            return w * (model(c_, x) - y)

    def on_points(c_):
        r = residual(c_)
        return float(np.max(np.abs(r))) if np.all(np.isfinite(r)) else np.inf

    value = on_points(c)
    radius = 0.1 * (np.abs(c) + 1e-3)
    for _ in range(steps):
        r = residual(c)
        with np.errstate(all="ignore"):
            J = w[:, None] * jacobian(c, x)
        if not (np.all(np.isfinite(r)) and np.all(np.isfinite(J))):
            break
        scale = max(value, 1e-300)      # step and error in units of the largest error (module docstring)
        solved = linear_minimax(J, r / scale, radius / scale)
        if solved is None:
            break
        level, step = solved
        step = step * scale
        if level >= 1.0 - STATIONARY and np.all(np.abs(step) < 0.5 * radius):
            break                       # no linearized gain, not for want of room: stationary
        trial = c + step
        trial_value = on_points(trial)
        if trial_value < value:
            gained = value - trial_value
            c, value = trial, trial_value
            radius *= 2.0
            if gained <= 1e-13 * value:
                break
        else:
            radius *= 0.25
        if np.all(radius <= 1e-13 * (np.abs(c) + 1e-13)):
            break
    return c, value


def along(problems, start, own=None, previous: float | None = None,
          give_up: float = np.inf) -> tuple[np.ndarray, np.ndarray]:
    """`slp_points` at each of `problems` in order (a parameter's values, neighbours in turn), each a
    tuple (model, jacobian, target_values, weights, x): the first from `start` (the optimum of a
    neighbour whose error was `previous`, if any), each other from the previous one's constants; also
    from `own(i)` (a start of the form's own at problem i, or None) where an error is not finite or
    more than GROWTH times the previous one's (a neighbour's optimum can lead into another basin). The
    better is kept. Returns (constants (problems, count), errors), cut after the first problem whose
    error is finite and `give_up` or more."""
    constants, errors = [], []
    c = np.asarray(start, dtype=np.float64)
    for i, (model, jacobian, y, w, x) in enumerate(problems):
        c, e = slp_points(model, jacobian, c, y, w, x)
        if not np.isfinite(e) or (previous is not None and e > GROWTH * previous):
            other = own(i) if own is not None else None
            if other is not None:
                c_other, e_other = slp_points(model, jacobian, np.asarray(other, dtype=np.float64), y, w, x)
                if e_other < e:
                    c, e = c_other, e_other
        constants.append(c)
        errors.append(e)
        previous = e
        if np.isfinite(e) and e >= give_up:
            break
        if not np.isfinite(e):
            c = np.asarray(start, dtype=np.float64)
    return np.array(constants).reshape(len(constants), np.size(start)), np.array(errors)


def numerical_jacobian(model):
    """jacobian(c, x) of `model` by central differences (steps 1e-7 (|c| + 1e-7) of each constant):
    for forms with no derivative of their own (a grammar form's, a family's in its scaled variable);
    `slp_points` keeps a step only where the true error falls, so the derivative's rounding costs
    steps, not accuracy."""
    def jacobian(c, x):
        c = np.asarray(c, dtype=np.float64)
        columns = []
        for j in range(c.size):
            h = 1e-7 * (abs(c[j]) + 1e-7)
            up, down = c.copy(), c.copy()
            up[j] += h
            down[j] -= h
            columns.append((model(up, x) - model(down, x)) / (2.0 * h))
        return np.stack(columns, axis=1)
    return jacobian


def slp(model, jacobian, c0, target, weight, lo: float, hi: float, steps: int = SLP_STEPS,
        exchanges: int = EXCHANGES, points=None):
    """Minimax constants of `model(c, x)` (numpy; `jacobian(c, x)`: (points, constants)) for
    `target` with `weight` on [lo, hi], from c0 (module docstring). Returns (constants, the largest
    weighted error over the interval, measured by `measure.largest`)."""
    c = np.asarray(c0, dtype=np.float64)
    x = chebyshev_points(lo, hi, POINTS) if points is None else np.asarray(points, dtype=np.float64)

    def residual(c_, s):
        with np.errstate(all="ignore"):
            return weight(s) * (model(c_, s) - target(s))

    def whole(c_):
        return measure.largest(lambda s: residual(c_, s), lo, hi)

    best_value, _ = whole(c)
    best_c = c
    for _ in range(exchanges + 1):
        with np.errstate(all="ignore"):
            c, value = slp_points(model, jacobian, c, target(x), weight(x), x, steps)
        measured, where = whole(c)
        if measured < best_value:
            best_value, best_c = measured, c
        if not np.isfinite(measured) or measured <= value * (1 + 1e-9):
            break
        x = np.unique(np.r_[x, where])          # the interval's worst point joins the points
    return best_c, best_value
