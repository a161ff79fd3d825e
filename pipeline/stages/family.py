"""The derivation's steps at any power m of the family (k (cos x - 1) + 1)^m, shared by the stages
that run them: the Q scan and its continuous optimum (`q_scan` for the run's power, `power_front`
for each power of the front), and the line k(n) = a n + b through k_Q(n) (`linear_coefficient`,
`power_front`).

The continuous optimum of a minimax metric (d or D) is where its largest over-estimate and its
largest under-estimate (each maximized over n) are equal: there the maximum stops falling and
starts rising. It is found by bisection on over(Q) - under(Q). For the RMS metric it is the root
of d/dQ of max_n rms (by `jax.grad`). Every grid is evaluated in chunks of `CHUNK` values of Q by
one compiled function.

"least_squares" (the paper's linear regression) minimizes sum_n (slope n + intercept - k_Q(n))^2
over every integer n in range, with optimistix. "minimax" minimizes the worst relative error
max_n |(slope n + intercept) / k_Q(n) - 1|, a linear program (scipy's HiGHS).
"""

import functools

from ..optics.numerics import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx
from scipy.optimize import linprog

from ..optics.lobes import k_Q
from ..optics.roots import SolverError, SolverSettings, bracketed_root
from .common import lobe_measures, require_converged

# Objective of each metric: the measure whose max over n it minimizes.
OBJECTIVE = {"relative_epicenter": "d", "absolute": "D", "rms": "rms"}
CHUNK = 32


def _maxima(n, Q, level, settings, power):
    m = lobe_measures(n, k_Q(n, Q, power), level, settings, power)
    return {name: jnp.max(m[name]) for name in
            ("d", "d_over", "d_under", "D", "D_over", "D_under", "rms")} | {"ok": jnp.all(m["ok"])}


@functools.partial(jax.jit, static_argnames="settings")
def _chunk(n, Qs, level, settings, power):
    return jax.vmap(lambda Q: _maxima(n, Q, level, settings, power))(Qs)


def scan(n, Qs, level, settings: SolverSettings, power: int = 2) -> dict[str, np.ndarray]:
    """max over n of each measure of f_Q (power m), for every Q of Qs."""
    Qs = np.asarray(Qs, dtype=np.float64)
    size = -(-len(Qs) // CHUNK) * CHUNK
    padded = np.concatenate([Qs, np.full(size - len(Qs), Qs[-1])])
    parts = [_chunk(n, padded[i:i + CHUNK], level, settings, jnp.asarray(float(power))) for i in range(0, size, CHUNK)]
    out = {k: np.concatenate([np.asarray(p[k]) for p in parts])[: len(Qs)] for k in parts[0]}
    require_converged(out["ok"], "Q scan (max D of f_Q)", Q=Qs)
    return out


def _residual(Q, args):
    n, level, metric, settings, power = args
    if metric == "rms":
        return jax.grad(lambda q: _maxima(n, q, level, settings, power)["rms"])(Q)
    m = _maxima(n, Q, level, settings, power)
    part = OBJECTIVE[metric]
    return m[part + "_over"] - m[part + "_under"]


@functools.partial(jax.jit, static_argnames=("metric", "settings"))
def _continuous_optimum(n, level, lower, upper, metric: str, settings: SolverSettings, power):
    return bracketed_root(lambda Q, a: _residual(Q, (a[0], a[1], metric, settings, a[2])), lower, upper,
                          (n, level, power), settings)


def continuous_optimum(n, level, lower, upper, metric: str, settings: SolverSettings, power=2):
    """(Q, has_root, ok): root of the metric's optimality residual on [lower, upper]; one compiled
    program for every power (traced)."""
    return _continuous_optimum(n, level, lower, upper, metric, settings, jnp.asarray(float(power)))


def grid(start, stop, step):
    """Q values start, start + step, ... <= stop, rounded to the step's decimals."""
    count = int(np.floor((stop - start) / step + 1e-9)) + 1
    return np.round(start + step * np.arange(count), 12)


def best_Q(n, level, settings: SolverSettings, metric: str, power: int, coarse_step: float, fine_step: float,
           continuous: bool = True) -> dict:
    """The paper's search for Q at power m: the best of a coarse grid, of a fine grid around it,
    and (if `continuous`) the continuous optimum between the fine grid's neighbours of its best
    point (NaN otherwise)."""
    objective = OBJECTIVE[metric]
    coarse_Q = grid(coarse_step, 1.0 - 1e-9, coarse_step)
    coarse = scan(n, coarse_Q, level, settings, power)
    Q_coarse = float(coarse_Q[np.argmin(coarse[objective])])
    lo = max(Q_coarse - coarse_step, fine_step)
    fine_Q = grid(lo, min(Q_coarse + coarse_step, 1.0 - fine_step), fine_step)
    fine = scan(n, fine_Q, level, settings, power)
    i_best = int(np.argmin(fine[objective]))
    Q_best = float(fine_Q[i_best])

    grids = dict(coarse_Q=coarse_Q, coarse_objective=coarse[objective], Q_scan_coarse=Q_coarse,
                 fine_Q=fine_Q, fine_objective=fine[objective], Q_scan_best=Q_best,
                 objective_at_scan_best=float(fine[objective][i_best]))
    if not continuous:
        return grids | dict(Q_continuous_best=float("nan"))
    # Continuous optimum, bracketed by the fine grid's neighbours of its best point.
    bracket = (float(fine_Q[max(i_best - 1, 0)]), float(fine_Q[min(i_best + 1, len(fine_Q) - 1)]))
    Q_opt, has_root, ok = continuous_optimum(n, level, *bracket, metric, settings, power)
    if not bool(has_root):
        raise SolverError(f"continuous optimum of {metric}: no sign change of its optimality residual "
                          f"on Q in {bracket}; the optimum is not interior to the fine grid")
    if not bool(ok):
        raise SolverError(f"continuous optimum of {metric}: bisection on Q in {bracket} did not converge "
                          f"(solver.max_steps = {settings.max_steps})")
    return grids | dict(Q_continuous_best=float(Q_opt))


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


def fit_line(n, k, fit: str, settings: SolverSettings) -> tuple[float, float]:
    """(slope, intercept) of the line through k_Q(n) by the configured fit."""
    if fit == "least_squares":
        return least_squares_line(n, k, settings.rtol, settings.atol, settings.max_steps)
    return minimax_line(n, k)
