"""The cheap forms the lobe search fits to cos^n (`pipeline.stages.lobe_search`): each a function
g(t; A, B, C) of t = cos x whose parameters are per material (uniforms of the shader: any function
of n, computed once), fitted per n by minimax of the relative error d in the epicenter zone.

Each family is written three ways from one entry: in t with its shader parameters (the GLSL body,
and `value_t` for numpy and JAX alike), and in the scaled variable w = n u (u = 1 - t) with
parameters q of order 1 for every n, in which the fit runs (`shader_parameters` maps q to A, B, C):
cos^n = (1 - w/n)^n ~ exp(-w), so every family's q barely moves with n and the fit at one n starts
from the previous n's optimum.

- `square`, `cube`, `fourth`: max(A t + B, 0)^m = q0 max(1 - q1 w, 0)^m: the paper's family with a
  free peak (f_Q2 is q0 = 1 with q1 n = k; A = q0^(1/m) q1 n, B = q0^(1/m) (1 - q1 n)). Beaudoin and
  Guardado (ShaderX 2002) fit this form per n by minimax.
- `square_peak1`: (k (t - 1) + 1)^2 clamped, one parameter k: f_Q2 with the best k per n.
- `exp2_linear`: exp2(A t + B) = exp(q0 - q1 w): the spherical Gaussian's class.
- `exp2_quadratic`: exp2((A t + B) t + C) = exp(q0 - q1 w - q2 w^2 / n).
- `rational`: t / (A t + B) = q0 t / (1 + q1 w): Schlick's class (Schlick's own: q0 = 1,
  q1 = (n - 1)/n).
- `rational_square`: (t / (A t + B))^2.

The fit (`pipeline.stages.lobe_search.fit_family`, by `pipeline derive`'s minimax,
`approximate.search.minimax.along`) minimizes max |g / cos^n - 1| over `ZONE_POINTS` points of the zone
(Chebyshev points in w, which crowd its ends, where the error peaks). The fitted lobes' d and D are
then measured exactly (`optics.extrema`), not on the points.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ..engine.config import LOBE_FAMILIES, LOBE_TARGETS

LN2 = math.log(2.0)
ZONE_POINTS = 256


@dataclasses.dataclass(frozen=True)
class Family:
    """One form: its name, the formula in t, its shader parameters, the start of its q, the GLSL body
    (reading the uniforms A, B, C; HLSL reads it alike), the form in `pipeline.symbolic.grammar`'s
    operations (for the cost tables' prediction), the clamps max(., 0) it adds to that form, and the
    Python expression of the exported twin (in t, A, B, C)."""

    name: str
    formula: str
    parameters: tuple[str, ...]
    start: tuple[float, ...]
    glsl: str
    grammar: str
    clamps: int
    python: str


FAMILIES: dict[str, Family] = {f.name: f for f in (
    Family("square_peak1", "max(k (t - 1) + 1, 0)^2", ("A", "B"), (0.45,),
           "float b = max(A * t + B, 0.0);\n    return b * b;", "square(c * x + c)", 1, "max(A * t + B, 0.0) ** 2"),
    Family("square", "max(A t + B, 0)^2", ("A", "B"), (1.0, 0.45),
           "float b = max(A * t + B, 0.0);\n    return b * b;", "square(c * x + c)", 1, "max(A * t + B, 0.0) ** 2"),
    Family("cube", "max(A t + B, 0)^3", ("A", "B"), (1.0, 0.3),
           "float b = max(A * t + B, 0.0);\n    return b * b * b;", "cube(c * x + c)", 1, "max(A * t + B, 0.0) ** 3"),
    Family("fourth", "max(A t + B, 0)^4", ("A", "B"), (1.0, 0.23),
           "float b = max(A * t + B, 0.0);\n    float b2 = b * b;\n    return b2 * b2;",
           "square(square(c * x + c))", 1, "max(A * t + B, 0.0) ** 4"),
    Family("exp2_linear", "exp2(A t + B)", ("A", "B"), (0.0, 1.0),
           "return exp2(A * t + B);", "exp(c * x + c)", 0, "2.0 ** (A * t + B)"),
    Family("exp2_quadratic", "exp2((A t + B) t + C)", ("A", "B", "C"), (0.0, 1.0, 0.5),
           "return exp2((A * t + B) * t + C);", "exp((c * x + c) * x + c)", 0, "2.0 ** ((A * t + B) * t + C)"),
    Family("rational", "t / (A t + B)", ("A", "B"), (1.0, 1.0),
           "return t / (A * t + B);", "x / (c * x + c)", 0, "t / (A * t + B)"),
    Family("rational_square", "(t / (A t + B))^2", ("A", "B"), (1.0, 0.5),
           "float r = t / (A * t + B);\n    return r * r;", "square(x / (c * x + c))", 0, "(t / (A * t + B)) ** 2"),
)}
NAMES = tuple(FAMILIES)
assert NAMES == LOBE_FAMILIES, "the config's lobe_search.families names these families, in this order"
TARGETS = LOBE_TARGETS          # what the search approximates (`target_u`)
POWERS = {"square_peak1": 2, "square": 2, "cube": 3, "fourth": 4}


def shader_parameters(name: str, n, q) -> np.ndarray:
    """(A, B, C) of the family at exponents n (array) from its scaled parameters q (array n x len(q));
    C = 0 where the family has none."""
    n = np.asarray(n, dtype=np.float64)
    q = np.asarray(q, dtype=np.float64).reshape(n.shape + (-1,))
    zero = np.zeros_like(n)
    if name == "square_peak1":
        k = q[..., 0] * n
        return np.stack([k, 1.0 - k, zero], axis=-1)
    if name in POWERS:
        scale = np.abs(q[..., 0]) ** (1.0 / POWERS[name])
        return np.stack([scale * q[..., 1] * n, scale * (1.0 - q[..., 1] * n), zero], axis=-1)
    if name == "exp2_linear":
        return np.stack([q[..., 1] * n, q[..., 0] - q[..., 1] * n, zero], axis=-1) / LN2
    if name == "exp2_quadratic":
        q0, q1, q2 = q[..., 0], q[..., 1], q[..., 2]
        # q0 - q1 n (1 - t) - q2 n (1 - t)^2 as a polynomial in t.
        return np.stack([-q2 * n, q1 * n + 2.0 * q2 * n, q0 - q1 * n - q2 * n], axis=-1) / LN2
    if name in ("rational", "rational_square"):
        # q0 t / (1 + q1 n (1 - t)) = t / (A t + B) (rational_square: the square root of q0).
        q0 = np.sqrt(np.abs(q[..., 0])) if name == "rational_square" else q[..., 0]
        return np.stack([-q[..., 1] * n / q0, (1.0 + q[..., 1] * n) / q0, zero], axis=-1)
    raise KeyError(name)


def value_t(xp, index: int, t, P):
    """The family `NAMES[index]` at t with shader parameters P = (A, B, C), in numpy or jax.numpy
    (`xp`); index is a Python int."""
    A, B, C = P[..., 0], P[..., 1], P[..., 2]
    name = NAMES[index]
    if name in POWERS:
        return xp.maximum(A * t + B, 0.0) ** POWERS[name]
    if name == "exp2_linear":
        return xp.exp2(A * t + B)
    if name == "exp2_quadratic":
        return xp.exp2((A * t + B) * t + C)
    if name == "rational":
        return t / (A * t + B)
    return (t / (A * t + B)) ** 2


def target_u(xp, target: str, u, n):
    """The function the search approximates, of u = 1 - t, peak 1 at u = 0 (numpy or jax.numpy):
    "cos_n", cos^n; "beckmann", Beckmann's D(t = N.H) over its peak, exp((t^2 - 1) / (a^2 t^2)) / t^4
    with the roughness matched to n, a^2 = 2 / (n + 2) (as the `ndf` stage matches them), 0 where
    t < 0.05 (below 1e-30 there for every n >= 1)."""
    t = 1.0 - u
    if target == "cos_n":
        return t ** n
    if target == "beckmann":
        a2 = 2.0 / (n + 2.0)
        safe = xp.maximum(t, 0.05)
        return xp.where(t >= 0.05, xp.exp((safe * safe - 1.0) / (a2 * safe * safe)) / safe ** 4, 0.0)
    raise KeyError(target)


def zone_w(n, level, target: str = "cos_n") -> float:
    """Edge of the epicenter zone {target >= level} in w = n u: closed form for cos^n, else the root
    of the (decreasing) target by Brent's method."""
    if target == "cos_n":
        return -n * math.expm1(math.log(level) / n)
    from scipy.optimize import brentq
    return brentq(lambda w: float(target_u(np, target, w / n, n)) - level, 0.0, 0.95 * n, xtol=1e-14, rtol=1e-14)


NEWTON_STEPS = 12      # Newton steps to Beckmann's zone edge (quadratic convergence from the left)


@dataclasses.dataclass(frozen=True)
class ZoneStart:
    """t at the edge of the epicenter zone {target >= level}, a numpy function of n (arrays): the
    lower end of t in the search's box (`approximate.targets.Axis.lo_of`). cos^n: level^(1/n).
    Beckmann: the root of g(t) = (n + 2) (1 - 1 / t^2) / 2 - 4 log t - log level, by Newton's method
    from the root without its 4 log t (g is increasing and concave in t <= 1 for n >= 2: every step
    after the first lands left of the root and climbs to it); `zone_w`'s root where Newton's does
    not hold g to 1e-12."""

    level: float
    target: str = "cos_n"

    def __str__(self) -> str:
        return f"t_L(n), {self.target} >= {self.level:g}"

    def __call__(self, n):
        n = np.asarray(n, dtype=np.float64)
        if self.target == "cos_n":
            return self.level ** (1.0 / n)
        log_level = math.log(self.level)
        t = 1.0 / np.sqrt(1.0 - 2.0 * log_level / (n + 2.0))
        for _ in range(NEWTON_STEPS):
            g = 0.5 * (n + 2.0) * (1.0 - 1.0 / (t * t)) - 4.0 * np.log(t) - log_level
            t = t - g / ((n + 2.0) / t ** 3 - 4.0 / t)
        g = 0.5 * (n + 2.0) * (1.0 - 1.0 / (t * t)) - 4.0 * np.log(t) - log_level
        off = ~(np.abs(g) <= 1e-12)
        if np.any(off):
            t = np.array(t, copy=True)
            t[off] = [1.0 - zone_w(float(x), self.level, self.target) / float(x) for x in np.broadcast_to(n, t.shape)[off]]
        return t


def zone_points(n, level, count: int = ZONE_POINTS, target: str = "cos_n") -> np.ndarray:
    """u at `count` Chebyshev points of the zone [0, u_L] (its ends included)."""
    w = zone_w(n, level, target) * 0.5 * (1.0 - np.cos(np.linspace(0.0, np.pi, count)))
    return w / n


def value_w(name: str, w, n: float, q):
    """The family at w = n u with scaled parameters q (numpy): the same function as `value_t` at
    t = 1 - w / n with `shader_parameters(name, n, q)` (the tests check it), better conditioned."""
    if name == "square_peak1":
        return np.maximum(1.0 - q[0] * w, 0.0) ** 2
    if name in POWERS:
        return np.abs(q[0]) * np.maximum(1.0 - q[1] * w, 0.0) ** POWERS[name]
    if name == "exp2_linear":
        return np.exp(q[0] - q[1] * w)
    if name == "exp2_quadratic":
        return np.exp(q[0] - q[1] * w - q[2] * w * w / n)
    if name == "rational":
        return q[0] * (1.0 - w / n) / (1.0 + q[1] * w)
    return np.abs(q[0]) * ((1.0 - w / n) / (1.0 + q[1] * w)) ** 2


def form_value_w(form, w, n: float, q):
    """A family (by name) or any form given as a function value(w, n, q) (a grammar form's, from the
    stage), at w = n u."""
    if isinstance(form, str):
        return value_w(form, w, n, q)
    return form(w, n, q)
