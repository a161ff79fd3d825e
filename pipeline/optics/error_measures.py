"""Error measures of a lobe of the family (1 - k u)^m against the reference cos^n, with exact
extrema (m = 2 in the paper; the power is a static int argument).

With u = 1 - cos x in [0, 1] (x in [0, pi/2]):

- d, the relative error |f - f_b| / f_b, is measured in the epicenter zone {f_b >= L}, i.e.
  u <= u_L = 1 - L^(1/n). log(f/f_b) = m log(1 - k u) - n log(1 - u) has exactly one stationary
  point, in closed form u* = (n - m k) / (k (n - m)), so the extrema of f/f_b are at u*, at u_L,
  or at u = 0 (where it is 0).
- D, the absolute error |f - f_b|, is measured over the whole of [0, 1]. Its derivative in u is
  n (1 - u)^(n-1) - m k (1 - k u)^(m-1); the log of the ratio of its two terms,
  (n - 1) log(1 - u) - (m - 1) log(1 - k u) + const, has one stationary point,
  u_c = ((n - 1) - (m - 1) k) / (k (n - m)) (closed form), so the derivative has at most two
  roots, one on each side of u_c. Each root is found by bisection on its own bracket; past the
  lobe's zero u = 1/k, |f - f_b| = f_b only decreases.
- rms, the relative RMS error over the lobe sqrt(int (f - f_b)^2 du / int f_b^2 du): in closed
  form for m = 2 (polynomials in 1 - u times powers of 1 - u); for m > 2 the expanded closed form
  cancels catastrophically (terms of size k^m), so the cross term is integrated by Gauss-Legendre
  quadrature on the lobe's support instead (`RMS_NODES` nodes; the tests compare it with the
  closed form at m = 2 and with a dense grid).

Each measure is returned as its signed parts (over, under) >= 0: the largest over-estimate and
the largest under-estimate. The measure is max(over, under); a Q that balances the two parts is
where a minimax objective has its optimum.
"""

from __future__ import annotations

import jax.numpy as jnp

import numpy as np

from .lobes import f_b_u, linear_power_u
from .roots import SolverSettings, bracketed_root

RMS_NODES = 64


def zone_u(n, level):
    """Edge of the epicenter zone {cos^n x >= level} in u = 1 - cos x: 1 - level^(1/n)."""
    return -jnp.expm1(jnp.log(level) / n)


def relative_error_u(u, n, k, power: int = 2):
    """Signed relative error f / f_b - 1 of the clamped lobe (1 - k u)^m."""
    return linear_power_u(u, k, power) / f_b_u(u, n) - 1.0


def relative_stationary_u(n, k, power: int = 2):
    """Closed-form stationary point u* of f / f_b; meaningful for n != m only (at n = m, f / f_b is
    monotone unless k = 1)."""
    return (n - power * k) / (k * jnp.where(n != power, n - power, 1e-300))


def relative_parts(n, k, level, power: int = 2):
    """(over, under, u_over, u_under) of the relative error on the epicenter zone [0, u_L]."""
    u_L = zone_u(n, level)
    u_s = relative_stationary_u(n, k, power)
    inside = (n != power) & (u_s > 0.0) & (u_s < u_L) & (k * u_s < 1.0)
    u_s = jnp.where(inside, u_s, 0.0)
    r_s = relative_error_u(u_s, n, k, power)
    r_L = relative_error_u(u_L, n, k, power)
    over = jnp.maximum(jnp.maximum(r_s, r_L), 0.0)
    under = jnp.maximum(jnp.maximum(-r_s, -r_L), 0.0)
    u_over = jnp.where(r_s >= r_L, u_s, u_L)
    u_under = jnp.where(-r_s >= -r_L, u_s, u_L)
    return over, under, u_over, u_under


def absolute_error_u(u, n, k, power: int = 2):
    """Signed absolute error f - f_b of the clamped lobe (1 - k u)^m."""
    return linear_power_u(u, k, power) - f_b_u(u, n)


def _scaled_slope(w, args, power: int = 2):
    # -d(f - f_b)/du divided by n, in the scaled variable w = n u: both the bracket and the values
    # are O(1) for every n, so one absolute tolerance serves the whole range.
    n, k = args
    u = w / n
    return (1.0 - u) ** (n - 1.0) - (power * k / n) * jnp.maximum(1.0 - k * u, 0.0) ** (power - 1)


def _slope_of_args(w, args):
    """`_scaled_slope` with the power among the args: one function for every power, so that
    `roots.bracketed_root` reuses its compiled root find (the power traced or a Python int)."""
    n, k, power = args
    return _scaled_slope(w, (n, k), power)


def slope_split_u(n, k, power: int = 2):
    """u_c, the one stationary point of the log-ratio of the two terms of d(f - f_b)/du, clipped
    to the lobe's support [0, min(1/k, 1)]: each side holds at most one root of the slope. At
    n = m the log-ratio is monotone (one root at most), and any split serves."""
    c = jnp.minimum(1.0 / k, 1.0)
    u_c = ((n - 1.0) - (power - 1.0) * k) / (k * jnp.where(n != power, n - power, 1e-300))
    return jnp.clip(jnp.where(n != power, u_c, c), 0.0, c)


def absolute_parts(n, k, settings: SolverSettings, power: int = 2):
    """(over, under, u_over, u_under, ok) of the absolute error over u in [0, 1]; scalar n, k."""
    c = jnp.minimum(1.0 / k, 1.0)
    u_m = slope_split_u(n, k, power)
    w1, _, ok1 = bracketed_root(_slope_of_args, jnp.zeros_like(n), n * u_m, (n, k, power), settings)
    w2, _, ok2 = bracketed_root(_slope_of_args, n * u_m, n * c, (n, k, power), settings)
    u = jnp.stack([w1 / n, w2 / n, c, jnp.ones_like(c)])
    h = absolute_error_u(u, n, k, power)
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


def _cross_quadrature(n, k, c, power):
    """int_0^c (1 - k u)^m (1 - u)^n du by Gauss-Legendre on [0, c] (a smooth integrand)."""
    x, w = np.polynomial.legendre.leggauss(RMS_NODES)
    u = 0.5 * c * (x + 1.0)
    return 0.5 * c * jnp.sum(w * linear_power_u(u, k, power) * (1.0 - u) ** n)


def rms_relative(n, k, power: int = 2):
    """sqrt(int_0^1 (f - f_b)^2 du / int_0^1 f_b^2 du) (v = 1 - u); closed form at m = 2."""
    # On the lobe, 1 - k u = (1 - k) + k v with v = 1 - u; the lobe lives on v in [1 - c, 1].
    c = jnp.minimum(1.0 / k, 1.0)
    v0 = 1.0 - c
    a, b = 1.0 - k, k
    ff = (1.0 - (1.0 - k * c) ** (2 * power + 1)) / ((2 * power + 1) * k)   # int_0^c (1 - k u)^(2m) du
    fb = 1.0 / (2.0 * n + 1.0)                            # int_0^1 (1 - u)^(2n) du
    # int_0^c (1 - k u)^m (1 - u)^n du: closed form at m = 2 (the power may be traced: both are cheap).
    cross = jnp.where(power == 2, _power_moment(a, b, n, v0), _cross_quadrature(n, k, c, power))
    ratio = (ff - 2.0 * cross + fb) / fb
    # Where the lobe is exact (n = 2, k = 1) the ratio is 0; keep sqrt's gradient finite there.
    positive = ratio > 0.0
    return jnp.where(positive, jnp.sqrt(jnp.where(positive, ratio, 1.0)), 0.0)
