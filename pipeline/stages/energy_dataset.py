"""Energy dataset (Fig. 7): the ideal normalization y(n) = 1 / (2 pi Int(n)) of f_Q2, with

    Int(n) = int_0^gran(n) f_Q2(g) cos(g) sin(g) dg,   gran(n) = arccos(1 - 1/k_Q2(n)),

by Gauss-Legendre quadrature in JAX, for every n in range and for the 50-point sample. As in the
paper, the integral runs up to the lobe's zero crossing gran(n) even where it lies past the
horizon (k < 1, e.g. n = 2 with the paper's constants), where cos(g) < 0.
"""

import jax
import jax.numpy as jnp
import numpy as np

from ..lobes import gran, k_Q2, quadratic
from .common import RANGE_KEYS, n_range

READS = RANGE_KEYS + ("energy.*", "sample.*")
UPSTREAM = ("linear_coefficient",)


def hemispherical_integral(k, nodes, weights):
    """Int = int_0^gran f(g) cos g sin g dg for the quadratic lobe with coefficient k (scalar)."""
    top = gran(k)
    g = 0.5 * top * (nodes + 1.0)
    return 0.5 * top * jnp.sum(weights * quadratic(g, k) * jnp.cos(g) * jnp.sin(g))


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


def run(config, upstream):
    lin = upstream["linear_coefficient"]
    n = n_range(config)
    nodes, weights = np.polynomial.legendre.leggauss(config["energy.quadrature_nodes"])
    k = k_Q2(n, lin["slope_used"], lin["intercept_used"])
    integral = jax.jit(jax.vmap(hemispherical_integral, (0, None, None)))(k, nodes, weights)
    y = 1.0 / (2.0 * jnp.pi * integral)
    n_np, y_np = np.asarray(n), np.asarray(y)
    sample = sample_exponents(config)
    y_sample = y_np[sample - config["derivation.n_min"]]
    decimals = config["sample.y_decimals"]
    if decimals >= 0:
        y_sample = np.round(y_sample, decimals)
    first = n_np[(n_np >= 2) & (n_np <= 10)]
    return dict(n=n_np, Int=np.asarray(integral), y=y_np, gran=np.asarray(gran(k)),
                sample_n=sample.astype(np.float64), sample_y=y_sample,
                sample_size=int(len(sample)), sample_mean_y=float(np.mean(y_sample)),
                sample_std_y=float(np.std(y_sample)),
                y_n2_to_10=y_np[(n_np >= 2) & (n_np <= 10)], y_n2_to_10_n=first,
                slope_used=lin["slope_used"], intercept_used=lin["intercept_used"],
                lobe_below_horizon_n=n_np[np.asarray(k) < 1.0])
