"""Linear coefficient (Fig. 4): k_Q(n) (of the run's power m) replaced by slope * n + intercept.

"least_squares" (the paper's linear regression) minimizes sum_n (slope n + intercept - k_Q(n))^2
over every integer n in range, with optimistix. "minimax" minimizes the worst relative error
max_n |(slope n + intercept) / k_Q(n) - 1|, a linear program (scipy's HiGHS).
This stage also fixes the constants the later stages use: the paper's rounded ones or this fit.
"""

from ..optics.numerics import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx
from scipy.optimize import linprog

from ..optics.lobes import k_Q
from ..optics.roots import SolverError
from .common import n_range


def _line_residuals(p, args):
    n_scaled, k = args
    return p[0] * n_scaled + p[1] - k


def least_squares_line(n, k, rtol, atol, max_steps):
    """(slope, intercept) minimizing sum (slope n + intercept - k)^2, by Gauss-Newton."""
    scale = float(jnp.max(n))
    # The slope is solved for in units of 1/max(n), so that both unknowns are O(1).
    sol = optx.least_squares(_line_residuals, optx.GaussNewton(rtol=rtol, atol=atol), jnp.zeros(2),
                             args=(n / scale, k), max_steps=max_steps, throw=False)
    if sol.result != optx.RESULTS.successful:
        raise SolverError(f"least-squares line through k_Q(n), n in [{float(n[0]):g}, "
                          f"{float(n[-1]):g}]: {optx.RESULTS[sol.result]}")
    return float(sol.value[0]) / scale, float(sol.value[1])


def minimax_line(n, k):
    """(slope, intercept) minimizing max |(slope n + intercept) / k - 1|, as a linear program."""
    n, k = np.asarray(n), np.asarray(k)
    # Variables (slope, intercept, t); minimize t s.t. -t <= (slope n + intercept)/k - 1 <= t.
    a = np.column_stack([n / k, 1.0 / k])
    A_ub = np.block([[a, -np.ones((len(n), 1))], [-a, -np.ones((len(n), 1))]])
    b_ub = np.concatenate([np.ones(len(n)), -np.ones(len(n))])
    res = linprog(c=[0.0, 0.0, 1.0], A_ub=A_ub, b_ub=b_ub, bounds=[(None, None)] * 3, method="highs")
    if res.status != 0:
        raise SolverError(f"minimax line through k_Q(n), n in [{n[0]:g}, {n[-1]:g}]: {res.message}")
    return float(res.x[0]), float(res.x[1])


def asymptote(Q: float, power: int = 2) -> tuple[float, float]:
    """(slope, intercept) of the large-n line of k_Q(n) = (Q^(1/m) - 1) / (Q^(1/n) - 1):
    (1 - Q^(1/m)) / (-ln Q) and (1 - Q^(1/m)) / 2, from Q^(1/n) - 1 = ln Q / n + (ln Q)^2 / (2 n^2) + ..."""
    drop = float(-np.expm1(np.log(Q) / power))
    return drop / float(-np.log(Q)), drop / 2.0


def run(config, inputs, memo):
    n = n_range(config)
    Q = inputs["q_choice.Q_used"]
    power = config["lobe.power"]
    k = np.asarray(jax.jit(k_Q, static_argnames="power")(n, Q, power=power))
    fit = config["derivation.fit"]
    if fit == "least_squares":
        slope, intercept = least_squares_line(n, k, config["solver.rtol"], config["solver.atol"],
                                              config["solver.max_steps"])
    else:
        slope, intercept = minimax_line(n, k)
    rel = np.asarray((slope * n + intercept) / k - 1.0)
    paper_slope, paper_intercept = config["paper_model.slope"], config["paper_model.intercept"]
    rel_paper = np.asarray((paper_slope * n + paper_intercept) / k - 1.0)
    use_paper = config["derivation.constants"] == "paper"

    # Other fits of the same line, to show where the paper's intercept could come from: ordinary
    # least squares on other sets of n, and least squares of the relative error (weights 1/k^2).
    def ols(ns, weights=None):
        ks = np.asarray(jax.jit(k_Q, static_argnames="power")(ns, Q, power=power))
        w = np.ones_like(ns) if weights is None else weights(ks)
        A = np.column_stack([ns, np.ones_like(ns)]) * np.sqrt(w)[:, None]
        (a, b), *_ = np.linalg.lstsq(A, ks * np.sqrt(w), rcond=None)
        return dict(slope=float(a), intercept=float(b))
    n_max = config["derivation.n_max"]
    variants = [dict(variant=f"every n from 1 to {n_max}", **ols(np.arange(1.0, n_max + 1))),
                dict(variant=f"every n from {n[0]:g} to {min(100, n_max)}", **ols(np.arange(n[0], min(100, n_max) + 1))),
                dict(variant="the regression sample's n", **ols(np.asarray(inputs["sample.sample_n"]))),
                dict(variant="relative error (weights 1/k^2), every n", **ols(n, lambda ks: 1.0 / ks**2))]
    # The intercept that puts the paper's rounded slope exactly on its stated bound at the smallest n.
    intercept_at_bound = float((1.0 - config["paper_model.line_max_rel_error"]) * k[0] - paper_slope * n[0])
    # The large-n asymptote of k_Q(n), a check on the fit: k_Q(n) = n (1 - Q^(1/m)) / (-ln Q)
    # + (1 - Q^(1/m)) / 2 + O(1/n) (at m = 2, 1 - sqrt Q).
    slope_asymptote, intercept_asymptote = asymptote(Q, power)
    return dict(
        k_Q=np.asarray(k), lin_slope=slope, lin_intercept=intercept, lin_max_rel_error=float(np.max(np.abs(rel))),
        lin_rel_error=rel, paper_line_rel_error=rel_paper,
        paper_line_max_rel_error=float(np.max(np.abs(rel_paper))),
        asymptotic_slope=slope_asymptote, asymptotic_intercept=intercept_asymptote,
        slope_minus_asymptote=slope - slope_asymptote,
        intercept_variants=variants, intercept_at_bound=intercept_at_bound,
        slope_used=paper_slope if use_paper else slope,
        intercept_used=paper_intercept if use_paper else intercept,
    )
