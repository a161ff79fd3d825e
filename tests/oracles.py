"""Independent reference computations (plain numpy / scipy), never the pipeline's own functions."""

import numpy as np


def quadratic_np(u, k):
    base = 1.0 - k * u
    return np.where(base > 0, base**2, 0.0)


def dense_max_errors(n, k, level, points=200_001):
    """(max relative error on the zone, max absolute error on [0, pi/2]) on a dense x grid."""
    # The zone edge itself is on the grid: a maximum at the edge is then found, not stepped over.
    x = np.sort(np.append(np.linspace(0.0, np.pi / 2, points), np.arccos(level ** (1.0 / n))))
    u = 1.0 - np.cos(x)
    fb = (1.0 - u) ** n
    f = quadratic_np(u, k)
    zone = fb >= level * (1 - 1e-12)   # keep the edge point despite rounding in cos and pow
    return float(np.max(np.abs(f[zone] / fb[zone] - 1))), float(np.max(np.abs(f - fb)))


def k_Q_np(n, Q):
    return (np.sqrt(Q) - 1.0) / np.expm1(np.log(Q) / n)
