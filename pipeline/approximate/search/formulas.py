"""A template's constants as formulas of the parameter (lines, quadratics, a + b p + c / p and
cheaper mixes), polished together by minimax over the whole box (`polish_formulas`, the parametric
engine's step 3), the box's measure (`measure_box`), the formulas the symbolic regression corrects
(`corrected`) and every template's forms (`material_forms`)."""

from __future__ import annotations

import dataclasses
import time

import numpy as np

from . import minimax
from ..forms import free_numbers
from .settings import EXCHANGES, MAX_CONSTANTS, PRUNE
from ..targets import AXIS_POINTS, MEASURE_GRID, mesh, numpy_function, PARAMETER_VALUES, place, Target, unit_box, weight_of
from .per_value import Dropped, fit_per_value, Model, PerValue
from .templates import constant_symbols, sympy_functions, Template


# The rule that drops a template before its formulas (`material_forms`), as the report states it.
DROP_RULE = ("a template whose optimum at one value of the parameter is already no better than the best "
             "constant's error over the whole box is dropped there: no formula of the parameter beats its "
             "per-value optimum, so none of its forms would beat a constant; its other values are not fitted")


@dataclasses.dataclass
class Fitted:
    """A template with its constants as formulas (coefficients, lowest power first) of the
    parameter, polished on the whole box, and its errors."""

    template: Template
    formula: str
    coefficients: np.ndarray        # (count, degree + 1)
    per_value: PerValue
    errors: dict                    # max_abs_error, max_rel_error over the box
    pixel: object                   # sympy: the formulas substituted (the parameter per pixel)
    material: object                # sympy: the constants as push constants c0, c1, ...
    formulas: tuple | None = None   # sympy, per constant, where not the coefficients' (`corrected`)

    @property
    def name(self) -> str:
        return f"{self.template.name}_{self.formula}"

    def constant_formulas(self, parameter) -> list:
        return list(self.formulas) if self.formulas is not None else formula_expressions(self.coefficients, parameter)


# Each constant's formula in the parameter p: its powers of p (`laurent`, a + b p + c / p, where the
# parameter's range excludes 0: GGX's D in alpha^2 has such constants, pi / alpha^2 among them).
KINDS = {"constant": (0,), "proportional": (1,), "line": (0, 1), "quadratic": (0, 1, 2), "laurent": (-1, 0, 1)}
TAGS = {"constant": "c", "proportional": "p", "line": "l", "quadratic": "q", "laurent": "i"}
POWERS = (-1, 0, 1, 2)      # the coefficients' columns, in this order


def formula_name(kinds) -> str:
    """`line` or `quadratic` where every constant has that formula, else one letter per constant
    (c constant, p proportional, l line, q quadratic): `formulas_pl`."""
    if len(set(kinds)) == 1 and kinds[0] in ("line", "quadratic", "laurent"):
        return kinds[0]
    return "formulas_" + "".join(TAGS[k] for k in kinds)


def formula_variants(count: int, reduce: bool, laurent: bool = False) -> list[tuple]:
    """The formulas tried for a template of `count` constants: every constant a line, every one a
    quadratic, every one a + b p + c / p (`laurent`: a parameter range without 0); with `reduce`,
    also each constant alone a proportion or a constant (the others lines), and every constant a
    proportion or a constant, whichever fits its values (`None` there: chosen by `_cheapest`)."""
    out = [("line",) * count, ("quadratic",) * count] + ([("laurent",) * count] if laurent else [])
    if reduce:
        for i in range(count):
            for kind in ("proportional", "constant"):
                out.append(tuple(kind if j == i else "line" for j in range(count)))
        if count > 1:
            out.append(None)
    return out


def formula_expressions(coefficients, parameter) -> list:
    """Each constant's formula as sympy in the parameter's symbol (a polynomial in Horner form), from
    its coefficients of the POWERS of p (zero where the formula has no such term)."""
    import sympy as sp

    out = []
    for row in coefficients:
        terms = sum(((sp.Integer(1) if a == 1 else sp.Float(float(a), 17)) * parameter ** j
                     for j, a in zip(POWERS, row) if a != 0), sp.Integer(0))
        polynomial = terms.is_Add and row[POWERS.index(-1)] == 0
        out.append(sp.horner(terms, parameter) if polynomial else terms)
    return out


def _start_coefficients(per_value: PerValue, kinds) -> np.ndarray:
    """(count, len(POWERS)): each constant's formula fitted by least squares to its values on the grid."""
    grid = per_value.on_grid
    p = per_value.values[grid]
    out = np.zeros((len(kinds), len(POWERS)))
    for i, kind in enumerate(kinds):
        powers = KINDS[kind]
        A = np.power.outer(p, np.array(powers, dtype=float))
        solution, *_ = np.linalg.lstsq(A, per_value.constants[grid, i], rcond=None)
        out[i, [POWERS.index(k) for k in powers]] = solution
    return out


