"""Extrema of the error of any lobe against cos^n, for lobes without a closed-form stationary point.

The error e(w) is taken in the scaled variable w = n u (u = 1 - cos x), on which every lobe of
width ~1/n looks alike. It is sampled on a grid uniform in s = log(1 + w), which resolves both the
lobe's core (w ~ 0.01 .. 10) and heavy tails (w up to n). The grid's largest (smallest) value is
then refined to the true extremum: a root of de/ds found by bisection on the two cells around the
grid point where de/ds changes sign there, else the grid point itself (an endpoint extremum).

Assumption, checked by the tests against dense grids: the grid's best point lies in the cell pair
of the true extremum (no narrower, higher peak elsewhere between grid points).
"""

from __future__ import annotations

import functools

from .numerics import jax
import jax.numpy as jnp
import numpy as np

from .lobes import SHAPE_NAMES, lobe_of_shape
from .roots import SolverSettings, bracketed_root


def _refine(e, s, values, j, sign, args, settings: SolverSettings):
    """Extremum of sign * e near grid index j: (value, s at the value, ok)."""
    last = s.shape[0] - 1
    lo, hi = s[jnp.maximum(j - 1, 0)], s[jnp.minimum(j + 1, last)]
    slope = jax.grad(lambda s_, a: sign * e(s_, a))
    root, has_root, ok = bracketed_root(lambda s_, a: -slope(s_, a), lo, hi, args, settings)
    at_root = sign * e(root, args)
    better = has_root & (at_root > sign * values[j])
    return jnp.where(better, at_root, sign * values[j]), jnp.where(better, root, s[j]), ok


def error_extrema(e, w_max, args, cells: int, settings: SolverSettings):
    """(over, under, w_over, w_under, ok) of e(s, args) for s in [0, log(1 + w_max)].

    e is a function of s = log(1 + w) (scalar) and args. over = max(e, 0), under = max(-e, 0).
    """
    s = jnp.linspace(0.0, jnp.log1p(w_max), cells + 1)
    values = jax.vmap(e, (0, None))(s, args)
    over, s_over, ok1 = _refine(e, s, values, jnp.argmax(values), 1.0, args, settings)
    under, s_under, ok2 = _refine(e, s, values, jnp.argmin(values), -1.0, args, settings)
    return (jnp.maximum(over, 0.0), jnp.maximum(under, 0.0), jnp.expm1(s_over), jnp.expm1(s_under),
            ok1 & ok2)


def lobe_errors(lobe, n, level, cells: int, settings: SolverSettings):
    """d (relative error in the zone {cos^n >= level}) and D (absolute error on [0, pi/2]) of a lobe.

    lobe(u, n) is any lobe; scalar n. Returns dict(d, D, d_w, D_w, ok) with w = n u where attained.
    """
    def relative(s, n_):
        u = jnp.expm1(s) / n_
        return lobe(u, n_) / (1.0 - u) ** n_ - 1.0

    def absolute(s, n_):
        u = jnp.minimum(jnp.expm1(s) / n_, 1.0)   # s = log(1 + n) may round to u just above 1
        return lobe(u, n_) - (1.0 - u) ** n_

    w_zone = -n * jnp.expm1(jnp.log(level) / n)
    d_over, d_under, d_w_over, d_w_under, ok_d = error_extrema(relative, w_zone, n, cells, settings)
    D_over, D_under, D_w_over, D_w_under, ok_D = error_extrema(absolute, n, n, cells, settings)
    return dict(d=jnp.maximum(d_over, d_under), D=jnp.maximum(D_over, D_under),
                d_w=jnp.where(d_over >= d_under, d_w_over, d_w_under),
                D_w=jnp.where(D_over >= D_under, D_w_over, D_w_under), ok=ok_d & ok_D)


@functools.partial(jax.jit, static_argnames=("cells", "settings"))
def _error_curves(shape_index, n, p, level, cells: int, settings: SolverSettings, power):
    return jax.vmap(lambda n_, p_: lobe_errors(lambda u, _: lobe_of_shape(shape_index, u, p_, power), n_, level,
                                               cells, settings))(n, p)


def error_curves(shape: str, n, p, level, cells: int, settings: SolverSettings, power: int = 2):
    """`lobe_errors` of the lobe `SHAPES[shape](u, p, power)` for every n of the array n (p per n):
    one compiled program for every shape (per power of the family)."""
    return _error_curves(SHAPE_NAMES.index(shape), n, p, level, cells, settings, np.float64(power))
