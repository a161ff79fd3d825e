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


def alternative_samples(config, n_s, y_s, y_all) -> dict:
    """Other samples of the kind the paper's could be, each as (n, y) with y rounded as configured:
    the configured one, it unrounded, every n, other splits between consecutive and spread n
    (same size), and log-spaced n. Used to say how fitted constants depend on the unknown sample."""
    n_min, n_max = config["derivation.n_min"], config["derivation.n_max"]
    n_all = np.arange(n_min, n_max + 1, dtype=np.float64)
    decimals = config["sample.y_decimals"]

    def at(ns, rounded=True):
        y = y_all[np.asarray(ns, dtype=np.int64) - n_min]
        return np.round(y, decimals) if rounded and decimals >= 0 else y

    alternatives = {"configured sample": (n_s, y_s),
                    "configured sample, y unrounded": (n_s, at(n_s, rounded=False)),
                    "every n in range": (n_all, y_all)}
    size = len(n_s)
    for head_to in (11, 21, 41):
        if n_min <= head_to < n_max and size - (head_to - n_min + 1) >= 2:
            cfg = dict(config) | {"sample.consecutive_to": head_to, "sample.spread_from": head_to + 1,
                                  "sample.spread_count": size - (head_to - n_min + 1)}
            ns = sample_exponents(cfg).astype(np.float64)
            alternatives[f"n_min..{head_to}, then {size - (head_to - n_min + 1)} evenly spaced"] = (ns, at(ns))
    geo = np.unique(np.round(np.geomspace(n_min, n_max, size)))
    alternatives[f"{len(geo)} log-spaced n"] = (geo, at(geo))
    return alternatives


def same_kind(label: str, size: int, configured_size: int) -> bool:
    """Whether an alternative sample is of the configured sample's kind: its size, y rounded."""
    return size == configured_size and "unrounded" not in label


def run(config, inputs, memo):
    sample = sample_exponents(config)
    return dict(sample_n=sample.astype(np.float64), sample_size=int(len(sample)))
