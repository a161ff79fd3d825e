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

Each program goes to scipy's own build of HiGHS (`scipy.optimize._highspy._core`, scipy pinned) with
the options `linprog(method="highs")` passes it (`solve`): linprog's checks of its options took three
quarters of the time of these small programs (measured: 10,266 programs of a visibility run, 22 s in
linprog, 6.5 s in HiGHS); the tests hold `solve` to linprog's solutions bit for bit.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize._highspy import _core as highs_core

HIGHS = dict(primal_feasibility_tolerance=1e-10, dual_feasibility_tolerance=1e-10)


def _options():
    """The options `linprog(method="highs", options=HIGHS)` sets (scipy 1.17: presolve on, no output,
    the dual simplex, HIGHS's tolerances)."""
    options = highs_core.HighsOptions()
    options.presolve = "on"
    options.highs_debug_level = 0
    options.log_to_console = False
    options.output_flag = False
    options.simplex_strategy = int(highs_core.simplex_constants.SimplexStrategy.kSimplexStrategyDual)
    for key, value in HIGHS.items():
        setattr(options, key, value)
    return options


OPTIONS = _options()


def solve(c, A, b, lower, upper) -> np.ndarray | None:
    """x minimizing c x subject to A x <= b (A dense) and lower <= x <= upper (inf: none), as
    `linprog(c, A_ub=A, b_ub=b, bounds=..., method="highs", options=HIGHS)` finds it; None where HiGHS
    finds no optimum."""
    infinite = highs_core.kHighsInf
    rows, columns = A.shape
    lp = highs_core.HighsLp()
    lp.num_col_, lp.num_row_ = columns, rows
    matrix = lp.a_matrix_
    matrix.num_col_, matrix.num_row_ = columns, rows
    matrix.format_ = highs_core.MatrixFormat.kColwise
    by_column = np.ascontiguousarray(A.T)
    nonzero = by_column != 0
    matrix.start_ = np.r_[0, np.cumsum(nonzero.sum(axis=1))].astype(np.int32)
    matrix.index_ = np.nonzero(nonzero)[1].astype(np.int32)
    matrix.value_ = by_column[nonzero]
    lp.col_cost_ = np.asarray(c, dtype=np.float64)
    lp.col_lower_ = np.clip(np.asarray(lower, dtype=np.float64), -infinite, infinite)      # (inf: HiGHS's)
    lp.col_upper_ = np.clip(np.asarray(upper, dtype=np.float64), -infinite, infinite)
    lp.row_lower_ = np.full(rows, -infinite)
    lp.row_upper_ = np.clip(np.asarray(b, dtype=np.float64), -infinite, infinite)
    highs = highs_core._Highs()
    if (highs.passOptions(OPTIONS) == highs_core.HighsStatus.kError
            or highs.passModel(lp) == highs_core.HighsStatus.kError
            or highs.run() == highs_core.HighsStatus.kError
            or highs.getModelStatus() != highs_core.HighsModelStatus.kOptimal):
        return None
    return np.array(highs.getSolution().col_value)
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
    lower = np.r_[-np.asarray(radius, dtype=np.float64)[:k], 0.0]
    upper = np.r_[np.asarray(radius, dtype=np.float64)[:k], np.inf]
    while True:
        size = work.size
        A = np.block([[J[work], -np.ones((size, 1))], [-J[work], -np.ones((size, 1))]])
        b = np.concatenate([-r[work], r[work]])
        x = solve(objective, A, b, lower, upper)
        if x is None:
            return None
        d, t = x[:k], x[k]
        excess = np.abs(r + J @ d) - t
        excess[work] = 0.0              # (rows of the set: satisfied to HiGHS's tolerance)
        violated = np.flatnonzero(excess > 0.0)
        if violated.size == 0:
            return float(t), d
        work = np.r_[work, violated[np.argsort(-excess[violated], kind="stable")[:first]]]
