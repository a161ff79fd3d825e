"""The lobe as a microfacet normal distribution D(h), beside the distributions engines ship.

Used as the D of a Cook-Torrance BRDF, f = D(h) G F / (4 (n.l)(n.v)), a lobe of t = n.h is
normalized by the projected-area condition int D(h) (n.h) dw_h = 1 over the hemisphere. For the
family (k (t - 1) + 1)^m this is the integral of the Phong form, so the NDF coef is the exact
Phong-form coef, ((m + 1)(m + 2) k^2) / (2 pi ((m + 2) k - 1)) for k >= 1, not the Blinn-form one
(about 4x smaller); for cos^n it is (n + 2) / (2 pi). A Blinn-Phong exponent n maps to Beckmann's
roughness by alpha = sqrt(2 / (n + 2)) (Walter et al. 2007), at which the two distributions agree
at the peak: D(1) = 1 / (pi alpha^2) = (n + 2) / (2 pi).

Everything here is numpy, on arrays of t = cos(theta_h) (or angles theta_h).
"""

from __future__ import annotations

import numpy as np


def alpha_of_n(n):
    """Beckmann's roughness matched to a Blinn-Phong exponent: sqrt(2 / (n + 2))."""
    return np.sqrt(2.0 / (np.asarray(n, dtype=np.float64) + 2.0))


def beckmann(t, alpha):
    """Beckmann's D at t = n.h: exp(-tan^2 / alpha^2) / (pi alpha^2 t^4); 0 for t <= 0."""
    t = np.asarray(t, dtype=np.float64)
    safe = np.where(t > 0.0, t, 1.0)
    tan2 = (1.0 - safe * safe) / (safe * safe)
    return np.where(t > 0.0, np.exp(-tan2 / (alpha * alpha)) / (np.pi * alpha * alpha * safe ** 4), 0.0)


def ggx(t, alpha):
    """GGX (Trowbridge-Reitz) D at t = n.h: alpha^2 / (pi (t^2 (alpha^2 - 1) + 1)^2); 0 for t <= 0."""
    t = np.asarray(t, dtype=np.float64)
    a2 = alpha * alpha
    d = t * t * (a2 - 1.0) + 1.0
    return np.where(t > 0.0, a2 / (np.pi * d * d), 0.0)


def smith_g1_beckmann(cos_v, alpha):
    """Smith's shadowing term of the Beckmann distribution for a direction at cos_v to the normal,
    by Walter et al.'s rational approximation (the one Mitsuba 3 uses)."""
    cos_v = np.clip(np.asarray(cos_v, dtype=np.float64), 1e-12, 1.0)
    tan = np.sqrt(np.maximum(1.0 - cos_v * cos_v, 0.0)) / cos_v
    a = 1.0 / np.maximum(alpha * tan, 1e-12)
    low = np.minimum(a, 1.6)            # past 1.6 the approximation is 1
    g = (3.535 * low + 2.181 * low * low) / (1.0 + 2.276 * low + 2.577 * low * low)
    return np.where(a >= 1.6, 1.0, g)


def projected_area(D, alpha, points: int = 4001) -> np.ndarray:
    """int D(h) (n.h) dw_h over the hemisphere, per alpha, for D(t, i) a function of t = cos(theta_h)
    (arrays) and the index i of the alpha; by Simpson's rule on theta_h in [0, min(pi/2, 12 alpha)]
    (Beckmann's D is below exp(-144) of its peak past 12 alpha): about 5e-12 for cos^n and
    Beckmann, 1e-8 for the clamped family (its zero crossing falls inside a cell)."""
    from scipy.integrate import simpson

    alpha = np.atleast_1d(np.asarray(alpha, dtype=np.float64))
    top = np.minimum(0.5 * np.pi, 12.0 * alpha)
    theta = np.linspace(0.0, 1.0, points)[None, :] * top[:, None]
    t = np.cos(theta)
    integrand = D(t) * t * np.sin(theta) * 2.0 * np.pi
    return simpson(integrand, x=theta, axis=1)


def errors_against_beckmann(candidate, n, alpha, level, points: int = 4001):
    """(d, D) per n of a normalized NDF `candidate(t)` (arrays over n x points) against Beckmann at
    alpha (per n): d, the largest relative error where Beckmann's D is at least `level` of its
    peak; D, the largest absolute error over theta_h in [0, pi/2], as a fraction of Beckmann's peak
    1 / (pi alpha^2). On a grid of `points` angles per n, scaled to alpha (up to 12 alpha or
    pi/2), where the grid resolves Beckmann's width with hundreds of points."""
    return errors_against_beckmann_of_each([candidate], n, alpha, level, points)[0]


def errors_against_beckmann_of_each(candidates, n, alpha, level, points: int = 4001) -> list:
    """`errors_against_beckmann` of each of `candidates`, [(d, D), ...]: Beckmann's D on the grid and
    the zone's edge are computed once for all of them."""
    n = np.asarray(n, dtype=np.float64)
    top = np.minimum(0.5 * np.pi, 12.0 * alpha)
    theta = np.linspace(0.0, 1.0, points)[None, :] * top[:, None]
    t = np.cos(theta)
    reference = beckmann(t, alpha[:, None])
    peak = 1.0 / (np.pi * alpha * alpha)
    zone = reference >= level * peak[:, None]
    # The zone's edge itself (a relative error is often largest there): bisection in the grid cell
    # where Beckmann's D falls below the level (it falls monotonically in theta).
    last = zone.sum(axis=1) - 1
    rows = np.arange(len(n))
    lo, hi = theta[rows, last], theta[rows, np.minimum(last + 1, points - 1)]
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        inside = beckmann(np.cos(mid), alpha) >= level * peak
        lo, hi = np.where(inside, mid, lo), np.where(inside, hi, mid)
    t_edge = np.cos(lo)[:, None]
    reference_edge = beckmann(t_edge[:, 0], alpha)
    safe_reference = np.where(zone, reference, 1.0)
    out = []
    for candidate in candidates:
        value = candidate(t)
        relative = np.where(zone, np.abs(value / safe_reference - 1.0), 0.0)
        absolute = np.abs(value - reference) / peak[:, None]
        edge = np.abs(candidate(np.broadcast_to(t_edge, (len(n), points)))[:, 0] / reference_edge - 1.0)
        out.append((np.maximum(relative.max(axis=1), edge), absolute.max(axis=1)))
    return out
