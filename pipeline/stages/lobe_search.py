"""The lobe as a search (beyond the paper): which cheap form is closest to cos^n on each GPU and range
of n, at each cost in machine code?

Every family of `optics.lobe_families` (the paper's clamped square with a free peak and with its
peak at 1, its powers 3 and 4, exp2 of a linear and of a quadratic function of t, Schlick's rational
class and its square; `lobe_search.families`) is fitted at each n of a grid (log-spaced points in
each range of `lobe_search.n_ranges`, their ends included) by minimax of the relative error d in
the run's epicenter zone; its d and D at those parameters are then measured exactly
(`optics.extrema`). A family's error on a range is its worst n there. The grid is checked: the
fit is repeated halfway between neighbouring points (geometric midpoints), and the largest error
found there beyond the grid's maximum is reported (`grid_check`). Each family's shader parameters
are also given as lines in n per range, as the paper does for k, fitted as `pipeline derive` fits a
parameter's formulas: the range is the registry's `cos_n` target (t over the zone, n over the
range; `search_target`), the family its template (`template`), its lines started by least squares
to the per-n optima and polished together by minimax of d over the box
(`approximate.search.formulas.polish_formulas`); they are then measured exactly at every integer n of
the range: what a per-material line costs in accuracy. Where a line is not enough (its d more
than `LINE_ENOUGH` times the per-n optimum's) and `lobe_search.formula_complexity` > 0 (a refit: 0
by default, for the run's time), the parameters take the formulas `derive` finds with the symbolic
regression (`approximate.search.formulas.corrected`: each parameter's per-n optima at the grid's and the
halfway exponents searched up to that complexity, each level's formulas polished on the box, the
best level kept where it beats the lines), computed once per material; they are kept where their d,
measured at every integer n, is below the lines'.

Beside the families, the grammar's forms in w = n (1 - t) (`lobe_search.grammar_complexity`; 0 by
default, for the run's time: a refit) are screened and the best kept and fitted alike; a form that
goes below 0 somewhere on the hemisphere at some n (a grammar form is not clamped) is not a lobe: it
is reported, never on a front. The target is cos^n, or Beckmann's D over its peak
(`lobe_search.target`: the same search for another function a shader approximates).

Each family is compiled for every architecture of `pipeline.isa.architectures` whose compiler runs
here by `derive`'s costing (`isa.machine_code.form_cycles`, its parameters push constants) and
its cycles by the vendor's cost model, net of the shader returning t, are its cost; the cost tables of
`symbolic.gpu_costs` (fitted to `lobe_search.calibration_forms` random forms) give the predicted
cost beside it. Per architecture and range the front is the families no other family beats at
equal or lower cycles; the registry's lobes (the paper's f_Q2 with the run's line, the spherical
Gaussians, Schlick, f_2, cos^n itself) are placed on it with their own compiled cycles and their
d and D from `lobe_comparison`. Where no compiler runs, the stage fits and measures the families and
says why there are no cycles (no fronts).
"""

from __future__ import annotations

import functools
import re

from ..optics.numerics import jax
import jax.numpy as jnp
import numpy as np

from ..approximate.measures import fronts
from ..approximate.search import minimax
from ..engine import expressions, toolchains
from ..isa import machine_code
from ..optics import lobe_families, registry
from ..optics.extrema import error_extrema
from ..optics.roots import SolverSettings
from .common import n_range, require_converged

# The families' and grammar forms' shaders are `derive`'s (`compiled_cycles`): a grammar form is
# written in w = n (1 - t), its constants of order 1 for every n (one multiply-add more than a form in t).
BLOCK = 512        # exponents per exact measurement call (one compiled program)
LINE_ENOUGH = 1.1  # a line is enough where its d is at most this times the per-n optimum's


def n_grid(ranges, points: int) -> np.ndarray:
    """The fit's exponents: `points` log-spaced exponents over each range, its ends included."""
    return np.unique(np.concatenate([np.geomspace(lo, hi, points) for lo, hi in ranges]))


def midpoints(n) -> np.ndarray:
    return np.sqrt(n[1:] * n[:-1])


