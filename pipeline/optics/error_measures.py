"""Error measures of a quadratic lobe (1 - k u)^2 against the reference cos^n, with exact extrema.

With u = 1 - cos x in [0, 1] (x in [0, pi/2]):

- d, the relative error |f - f_b| / f_b, is measured in the epicenter zone {f_b >= L}, i.e.
  u <= u_L = 1 - L^(1/n). f/f_b has exactly one stationary point, in closed form
  u* = (n - 2k) / (k (n - 2)), so its extrema are at u*, at u_L, or at u = 0 (where it is 0).
- D, the absolute error |f - f_b|, is measured over the whole of [0, 1]. Its derivative in u,
  n (1 - u)^(n-1) - 2k (1 - k u), is convex, so it has at most two roots, one on each side of its
  minimum u_m = 1 - (2k^2 / (n (n - 1)))^(1 / (n - 2)) (closed form). Each root is found by
  bisection on its own bracket; past the lobe's zero u = 1/k, |f - f_b| = f_b only decreases.
- rms, the relative RMS error over the lobe sqrt(int (f - f_b)^2 du / int f_b^2 du), in closed
  form (the integrands are polynomials in 1 - u times powers of 1 - u).

Each measure is returned as its signed parts (over, under) >= 0: the largest over-estimate and
the largest under-estimate. The measure is max(over, under); a Q that balances the two parts is
where a minimax objective has its optimum.
"""

from __future__ import annotations

import jax.numpy as jnp

from .lobes import f_b_u, quadratic_u
from .roots import SolverSettings, bracketed_root


def zone_u(n, level):
    """Edge of the epicenter zone {cos^n x >= level} in u = 1 - cos x: 1 - level^(1/n)."""
    return -jnp.expm1(jnp.log(level) / n)


def relative_error_u(u, n, k):
    """Signed relative error f / f_b - 1 of the clamped quadratic lobe."""
    return quadratic_u(u, k) / f_b_u(u, n) - 1.0


def relative_stationary_u(n, k):
    """Closed-form stationary point u* of f / f_b; meaningful for n > 2 only."""
    return (n - 2.0 * k) / (k * jnp.maximum(n - 2.0, 1e-300))


def relative_parts(n, k, level):
    """(over, under, u_over, u_under) of the relative error on the epicenter zone [0, u_L]."""
    u_L = zone_u(n, level)
    u_s = relative_stationary_u(n, k)
    inside = (n > 2.0) & (u_s > 0.0) & (u_s < u_L) & (k * u_s < 1.0)
    u_s = jnp.where(inside, u_s, 0.0)
    r_s = relative_error_u(u_s, n, k)
    r_L = relative_error_u(u_L, n, k)
    over = jnp.maximum(jnp.maximum(r_s, r_L), 0.0)
    under = jnp.maximum(jnp.maximum(-r_s, -r_L), 0.0)
    u_over = jnp.where(r_s >= r_L, u_s, u_L)
    u_under = jnp.where(-r_s >= -r_L, u_s, u_L)
    return over, under, u_over, u_under


def absolute_error_u(u, n, k):
    """Signed absolute error f - f_b of the clamped quadratic lobe."""
    return quadratic_u(u, k) - f_b_u(u, n)


def _scaled_slope(w, args):
    # d(f - f_b)/du divided by n, in the scaled variable w = n u: both the bracket and the values
    # are O(1) for every n, so one absolute tolerance serves the whole range.
    n, k = args
    u = w / n
    return (1.0 - u) ** (n - 1.0) - (2.0 * k / n) * jnp.maximum(1.0 - k * u, 0.0)


def absolute_parts(n, k, settings: SolverSettings):
    """(over, under, u_over, u_under, ok) of the absolute error over u in [0, 1]; scalar n, k."""
    c = jnp.minimum(1.0 / k, 1.0)
    ratio = 2.0 * k * k / (n * jnp.maximum(n - 1.0, 1.0))
    u_m = jnp.where(n > 2.0, 1.0 - ratio ** (1.0 / jnp.maximum(n - 2.0, 1e-300)), c)
    u_m = jnp.clip(u_m, 0.0, c)
    w1, _, ok1 = bracketed_root(_scaled_slope, jnp.zeros_like(n), n * u_m, (n, k), settings)
    w2, _, ok2 = bracketed_root(_scaled_slope, n * u_m, n * c, (n, k), settings)
    u = jnp.stack([w1 / n, w2 / n, c, jnp.ones_like(c)])
    h = absolute_error_u(u, n, k)
    over = jnp.maximum(jnp.max(h, axis=0), 0.0)
    under = jnp.maximum(jnp.max(-h, axis=0), 0.0)
    u_over, u_under = u[jnp.argmax(h)], u[jnp.argmax(-h)]
    return over, under, u_over, u_under, ok1 & ok2


def _power_moment(a, b, m, v0):
    """int_{v0}^{1} (a + b v)^2 v^m dv, exactly."""
    # v0 = 0 (lobe reaching the horizon) must not give 0 * log(0) = NaN in gradients.
    safe = jnp.where(v0 > 0.0, v0, 1.0)

    def mono(p):
        return (1.0 - jnp.where(v0 > 0.0, safe ** (p + 1.0), 0.0)) / (p + 1.0)
    return a * a * mono(m) + 2.0 * a * b * mono(m + 1.0) + b * b * mono(m + 2.0)


def rms_relative(n, k):
    """sqrt(int_0^1 (f - f_b)^2 du / int_0^1 f_b^2 du), in closed form (v = 1 - u)."""
    # On the lobe, 1 - k u = (1 - k) + k v with v = 1 - u; the lobe lives on v in [1 - c, 1].
    c = jnp.minimum(1.0 / k, 1.0)
    v0 = 1.0 - c
    a, b = 1.0 - k, k
    ff = (1.0 - (1.0 - k * c) ** 5) / (5.0 * k)          # int_0^c (1 - k u)^4 du
    fb = 1.0 / (2.0 * n + 1.0)                            # int_0^1 (1 - u)^(2n) du
    cross = _power_moment(a, b, n, v0)                    # int_0^c (1 - k u)^2 (1 - u)^n du
    ratio = (ff - 2.0 * cross + fb) / fb
    # Where the lobe is exact (n = 2, k = 1) the ratio is 0; keep sqrt's gradient finite there.
    positive = ratio > 0.0
    return jnp.where(positive, jnp.sqrt(jnp.where(positive, ratio, 1.0)), 0.0)
