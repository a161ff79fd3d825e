"""The regression sample (the paper's newenergy.txt): 50 exponents n whose y(n) the symbolic
regression fits. The paper does not list them; the design here takes every n from n_min to
sample.consecutive_to, then sample.spread_count values evenly spaced up to n_max (docs/choices.md: chosen so
that the sample's mean and spread match TuringBot's size-1 row).
"""

import numpy as np

from .common import sample_exponents


def run(config, inputs, memo):
    sample = sample_exponents(config)
    return dict(sample_n=sample.astype(np.float64), sample_size=int(len(sample)))
