"""Accuracy of f_Q2 (Figs. 5, 6): max d and max D of f_Q2 and of f_2 over n, the curves over n,
the lobes at n = 20, and how the epicenter figures move with the zone's level.
"""

import jax
import jax.numpy as jnp
import numpy as np

from ..lobes import f_b, k_2, k_Q, k_Q2, quadratic
from ..roots import SolverSettings
from .common import RANGE_KEYS, lobe_measures, n_range, require_converged

READS = RANGE_KEYS + ("zone.sensitivity_levels", "solver.*")
UPSTREAM = ("zone", "q_scan", "linear_coefficient")
FIG5_N = 20.0


def run(config, upstream):
    n = n_range(config)
    settings = SolverSettings.from_config(config)
    level = upstream["zone"]["level"]
    lin = upstream["linear_coefficient"]
    Q = upstream["q_scan"]["Q_used"]
    lobes = {"f_Q2": k_Q2(n, lin["slope_used"], lin["intercept_used"]), "f_2": k_2(n),
             "f_Q": k_Q(n, Q)}
    measure = jax.jit(lambda k, L: lobe_measures(n, k, L, settings))
    out = dict(n=np.asarray(n), slope_used=lin["slope_used"], intercept_used=lin["intercept_used"])
    for name, k in lobes.items():
        m = measure(k, level)
        require_converged(m["ok"], f"max D of {name}", n=n)
        out[f"d_{name}_curve"] = np.asarray(m["d"])
        out[f"D_{name}_curve"] = np.asarray(m["D"])
        out[f"d_{name}"] = float(jnp.max(m["d"]))
        out[f"D_{name}"] = float(jnp.max(m["D"]))
        out[f"rms_{name}"] = float(jnp.max(m["rms"]))
        out[f"d_{name}_n_at_max"] = float(n[jnp.argmax(m["d"])])
        out[f"D_{name}_n_at_max"] = float(n[jnp.argmax(m["D"])])
        out[f"D_{name}_x_at_max"] = float(np.arccos(1.0 - float(m["D_u"][jnp.argmax(m["D"])])))
    out["epicenter_gain"] = out["d_f_2"] / out["d_f_Q2"]
    out["absolute_gain"] = out["D_f_2"] / out["D_f_Q2"]

    levels = sorted(set(config["zone.sensitivity_levels"]) | {level})
    for name, k in lobes.items():
        out[f"zone_d_{name}"] = np.array([float(jnp.max(measure(k, L)["d"])) for L in levels])
    out["zone_levels"] = np.array(levels)

    x = np.linspace(0.0, np.pi / 2, 721)
    out["fig5_x"] = x
    out["fig5_f_b"] = np.asarray(f_b(x, FIG5_N))
    out["fig5_f_2"] = np.asarray(quadratic(x, k_2(FIG5_N)))
    out["fig5_f_Q2"] = np.asarray(quadratic(x, k_Q2(FIG5_N, lin["slope_used"], lin["intercept_used"])))
    out["fig5_zone_edge_x"] = float(np.arccos(level ** (1.0 / FIG5_N)))
    return out