def fit_family(family: str, n, level: float, zone_points: int, target: str = "cos_n", own_start=None) -> dict:
    """The family's (or the grammar form's, by its text in w, from `own_start`) minimax fit to the
    target at every exponent of n, in order, each from the previous optimum, and at the geometric
    midpoints: q, the shader parameters (families) and the zone error on the points. The fit is
    `pipeline derive`'s (`approximate.search.minimax.along`: sequential linear programs on `zone_points`
    points of the zone, weight 1 / target: the relative error), in the scaled variable w."""
    from ..symbolic import grammar
    form = family
    if own_start is not None:
        tree = grammar.parse(family)

        def form(w, n_, q):
            return grammar.evaluate_numpy(tree, q, w)
    start = lobe_families.FAMILIES[family].start if own_start is None else own_start
    out = {}
    for key, exponents in (("grid", np.asarray(n, dtype=np.float64)), ("mid", midpoints(np.asarray(n)))):
        problems = []
        for n_ in exponents:
            u = lobe_families.zone_points(n_, level, zone_points, target)
            y = lobe_families.target_u(np, target, u, n_)
            model = functools.partial(_scaled_form, form, float(n_))
            problems.append((model, minimax.numerical_jacobian(model), y, 1.0 / y, n_ * u))
        q, errors = minimax.along(problems, start, own=lambda i: start)
        out[f"{key}_q"] = q
        out[f"{key}_zone_error"] = errors
        if own_start is None:
            out[f"{key}_P"] = lobe_families.shader_parameters(family, exponents, q) if exponents.size else np.zeros((0, 3))
    return out


def _scaled_form(form, n_: float, q, w):
    """The family (by name) or form value(w, n, q) at w = n u, as a model of its constants q."""
    with np.errstate(all="ignore"):
        return lobe_families.form_value_w(form, w, n_, q)


DENSE_ZONE = 4001       # zone points on which a grammar form's d is measured
DENSE_LOBE = 8001       # points in log(1 + w) over [0, pi/2] on which its D is measured


def dense_errors(text: str, n, q, level, target: str = "cos_n") -> dict:
    """d and D of a grammar form (its text in w = n (1 - t), constants q per n) on dense grids: d on
    `DENSE_ZONE` Chebyshev points of the zone, D on `DENSE_LOBE` points uniform in log(1 + w) (the grid
    of `optics.extrema`, without its refinement)."""
    from ..symbolic import grammar
    form = grammar.parse(text)
    d, D, lowest = [], [], []
    for n_, q_ in zip(np.asarray(n, dtype=np.float64), np.asarray(q)):
        u = lobe_families.zone_points(n_, level, DENSE_ZONE, target)
        with np.errstate(all="ignore"):
            r = grammar.evaluate_numpy(form, q_, n_ * u) / lobe_families.target_u(np, target, u, n_) - 1.0
            u_all = np.minimum(np.expm1(np.linspace(0.0, np.log1p(n_), DENSE_LOBE)) / n_, 1.0)
            g = grammar.evaluate_numpy(form, q_, n_ * u_all)
            a = g - lobe_families.target_u(np, target, u_all, n_)
        d.append(np.max(np.abs(r)) if np.all(np.isfinite(r)) else np.inf)
        D.append(np.max(np.abs(a)) if np.all(np.isfinite(a)) else np.inf)
        lowest.append(np.min(g) if np.all(np.isfinite(g)) else -np.inf)
    return dict(d=np.array(d), D=np.array(D), lowest=np.array(lowest))


SCREEN_POINTS = 64      # zone points of the grammar's screening fit


def grammar_reach(complexity: int, operations: str, level: float, n_screen, keep: int, target: str,
                  table) -> dict:
    """The grammar's forms in w = n (1 - t) (`symbolic.grammar`, the operations given, up to
    `complexity`, each with a constant at least), fitted by least squares at each exponent of
    n_screen (`symbolic.search.fit_forms`); kept: the forms that no form of fewer predicted cycles
    (the table's, with the multiply-add that makes w) fits better at the worst of those exponents; of
    those, the `keep` most accurate, cheapest first. Returns the number searched, the kept forms' text and constants
    (fitted at the last exponent)."""
    from ..symbolic import grammar, search
    ops = grammar.operations(operations)
    forms = [f for f in grammar.enumerate_forms(int(complexity), ops)
             if grammar.constants(f) >= 1 and "x" in grammar.show(f)]
    w, y = [], []
    for n_ in n_screen:
        u = lobe_families.zone_points(n_, level, SCREEN_POINTS, target)
        w.append(n_ * u)
        y.append(lobe_families.target_u(np, target, u, n_))
    fits = search.fit_forms(forms, np.array(w), np.array(y))
    score = np.array([max(sample[i][1] for sample in fits) for i in range(len(forms))])
    score = np.where(np.isfinite(score), score, np.inf)
    cost = np.array([grammar_predicted(grammar.show(f), table) if table else grammar.complexity(f) for f in forms])
    pareto, best = [], np.inf
    for i in np.lexsort((score, cost)):
        if score[i] < best * (1.0 - 1e-6):
            pareto.append(int(i))
            best = score[i]
    kept = pareto[-keep:]       # the most accurate of them
    return dict(searched=len(forms), kept=[grammar.show(forms[i]) for i in kept],
                constants=[[float(c) for c in fits[-1][i][0][:grammar.constants(forms[i])]] for i in kept])


