"""The linear program of one minimax step: minimize t subject to |r + J d| <= t at every point and
|d_j| <= radius_j, the step d of sequential linear programming (`approximate.minimax.slp_points`,
`symbolic.search`'s refit) in the constants of a form whose residuals r and Jacobian J are taken at
the current constants.

A minimax solution is fixed by a few active points (the extrema of the error; Remez's exchange in
one variable), so the program is solved on a working set: the points of the largest |r| first,
then the points whose rows the solution violates most (as many again), solved again until none is. A relaxation whose
optimum is feasible for every point is the whole program's optimum; each round costs a program of
a few dozen rows where the whole one has thousands. HiGHS's feasibility tolerances are 1e-10 (its
default 1e-7 is absolute: the optimum's level would differ between row sets in the eighth digit).
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import linprog

HIGHS = dict(primal_feasibility_tolerance=1e-10, dual_feasibility_tolerance=1e-10)
WORKING = 4         # points per unknown (the constants and t) in the first working set


def linear_minimax(J, r, radius) -> tuple[float, np.ndarray] | None:
    """(t, d) minimizing t subject to |r + J d| <= t at every point (J: (points, constants), r:
    (points,)) and |d_j| <= radius_j, on a growing working set (module docstring); None where HiGHS
    finds no solution."""
    J = np.asarray(J, dtype=np.float64)
    r = np.asarray(r, dtype=np.float64)
    k = J.shape[1]
    first = WORKING * (k + 1)
    work = np.argsort(-np.abs(r), kind="stable")[:first]
    objective = np.r_[np.zeros(k), 1.0]
    bounds = [(-radius[j], radius[j]) for j in range(k)] + [(0, None)]
    while True:
        size = work.size
        A = np.block([[J[work], -np.ones((size, 1))], [-J[work], -np.ones((size, 1))]])
        b = np.concatenate([-r[work], r[work]])
        lp = linprog(objective, A_ub=A, b_ub=b, bounds=bounds, method="highs", options=HIGHS)
        if lp.status != 0:
            return None
        d, t = lp.x[:k], lp.x[k]
        excess = np.abs(r + J @ d) - t
        excess[work] = 0.0              # (rows of the set: satisfied to HiGHS's tolerance)
        violated = np.flatnonzero(excess > 0.0)
        if violated.size == 0:
            return float(t), d
        work = np.r_[work, violated[np.argsort(-excess[violated], kind="stable")[:first]]]
