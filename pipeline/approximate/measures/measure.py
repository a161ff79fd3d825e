"""The largest error of an approximation over a target's whole domain, found as
`pipeline.optics.extrema` finds the lobes': on a grid, then refined to the true extremum.

The grid is the union of `GRID` uniform cells and `CHEBYSHEV` Chebyshev-Lobatto points (which
crowd the ends, where minimax errors and singular targets peak). The `PEAKS` largest local maxima
of |error| on the grid are each refined by a bounded scalar search (Brent's, scipy) over the two
cells around them; the largest value found, grid or refined, is the error. Assumption (as there):
the true maximum lies in the cell pair of one of the grid's largest local maxima; the tests check
it against 20x denser grids.

An approximation that is not finite anywhere on the grid has error inf.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import minimize_scalar

GRID = 4096
CHEBYSHEV = 1025
PEAKS = 8


def grid(lo: float, hi: float) -> np.ndarray:
    """The measuring grid of [lo, hi] (module docstring), sorted, without repeats."""
    k = np.arange(CHEBYSHEV)
    chebyshev = lo + (hi - lo) * (1 - np.cos(np.pi * k / (CHEBYSHEV - 1))) / 2
    return np.unique(np.concatenate([np.linspace(lo, hi, GRID + 1), chebyshev]))


def error_function(approx, target, metric: str, floor: float = 0.0):
    """e(x): approx(x) - target(x), divided by max(|target(x)|, floor) for `rel` (0 where both are 0)."""
    def e(x):
        x = np.asarray(x, dtype=np.float64)
        with np.errstate(all="ignore"):
            f = target(x)
            diff = approx(x) - f
            if metric == "abs":
                return diff
            scale = np.maximum(np.abs(f), floor)
            return np.where(diff == 0, 0.0, diff / scale)
    return e


def largest(e, lo: float, hi: float) -> tuple[float, float]:
    """(max |e(x)| over [lo, hi], the x where it is attained), by the grid and refinement of the
    module docstring; (inf, x) where e is not finite somewhere on the grid."""
    x = grid(lo, hi)
    v = np.abs(e(x))
    if not np.all(np.isfinite(v)):
        return float("inf"), float(x[np.flatnonzero(~np.isfinite(v))[0]])
    # local maxima of |e| on the grid (the ends count), the PEAKS largest refined
    left = np.r_[-np.inf, v[:-1]]
    right = np.r_[v[1:], -np.inf]
    peaks = np.flatnonzero((v >= left) & (v >= right))
    peaks = peaks[np.argsort(v[peaks])[::-1][:PEAKS]]
    best, where = float(np.max(v)), float(x[np.argmax(v)])
    for j in peaks:
        a, b = x[max(j - 1, 0)], x[min(j + 1, x.size - 1)]
        if b <= a:
            continue
        found = minimize_scalar(lambda s: -float(np.abs(e(np.array([s]))[0])), bounds=(a, b), method="bounded",
                                options=dict(xatol=1e-15 * max(abs(a), abs(b), hi - lo)))
        value = -float(found.fun)
        if np.isfinite(value) and value > best:
            best, where = value, float(found.x)
    return best, where


def max_error(approx, target, lo: float, hi: float, floor: float = 0.0) -> dict:
    """{max_abs_error, max_rel_error, x_abs, x_rel} of the numpy callable `approx` against
    `target` on [lo, hi] (the relative error's divisor max(|f|, floor): inf where f reaches 0 and
    floor is 0 while the approximation does not)."""
    abs_error, x_abs = largest(error_function(approx, target, "abs"), lo, hi)
    rel_error, x_rel = largest(error_function(approx, target, "rel", floor), lo, hi)
    return dict(max_abs_error=abs_error, max_rel_error=rel_error, x_abs=x_abs, x_rel=x_rel)


def best_constant_error(values, metric: str, floor: float = 0.0) -> float:
    """The error of the best constant (minimax) against the target's `values`: abs, (max f - min f) / 2;
    rel (f of one sign), (max |f| - min |f|) / (max |f| + min |f|), the floor raising min |f|; 1 where
    f changes sign. A form worth a cycle beats it."""
    values = np.asarray(values, dtype=np.float64)
    if metric == "abs":
        return float(values.max() - values.min()) / 2
    if values.min() < 0 < values.max():
        return 1.0
    size = np.maximum(np.abs(values), floor)
    return float((size.max() - size.min()) / (size.max() + size.min()))