def grammar_predicted(text: str, table: dict) -> float:
    """A grammar form's cycles by the cost table, with the multiply-add that makes w = n (1 - t)."""
    from ..symbolic import gpu_costs, grammar
    counts = gpu_costs.operation_counts(grammar.parse(text))
    return round(float(np.dot(counts, [table[op] for op in gpu_costs.OPERATIONS]) + table["*"] + table["-"]), 2)


@functools.partial(jax.jit, static_argnames=("target", "cells", "settings"))
def _errors(index, n, P, w_zone, target: str, cells: int, settings: SolverSettings):
    """d and D of the family `NAMES[index]` (traced: one program for every family) against the target,
    per n: the extrema of the relative error on the zone [0, w_zone] and of the absolute error on
    [0, pi/2], each on a grid in log(1 + w) refined by bisection (`optics.extrema`)."""
    forms = [functools.partial(lobe_families.value_t, jnp, i) for i in range(len(lobe_families.NAMES))]

    def one(n_, P_, w_):
        def g(u):
            return jax.lax.switch(index, forms, jnp.maximum(1.0 - u, 0.0), P_)

        def relative(s_, n__):
            u = jnp.expm1(s_) / n__
            return g(u) / lobe_families.target_u(jnp, target, u, n__) - 1.0

        def absolute(s_, n__):
            u = jnp.minimum(jnp.expm1(s_) / n__, 1.0)   # s = log(1 + n) may round to u just above 1
            return g(u) - lobe_families.target_u(jnp, target, u, n__)

        d_over, d_under, _, _, ok_d = error_extrema(relative, w_, n_, cells, settings)
        D_over, D_under, _, _, ok_D = error_extrema(absolute, n_, n_, cells, settings)
        return dict(d=jnp.maximum(d_over, d_under), D=jnp.maximum(D_over, D_under), ok=ok_d & ok_D)
    return jax.vmap(one)(n, P, w_zone)


def exact_errors(name: str, n, P, level, cells: int, settings: SolverSettings, target: str = "cos_n") -> dict:
    """d and D of the family with shader parameters P (one row per n) against the target, measured
    exactly, in blocks of one shape."""
    n = np.asarray(n, dtype=np.float64)
    w_zone = np.array([lobe_families.zone_w(float(x), level, target) for x in n])
    d, D, ok = [], [], []
    for start in range(0, n.size, BLOCK):
        stop = min(start + BLOCK, n.size)
        pad = BLOCK - (stop - start)
        block = [np.concatenate([a[start:stop], np.repeat(a[stop - 1:stop], pad, axis=0)]) for a in (n, P, w_zone)]
        m = _errors(jnp.asarray(lobe_families.NAMES.index(name)), *block, target, int(cells), settings)
        d.append(np.asarray(m["d"])[:stop - start])
        D.append(np.asarray(m["D"])[:stop - start])
        ok.append(np.asarray(m["ok"])[:stop - start])
    d, D, ok = (np.concatenate(v) for v in (d, D, ok))
    require_converged(ok, f"extrema of the {name} lobe", n=n)
    return dict(d=d, D=D)


