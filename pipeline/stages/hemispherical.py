"""Hemispherical check (Fig. 11): deviation of coef(n) 2 pi Int(n) from 1 over n, where coef(n) is
the paper's 0.214 (0.807 + n) or this run's own two-term fit.
"""

import numpy as np

from .common import RANGE_KEYS

READS = RANGE_KEYS + ("derivation.constants", "paper_model.coef_scale", "paper_model.coef_offset")
UPSTREAM = ("energy_dataset", "sparse_regression")


def run(config, upstream):
    data, reg = upstream["energy_dataset"], upstream["sparse_regression"]
    if config["derivation.constants"] == "paper":
        scale, offset = config["paper_model.coef_scale"], config["paper_model.coef_offset"]
    else:
        scale, offset = reg["coef_scale"], reg["coef_offset"]
    n = data["n"]
    deviation = scale * (offset + n) * 2.0 * np.pi * data["Int"] - 1.0
    i = int(np.argmax(np.abs(deviation)))
    return dict(n=n, deviation=deviation, coef_scale_used=scale, coef_offset_used=offset,
                hemi_max_abs_dev=float(abs(deviation[i])), hemi_n_at_max=float(n[i]),
                hemi_max_excess=float(np.max(deviation)))
