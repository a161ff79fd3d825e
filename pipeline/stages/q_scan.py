"""Q scan (Figs. 2, 3): max d and max D of f_Q over n versus Q; the best Q on the paper's grids
(coarse, then refined) and the continuous optimum of the chosen metric, for the run's power m
(`lobe.power`; the paper's m = 2). The search itself is `pipeline.stages.family.best_Q`.
"""

import numpy as np

from ..optics.roots import SolverSettings
from .common import n_range
from .family import OBJECTIVE, best_Q, scan


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