def search_target(target: str, level: float, lo: float, hi: float):
    """The search's problem on the range [lo, hi] of n as `pipeline derive`'s parametric target (t
    over the epicenter zone, which moves with n; the relative error): cos^n is the registry's `cos_n`
    (`approximate.targets.cos_n_target`) at the run's level; Beckmann's D over its peak,
    exp((t^2 - 1) (n + 2) / (2 t^2)) / t^4 (`lobe_families.target_u`, whose t >= 0.05 holds in every
    zone), with the zone's edge `lobe_families.ZoneStart`."""
    from ..approximate import targets

    if target == "cos_n":
        return targets.with_range(targets.cos_n_target(level), (lo, hi))
    edge = lobe_families.ZoneStart(level, target)
    return targets.check(targets.Target(
        target, "exp((t**2 - 1)*(n + 2)/(2*t**2))/t**4",
        (targets.Axis("t", float(np.min(edge(np.array([lo, hi])))), 1.0, lo_of=edge),), targets.Axis("n", lo, hi),
        "rel", description="Beckmann's D over its peak, its roughness matched to n"))


def template(family: str, text: str = ""):
    """The family (or the grammar form `text`, in w = n (1 - t)) as `pipeline derive`'s template
    (`approximate.search.templates.Template`) in t, its constants what is per material: a family's shader
    parameters A, B, C (square_peak1's k alone: A = k, B = 1 - k), a grammar form's c0, c1, ...
    (the form reads n)."""
    import sympy as sp

    from ..approximate.search import templates
    from ..symbolic import grammar

    t, n = sp.Symbol("t", real=True), sp.Symbol("n", real=True)
    if text:
        form = grammar.parse(text)
        k = templates.constant_symbols(grammar.constants(form))
        expression = grammar.substitute(form, k, [n * (1 - t)], templates.sympy_functions())
        return templates.Template(family, "grammar", expression, len(k), text)
    entry = lobe_families.FAMILIES[family]
    symbols = {p: sp.Symbol(p, real=True) for p in "ABC"}
    expression = expressions.parse(entry.python, dict(symbols, t=t), what=f"the family {family}")
    expression = expression.xreplace({v: sp.Integer(int(v)) for v in expression.atoms(sp.Float) if v == int(v)})
    if family == "square_peak1":
        expression = expression.xreplace({symbols["B"]: 1 - symbols["A"]})
    count = len(entry.start)
    k = templates.constant_symbols(count)
    return templates.Template(family, "lobe", expression.xreplace(dict(zip([symbols[p] for p in "ABC"], k))), count,
                               entry.formula)


def shader_parameters(family: str, constants) -> list:
    """The shader parameters (A, B, ...; a grammar form's c0, c1, ...) from the template's constants
    (one per constant: numbers, arrays or sympy expressions): the constants themselves, but for
    square_peak1, whose one constant k is A = k, B = 1 - k. Every map is affine in the constants."""
    constants = list(constants)
    return [constants[0], 1 - constants[0]] if family == "square_peak1" else constants


def shader_values(family: str, constants) -> np.ndarray:
    """`shader_parameters` of constants given per n (rows): a family's (A, B, C), C = 0 where it has
    none, as `exact_errors` reads them; a grammar form's constants as they are."""
    constants = np.asarray(constants, dtype=np.float64)
    P = np.stack(shader_parameters(family, constants.T), axis=1)
    if family not in lobe_families.FAMILIES:
        return P
    return np.concatenate([P, np.zeros((P.shape[0], 3 - P.shape[1]))], axis=1)


def parameter_formulas(family: str, text: str, values, constants, errors, on_grid, level: float, target: str,
                       lo: float, hi: float, complexity: int = 0) -> dict:
    """The template's constants as functions of n on [lo, hi], fitted as `pipeline derive` fits a
    parameter's formulas (`approximate.search.formulas`): lines, by least squares to the per-n optima at
    the grid's exponents, then every line's coefficients polished together by minimax of the relative
    error over the box of zone and n, its worst point added (`polish_formulas`). With `complexity`
    > 0, also the symbolic regression's formulas of the per-n optima at the grid's and the halfway
    exponents (`corrected`: each level's formulas polished on the box, the best level kept where it
    beats the lines). Returns the lines' slopes and intercepts, their error on the box, and the
    formulas (sympy text in n, one per constant; empty where none beats the lines)."""
    from ..approximate.search import formulas, templates
    from ..approximate.search.per_value import PerValue

    form = template(family, text)
    problem = search_target(target, level, lo, hi)
    f = problem.numpy()
    per_value = PerValue(np.asarray(values, dtype=np.float64), np.asarray(constants, dtype=np.float64),
                                    np.asarray(errors, dtype=np.float64), np.asarray(on_grid, dtype=bool))
    coefficients, box_error = formulas.polish_formulas(form, per_value, ("line",) * form.count, problem, f)
    out = dict(slopes=coefficients[:, formulas.POWERS.index(1)], intercepts=coefficients[:, formulas.POWERS.index(0)],
               box_error=float(box_error), formulas=[], formulas_box_error=float("nan"), formula_level=0)
    if complexity > 0:
        n = problem.symbols()[-1]
        k = templates.constant_symbols(form.count)
        pixel = form.expression.xreplace(dict(zip(k, formulas.formula_expressions(coefficients, n))))
        line = formulas.Fitted(form, "line", coefficients, per_value, formulas.measure_box(pixel, problem, f), pixel,
                                 None)
        better = formulas.corrected(line, problem, f, int(complexity), log=lambda _: None)
        if better is not None:
            out.update(formulas=[str(e) for e in better.formulas], formula_level=int(better.formula[len("found"):]),
                       formulas_box_error=float(better.errors["max_rel_error"]))
    return out


