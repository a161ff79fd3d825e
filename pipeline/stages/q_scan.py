"""Q scan (Figs. 2, 3): max d and max D of f_Q over n versus Q; the best Q on the paper's grids
(coarse, then refined) and the continuous optimum of the chosen metric.

The continuous optimum of a minimax metric (d or D) is where its largest over-estimate and its
largest under-estimate (each maximized over n) are equal: there the maximum stops falling and
starts rising. It is found by bisection on over(Q) - under(Q). For the RMS metric it is the root
of d/dQ of max_n rms (by `jax.grad`).
"""

import jax
import jax.numpy as jnp
import numpy as np

from ..lobes import k_2, k_Q
from ..roots import SolverError, SolverSettings, bracketed_root
from .common import RANGE_KEYS, lobe_measures, n_range, require_converged

READS = RANGE_KEYS + ("derivation.Q", "derivation.metric", "scan.*", "solver.*")
UPSTREAM = ("zone",)

# Objective of each metric and the residual whose root is its continuous optimum.
OBJECTIVE = {"relative_epicenter": "d", "absolute": "D", "rms": "rms"}
_PAD = 32


def _maxima(measures):
    return {name: jnp.max(measures[name]) for name in
            ("d", "d_over", "d_under", "D", "D_over", "D_under", "rms")} | {"ok": jnp.all(measures["ok"])}


def _make_scan(n, level, settings):
    def per_q(Q):
        return _maxima(lobe_measures(n, k_Q(n, Q), level, settings))

    batched = jax.jit(jax.vmap(per_q))

    def scan(Qs):
        # Pad to a multiple of _PAD so that grids of similar size share one compiled function.
        Qs = np.asarray(Qs, dtype=np.float64)
        size = -(-len(Qs) // _PAD) * _PAD
        padded = np.concatenate([Qs, np.full(size - len(Qs), Qs[-1])])
        out = {k: np.asarray(v)[: len(Qs)] for k, v in batched(padded).items()}
        require_converged(out["ok"], "Q scan (max D of f_Q)", Q=Qs)
        return out

    return per_q, scan


def grid(start, stop, step):
    """Q values start, start + step, ... <= stop, rounded to the step's decimals."""
    count = int(np.floor((stop - start) / step + 1e-9)) + 1
    return np.round(start + step * np.arange(count), 12)


def run(config, upstream):
    n = n_range(config)
    level = upstream["zone"]["level"]
    settings = SolverSettings.from_config(config)
    metric = config["derivation.metric"]
    objective = OBJECTIVE[metric]
    per_q, scan = _make_scan(n, level, settings)

    coarse_step, fine_step = config["scan.coarse_step"], config["scan.fine_step"]
    coarse_Q = grid(coarse_step, 1.0 - 1e-9, coarse_step)
    coarse = scan(coarse_Q)
    Q_coarse = float(coarse_Q[np.argmin(coarse[objective])])
    lo = max(Q_coarse - coarse_step, fine_step)
    fine_Q = grid(lo, min(Q_coarse + coarse_step, 1.0 - fine_step), fine_step)
    fine = scan(fine_Q)
    i_best = int(np.argmin(fine[objective]))
    Q_best = float(fine_Q[i_best])

    # Continuous optimum, bracketed by the fine grid's neighbours of its best point.
    bracket = (float(fine_Q[max(i_best - 1, 0)]), float(fine_Q[min(i_best + 1, len(fine_Q) - 1)]))
    if metric == "rms":
        def residual(Q, args):
            return jax.grad(lambda q: per_q(q)["rms"])(Q)
    else:
        part = OBJECTIVE[metric]

        def residual(Q, args):
            m = per_q(Q)
            return m[part + "_over"] - m[part + "_under"]
    Q_opt, has_root, ok = jax.jit(lambda a, b: bracketed_root(residual, a, b, None, settings))(*bracket)
    if not bool(has_root):
        raise SolverError(f"continuous optimum of {metric}: no sign change of its optimality residual "
                          f"on Q in {bracket}; the optimum is not interior to the fine grid")
    if not bool(ok):
        raise SolverError(f"continuous optimum of {metric}: bisection on Q in {bracket} did not converge")
    Q_opt = float(Q_opt)

    choice = config["derivation.Q"]
    Q_used = {"scan": Q_best, "optimize": Q_opt}.get(choice, choice)
    at = scan(np.array([Q_used, Q_opt]))
    curve_Q = np.linspace(0.02, 0.98, config["scan.curve_points"])
    curve = scan(curve_Q)

    # Where f_Q(Q_used) attains its max D: outside the epicenter zone means the blooming zone (P4).
    k_used = k_Q(n, Q_used)
    measures = lobe_measures(n, k_used, level, settings)
    i_D = int(jnp.argmax(measures["D"]))
    u_edge = float(-np.expm1(np.log(level) / float(n[i_D])))
    ref = lobe_measures(n, k_2(n), level, settings)
    require_converged(ref["ok"], "max D of f_2", n=n)
    D_f2 = float(jnp.max(ref["D"]))
    return dict(
        metric=metric, objective=objective,
        coarse_Q=coarse_Q, coarse_objective=coarse[objective], Q_scan_coarse=Q_coarse,
        fine_Q=fine_Q, fine_objective=fine[objective], Q_scan_best=Q_best,
        Q_continuous_best=Q_opt, objective_at_continuous=float(at[objective][1]),
        objective_at_scan_best=float(fine[objective][i_best]),
        Q_used=float(Q_used),
        d_fQ_at_Q=float(at["d"][0]), D_fQ_at_Q=float(at["D"][0]), rms_fQ_at_Q=float(at["rms"][0]),
        d_fQ_at_continuous=float(at["d"][1]), D_fQ_at_continuous=float(at["D"][1]),
        D_fQ_n_at_max=float(n[i_D]), D_fQ_x_at_max=float(np.arccos(1.0 - float(measures["D_u"][i_D]))),
        D_fQ_zone_edge_x=float(np.arccos(1.0 - u_edge)),
        D_fQ_in_blooming_zone=bool(float(measures["D_u"][i_D]) > u_edge),
        D_fQ_below_f2=bool(at["D"][0] < D_f2),
        D_fQ_below_f2_in_blooming_zone=bool(at["D"][0] < D_f2 and float(measures["D_u"][i_D]) > u_edge),
        curve_Q=curve_Q, curve_d=curve["d"], curve_D=curve["D"], curve_rms=curve["rms"],
        d_f2=float(jnp.max(ref["d"])), D_f2=D_f2, rms_f2=float(jnp.max(ref["rms"])),
    )
