"""The decision's lobe candidates as functions: each one's value in float64 (of t = N.H or R.V) and in
float16 (of t16 and u16 = 1 - t from the cross product, per route), the GLSL of each route, made from
a plain descriptor (`evaluator`), and the integral that normalizes a lobe (`phong_integral`). Read by
the decision (`stages.decision`) and by the renders of its lobes (`stages.lobe_renders`)."""

from __future__ import annotations

import numpy as np
from scipy.integrate import quad

from . import lobe_families, registry
from .float16 import float16_power, power_expression


def _f16(x):
    return np.asarray(x, dtype=np.float64).astype(np.float16)


def _transcendental16(f, x16):
    """A transcendental of a float16 argument as a GPU computes it: at higher precision, rounded."""
    return f(x16.astype(np.float32)).astype(np.float16)


def linear_power(k: float, power: int):
    """max(k (t - 1) + 1, 0)^power: (float64 of t, float16 routes, the routes' GLSL `SHADERS`)."""
    def v64(t):
        return np.maximum(k * (t - 1.0) + 1.0, 0.0) ** power

    def v16(t16, u16):
        k16, one = _f16(k), np.float16(1)
        return {"t": float16_power(np.maximum(k16 * t16 + (one - k16), np.float16(0)), power),
                "u": float16_power(np.maximum(one - k16 * u16, np.float16(0)), power)}
    return v64, v16, {"t": (power_expression("max(p0 * x + (1.0 - p0), 0.0)", power), (k,)),
                      "u": (power_expression("max(1.0 - p0 * x, 0.0)", power), (k,))}


def cos_power(n: float):
    def v64(t):
        return np.maximum(t, 0.0) ** n

    def v16(t16, u16):
        power = lambda x: np.power(np.clip(x.astype(np.float32), 0, 1), np.float32(n)).astype(np.float16)
        return {"t": power(t16), "u": power((np.float16(1) - u16).astype(np.float16))}
    return v64, v16, {"t": ("pow(clamp(x, 0.0, 1.0), p0)", (n,)), "u": ("pow(1.0 - x, p0)", (n,))}


def exponential(rate: float):
    """exp(rate (t - 1)): the spherical Gaussians."""
    def v64(t):
        return np.exp(rate * (t - 1.0))

    def v16(t16, u16):
        r16 = _f16(rate)
        return {"t": _transcendental16(np.exp, (r16 * t16 - r16).astype(np.float16)),
                "u": _transcendental16(np.exp, (-(r16 * u16)).astype(np.float16))}
    return v64, v16, {"t": ("exp(p0 * x - p0)", (rate,)), "u": ("exp(-(p0 * x))", (rate,))}


def schlick(n: float):
    """t / (n - n t + t)."""
    def v64(t):
        return t / (n - n * t + t)

    def v16(t16, u16):
        n16, one = _f16(n), np.float16(1)
        return {"t": (t16 / (n16 - n16 * t16 + t16)).astype(np.float16),
                "u": ((one - u16) / (n16 * u16 + (one - u16))).astype(np.float16)}
    return v64, v16, {"t": ("x / (p0 - p0 * x + x)", (n,)), "u": ("(1.0 - x) / (p0 * x + (1.0 - x))", (n,))}


def family(name: str, P):
    """A lobe-search family at shader parameters P = (A, B, C). Its u route folds the per-material
    constants (in float64, then rounded to float16 as uniforms): A t + B = (A + B) - A u, and
    (A t + B) t + C = (A u - (2 A + B)) u + (A + B + C)."""
    index = lobe_families.NAMES.index(name)
    A, B, C = (float(p) for p in P)

    def v64(t):
        return lobe_families.value_t(np, index, np.asarray(t, dtype=np.float64), np.array([A, B, C]))

    def v16(t16, u16):
        a, b, c = _f16(A), _f16(B), _f16(C)
        a0, a1 = _f16(A + B), _f16(A)
        one, zero = np.float16(1), np.float16(0)
        if name in lobe_families.POWERS:
            m = lobe_families.POWERS[name]
            return {"t": float16_power(np.maximum(a * t16 + b, zero), m), "u": float16_power(np.maximum(a0 - a1 * u16, zero), m)}
        if name == "exp2_linear":
            return {"t": _transcendental16(np.exp2, (a * t16 + b).astype(np.float16)),
                    "u": _transcendental16(np.exp2, (a0 - a1 * u16).astype(np.float16))}
        if name == "exp2_quadratic":
            q1, q0 = _f16(2 * A + B), _f16(A + B + C)
            return {"t": _transcendental16(np.exp2, ((a * t16 + b) * t16 + c).astype(np.float16)),
                    "u": _transcendental16(np.exp2, ((a1 * u16 - q1) * u16 + q0).astype(np.float16))}
        ratio_t = (t16 / (a * t16 + b)).astype(np.float16)
        ratio_u = ((one - u16) / (a0 - a1 * u16)).astype(np.float16)
        if name == "rational":
            return {"t": ratio_t, "u": ratio_u}
        return {"t": (ratio_t * ratio_t).astype(np.float16), "u": (ratio_u * ratio_u).astype(np.float16)}

    line_t, line_u = ("p0 * x + p1", (A, B)), ("p0 - p1 * x", (A + B, A))
    if name in lobe_families.POWERS:
        m = lobe_families.POWERS[name]
        shader = {"t": (power_expression(f"max({line_t[0]}, 0.0)", m), line_t[1]),
                  "u": (power_expression(f"max({line_u[0]}, 0.0)", m), line_u[1])}
    elif name == "exp2_linear":
        shader = {"t": (f"exp2({line_t[0]})", line_t[1]), "u": (f"exp2({line_u[0]})", line_u[1])}
    elif name == "exp2_quadratic":
        shader = {"t": ("exp2((p0 * x + p1) * x + p2)", (A, B, C)),
                  "u": ("exp2((p0 * x - p1) * x + p2)", (A, 2 * A + B, A + B + C))}
    else:
        ratio = {"t": ("x / (p0 * x + p1)", (A, B)), "u": ("(1.0 - x) / (p0 - p1 * x)", (A + B, A))}
        shader = ratio if name == "rational" else {r: (f"({e}) * ({e})", q) for r, (e, q) in ratio.items()}
    return v64, v16, shader


