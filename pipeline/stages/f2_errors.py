"""The baseline (Fig. 6, P9, P10): max d and max D of the original cosine-quadratic lobe
f_2 = ((n/2)(cos x - 1) + 1)^2 over n, and how its max d moves with the zone's level. It depends
on neither Q nor the line, so a refit that changes those keeps it (and its checks).
"""

import numpy as np

from ..optics.lobes import k_2
from ..optics.roots import SolverSettings
from .common import measures, n_range, require_converged


def quadratic_errors(n, k, level, levels, rtol, atol, max_steps):
    """Measures of the quadratic lobe with coefficients k over n: curves of d, D and rms, where D
    is attained (u), and max d at each zone level of `levels`."""
    settings = SolverSettings(rtol, atol, max_steps)
    m = measures(n, k, level, settings)
    require_converged(m["ok"], "max D", n=n)
    return dict(d=np.asarray(m["d"]), D=np.asarray(m["D"]), rms=np.asarray(m["rms"]), D_u=np.asarray(m["D_u"]),
                zone_d=np.array([float(np.max(measures(n, k, L, settings)["d"])) for L in levels]))


def summary(name, n, m) -> dict:
    """The stage fields of one lobe's measures: maxima, curves and where the maxima are attained."""
    d, D = m["d"], m["D"]
    return {f"d_{name}_curve": d, f"D_{name}_curve": D, f"d_{name}": float(d.max()), f"D_{name}": float(D.max()),
            f"rms_{name}": float(m["rms"].max()), f"d_{name}_n_at_max": float(n[d.argmax()]),
            f"D_{name}_n_at_max": float(n[D.argmax()]),
            f"D_{name}_x_at_max": float(np.arccos(1.0 - m["D_u"][D.argmax()])), f"zone_d_{name}": m["zone_d"]}


def run(config, inputs, memo):
    n = np.asarray(n_range(config))
    level = inputs["zone.level"]
    levels = sorted(set(config["zone.sensitivity_levels"]) | {level})
    m = quadratic_errors(n, np.asarray(k_2(n)), level, levels, config["solver.rtol"], config["solver.atol"],
                         config["solver.max_steps"])
    return summary("f_2", n, m) | dict(zone_levels=np.array(levels))