def formulas_at(formulas, n) -> np.ndarray:
    """The constants at the exponents n from their formulas (sympy text in n): (n, constants)."""
    import sympy as sp
    symbol = sp.Symbol("n", real=True)
    n = np.asarray(n, dtype=np.float64)
    return np.stack([np.broadcast_to(np.asarray(sp.lambdify([symbol], expressions.parse(e, {"n": symbol}), "numpy")(n),
                                                dtype=np.float64), n.shape) for e in formulas], axis=1)


def line_text(a: float, b: float) -> str:
    """A line in n as text: "1.44269 n - 0.377261"."""
    return f"{a:.6g} n {'-' if b < 0 else '+'} {abs(b):.6g}"


def shader_lines(family: str, slopes, intercepts) -> tuple[np.ndarray, np.ndarray]:
    """The shader parameters' lines in n from the template constants' lines (`shader_parameters` is
    affine: its values at n = 0 and n = 1 give them)."""
    at_0 = np.asarray(shader_parameters(family, np.asarray(intercepts, dtype=np.float64)), dtype=np.float64)
    at_1 = np.asarray(shader_parameters(family, np.add(slopes, intercepts)), dtype=np.float64)
    return at_1 - at_0, at_0


def shader_formulas(family: str, formulas) -> list[str]:
    """The shader parameters' formulas (sympy text in n, full precision) from the template constants'."""
    import sympy as sp
    symbol = sp.Symbol("n", real=True)
    return [str(e) for e in shader_parameters(family, [expressions.parse(e, {"n": symbol}) for e in formulas])]


def parameter_texts(names, slopes, intercepts, formulas=()) -> dict[str, str]:
    """Each shader parameter as text: its line, or its formula (6 significant digits)."""
    import sympy as sp
    if formulas:
        return {p: str(expressions.parse(e, {"n": sp.Symbol("n", real=True)}).evalf(6)) for p, e in zip(names, formulas)}
    return {p: line_text(a, b) for p, a, b in zip(names, slopes, intercepts)}


@toolchains.uses(*toolchains.MACHINE_CODE)
def compiled_cycles(families, grammar=()) -> dict:
    """{architecture: {family or grammar form: cycles net of the shader returning t}} of each
    family's shader and each grammar form's (its text in w = n (1 - t)), compiled for every
    architecture whose compiler runs here by `derive`'s costing (`isa.machine_code.form_cycles`:
    the parameters push constants, A, B, C as c0, c1, c2; a grammar form's constants c0 ... and n after
    them), or {"reason": why not}."""
    from ..approximate.search import settings
    from ..symbolic import grammar as grammar_

    bodies = {name: (re.sub(r"\b[ABC]\b", lambda m: f"c{'ABC'.index(m.group(0))}", lobe_families.FAMILIES[name].glsl),
                     ["t"]) for name in families}
    n_at = settings.MAX_CONSTANTS          # (after the most constants a form has)
    for text in grammar:
        form = grammar_.glsl(grammar_.parse(text), [], variable="w", uniforms="c")
        bodies[text] = (f"float w = c{n_at} - c{n_at} * t;\n    return "
                        + re.sub(r"\bc\[(\d+)\]", r"c\1", form) + ";", ["t"])
    try:
        cycles, _, devices = machine_code.form_cycles(bodies, ["t"])
    except machine_code.CompilerMissing as e:
        return dict(available=False, reason=str(e), cycles={}, devices={})
    cycles = {a: {name: round(c, 1) for name, c in by.items()} for a, by in cycles.items() if by}
    return dict(available=True, reason="", cycles=cycles, devices=devices)


