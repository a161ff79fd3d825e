"""The linear program of one minimax step: minimize t subject to |r + J d| <= t at every point and
|d_j| <= radius_j, the step d of sequential linear programming (`approximate.search.minimax.slp_points`,
`symbolic.search`'s refit) in the constants of a form whose residuals r and Jacobian J are taken at
the current constants.

A minimax solution is fixed by a few active points (the extrema of the error; Remez's exchange in
one variable), so the program is solved on a working set: the points of the largest |r| first,
then the points whose rows the solution violates most (as many again), solved again until none is. A relaxation whose
optimum is feasible for every point is the whole program's optimum; each round costs a program of
a few dozen rows where the whole one has thousands. HiGHS's feasibility tolerances are 1e-10 (its
default 1e-7 is absolute: the optimum's level would differ between row sets in the eighth digit).
A program HiGHS has not solved in `ITERATIONS` simplex iterations has no optimum (the step is not
taken): the programs of a few dozen rows take tens of iterations, but the dual simplex can cycle on
a degenerate one (seen on a rational fitted to a linear function, whose fit is exact for a line of
constants, on a short interval); a count, not seconds, so that every machine stops at the same step.

Each program goes to scipy's own build of HiGHS (`scipy.optimize._highspy._core`, scipy pinned) with
the options `linprog(method="highs")` passes it (`solve`): linprog's checks of its options took three
quarters of the time of these small programs (measured: 10,266 programs of a visibility run, 22 s in
linprog, 6.5 s in HiGHS); the tests hold `solve` to linprog's solutions bit for bit. The first
round is `solve`'s program; each later round adds the new points' rows to the program HiGHS holds
and solves again from the last optimum's basis (the dual simplex's warm start, the cutting-plane
method's usual step): measured on 1,455 steps of a visibility run, 1.2 s where solving each round
afresh took 2.7 to 3.0 s, the same level to 1e-14 relative in 99 % of them (at most 4e-5 on a
degenerate one: HiGHS's tolerances).
"""

from __future__ import annotations

import numpy as np
from scipy.optimize._highspy import _core as highs_core

HIGHS = dict(primal_feasibility_tolerance=1e-10, dual_feasibility_tolerance=1e-10)
ITERATIONS = 20_000         # simplex iterations a program may take (linprog's `maxiter`): then no step


def _options():
    """The options `linprog(method="highs", options=HIGHS | dict(maxiter=ITERATIONS))` sets (scipy
    1.17: presolve on, no output, the dual simplex, HIGHS's tolerances, the iteration limit)."""
    options = highs_core.HighsOptions()
    options.presolve = "on"
    options.highs_debug_level = 0
    options.log_to_console = False
    options.output_flag = False
    options.simplex_strategy = int(highs_core.simplex_constants.SimplexStrategy.kSimplexStrategyDual)
    for key, value in HIGHS.items():
        setattr(options, key, value)
    options.simplex_iteration_limit = ITERATIONS
    return options


OPTIONS = _options()


def solve(c, A, b, lower, upper) -> np.ndarray | None:
    """x minimizing c x subject to A x <= b (A dense) and lower <= x <= upper (inf: none), as
    `linprog(c, A_ub=A, b_ub=b, bounds=..., method="highs", options=HIGHS)` finds it; None where HiGHS
    finds no optimum."""
    return _optimum(_program(c, A, b, lower, upper))


def _program(c, A, b, lower, upper):
    """HiGHS holding the program `solve` solves, with linprog's options, not yet run."""
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
            or highs.passModel(lp) == highs_core.HighsStatus.kError):
        return None
    return highs


def _optimum(highs) -> np.ndarray | None:
    """The optimum of the program `highs` holds (run from its current basis, if any), or None."""
    if (highs is None or highs.run() == highs_core.HighsStatus.kError
            or highs.getModelStatus() != highs_core.HighsModelStatus.kOptimal):
        return None
    return np.array(highs.getSolution().col_value)


def _rows(J, r, points):
    """The two rows |r + J d| <= t of each of `points`: (A, b) of A (d, t) <= b."""
    ones = np.ones((points.size, 1))
    return np.block([[J[points], -ones], [-J[points], -ones]]), np.concatenate([-r[points], r[points]])


def _add_rows(highs, A, b) -> bool:
    """Rows A x <= b added to the program `highs` holds (its basis kept); False where HiGHS refuses."""
    nonzero = A != 0
    starts = np.r_[0, np.cumsum(nonzero.sum(axis=1))[:-1]].astype(np.int32)
    status = highs.addRows(A.shape[0], np.full(A.shape[0], -highs_core.kHighsInf),
                           np.clip(b, -highs_core.kHighsInf, highs_core.kHighsInf), int(nonzero.sum()), starts,
                           np.nonzero(nonzero)[1].astype(np.int32), A[nonzero])
    return status != highs_core.HighsStatus.kError


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
    highs = _program(objective, *_rows(J, r, work), lower, upper)
    while True:
        x = _optimum(highs)
        if x is None:
            return None
        d, t = x[:k], x[k]
        excess = np.abs(r + J @ d) - t
        excess[work] = 0.0              # (rows of the set: satisfied to HiGHS's tolerance)
        violated = np.flatnonzero(excess > 0.0)
        if violated.size == 0:
            return float(t), d
        new = violated[np.argsort(-excess[violated], kind="stable")[:first]]
        if not _add_rows(highs, *_rows(J, r, new)):
            return None
        work = np.r_[work, new]
