"""Independent reference computations (plain numpy / scipy), never the pipeline's own functions."""

import math

import numpy as np
from scipy import integrate


def quadratic_np(u, k, power=2):
    base = 1.0 - k * u
    return np.where(base > 0, np.where(base > 0, base, 0.0) ** power, 0.0)


def dense_max_errors(n, k, level, points=200_001, power=2):
    """(max relative error on the zone, max absolute error on [0, pi/2]) on a dense x grid."""
    # The zone edge itself is on the grid: a maximum at the edge is then found, not stepped over.
    x = np.sort(np.append(np.linspace(0.0, np.pi / 2, points), np.arccos(level ** (1.0 / n))))
    u = 1.0 - np.cos(x)
    fb = (1.0 - u) ** n
    f = quadratic_np(u, k, power)
    zone = fb >= level * (1 - 1e-12)   # keep the edge point despite rounding in cos and pow
    return float(np.max(np.abs(f[zone] / fb[zone] - 1))), float(np.max(np.abs(f - fb)))


def k_Q_np(n, Q):
    return (np.sqrt(Q) - 1.0) / np.expm1(np.log(Q) / n)


def scipy_albedo(form, k, theta_i, coef=1.0, tolerance=1e-12):
    """a(theta_i) of coef (k (t - 1) + 1)^2 by scipy's adaptive 2-D quadrature over the hemisphere, to
    `tolerance` (absolute and relative). The integrand is scalar math (about 15x faster than numpy
    vectors of three), with L in the x-z plane: R = (-L_x, 0, L_z), H = (L + V) / |L + V|."""
    lx, lz = math.sin(theta_i), math.cos(theta_i)

    def f(phi, theta):
        sin_t, cos_t = math.sin(theta), math.cos(theta)
        vx, vy = sin_t * math.cos(phi), sin_t * math.sin(phi)
        if form == "phong":
            t = -lx * vx + lz * cos_t
        else:
            hx, hz = lx + vx, lz + cos_t
            t = hz / math.sqrt(hx * hx + vy * vy + hz * hz)
        base = 1.0 - k * (1.0 - t)
        return coef * (base * base if base > 0 else 0.0) * cos_t * sin_t
    return integrate.dblquad(f, 0, np.pi / 2, 0, 2 * np.pi, epsabs=tolerance, epsrel=tolerance)[0]


def scipy_normal_albedo(lobe, form, n):
    """a(0) per unit coef of `lobe(t)`, a function of t = cos of the lobe's angle, at normal
    incidence, by scipy's adaptive quadrature over the outgoing polar angle theta (the azimuth
    gives 2 pi): t = cos theta for the Phong form (the mirror direction is the normal), t =
    cos(theta / 2) for the Blinn form (the half vector of the normal and the outgoing direction).
    The lobe's width ~1/sqrt(n) is split into pieces so that a narrow lobe is resolved."""
    width = min(np.pi / 2, 40.0 / np.sqrt(n))
    points = np.concatenate([np.linspace(0.0, width, 41)[1:-1], [width]]) if width < np.pi / 2 else None

    def integrand(theta):
        t = np.cos(theta) if form == "phong" else np.cos(theta / 2)
        return 2 * np.pi * lobe(t) * np.cos(theta) * np.sin(theta)

    return integrate.quad(integrand, 0.0, np.pi / 2, points=points, limit=400, epsabs=0.0, epsrel=1e-12)[0]
