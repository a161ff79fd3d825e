"""The lobes' JAX code: the shape families every registry lobe evaluates with, as functions of
u = 1 - cos x, and the paper's lobes as functions of x.

Every lobe of the paper's family has the form (k (cos x - 1) + 1)^m, i.e. (1 - k u)^m, with the
power m = 2 in the paper (`lobe.power` in the config: any integer m >= 2), clamped to 0 beyond its
zero crossing cos x = 1 - 1/k (u = 1/k). They differ only in k(n), whose formulas the registry
declares (`pipeline.optics.registry`: k_2 = n / 2, the level-matched k_Q, the line
k_Q2 = slope n + intercept). The reference lobe f_b (Phong / Blinn-Phong) is cos(x)^n.

The power is either a Python int (then `base ** m` is at most m - 1 multiplies, squarings, never
a pow) or a traced float, as the jitted functions that scan, measure and integrate lobes pass it,
so that one compiled program serves every power (there base^m is exp(m log base), within a few
ulp of the product in float64).
"""

import functools

import jax
import jax.numpy as jnp
import numpy as np

from . import registry


def k_2(n):
    """Coefficient k of f_2: n / 2."""
    return registry.k_2(n)


def k_Q(n, Q, power: int = 2):
    """Coefficient k of f_Q for Q in (0, 1) and the power m (`registry.k_Q` in JAX)."""
    return registry.k_Q(n, Q, jnp, power)


def k_Q2(n, slope, intercept):
    """Coefficient k of f_Q2: the line slope * n + intercept."""
    return registry.k_Q2(n, slope, intercept)


def f_b_u(u, n):
    """Reference lobe cos^n x at u = 1 - cos x, u in [0, 1]."""
    return (1.0 - u) ** n


def linear_power_u(u, k, power=2):
    """The family's lobe (1 - k u)^m at u = 1 - cos x, clamped to 0 for u >= 1/k."""
    base = 1.0 - k * u
    positive = base > 0.0
    if isinstance(power, int):
        return jnp.where(positive, base ** power, 0.0)
    # A traced power: the untaken branch must not see log(0) (its gradient would be NaN).
    return jnp.where(positive, jnp.where(positive, base, 1.0) ** power, 0.0)


def f_b(x, n):
    """Reference lobe cos(x)^n for x in [0, pi/2]."""
    return f_b_u(1.0 - jnp.cos(x), n)


def linear_power(x, k, power: int = 2):
    """The family's lobe (k (cos x - 1) + 1)^m, clamped to 0 past its zero crossing."""
    return linear_power_u(1.0 - jnp.cos(x), k, power)


def f_2(x, n):
    """The original cosine-quadratic lobe ((n/2)(cos x - 1) + 1)^2, clamped."""
    return linear_power(x, k_2(n))


def f_Q(x, n, Q, power: int = 2):
    """The level-matched lobe (k_Q(n)(cos x - 1) + 1)^m, clamped."""
    return linear_power(x, k_Q(n, Q, power), power)


def f_Q2(x, n, slope, intercept, power: int = 2):
    """The paper's model ((slope n + intercept)(cos x - 1) + 1)^m (m = 2 in the paper), clamped."""
    return linear_power(x, k_Q2(n, slope, intercept), power)


def gran(k):
    """Zero crossing x of a lobe of the family: arccos(1 - 1/k); exceeds pi/2 when k < 1, and is pi
    when k <= 1/2 (the lobe is then positive over the whole sphere and has no zero crossing)."""
    return jnp.arccos(jnp.maximum(1.0 - 1.0 / k, -1.0))


# The shape families, as functions of (u, p, power) with one parameter p per exponent n: the
# coefficient k for the family (k (t - 1) + 1)^m, n for cos^n and Schlick, the rate for the
# exponentials; only the family reads the (static) power. A family is a static argument (or a
# traced index) of the jitted functions that evaluate lobes, so each compiles once per power and
# every lobe of that family (f_2, f_Q, f_Q2 are all "linear_power") reuses the program.
# Past u = 1 (t = cos x < 0, reachable in the Phong form) a shader's max(t, 0) holds the lobe at
# its t = 0 value: 0 for cos^n and Schlick, exp(-p) for the exponentials.
def power_u(u, n, power: int = 2):
    """cos^n at u, with t clamped at 0."""
    return f_b_u(jnp.minimum(u, 1.0), n)


def schlick_u(u, n, power: int = 2):
    """Schlick's t / (n - n t + t) at u, with t clamped at 0."""
    u = jnp.minimum(u, 1.0)
    return (1.0 - u) / (n * u + 1.0 - u)


def exp_u(u, rate, power: int = 2):
    """exp(rate (t - 1)) at u, with t clamped at 0."""
    return jnp.exp(-rate * jnp.minimum(u, 1.0))


SHAPES = {"linear_power": linear_power_u, "power": power_u, "schlick": schlick_u, "exp": exp_u}
SHAPE_NAMES = registry.SHAPE_NAMES
assert tuple(SHAPES) == SHAPE_NAMES, "the registry names the shape families of this module, in this order"


def support_end(shape: str, p):
    """The u past which the lobe is 0: 1/k for the family; elsewhere the lobe is held at its t = 0
    value past u = 1, so its support is the whole sphere (u up to 2)."""
    p = np.asarray(p, dtype=np.float64)
    return 1.0 / p if shape == "linear_power" else np.full_like(p, 2.0)


def lobe_of_shape(shape_index, u, p, power=2):
    """`SHAPES[SHAPE_NAMES[shape_index]](u, p, power)` with a traced index (and power): one compiled
    program serves every shape (the index is the same for a whole call, so only its branch runs)."""
    branches = tuple(functools.partial(fn, power=power) for fn in SHAPES.values())
    return jax.lax.switch(shape_index, branches, u, p)
