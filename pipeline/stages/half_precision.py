"""Half precision (beyond the paper): what a mobile shader computing in float16 sees across the
visible highlight (where cos^n x >= 1/255) at each rendered exponent n.

Pairs of unit vectors N, H at angles x spread over the highlight (random orientations, fixed seed)
are rounded to float16 and the lobe is evaluated in float16, one rounding per operation (numpy's
float16 arithmetic; a dot product rounds its products and then its sum once, as numpy accumulates
float16 sums in float32 and a fused dot instruction does), by two routes for u = 1 - cos x:

- "1 - N.H": t = dot(N, H) in float16, then the lobe of t. Near t = 1 float16 steps by 2^-11, so a
  narrow lobe sees only a few distinct t;
- "dot(c, c) / (1 + N.H), c = N x H": u from the cross product, which keeps its relative precision at small
  angles; the quadratic lobe is then (1 - k u)^2 (cos^n must still form 1 - u, which rounds again).

Reported per n and route: the number of distinct values the lobe takes over the highlight (fewer
means visible bands) and the largest absolute error against the float64 lobe (peak 1).
"""

import numpy as np

from ..optics.float16 import float16_power, routes, vectors

SAMPLES = 20000
VISIBLE = 1.0 / 255.0


def half_lobes(n: float, k: float, seed: int = 0, power: int = 2) -> list[dict]:
    """Rows (lobe, route, distinct values, max absolute error) at exponent n, f_Q2 coefficient k
    (f_Qm at power m; the rows keep the registry key f_Q2)."""
    x = np.linspace(0.0, np.arccos(VISIBLE ** (1.0 / n)), SAMPLES)
    N, H = (v.astype(np.float16) for v in vectors(x, seed))
    one, zero, k16 = np.float16(1), np.float16(0), np.float16(k)
    t, u = routes(N, H)
    quad_t = np.maximum(k16 * t + (one - k16), zero)
    quad_u = np.maximum(one - k16 * u, zero)
    # GPUs evaluate pow through exp2(n log2(t)) at higher precision and round the result: so here.
    values = {
        ("f_b", "1 - N.H"): np.power(np.clip(t, 0, 1).astype(np.float32), np.float32(n)).astype(np.float16),
        ("f_b", "dot(c, c) / (1 + N.H), c = N x H"): np.power((one - u).astype(np.float32), np.float32(n)).astype(np.float16),
        ("f_Q2", "1 - N.H"): float16_power(quad_t, power),
        ("f_Q2", "dot(c, c) / (1 + N.H), c = N x H"): float16_power(quad_u, power),
    }
    exact = {"f_b": np.cos(x) ** n, "f_Q2": np.maximum(1.0 - k * (1.0 - np.cos(x)), 0.0) ** power}
    return [dict(n=float(n), lobe=lobe, route=route, distinct=int(len(np.unique(v))),
                 max_abs_error=float(np.max(np.abs(v.astype(np.float64) - exact[lobe]))))
            for (lobe, route), v in values.items()]


def run(config, inputs, memo):
    a, b = inputs["linear_coefficient.slope_used"], inputs["linear_coefficient.intercept_used"]
    rows = [row for n in config["render.exponents"]
            for row in half_lobes(float(n), a * float(n) + b, power=config["lobe.power"])]
    return dict(rows=rows, samples=SAMPLES)
