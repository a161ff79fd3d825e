"""The regression sample (the paper's newenergy.txt): 50 exponents n whose y(n) the symbolic
regression fits. The paper does not list them; the design here takes every n from n_min to
sample.consecutive_to, then sample.spread_count values evenly spaced up to n_max (README: chosen so
that the sample's mean and spread match TuringBot's size-1 row).
"""

import numpy as np


def sample_exponents(config) -> np.ndarray:
    """The regression sample: n_min..consecutive_to, then spread_count evenly spaced n up to n_max."""
    head = np.arange(config["derivation.n_min"], config["sample.consecutive_to"] + 1)
    tail = np.round(np.linspace(config["sample.spread_from"], config["derivation.n_max"],
                                config["sample.spread_count"]))
    sample = np.unique(np.concatenate([head, tail]).astype(np.int64))
    if len(sample) != len(head) + len(tail):
        raise ValueError(f"sample.spread_count = {config['sample.spread_count']} makes repeated n "
                         f"between {config['sample.spread_from']} and {config['derivation.n_max']}")
    return sample


def run(config, inputs, memo):
    sample = sample_exponents(config)
    return dict(sample_n=sample.astype(np.float64), sample_size=int(len(sample)))
