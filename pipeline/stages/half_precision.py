"""Half precision (beyond the paper): what a mobile shader computing in float16 sees across the
visible highlight (where cos^n x >= 1/255) at each rendered exponent n.

Pairs of unit vectors N, H at angles x spread over the highlight (random orientations, fixed seed)
are rounded to float16, and u = 1 - cos x is formed in float16 (one rounding per operation; a dot
product rounds its products and then its sum once, as numpy accumulates float16 sums in float32 and
a fused dot instruction does) by two routes:

- "1 - N.H": t = dot(N, H), then the lobe of t. Near t = 1 float16 steps by 2^-11, so a narrow lobe
  sees only a few distinct t;
- "dot(c, c) / (1 + N.H), c = N x H": u from the cross product, which keeps its relative precision at
  small angles; the quadratic lobe is then (1 - k u)^m (cos^n must still form 1 - u, which rounds
  again).

The lobe of t (or of u) is then executed: its GLSL (pow(t, n); max(k t + (1 - k), 0)^m by squarings;
the same of u) run in float16 with explicit 16-bit types by Mesa's lavapipe (`isa.execution`: its
pow is Mesa's lowering, exp2(n log2 t) in float16, as RADV, turnip and panfrost compute it). Where
lavapipe cannot run, numpy's per-operation float16 with pow computed in float32 and rounded stands
in, and `executed_by` says so; beside each executed row, that emulation's numbers (`_emulated`), so
that a difference the driver makes is seen.

Reported per n and route: the number of distinct values the lobe takes over the highlight (fewer
means visible bands) and the largest absolute error against the float64 lobe (peak 1). Beside it the
exhaustive maximum: each lobe executed at every float16 of its input in [0, 1] (`EVERY_INPUT`, t or
u: 15,361 values) against the same lobe in float64 at that input, its constants n and k float64's:
the most float16 arithmetic and constants cost any input, with the input where it lies.
"""

import numpy as np

from ..optics.float16 import float16_power, power_expression, routes, vectors

SAMPLES = 20000
VISIBLE = 1.0 / 255.0
T_ROUTE, U_ROUTE = "1 - N.H", "dot(c, c) / (1 + N.H), c = N x H"
EVERY_INPUT = np.arange(0, int(np.float16(1.0).view(np.uint16)) + 1, dtype=np.uint16).view(np.float16)   # [0, 1]


def bodies(n: float, k: float, power: int) -> dict[tuple[str, str], str]:
    """The GLSL of each (lobe, route) in the float16 value x (t, or u), its numbers float16's."""
    n16, k16 = repr(float(np.float16(n))), repr(float(np.float16(k)))
    quadratic_t = power_expression(f"max({k16} * x + (1.0 - {k16}), 0.0)", power)
    return {("f_b", T_ROUTE): f"pow(clamp(x, 0.0, 1.0), {n16})", ("f_b", U_ROUTE): f"pow(1.0 - x, {n16})",
            ("f_Q2", T_ROUTE): quadratic_t, ("f_Q2", U_ROUTE): power_expression(f"max(1.0 - {k16} * x, 0.0)", power)}