def _cheapest(per_value: PerValue, count: int) -> tuple:
    """Per constant, a proportion or a constant, whichever fits its values on the grid better (least
    squares)."""
    grid = per_value.on_grid
    p = per_value.values[grid]
    kinds = []
    for i in range(count):
        v = per_value.constants[grid, i]
        spread = {kind: float(np.sum((np.power.outer(p, np.array(KINDS[kind]))
                                       @ np.linalg.lstsq(np.power.outer(p, np.array(KINDS[kind])), v, rcond=None)[0]
                                       - v) ** 2)) for kind in ("proportional", "constant")}
        kinds.append(min(spread, key=spread.get))
    return tuple(kinds)


def polish_formulas(template: Template, per_value: PerValue, kinds, target: Target, f, zero=None):
    """Step 3: (coefficients (count, len(POWERS)), error over the box) of the template's constants as
    the formulas `kinds` (one of KINDS per constant) of the parameter; the coefficients marked in
    `zero` (a boolean array of their shape) held at 0. A template may read the parameter itself
    (the lobe search's forms in w = n (1 - t))."""
    coefficients = _start_coefficients(per_value, kinds)
    mask = np.zeros(coefficients.shape, dtype=bool)
    for i, kind in enumerate(kinds):
        mask[i, [POWERS.index(k) for k in KINDS[kind]]] = True
    if zero is not None:
        mask &= ~zero
        coefficients[zero] = 0.0
    symbols = target.symbols()
    reads_parameter = symbols[-1] in template.expression.free_symbols and target.parameter is not None
    variables = symbols if reads_parameter else symbols[:len(target.variables)]
    model = Model(template.expression, variables, constant_symbols(template.count))
    axes = slice(None) if reads_parameter else slice(0, -1)
    used = mask.any(axis=0)                 # (the powers some formula has: 1 / p only where one has it)
    powers = np.array(POWERS, dtype=float)[used]

    def full(a):
        A = np.zeros(coefficients.shape)
        A[mask] = a
        return A

    def joint(a, x):
        shape = np.shape(x[0])
        x = [np.ravel(c) for c in x]
        k = np.power.outer(x[-1], powers) @ full(a)[:, used].T        # (points, count)
        return model(list(k.T), x[axes]).reshape(shape)

    def jacobian(a, x):
        P = np.power.outer(x[-1], powers)
        J = model.jacobian(list((P @ full(a)[:, used].T).T), x[axes])  # (points, count)
        return (J[:, :, None] * P[:, None, :])[:, mask[:, used]]

    a, error = minimax_on_box(joint, jacobian, coefficients[mask], target, f, per_value.values)
    return full(a), error


def minimax_on_box(model, jacobian, a0, target, f, values) -> tuple[np.ndarray, float]:
    """(the constants, the error over the whole box) of `model(a, points)` (the points: the axes'
    columns) fitted by minimax on the variables' mesh at the parameter's `values`, the box's worst point
    added and fitted again (`EXCHANGES` times): the polish of every formula's constants together."""
    return minimax_on_box_parts([(model, jacobian, target, f)], a0, values)


def minimax_on_box_parts(parts, a0, values) -> tuple[np.ndarray, float]:
    """`minimax_on_box` for several outputs sharing their constants (a pair's A and B): `parts` are
    (model, jacobian, target, f) on one box; the error is the largest of the parts', each part's
    worst point added to every part's points."""
    from ...optics import brdf

    target = parts[0][2]
    points = mesh(target, AXIS_POINTS, values)
    lo, hi = unit_box(target)
    a = np.asarray(a0, dtype=np.float64)
    best = None
    for _ in range(EXCHANGES + 1):
        ys = [part_f(*points) for _, _, _, part_f in parts]
        y = np.concatenate(ys)
        weight = np.concatenate([weight_of(t)(v) for (_, _, t, _), v in zip(parts, ys)])
        model = lambda c, x: np.concatenate([m(c, x) for m, *_ in parts])       # noqa: E731
        jacobian = lambda c, x: np.concatenate([j(c, x) for _, j, *_ in parts])  # noqa: E731
        a, on_points = minimax.slp_points(model, jacobian, a, y, weight, points)
        measured = [brdf.largest_error(lambda *s, m=m: m(a, place(t, s)), lambda *s, t=t, g=g: g(*place(t, s)), lo, hi,
                                       relative=t.metric == "rel", **MEASURE_GRID) for m, _, t, g in parts]
        e = max(err for err, _ in measured)
        if best is None or e < best[1]:
            best = (a.copy(), e)
        if not np.isfinite(e) or e <= on_points * (1 + 1e-9):
            break
        for _, where in measured:
            where = place(target, [np.atleast_1d(w) for w in where])
            points = [np.r_[p, w] for p, w in zip(points, where)]
    return best


