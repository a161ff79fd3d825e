"""Q scan (Figs. 2, 3): max d and max D of f_Q over n versus Q; the best Q on the paper's grids
(coarse, then refined) and the continuous optimum of the chosen metric, for the run's power m
(`lobe.power`; the paper's m = 2).

The continuous optimum of a minimax metric (d or D) is where its largest over-estimate and its
largest under-estimate (each maximized over n) are equal: there the maximum stops falling and
starts rising. It is found by bisection on over(Q) - under(Q). For the RMS metric it is the root
of d/dQ of max_n rms (by `jax.grad`).

Every grid is evaluated in chunks of `CHUNK` values of Q by one compiled function.
"""

import functools

from ..optics.numerics import jax
import jax.numpy as jnp
import numpy as np

from ..optics.lobes import k_Q
from ..optics.roots import SolverError, SolverSettings, bracketed_root
from .common import lobe_measures, n_range, require_converged

# Objective of each metric: the measure whose max over n it minimizes.
OBJECTIVE = {"relative_epicenter": "d", "absolute": "D", "rms": "rms"}
CHUNK = 32


def _maxima(n, Q, level, settings, power):
    m = lobe_measures(n, k_Q(n, Q, power), level, settings, power)
    return {name: jnp.max(m[name]) for name in
            ("d", "d_over", "d_under", "D", "D_over", "D_under", "rms")} | {"ok": jnp.all(m["ok"])}


@functools.partial(jax.jit, static_argnames=("settings", "power"))
def _chunk(n, Qs, level, settings, power):
    return jax.vmap(lambda Q: _maxima(n, Q, level, settings, power))(Qs)


def scan(n, Qs, level, settings: SolverSettings, power: int = 2) -> dict[str, np.ndarray]:
    """max over n of each measure of f_Q (power m), for every Q of Qs."""
    Qs = np.asarray(Qs, dtype=np.float64)
    size = -(-len(Qs) // CHUNK) * CHUNK
    padded = np.concatenate([Qs, np.full(size - len(Qs), Qs[-1])])
    parts = [_chunk(n, padded[i:i + CHUNK], level, settings, int(power)) for i in range(0, size, CHUNK)]
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


@functools.partial(jax.jit, static_argnames=("metric", "settings", "power"))
def continuous_optimum(n, level, lower, upper, metric: str, settings: SolverSettings, power: int = 2):
    """(Q, has_root, ok): root of the metric's optimality residual on [lower, upper]."""
    return bracketed_root(lambda Q, a: _residual(Q, (a[0], a[1], metric, settings, power)), lower, upper,
                          (n, level), settings)


def grid(start, stop, step):
    """Q values start, start + step, ... <= stop, rounded to the step's decimals."""
    count = int(np.floor((stop - start) / step + 1e-9)) + 1
    return np.round(start + step * np.arange(count), 12)


def run(config, inputs, memo):
    n = n_range(config)
    level = inputs["zone.level"]
    settings = SolverSettings.from_config(config)
    metric = config["derivation.metric"]
    power = config["lobe.power"]
    optimum = best_Q(n, level, settings, metric, power, config["scan.coarse_step"], config["scan.fine_step"])
    at = scan(n, np.array([optimum["Q_continuous_best"]]), level, settings, power)
    curve_Q = np.linspace(0.02, 0.98, config["scan.curve_points"])
    curve = scan(n, curve_Q, level, settings, power)
    i_min = int(np.argmin(curve["D"]))
    objective = OBJECTIVE[metric]
    return dict(
        optimum, objective_at_continuous=float(at[objective][0]),
        d_f_Q_at_continuous=float(at["d"][0]), D_f_Q_at_continuous=float(at["D"][0]),
        curve_Q=curve_Q, curve_d=curve["d"], curve_D=curve["D"], curve_rms=curve["rms"],
        curve_D_min=float(curve["D"][i_min]), curve_Q_at_D_min=float(curve_Q[i_min]),
        curve_d_at_D_min=float(curve["d"][i_min]),
    )


def best_Q(n, level, settings: SolverSettings, metric: str, power: int, coarse_step: float, fine_step: float) -> dict:
    """The paper's search for Q at power m: the best of a coarse grid, of a fine grid around it,
    and the continuous optimum between the fine grid's neighbours of its best point."""
    objective = OBJECTIVE[metric]
    coarse_Q = grid(coarse_step, 1.0 - 1e-9, coarse_step)
    coarse = scan(n, coarse_Q, level, settings, power)
    Q_coarse = float(coarse_Q[np.argmin(coarse[objective])])
    lo = max(Q_coarse - coarse_step, fine_step)
    fine_Q = grid(lo, min(Q_coarse + coarse_step, 1.0 - fine_step), fine_step)
    fine = scan(n, fine_Q, level, settings, power)
    i_best = int(np.argmin(fine[objective]))
    Q_best = float(fine_Q[i_best])

    # Continuous optimum, bracketed by the fine grid's neighbours of its best point.
    bracket = (float(fine_Q[max(i_best - 1, 0)]), float(fine_Q[min(i_best + 1, len(fine_Q) - 1)]))
    Q_opt, has_root, ok = continuous_optimum(n, level, *bracket, metric, settings, power)
    if not bool(has_root):
        raise SolverError(f"continuous optimum of {metric}: no sign change of its optimality residual "
                          f"on Q in {bracket}; the optimum is not interior to the fine grid")
    if not bool(ok):
        raise SolverError(f"continuous optimum of {metric}: bisection on Q in {bracket} did not converge "
                          f"(solver.max_steps = {settings.max_steps})")
    return dict(coarse_Q=coarse_Q, coarse_objective=coarse[objective], Q_scan_coarse=Q_coarse,
                fine_Q=fine_Q, fine_objective=fine[objective], Q_scan_best=Q_best,
                Q_continuous_best=float(Q_opt), objective_at_scan_best=float(fine[objective][i_best]))