def beckmann_over_peak(n: float):
    """Beckmann's D over its peak at a^2 = 2 / (n + 2): exp((t^2 - 1) / (a^2 t^2)) / t^4."""
    a2 = 2.0 / (n + 2.0)

    def v64(t):
        t = np.maximum(np.asarray(t, dtype=np.float64), 1e-3)
        return np.exp((t * t - 1.0) / (a2 * t * t)) / t ** 4

    def v16(t16, u16):
        a16, one = _f16(a2), np.float16(1)
        t2 = (t16 * t16).astype(np.float16)
        out_t = _transcendental16(np.exp, ((t2 - one) / (a16 * t2)).astype(np.float16))
        out_t = (out_t / (t2 * t2)).astype(np.float16)
        s = (one - u16).astype(np.float16)
        s2 = (s * s).astype(np.float16)
        out_u = _transcendental16(np.exp, (-(u16 * (np.float16(2) - u16)) / (a16 * s2)).astype(np.float16))
        return {"t": out_t, "u": (out_u / (s2 * s2)).astype(np.float16)}
    s2 = "((1.0 - x) * (1.0 - x))"
    return v64, v16, {"t": ("exp((x * x - 1.0) / (p0 * (x * x))) / ((x * x) * (x * x))", (a2,)),
                      "u": (f"exp(-(x * (2.0 - x)) / (p0 * {s2})) / ({s2} * {s2})", (a2,))}


def ggx_over_peak(n: float):
    """GGX's D over its peak at a^2 = 2 / (n + 2): (a^2 / (a^2 t^2 + 1 - t^2))^2."""
    a2 = 2.0 / (n + 2.0)

    def v64(t):
        return (a2 / (a2 * t * t + 1.0 - t * t)) ** 2

    def v16(t16, u16):
        a16, one = _f16(a2), np.float16(1)
        q_t = (a16 / (a16 * t16 * t16 + (one - t16 * t16))).astype(np.float16)
        s = (one - u16).astype(np.float16)
        q_u = (a16 / (a16 * s * s + u16 * (np.float16(2) - u16))).astype(np.float16)
        return {"t": (q_t * q_t).astype(np.float16), "u": (q_u * q_u).astype(np.float16)}
    q_t, q_u = "(p0 / (p0 * x * x + (1.0 - x * x)))", "(p0 / (p0 * (1.0 - x) * (1.0 - x) + x * (2.0 - x)))"
    return v64, v16, {"t": (f"{q_t} * {q_t}", (a2,)), "u": (f"{q_u} * {q_u}", (a2,))}


def phong_integral(v64, n: float) -> float:
    """int_0^1 g(t) t dt (2 pi times it is the lobe's albedo at normal incidence in the Phong form), in
    u = 1 - t with breakpoints where a lobe of width 1/n changes."""
    points = [p for p in (0.5 / n, 2.0 / n, 8.0 / n, 32.0 / n) if p < 1.0]
    value, _ = quad(lambda u: float(v64(np.array(1.0 - u))) * (1.0 - u), 0.0, 1.0, points=points or None,
                    limit=400, epsabs=0.0, epsrel=1e-10)
    return value


def _registry_lobe(key: str, p: registry.Parameters):
    lobe = registry.LOBES[key]

    def make(n):
        k = float(lobe.parameter(np, n, p))
        if lobe.shape == "linear_power":
            return linear_power(k, lobe.power_of(p))
        if lobe.shape == "power":
            return cos_power(k)
        if lobe.shape == "schlick":
            return schlick(k)
        return exponential(k)
    return make


def registry_descriptor(key: str, p: registry.Parameters) -> list:
    """A registry lobe as plain values: its key and the run parameters it reads (so that a refit that
    moves Q re-measures f_Q alone)."""
    lobe = registry.LOBES[key]
    fields = {}
    if "Q" in lobe.depends_on:
        fields["Q"] = float(p.Q)
    if "line" in lobe.depends_on:
        fields.update(slope=float(p.slope), intercept=float(p.intercept))
    if lobe.follows_power:
        fields["power"] = int(p.power)
    return ["registry", key, fields]


def evaluator(descriptor):
    """make(n) -> (float64, float16 routes) of a candidate from its descriptor: ["cos_n"], ["beckmann"],
    ["ggx"], ["registry", key, parameters], ["power", slope, intercept, m] (the family's line at power m)
    or ["family", name, slopes, intercepts] (a lobe search form with its lines in n)."""
    kind = descriptor[0]
    if kind == "cos_n":
        return cos_power
    if kind == "beckmann":
        return beckmann_over_peak
    if kind == "ggx":
        return ggx_over_peak
    if kind == "registry":
        return _registry_lobe(descriptor[1], registry.Parameters(**descriptor[2]))
    if kind == "power":
        _, a, b, m = descriptor
        return lambda n: linear_power(a * n + b, int(m))
    _, name, slopes, intercepts = descriptor

    def make(n):
        P = np.zeros(3)
        P[:len(slopes)] = np.asarray(slopes) * n + np.asarray(intercepts)
        return family(name, P)
    return make