def measure_box(expression, target: Target, f) -> dict:
    """{max_abs_error, max_rel_error} of a sympy expression in the axes over the whole box."""
    from ...optics import brdf

    exact = f
    approx = numpy_function(expression, target.symbols())
    if any(a.lo_of for a in target.variables):          # (measured on the unit box: `place`)
        approx = (lambda g: lambda *s: g(*place(target, s)))(approx)
        f = lambda *s: exact(*place(target, s))        # noqa: E731
    lo, hi = unit_box(target)
    out = {}
    for key, relative in (("max_abs_error", False), ("max_rel_error", True)):
        if relative and target.floor > 0:
            floor = target.floor
            value, _ = brdf.largest(lambda *s: (approx(*s) - f(*s)) / np.maximum(np.abs(f(*s)), floor), lo, hi,
                                    **MEASURE_GRID)
        else:
            value, _ = brdf.largest_error(approx, f, lo, hi, relative=relative, **MEASURE_GRID)
        out[key] = float(value)
    return out


def material_forms(templates, target, f, log, formula_complexity: int = 0,
                   dropped: list | None = None) -> list[Fitted]:
    """Steps 2 and 3 for every template: every template's constants as lines and quadratics; the
    templates no other of `templates` with as few constants beats per value (the front of constants
    against the per-value optimum) also with cheaper formulas (`formula_variants`) and, with
    `formula_complexity` > 0, with their lines corrected by the symbolic regression (`corrected`).
    A template whose optimum at a value is already no better than the best constant's error over the
    box is dropped there (`DROP_RULE`; the rest of its values not fitted), and appended to `dropped`
    as {template, at, per_value_error, constant_error, values_fitted}."""
    import sympy as sp

    symbols = target.symbols()
    parameter = symbols[-1]
    uniforms = [sp.Symbol(f"c{i}", real=True) for i in range(MAX_CONSTANTS)]
    from ..measures.fronts import rounding_floor

    constant = _constant_error(target, f)
    floor = rounding_floor(target, constant)
    fits = []
    for template in templates:
        per_value = fit_per_value(template, target, f, give_up=constant)
        if per_value is None:
            log(f"  {template.name}: no finite fit at some value of {target.parameter.name}; left out")
            continue
        if isinstance(per_value, Dropped):
            # no formula beats the per-value optimum, and no form at least the best constant's error is
            # on a front: nothing more to fit
            log(f"  {template.name}: dropped at {target.parameter.name} = {per_value.value:.4g} (value "
                f"{per_value.fitted} of {2 * PARAMETER_VALUES - 1} fitted): per value {per_value.error:.4g}, no better "
                f"than a constant ({constant:.4g}); no formulas")
            if dropped is not None:
                dropped.append(dict(template=template.name, at=per_value.value, per_value_error=per_value.error,
                                    constant_error=float(constant), values_fitted=per_value.fitted))
            continue
        fits.append((template, per_value))
    out = []
    for template, per_value in fits:
        started = time.perf_counter()
        reduce = not any(other.count <= template.count and other_fit.errors.max() < per_value.errors.max()
                         for other, other_fit in fits if other is not template)
        k = constant_symbols(template.count)
        found = []
        for kinds in formula_variants(template.count, reduce, laurent=target.parameter.lo > 0):
            kinds = _cheapest(per_value, template.count) if kinds is None else kinds
            name = formula_name(kinds)
            if any(m.formula == name for m in found):
                continue
            coefficients, _ = polish_formulas(template, per_value, kinds, target, f)
            pixel = template.expression.xreplace(dict(zip(k, formula_expressions(coefficients, parameter))))
            errors = measure_box(pixel, target, f)
            pruned = np.where(np.abs(coefficients) < PRUNE * np.abs(coefficients).max(), 0.0, coefficients)
            if np.any(pruned != coefficients):
                # a coefficient at rounding's level (a term the target lacks) dropped and the others polished
                # again without it, where that costs nothing
                pruned, _ = polish_formulas(template, per_value, kinds, target, f, zero=(pruned == 0) & (coefficients != 0))
                trial = template.expression.xreplace(dict(zip(k, formula_expressions(pruned, parameter))))
                measured = measure_box(trial, target, f)
                key = _error_key(target)
                if measured[key] <= max(errors[key] * (1 + 1e-6), floor):     # (float32 rounding: equal)
                    coefficients, pixel, errors = pruned, trial, measured
            zero = {ki: 0 for ki, row in zip(k, coefficients) if not np.any(row)}
            material = template.expression.xreplace(zero).xreplace(dict(zip(k, uniforms)))
            found.append(Fitted(template, name, coefficients, per_value, errors, pixel, material))
        line = next((m for m in found if m.formula == "line"), None)
        if formula_complexity > 0 and reduce and line is not None:
            better = corrected(line, target, f, formula_complexity, log)
            if better is not None:
                found.append(better)
        out += found
        log(f"  {template.name}: per value {per_value.errors.max():.4g}; "
            + ", ".join(f"{m.formula} {m.errors[_error_key(target)]:.4g}" for m in found)
            + f" ({time.perf_counter() - started:.1f} s)")
    return out