def route_values(n: float, seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(x, t, u): the angles over the highlight at n, and t and u in float16 (module docstring)."""
    x = np.linspace(0.0, np.arccos(VISIBLE ** (1.0 / n)), SAMPLES)
    N, H = (v.astype(np.float16) for v in vectors(x, seed))
    t, u = routes(N, H)
    return x, t, u


def emulated(n: float, k: float, t, u, power: int) -> dict[tuple[str, str], np.ndarray]:
    """Each lobe in numpy's float16, one rounding per operation, pow in float32 then rounded."""
    one, zero, k16 = np.float16(1), np.float16(0), np.float16(k)
    return {
        ("f_b", T_ROUTE): np.power(np.clip(t, 0, 1).astype(np.float32), np.float32(n)).astype(np.float16),
        ("f_b", U_ROUTE): np.power((one - u).astype(np.float32), np.float32(n)).astype(np.float16),
        ("f_Q2", T_ROUTE): float16_power(np.maximum(k16 * t + (one - k16), zero), power),
        ("f_Q2", U_ROUTE): float16_power(np.maximum(one - k16 * u, zero), power),
    }


def exact_of_input(n: float, k: float, v: np.ndarray, power: int) -> dict[tuple[str, str], np.ndarray]:
    """Each lobe in float64 at the input values v (t for the first route, u for the second)."""
    v = np.asarray(v, np.float64)
    return {("f_b", T_ROUTE): np.clip(v, 0, 1) ** n, ("f_b", U_ROUTE): (1.0 - v) ** n,
            ("f_Q2", T_ROUTE): np.maximum(k * v + (1.0 - k), 0.0) ** power,
            ("f_Q2", U_ROUTE): np.maximum(1.0 - k * v, 0.0) ** power}


def half_lobes(exponents, ks, seed: int = 0, power: int = 2) -> tuple[list[dict], str]:
    """(rows (n, lobe, route, distinct values, max absolute error, and the emulation's; the largest
    error at every float16 input, where, and the emulation's), what executed them) at each exponent n
    with its f_Q2 coefficient k (f_Qm at power m; the rows keep the registry key f_Q2): every lobe of
    every n in one run of lavapipe."""
    from ..isa import execution

    cases = []
    for n, k in zip(exponents, ks):
        x, t, u = route_values(float(n), seed)
        cases.append((float(n), float(k), x, t, u))
    inputs = np.concatenate([np.concatenate([t, u]) for _, _, _, t, u in cases])
    forms = {f"n{i}_{lobe}_{'t' if route == T_ROUTE else 'u'}": body
             for i, (n, k, *_) in enumerate(cases) for (lobe, route), body in bodies(n, k, power).items()}
    why = execution.available()
    done, every = execution.execute_sets([(forms, inputs, None, 0.0), (forms, EVERY_INPUT, None, 0.0)], "fp16") \
        if why is None else ({}, {})
    failed = [str(v) for results in (done, every) for v in results.values() if isinstance(v, execution.ExecutionError)]
    executed_by = ("lavapipe (Mesa's Vulkan driver on the CPU), float16 with explicit 16-bit types" if why is None
                   and not failed else "numpy's per-operation float16 emulation, pow in float32 and rounded ("
                   + (why or failed[0]) + ")")
    rows, offset = [], 0
    for i, (n, k, x, t, u) in enumerate(cases):
        exact = {"f_b": np.cos(x) ** n, "f_Q2": np.maximum(1.0 - k * (1.0 - np.cos(x)), 0.0) ** power}
        numpy_values = emulated(n, k, t, u, power)
        every_emulated = emulated(n, k, EVERY_INPUT, EVERY_INPUT, power)
        every_exact = exact_of_input(n, k, EVERY_INPUT, power)
        for (lobe, route), emulation in numpy_values.items():
            start = offset + (0 if route == T_ROUTE else t.size)
            key = f"n{i}_{lobe}_{'t' if route == T_ROUTE else 'u'}"
            v = done[key][start:start + t.size] if key in done and not failed else emulation

            def error(values):
                return float(np.max(np.abs(values.astype(np.float64) - exact[lobe])))

            def largest(values):
                e = np.abs(np.asarray(values, np.float64) - every_exact[(lobe, route)])
                return float(e.max()), float(EVERY_INPUT[int(np.argmax(e))])

            all_v = every[key] if key in every and not failed else every_emulated[(lobe, route)]
            (worst, at), (worst_emulated, _) = largest(all_v), largest(every_emulated[(lobe, route)])
            rows.append(dict(n=n, lobe=lobe, route=route, distinct=int(len(np.unique(v))), max_abs_error=error(v),
                             distinct_emulated=int(len(np.unique(emulation))), max_abs_error_emulated=error(emulation),
                             max_abs_error_every_input=worst, every_input_at=at,
                             max_abs_error_every_input_emulated=worst_emulated))
        offset += t.size + u.size
    return rows, executed_by


def run(config, inputs, memo):
    a, b = inputs["linear_coefficient.slope_used"], inputs["linear_coefficient.intercept_used"]
    exponents = [float(n) for n in config["render.exponents"]]
    rows, executed_by = half_lobes(exponents, [a * n + b for n in exponents], power=config["lobe.power"])
    return dict(rows=rows, samples=SAMPLES, every_input=int(EVERY_INPUT.size), executed_by=executed_by)
