"""Hemispherical check (Fig. 11): deviation of coef(n) 2 pi Int(n) from 1 over n, where coef(n) is
the paper's 0.214 (0.807 + n) or this run's own two-term fit. This stage also fixes the coef(n)
that the later stages use.
"""

import numpy as np

from .common import n_range, runs_of


def run(config, inputs, memo):
    if config["derivation.constants"] == "paper":
        scale, offset = config["paper_model.coef_scale"], config["paper_model.coef_offset"]
    else:
        scale, offset = inputs["sparse_regression.coef_scale"], inputs["sparse_regression.coef_offset"]
    n = n_range(config)
    deviation = scale * (offset + n) * 2.0 * np.pi * inputs["energy_dataset.Int"] - 1.0
    i = int(np.argmax(np.abs(deviation)))
    return dict(deviation=deviation, coef_scale_used=float(scale), coef_offset_used=float(offset),
                hemi_max_abs_dev=float(abs(deviation[i])), hemi_n_at_max=float(n[i]),
                hemi_max_excess=float(np.max(deviation)), hemi_excess_ranges=runs_of(deviation > 0.0, n))
