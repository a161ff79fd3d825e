"""Energy dataset (Fig. 7): the ideal normalization y(n) = 1 / (2 pi Int(n)) of f_Q2 (f_Qm at the
run's power m), with

    Int(n) = int_0^gran(n) f_Q2(g) cos(g) sin(g) dg,   gran(n) = arccos(1 - 1/k_Q2(n)),

by Gauss-Legendre quadrature in JAX, for every n in range and for the 50-point sample. As in the
paper, the integral runs up to the lobe's zero crossing gran(n) even where it lies past the
horizon (k < 1, e.g. n = 2 with the paper's constants), where cos(g) < 0.
"""

import functools

from ..optics.numerics import jax
import jax.numpy as jnp
import numpy as np

from ..optics.lobes import gran, k_Q2, linear_power
from .common import n_range


def hemispherical_integral(k, nodes, weights, power: int = 2):
    """Int = int_0^gran f(g) cos g sin g dg for the family's lobe with coefficient k (scalar)."""
    top = gran(k)
    g = 0.5 * top * (nodes + 1.0)
    return 0.5 * top * jnp.sum(weights * linear_power(g, k, power) * jnp.cos(g) * jnp.sin(g))


@functools.partial(jax.jit, static_argnames="nodes")
def _integrals(k, nodes: int, power):
    x, w = np.polynomial.legendre.leggauss(nodes)
    return jax.vmap(lambda k_: hemispherical_integral(k_, x, w, power))(k)


def integrals(k, nodes: int, power=2):
    """Int for every k of the array k, by `nodes`-point Gauss-Legendre quadrature (one compiled
    program for every power)."""
    return _integrals(k, nodes, np.float64(power))


def run(config, inputs, memo):
    sample = np.asarray(inputs["sample.sample_n"]).astype(np.int64)
    n = n_range(config)
    k = k_Q2(n, inputs["linear_coefficient.slope_used"], inputs["linear_coefficient.intercept_used"])
    integral = integrals(k, config["energy.quadrature_nodes"], config["lobe.power"])
    y = 1.0 / (2.0 * jnp.pi * integral)
    n_np, y_np = np.asarray(n), np.asarray(y)
    y_sample = y_np[sample - config["derivation.n_min"]]
    decimals = config["sample.y_decimals"]
    if decimals >= 0:
        y_sample = np.round(y_sample, decimals)
    return dict(Int=np.asarray(integral), y=y_np, gran=np.asarray(jax.jit(gran)(k)),
                sample_y=y_sample, sample_mean_y=float(np.mean(y_sample)),
                sample_std_y=float(np.std(y_sample)),
                y_n2_to_10=y_np[(n_np >= 2) & (n_np <= 10)],
                lobe_below_horizon_n=n_np[np.asarray(k) < 1.0])
