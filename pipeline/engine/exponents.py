"""The exponents n of a run: every integer in [derivation.n_min, derivation.n_max]. The one place
that builds the range; the stages' per-n arrays, the figures and the tables all run over it."""

import numpy as np


def n_range(config) -> np.ndarray:
    """Every integer exponent n in [n_min, n_max], as float64. `config` is anything that maps the keys
    derivation.n_min and derivation.n_max to their values."""
    return np.arange(config["derivation.n_min"], config["derivation.n_max"] + 1, dtype=np.float64)
