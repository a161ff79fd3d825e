"""The baseline (Fig. 6, P9, P10): max d and max D of the original cosine-quadratic lobe
f_2 = ((n/2)(cos x - 1) + 1)^2 over n, and how its max d moves with the zone's level. It depends
on neither Q nor the line, so a refit that changes those keeps it (and its checks).
"""

import numpy as np

from ..optics.lobes import k_2
from .common import n_range, family_errors, summary


def run(config, inputs, memo):
    n = np.asarray(n_range(config))
    level = inputs["zone.level"]
    levels = sorted(set(config["zone.sensitivity_levels"]) | {level})
    m = family_errors(n, np.asarray(k_2(n)), level, levels, config["solver.rtol"], config["solver.atol"],
                         config["solver.max_steps"])
    return summary("f_2", n, m) | dict(zone_levels=np.array(levels))
