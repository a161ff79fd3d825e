"""Accuracy of f_Q2 (Figs. 5, 6; f_Qm at the run's power m): max d and max D of f_Q2 and f_Q (at the Q used) over n, the
curves over n, the gain over f_2, where f_Q's max D lies (the paper's P4), the lobes at n = 20,
and how the epicenter figures move with the zone's level.

Each lobe's measures are one memoized call, so a refit that moves only the line keeps f_Q's.
"""

import numpy as np

from ..optics.numerics import jax
from ..optics.lobes import f_b, k_2, k_Q, k_Q2, linear_power
from .common import family_errors, n_range, summary

FIG5_N = 20.0


def run(config, inputs, memo):
    n = np.asarray(n_range(config))
    level = inputs["zone.level"]
    a, b = inputs["linear_coefficient.slope_used"], inputs["linear_coefficient.intercept_used"]
    levels = list(inputs["f2_errors.zone_levels"])
    solver = dict(rtol=config["solver.rtol"], atol=config["solver.atol"], max_steps=config["solver.max_steps"])
    power = config["lobe.power"]
    ks = {"f_Q2": np.asarray(k_Q2(n, a, b)),
          "f_Q": np.asarray(jax.jit(k_Q, static_argnames="power")(n, inputs["q_choice.Q_used"], power=power))}
    m = {name: memo("family_errors", family_errors, n=n, k=k, level=level, levels=levels, power=power, **solver)
         for name, k in ks.items()}
    out = summary("f_Q2", n, m["f_Q2"]) | summary("f_Q", n, m["f_Q"])
    d_f_2, D_f_2 = inputs["f2_errors.d_f_2"], inputs["f2_errors.D_f_2"]
    out["epicenter_gain"] = d_f_2 / out["d_f_Q2"]
    out["zone_gain"] = np.asarray(inputs["f2_errors.zone_d_f_2"]) / out["zone_d_f_Q2"]
    out["absolute_gain"] = D_f_2 / out["D_f_Q2"]

    # Where f_Q attains its max D: outside the epicenter zone means the blooming zone (P4).
    i_D = int(m["f_Q"]["D"].argmax())
    u_edge = float(-np.expm1(np.log(level) / n[i_D]))
    in_blooming = bool(m["f_Q"]["D_u"][i_D] > u_edge)
    below = bool(out["D_f_Q"] < D_f_2)
    out |= dict(D_f_Q_zone_edge_x=float(np.arccos(1.0 - u_edge)), D_f_Q_in_blooming_zone=in_blooming,
                D_f_Q_below_f_2=below, D_f_Q_below_f_2_in_blooming_zone=below and in_blooming)

    # Where f_Q2 ends: its zero crossing t0 = 1 - 1/k, where cos^n is still (1 - 1/k)^n of its peak
    # (0 where k <= 1: the lobe then reaches the horizon); for large n, exp(-1/a).
    k = ks["f_Q2"]
    fraction = np.where(k > 1.0, np.exp(n * np.log1p(-1.0 / np.where(k > 1.0, k, 2.0))), 0.0)
    out |= dict(cutoff_peak_fraction_curve=fraction, cutoff_peak_fraction_at_n_max=float(fraction[-1]),
                cutoff_peak_fraction_limit=float(np.exp(-1.0 / a)))

    x = np.linspace(0.0, np.pi / 2, 721)
    out |= dict(fig5_x=x, fig5_f_b=np.asarray(jax.jit(f_b)(x, FIG5_N)),
                fig5_f_2=np.asarray(jax.jit(linear_power)(x, k_2(FIG5_N))),
                fig5_f_Q2=np.asarray(jax.jit(linear_power, static_argnames="power")(x, k_Q2(FIG5_N, a, b), power=power)),
                fig5_zone_edge_x=float(np.arccos(level ** (1.0 / FIG5_N))))
    return out
