"""Linear coefficient (Fig. 4): k_Q(n) (of the run's power m) replaced by slope * n + intercept.

The fits ("least_squares", the paper's, or "minimax") are `pipeline.stages.family.fit_line`. This stage also fixes the constants the later stages use: the paper's rounded ones or this fit.
"""

from ..optics.numerics import jax
import numpy as np

from ..optics.lobes import k_Q
from ..optics.roots import SolverSettings
from .common import n_range
from .family import asymptote, fit_line


def run(config, inputs, memo):
    n = n_range(config)
    Q = inputs["q_choice.Q_used"]
    power = config["lobe.power"]
    k = np.asarray(jax.jit(k_Q, static_argnames="power")(n, Q, power=power))
    slope, intercept = fit_line(n, k, config["derivation.fit"], SolverSettings.from_config(config))
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