@toolchains.uses(*toolchains.MACHINE_CODE)
def cost_tables(count: int) -> dict:
    """`symbolic.gpu_costs.operation_costs` on `count` calibration forms, or why not."""
    from ..symbolic import gpu_costs
    try:
        return dict(available=True, **gpu_costs.operation_costs(int(count), uniforms=True))
    except machine_code.CompilerMissing as e:
        return dict(available=False, reason=str(e), tables={}, held_out={})


def predicted_cycles(name: str, table: dict) -> float:
    """The family's cycles by the cost table (fitted on forms with uniform constants): its form's
    operations, each clamp max(., 0) at the cost of an addition (one vector ALU instruction, as an
    addition is), and each exp2 at the table's exp less a multiply (exp x compiles to
    exp2(x log2 e))."""
    from ..symbolic import gpu_costs, grammar
    if name not in lobe_families.FAMILIES:
        return grammar_predicted(name, table)
    family = lobe_families.FAMILIES[name]
    counts = dict(zip(gpu_costs.OPERATIONS, gpu_costs.operation_counts(grammar.parse(family.grammar))))
    cycles = sum(counts[op] * table[op] for op in gpu_costs.OPERATIONS)
    return round(float(cycles + family.clamps * table["+"] - counts["exp"] * table["*"]), 2)


def front_of(rows) -> list[dict]:
    """The rows no other row beats at equal or lower cycles, by max d: `pipeline derive`'s front
    (`approximate.measures.fronts.front`; a tie kept by the row listed first: a family before a grammar form
    that is the same function written in w)."""
    return fronts.front(rows, "d")


def placement(cycles: float, d: float, front) -> dict | None:
    """The front member that beats a lobe of `cycles` and max d `d`: the most accurate member of at
    most its cycles (`approximate.measures.fronts.verdict`, as derive places its anchors), where its d is
    smaller; None where the lobe is on the front (nothing beats it)."""
    best = fronts.verdict(cycles, d, [dict(r, name=i) for i, r in enumerate(front)], "d")
    return front[best["by"]] if best["by"] is not None and best["ratio"] < 1.0 else None


def registry_cycles(rows, lobe: str, architecture: str, power: int):
    """Compiled cycles of a registry lobe alone (n and its parameter per material) from gpu_isa's rows;
    a lobe that follows the run's power (f_Q, f_Q2) is the family's row at that power (the same shader
    with k a uniform; the registry's own rows are compiled at m = 2)."""
    what = "lobe"
    if registry.LOBES[lobe].follows_power:     # f_Q, f_Q2 at the run's power: the family's shader, k a uniform
        lobe, what = registry.family_name(power), "family lobe"
    row = next((r for r in rows if r["lobe"] == lobe and r["what"] == what and r["architecture"] == architecture
                and r["normalization"] == ""), None)
    return None if row is None else float(row["cycles"])


