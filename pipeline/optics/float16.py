"""Half precision as a shader computes it: one rounding to float16 per operation (numpy's float16
arithmetic), the unit vectors N, H at given angles whose dot and cross products a shader forms, and
a power by squarings as GLSL.
Shared by the `half_precision` stage and the decision's float16 measure."""

import numpy as np

from .registry import power_steps


def vectors(x, seed):
    """Unit vectors N, H (float64) at the angles x between them, in random orientations."""
    rng = np.random.default_rng(seed)
    N = rng.normal(size=(len(x), 3))
    N /= np.linalg.norm(N, axis=1, keepdims=True)
    r = rng.normal(size=(len(x), 3))
    r -= np.sum(r * N, axis=1, keepdims=True) * N
    r /= np.linalg.norm(r, axis=1, keepdims=True)
    return N, np.cos(x)[:, None] * N + np.sin(x)[:, None] * r


def float16_power(base, power: int):
    """base^power in float16 as the exported shader computes it (`power_steps`: squarings and
    multiplies, each rounded to float16)."""
    values = {"b": base.astype(np.float16)}
    steps, result = power_steps("b", power)
    for name, expression in steps:
        left, right = (values[v.strip()] for v in expression.split("*"))
        values[name] = (left * right).astype(np.float16)
    return values[result]


def power_expression(base: str, power: int) -> str:
    """GLSL of base^power as one expression: the squarings and multiplies of `power_steps`, the
    shader text of what `float16_power` computes."""
    values = {"b": f"({base})"}
    steps, result = power_steps("b", power)
    for name, expression in steps:
        left, right = (values[v.strip()] for v in expression.split("*"))
        values[name] = f"({left} * {right})"
    return values[result]


def routes(N, H):
    """(t, u) in float16 from float16 unit vectors N, H, as a shader forms them: t = N.H (a dot product:
    products rounded, then their sum once) and u = 1 - t without cancellation, |N x H|^2 / (1 + N.H)."""
    t = np.sum(N * H, axis=1, dtype=np.float16)
    cross = np.cross(N, H).astype(np.float16)
    u = (np.sum(cross * cross, axis=1, dtype=np.float16) / (np.float16(1) + t)).astype(np.float16)
    return t, u