FORMULA_OPERATIONS = "+,-,*,/,log,sqrt"     # of a constant's formula in the parameter (per material: any is free)


def corrected(line: Fitted, target, f, complexity: int, log) -> Fitted | None:
    """The template's constants as formulas the symbolic regression finds, as the paper found coef(n):
    each constant's values at the per-value optima searched (`symbolic.search`, FORMULA_OPERATIONS,
    up to `complexity`, least squares), and so is their residual from their least-squares line (a
    formula is then that line plus the member: a line with a small correction, c / p say, is found
    at the correction's complexity; the polished line of `line` is no base, minimax lines being many
    where one value sets the error); at each complexity level every constant takes the member of least RMS
    at or below it (its line, from `line`, where none holds its values better), the formulas'
    numbers are polished together by minimax on the box (`_polished`: equal numbers are one), the
    box's error is measured, and the level of least error is kept where it beats the lines. None
    where no level does."""
    import sympy as sp

    from ...symbolic import grammar, search

    parameter = target.symbols()[-1]
    values = line.per_value.values
    line_expressions = formula_expressions(line.coefficients, parameter)
    fronts = []
    for j in range(line.template.count):
        y = line.per_value.constants[:, j]
        slope, intercept = np.polyfit(values, y, 1)
        residual = y - (slope * values + intercept)
        line_rms = float(np.sqrt(np.mean(residual ** 2)))
        members = []
        for base, base_values in ((sp.Integer(0), 0.0),
                                  (sp.Float(float(slope), 17) * parameter + sp.Float(float(intercept), 17), y - residual)):
            found = search.search(values, y - base_values, int(complexity), FORMULA_OPERATIONS)
            # a member that holds the constant's values no better than its line leaves the line in place
            members += [(int(found["complexity"][i]), float(found["rms"][i]),
                         base + grammar.substitute(found["forms"][i],
                                                   [sp.Float(float(c), 17) for c in
                                                    found["constants"][i][:grammar.constants(found["forms"][i])]],
                                                   [parameter], sympy_functions()))
                        for i in found["front"] if found["rms"][i] < line_rms]
        fronts.append(members)
    k = constant_symbols(line.template.count)
    key = _error_key(target)
    best = None
    for level in sorted({c for front in fronts for c, _, _ in front}):
        formulas = [expression if not any(c <= level for c, _, _ in front) else
                    min((m for m in front if m[0] <= level), key=lambda m: m[1])[2]
                    for expression, front in zip(line_expressions, fronts)]
        pixel, polished = _polished(line.template.expression.xreplace(dict(zip(k, formulas))), target, f, values)
        formulas = [e.xreplace(polished) for e in formulas]
        errors = measure_box(pixel, target, f)
        if errors[key] < (best.errors[key] if best else line.errors[key] * (1 - 1e-6)):
            best = dataclasses.replace(line, formula=f"found{level}", pixel=pixel, errors=errors,
                                       formulas=tuple(formulas))
    log(f"  {line.template.name}: lines {line.errors[key]:.4g}, formulas found "
        + (f"{best.errors[key]:.4g} ({best.formula})" if best else "no better"))
    return best


def _polished(expression, target, f, values):
    """(the expression (in the axes) with its numbers polished together by minimax on the box
    (`minimax_on_box`, from their values), {each number: its polished value})."""
    import sympy as sp

    (free,), q, numbers = free_numbers(expression)
    model = Model(free, target.symbols(), q)
    a, _ = minimax_on_box(model, model.jacobian, [float(v) for v in numbers], target, f, values)
    polished = {v: sp.Float(x, 17) for v, x in zip(numbers, a)}
    return free.xreplace(dict(zip(q, polished.values()))), polished


def _error_key(target) -> str:
    return "max_abs_error" if target.metric == "abs" else "max_rel_error"


def _constant_error(target, f) -> float:
    """The error of the best constant over the measuring grid (a form worth a cycle beats it)."""
    from ..measures.measure import best_constant_error

    return best_constant_error(f(*mesh(target, 17)), target.metric, target.floor)