def run(config, inputs, memo):
    n_all = np.asarray(n_range(config), dtype=np.float64)
    level = float(inputs["zone.level"])
    settings = SolverSettings(config["solver.rtol"], config["solver.atol"], config["solver.max_steps"])
    cells = config["comparison.grid_cells"]
    ranges = [(max(float(lo), n_all[0]), min(float(hi), n_all[-1])) for lo, hi in config["lobe_search.n_ranges"]]
    ranges = [(lo, hi) for lo, hi in ranges if lo < hi] or [(n_all[0], n_all[-1])]
    names = list(config["lobe_search.families"])
    target = config["lobe_search.target"]
    zone_points = config["lobe_search.zone_points"]
    n = n_grid(ranges, config["lobe_search.points_per_range"])
    tables = memo("gpu_cost_tables", cost_tables, count=config["lobe_search.calibration_forms"])

    # Every searched form: the families, then what the grammar reaches.
    forms = {}
    for name in names:
        fit = memo("lobe_family_fit", fit_family, family=name, n=n, level=level, zone_points=zone_points, target=target)
        exact = exact_errors(name, n, fit["grid_P"], level, cells, settings, target)
        family = lobe_families.FAMILIES[name]
        count = len(family.start)           # (the template's constants: A, B, C, or square_peak1's k = A)
        forms[name] = dict(fit, d=exact["d"], D=exact["D"], constants=fit["grid_P"][:, :count],
                           mid_constants=fit["mid_P"][:, :count], parameter_names=family.parameters,
                           expression=family.formula)
    reach = dict(searched=0, kept=[])
    if config["lobe_search.grammar_complexity"] > 0:
        from ..symbolic import grammar
        reach = memo("lobe_grammar_reach", grammar_reach, complexity=config["lobe_search.grammar_complexity"],
                     operations=config["lobe_search.grammar_operations"], level=level,
                     n_screen=[float(n[0]), float(n[-1])], keep=config["lobe_search.grammar_keep"], target=target,
                     table=tables["tables"].get("rdna3") if tables["available"] else None)
        for i, (text, start) in enumerate(zip(reach["kept"], reach["constants"]), 1):
            fit = memo("lobe_family_fit", fit_family, family=text, n=n, level=level, zone_points=zone_points,
                       target=target, own_start=list(start))
            dense = dense_errors(text, n, fit["grid_q"], level, target)
            count = len(start)
            forms[f"grammar_{i}"] = dict(fit, d=dense["d"], D=dense["D"], constants=fit["grid_q"],
                                         mid_constants=fit["mid_q"], grammar=text,
                                         admissible=bool(np.all(dense["lowest"] >= 0.0)),
                                         parameter_names=tuple(f"c{j}" for j in range(count)),
                                         expression=f"{grammar.show(grammar.parse(text), variable='w')}, "
                                                    "w = n (1 - t)")

    # Per range: the form's worst n on the grid, the grid check, and its constants as lines in n
    # (derive's formulas) measured at every integer n of the range (and, where a line is not enough,
    # the symbolic regression's formulas).
    members = []
    formula_complexity = config["lobe_search.formula_complexity"]

    def measured(name, f, constants, exponents):
        if "grammar" in f:
            return dense_errors(f["grammar"], exponents, constants, level, target)
        return exact_errors(name, exponents, shader_values(name, constants), level, cells, settings, target)

    for lo, hi in ranges:
        inside = (n >= lo) & (n <= hi)
        mids = midpoints(n)
        mid_inside = (mids >= lo) & (mids <= hi)
        integers = np.arange(np.ceil(lo), np.floor(hi) + 1.0)
        for name, f in forms.items():
            i = int(np.argmax(np.where(inside, f["d"], -np.inf)))
            grid_error = float(f["grid_zone_error"][inside].max())
            mid_error = float(f["mid_zone_error"][mid_inside].max()) if mid_inside.any() else grid_error
            per_n = dict(values=np.r_[n[inside], mids[mid_inside]],
                         constants=np.r_[f["constants"][inside], f["mid_constants"][mid_inside]],
                         errors=np.r_[f["grid_zone_error"][inside], f["mid_zone_error"][mid_inside]],
                         on_grid=np.r_[np.ones(inside.sum(), bool), np.zeros(mid_inside.sum(), bool)],
                         family=name if "grammar" not in f else "grammar", text=f.get("grammar", ""), level=level,
                         target=target, lo=lo, hi=hi)
            fitted = memo("lobe_parameter_formulas", parameter_formulas, **per_n)
            slopes, intercepts = np.asarray(fitted["slopes"]), np.asarray(fitted["intercepts"])
            line = measured(name, f, slopes * integers[:, None] + intercepts, integers)
            j = int(np.argmax(line["d"]))
            slopes, intercepts = shader_lines(name, slopes, intercepts)
            texts = parameter_texts(f["parameter_names"], slopes, intercepts)
            corrected = dict(formulas=texts, d_formula=float(line["d"][j]), D_formula=float(line["D"].max()),
                             formula_complexity=0, formula_searched=False, parameter_formulas=[])
            if formula_complexity > 0 and line["d"][j] > LINE_ENOUGH * f["d"][i]:
                found = memo("lobe_parameter_formulas", parameter_formulas, **per_n, complexity=formula_complexity)
                corrected["formula_searched"] = True
                if found["formulas"]:
                    errors = measured(name, f, formulas_at(found["formulas"], integers), integers)
                    if errors["d"].max() < corrected["d_formula"]:
                        full = shader_formulas(name, found["formulas"])
                        corrected.update(formulas=parameter_texts(f["parameter_names"], slopes, intercepts, full),
                                         d_formula=float(errors["d"].max()), D_formula=float(errors["D"].max()),
                                         formula_complexity=int(found["formula_level"]), parameter_formulas=full)
            members.append(dict(
                family=name, expression=f["expression"], grammar=f.get("grammar", ""), n_range=[lo, hi],
                admissible=f.get("admissible", True),
                d=float(f["d"][i]), n_at_max=float(n[i]),
                D=float(f["D"][inside].max()), D_n_at_max=float(n[inside][np.argmax(f["D"][inside])]),
                grid_check=max(mid_error / grid_error - 1.0, 0.0) if grid_error > 0 else 0.0,
                parameters=texts, parameter_slopes=[float(a) for a in slopes],
                parameter_intercepts=[float(b) for b in intercepts], line_box_error=float(fitted["box_error"]),
                d_line=float(line["d"][j]), d_line_n_at_max=float(integers[j]), D_line=float(line["D"].max()),
                **corrected))

    compiled = memo("lobe_family_cycles", compiled_cycles, families=sorted(names), grammar=list(reach["kept"]))
    lobes = inputs["lobe_comparison.lobes"]
    # The registry's lobes approximate cos^n: placed on its fronts only.
    placed_keys = [(i, lobe) for i, lobe in enumerate(lobes) if lobe["lobe"] == lobe["registry_key"]
                   and target == "cos_n"]
    front, candidates, placements = [], [], []
    if compiled["available"]:
        # The registry's order (a stored dict comes back with its keys sorted).
        for architecture in (a for a in machine_code.ARCHITECTURES if a in compiled["cycles"]):
            table = tables["tables"].get(architecture) if tables["available"] else None
            for lo, hi in ranges:
                rows = [dict(m, architecture=architecture, cycles=compiled["cycles"][architecture][m["grammar"] or m["family"]],
                             cycles_predicted=predicted_cycles(m["grammar"] or m["family"], table) if table
                             else float("nan"))
                        for m in members if m["n_range"] == [lo, hi]]
                on_front = front_of([r for r in rows if r["admissible"]])
                for row in rows:
                    row["on_front"] = row in on_front
                candidates += rows
                front += on_front
                inside = (n_all >= lo) & (n_all <= hi)
                for i, lobe in placed_keys:
                    cycles = registry_cycles(inputs["gpu_isa.rows"], lobe["registry_key"], architecture,
                                             inputs["gpu_isa.power"])
                    if cycles is None:
                        continue
                    d = float(np.asarray(inputs["lobe_comparison.d_curves"])[i][inside].max())
                    D = float(np.asarray(inputs["lobe_comparison.D_curves"])[i][inside].max())
                    best = placement(cycles, d, on_front)
                    placements.append(dict(
                        lobe=lobe["registry_key"], label=lobe["label"], architecture=architecture, n_range=[lo, hi],
                        cycles=cycles, d=d, D=D, on_front=best is None,
                        dominated_by=best["family"] if best else "", dominated_by_cycles=best["cycles"] if best else -1.0,
                        d_ratio=d / best["d"] if best else 1.0))
    prediction_error = {a: max((abs(c["cycles_predicted"] - c["cycles"]) for c in candidates if c["architecture"] == a),
                               default=float("nan")) for a in machine_code.ARCHITECTURES if a in compiled["cycles"]} \
        if tables["available"] else {}
    return dict(
        available=bool(compiled["available"]), reason=compiled["reason"], devices=compiled["devices"], target=target,
        cycles_prediction_max_error=prediction_error,
        n_grid=n, ranges=[list(r) for r in ranges], families=names,
        grammar_searched=int(reach["searched"]), grammar_kept=list(reach["kept"]),
        per_n=[dict(family=name, q=f["grid_q"].tolist(), P=f["grid_P"].tolist() if "grid_P" in f else [],
                    d=f["d"].tolist(), D=f["D"].tolist(), zone_error=f["grid_zone_error"].tolist())
               for name, f in forms.items()],
        members=members, candidates=candidates, front=front, placements=placements,
        grid_check_max=max(m["grid_check"] for m in members), line_enough=LINE_ENOUGH,
        cost_tables=tables["tables"], cost_tables_held_out=tables["held_out"])
