"""`derive` for targets of several variables and a per-material parameter: the height-correlated
Smith-GGX visibility V(NoV, NoL; alpha) (`targets.registry`), or any `targets.Target` of up to
three variables and parameter (in Python: `pipeline.derive(Target(...))`).

A target of this shape has variables computed per pixel (NoV, NoL), each with its range, and
at most one parameter with its range (alpha, roughness, n), which a material sets, or a texture per
pixel. Its error is the largest over the whole box, variables and parameter
(`optics.brdf.largest_error`: a grid, refined where the error peaks).

1. Templates: forms in the variables whose constants are left free:
   - the families linear in their constants under an outer function: a polynomial and the
     reciprocal of a polynomial, of total degree 1 and 2 and bilinear, each with and without its
     constant term, in symmetric monomials (x + y, x y, x^2 + y^2) where the target is symmetric in
     its two variables (checked on the fitting grid);
   - the grammar's forms in the variables, found by the ladder of grammars (`symbolic.ladder`) at the
     parameter's middle value.
2. Per value: each template's constants fitted by minimax (`minimax.slp_points`) at every value of
   the parameter's grid (`PARAMETER_VALUES` Chebyshev values and the values halfway between them,
   where the worst value is checked), each start from the neighbour's constants. The largest of
   these errors is the template's per-value optimum: no formula of the parameter does better, so a
   template whose optimum is no better than the best constant's error goes no further (no form at
   that error is on a front).
3. Formulas: each constant a formula of the parameter p (`KINDS`: a line, a quadratic, a + b p + c / p
   where p's range excludes 0, and cheaper mixes: `formula_variants`), fitted by least squares to
   the grid's values, then all the formulas' coefficients polished together by minimax on the points
   of every value, the box's worst point added and polished again (`EXCHANGES` times); the error
   measured over the whole box. A reciprocal template's pixel form is also written with one
   single-term formula's factor in the numerator (`_scaled`: the same function, cheaper on NVIDIA).
   With `formula_complexity` > 0, the templates on the per-value front also take formulas the
   symbolic regression finds from each constant's values and from their residual from their line
   (`corrected`, as the paper found coef(n)).
4. Per pixel: the grammar's forms in the variables and the parameter together, by the ladder; and
   each anchor's own form with its decimal numbers refitted by minimax on the box, and again with
   the factors a back end gets for free held and its sums' integers refitted
   (`anchor_refits.refitted_box_anchors`: the same operations, so mostly the same cost).
5. Costs: every form compiled for each architecture, a fragment shader with one input per variable
   and the parameter (`isa.machine_code.form_cycles`, net of the shader writing the variables the
   form reads): `parameter_per = "material"`, the constants push constants that
   the CPU computes once per material from the formulas; `pixel`, the formulas compiled into the
   shader with the parameter per pixel (textured roughness), the parameter's read paid by the form. The fronts are read off per
   architecture and per `parameter_per`; the anchors, which engines evaluate with the parameter per
   pixel, are pixel rows, held against the pixel front (`fronts.verdict`).

The parts, each in its room: the target and its box (`targets`); step 1 (`search.templates`); step
2 (`search.per_value`); step 3, the box's measure (`search.formulas`); the anchors' refits
(`search.anchor_refits`); the search kept between runs (`search.box_search`). Here: the costs, the
execution and `derive`; a pair's (`pairs.derive_pair`) beside it.
"""

from __future__ import annotations

import dataclasses
import functools
import time

import numpy as np

from ..forms import Form, not_printed
from ..targets import DeriveError

from ..search.box_search import _searched, _text
from ..search.formulas import _constant_error, _error_key, measure_box
from ..search.settings import MAX_FORMULA_COMPLEXITY
from ..targets import MEASURE_GRID, numpy_function, place, Target, unit_box


# ---- costs --------------------------------------------------------------------------------------

@functools.lru_cache(maxsize=4096)
def glsl_text(expr, precision: str | None = None) -> str:
    """A form as GLSL in its symbols' names (forms' printer: exp2, squarings, inversesqrt), with
    `precision` its numbers the format's (`forms.in_format`); in fp16 each push constant c0, c1, ...
    (float32, as a renderer sets them) converted to float16_t where it is read. Kept per expression:
    the costs and the execution print each form, and sympy's printing takes milliseconds."""
    import re

    from ..forms import _GLSL, printed

    text = printed(_GLSL(), expr, precision)
    return re.sub(r"\b(c\d+)\b", r"float16_t(\1)", text) if precision == "fp16" else text


def compile_forms(forms: dict, target: Target, architectures, precision: str = "fp32",
                  contract: str = "allowed") -> tuple[dict, dict]:
    """({architecture: {name: cycles}}, {what: why not}) of `forms` ({name: (sympy, parameter_per)}),
    by `isa.machine_code.form_cycles`: a material form reads the variables, a pixel form the parameter
    too (each only those its expression holds). Both are net of the shader that reads and writes the
    variables alone: a pixel form pays the read of its parameter (an interpolated input, where a
    renderer fetches a texture). Netted of its parameter's read too, a form whose arithmetic hides
    that read behind its own latency would cost less per pixel than per material (pow(t, n): 6
    cycles against 12 on RDNA3, both shaders 16). In fp16 the form computes in float16 (explicit
    16-bit types, `shaders.form_shader`). `contract` "never": each value `precise`
    (`shaders.precise_body`)."""
    from ...isa.machine_code import form_cycles
    from ...isa.shaders import precise_body

    names = list(target.names)
    variables = names[:len(target.variables)]
    bodies, missing = {}, {}
    for name, (expr, per) in forms.items():
        try:
            text = glsl_text(expr, precision)
        except Exception as e:          # a function the GLSL printer does not know
            missing[name] = not_printed(e)
            continue
        read = {s.name for s in expr.free_symbols}
        used = [n for n in (names if per == "pixel" else variables) if n in read] or names[:1]
        body = precise_body(f"return {text};", precision) if contract == "never" else f"return {text};"
        bodies[name] = (body, used, [n for n in used if n in variables] or used)
    cycles, more, _ = form_cycles(bodies, names, architectures, precision)
    return cycles, missing | more


# ---- the derivation -----------------------------------------------------------------------------

def execution_points(target, peaks=()) -> list[np.ndarray]:
    """Where a form of `target` is executed (`executed_box`), one array per axis (`target.names`'
    order): the box's measuring grid (`MEASURE_GRID` per axis of the unit box, placed in the box),
    then each peak (a point of the unit box)."""
    from ...optics import brdf

    lo, hi = unit_box(target)
    axes = [brdf.axis_grid(a, b, **MEASURE_GRID) for a, b in zip(lo, hi)]
    columns = [g.ravel() for g in np.meshgrid(*axes, indexing="ij")]
    extra = [np.asarray(p, dtype=np.float64) for p in peaks if p is not None and np.all(np.isfinite(p))]
    if extra:
        columns = [np.concatenate([c, [p[i] for p in extra]]) for i, c in enumerate(columns)]
    return place(target, columns)


def error_peaks(expression, target: Target, f) -> list[np.ndarray]:
    """Where a form's float64 error in the target's measure peaks on the unit box (`brdf.largest_error`,
    as `measure_box` finds it)."""
    from ...optics import brdf

    approx, exact = numpy_function(expression, target.symbols()), f
    if any(a.lo_of for a in target.variables):
        approx = (lambda g: lambda *s: g(*place(target, s)))(approx)
        exact = lambda *s: f(*place(target, s))        # noqa: E731
    lo, hi = unit_box(target)
    if target.metric == "rel" and target.floor > 0:
        value, where = brdf.largest(lambda *s: (approx(*s) - exact(*s)) / np.maximum(np.abs(exact(*s)), target.floor),
                                    lo, hi, **MEASURE_GRID)
    else:
        value, where = brdf.largest_error(approx, exact, lo, hi, relative=target.metric == "rel", **MEASURE_GRID)
    return [np.asarray(where, dtype=np.float64)] if np.isfinite(value) else []


def front_members(everything, per_of, cycles: dict, architectures, errors: dict, error_key: str, constant: float,
                  floor: float) -> set:
    """The found forms on some architecture's front, per pixel or per material, read off `errors`
    (those below the best constant's error)."""
    from ..measures.fronts import front

    out = set()
    for a in architectures:
        by_name = cycles.get(a, {})
        for per in ("pixel", "material"):
            rows = [dict(name=m.name, cycles=by_name[m.name], **errors[m.name]) for m in everything
                    if m.kind == "found" and per_of[m.name][1] == per and m.name in by_name
                    and errors[m.name][error_key] < constant]
            out |= {r["name"] for r in front(rows, error_key, floor)}
    return out


def _executed(everything, per_of, record, target, f, real, cycles, architectures, error_key, constant, floor,
              log, precision: str = "fp32") -> dict:
    """Every form executed in float32 (`executed_box`) at the box's grid and where the float64 error
    of each member of a float64 front, each anchor and the target itself peaks: dict(measured={name:
    its executed errors, NaN where not executed}, how, inputs, not_executed, peaks, seconds)."""
    from ..measures import executed_box

    started = time.perf_counter()
    provisional = front_members(everything, per_of, cycles, architectures, real, error_key, constant, floor)
    peaks = [where for m in everything if (m.name in provisional and per_of[m.name][1] == "pixel") or m.kind != "found"
             for where in error_peaks(m.expression, target, f)]
    bodies, unprinted = {}, {}
    for m in everything:
        try:
            bodies[m.name] = (glsl_text(m.expression, precision), record[m.name]["formulas"]["constants"]
                              if per_of[m.name][1] == "material" else None)
        except Exception as e:          # (a function the GLSL printer does not know)
            unprinted[m.name] = f"{m.name}: {not_printed(e)}"
    log(f"executing {len(bodies)} forms in {precision} over the box")
    run = executed_box.measure(bodies, target.names, execution_points(target, peaks), target.numpy(),
                               target.floor if target.metric == "rel" else 0.0, precision)
    measured = {m.name: run["errors"].get(m.name) or executed_box.nan_errors() for m in everything}
    log(f"executed on {run['inputs']} points by {run['how']} in {time.perf_counter() - started:.1f} s")
    return dict(measured=measured, how=run["how"], inputs=run["inputs"], not_executed=run["not_executed"] | unprinted,
                peaks=len(peaks), seconds=round(time.perf_counter() - started, 1))


def _checked(target: Target, gpu, budget, max_cycles, max_complexity: int,
             formula_complexity: int) -> list[str]:
    """The architectures of `gpu` (`options.checked_options`), once the options are checked
    (DeriveError naming what is wrong; the target was checked where it was read,
    `targets.reading.check`)."""
    from .options import checked_options

    architectures = checked_options(gpu, budget, max_cycles, max_complexity)
    if not (isinstance(formula_complexity, int) and 0 <= formula_complexity <= MAX_FORMULA_COMPLEXITY):
        raise DeriveError(f"--formula-complexity {formula_complexity}: give an integer in [0, {MAX_FORMULA_COMPLEXITY}]")
    if formula_complexity and target.parameter is None:
        raise DeriveError(f"{target.name} has no parameter: --formula-complexity applies to targets with one")
    return architectures


def _headline(target: Target, architectures) -> str:
    return (f"{target.name}: {target.expression} for {', '.join(a.text() for a in target.axes)}, error {target.metric}; "
            f"{len(architectures)} architecture{'s' * (len(architectures) > 1)}")


def _certified(everything, per_of, target: Target, precision: str, errors: dict, cycles: dict, architectures,
               error_key: str, constant: float, floor: float, log) -> dict:
    """`--certify` for a target of several variables (`certification.until_certified`): each member of
    a front, each anchor and the exact target bounded by interval branch and bound over the whole box
    (`measures.certified_box`, lavapipe's rounding), its error on the fronts the proven bound; a
    material member (its constants computed per material) is not certified. Then each certified
    form's worst under Vulkan's allowances and its architectures' vendors' documented figures.
    Returns dict(certified, not_certified, passes, bounds={name: {bound, found, at, boxes, status,
    sampled}}, spec={name: {vulkan, amd, ...: {bound, status, reason}}}, seconds)."""
    from ...isa.architectures import ARCHITECTURES
    from ...isa import special_functions
    from ..measures import certified_box
    from .certification import box_bounds, until_certified

    started = time.perf_counter()
    metric = target.metric
    relative_floor = target.floor if metric == "rel" else 0.0
    domain = [(a.lo, a.hi) for a in target.axes]
    inputs, symbols, expression = list(target.names), target.symbols(), target.sympy()
    bodies, why_not = {}, {}
    for m in everything:
        if per_of[m.name][1] != "pixel":
            why_not[m.name] = "its constants are computed per material (not certified)"
            continue
        try:
            bodies[m.name] = glsl_text(m.expression, precision)
        except Exception as e:          # (a function the GLSL printer does not know)
            why_not[m.name] = not_printed(e)
    out = dict(bounds={}, spec={})

    def needed(current):
        return {m.name for m in everything if m.kind != "found"} | front_members(
            everything, per_of, cycles, architectures, current, error_key, constant, floor)

    def certify_names(names):
        jobs = [(n, "lavapipe", bodies[n], inputs, expression, symbols, domain, precision, metric, relative_floor,
                 errors[n][error_key], certified_box.RATIO, n == "exact") for n in names if n in bodies]
        done = box_bounds(jobs)
        result = {}
        for n in names:
            c = done.get((n, "lavapipe"))
            if c is None or c.status == "not bounded":
                result[n] = (None, why_not.get(n) or c.reason)
                continue
            out["bounds"][n] = dict(bound=c.bound, found=c.found, at=list(c.at), boxes=c.boxes, status=c.status,
                                    sampled=errors[n][error_key], method=c.method)
            result[n] = ({error_key: c.bound}, None)
        return result

    out |= until_certified(needed, errors, error_key, certify_names, log)
    roundings = ["vulkan"] + sorted({ARCHITECTURES[a].vendor for a in architectures}
                                    & {v for v, p in special_functions.VENDOR if p == precision})
    jobs = [(n, r, bodies[n], inputs, expression, symbols, domain, precision, metric, relative_floor,
             out["bounds"][n]["found"] if r == "vulkan" else 0.0,     # (lavapipe is a conforming driver)
             certified_box.RATIO, n == "exact") for n in out["certified"] for r in roundings]
    for (n, r), c in box_bounds(jobs).items():
        out["spec"].setdefault(n, {})[r] = dict(bound=c.bound, status=c.status, reason=c.reason, method=c.method)
    out["seconds"] = round(time.perf_counter() - started, 1)
    proven = sum(b["status"] == "proven" for b in out["bounds"].values())
    log(f"certified {len(out['certified'])} forms by branch and bound ({proven} within {certified_box.RATIO}x of the "
        f"largest error found, the rest at the budget) in {out['seconds']:.0f} s")
    return out


def _certified_columns(name: str, certification: dict | None, sampled: dict, error_key: str) -> dict:
    """A row's `certified` (proven, budget, or sampled where not certified), its proven bound
    (`certified_abs_error` or `_rel_`), its ratio to the sampled error, the sampled error, and the
    worst a conforming driver may give (`max_abs_error_spec` or `_rel_`, per vendor `..._spec_amd`),
    with `--certify`; nothing without it."""
    if certification is None:
        return {}
    bound = certification["bounds"].get(name)
    short = error_key.removeprefix("max_").removesuffix("_error")
    out = {"certified": bound["status"] if bound else "sampled", f"certified_{short}_error": bound and bound["bound"],
           "certified_ratio": bound and (bound["bound"] / bound["sampled"] if bound["sampled"] > 0 else None),
           f"{error_key}_sampled": sampled[name][error_key]}
    for vendor, c in certification["spec"].get(name, {}).items():
        column = f"{error_key}_spec" if vendor == "vulkan" else f"{error_key}_spec_{vendor}"
        out[column] = c["bound"] if c["bound"] != float("inf") else None
    return out


def derive(target: Target, gpu=None, budget=None, max_cycles: float | None = None,
           max_complexity: int = 12, log=print, formula_complexity: int = 0, precision: str = "fp32",
           search: tuple[list[dict], dict] | None = None, certify: bool = False, contract: str = "allowed") -> dict:
    """The derivation of the module docstring for `target` on the architectures `gpu` (names;
    default every one whose compiler runs here), with `formula_complexity` > 0 the lines of the best
    templates also corrected by the symbolic regression (`corrected`); `search`: the search's
    (records, coverage) where it was computed beforehand (`derive_pair`: both parts' at once).
    Returns the results (results.json's content) with the rows of front.csv. `budget`: the searches'
    plans (a `symbolic.budgets.Budget`; default `options.DEFAULT_SECONDS`)."""
    from ..measures.fronts import front, rounding_floor, verdict

    budget = _budget(budget)
    architectures = _checked(target, gpu, budget, max_cycles, max_complexity, formula_complexity)
    started = time.perf_counter()
    f = target.numpy()
    error_key = _error_key(target)
    if search is None:
        log(_headline(target, architectures))
        search = _searched(target, f, budget, max_complexity, log, formula_complexity)
    found, coverage = search
    forms = [Form(r["name"], "found", r["family"], r["expression"], r["source"]) for r in found]
    per_of = {r["name"]: (r["expression"], r["per"]) for r in found}
    record = {r["name"]: r for r in found}
    anchors = [Form(a.name, "anchor", "anchor", expr, a.source)
               for a, expr in zip(target.anchors, target.anchor_expressions().values())]
    # (a table's own cost is a texture fetch, which these shaders do not measure)
    exact = [] if target.table is not None else [Form("exact", "exact", "exact", target.sympy(), "the target itself")]
    for m in anchors + exact:
        per_of[m.name] = (m.expression, "pixel")
    everything = forms + anchors + exact
    log(f"measuring {len(everything)} forms over the whole box and compiling them for {len(architectures)} "
        "architectures")
    errors = {m.name: record[m.name]["errors"] if m.name in record else measure_box(m.expression, target, f)
              for m in everything}
    cycles, missing = compile_forms(per_of, target, architectures, precision, contract)
    constant = _constant_error(target, f)
    floor = rounding_floor(target, constant, precision)
    real = errors
    execution = _executed(everything, per_of, record, target, f, real, cycles, architectures, error_key, constant,
                          floor, log, precision)
    errors = execution.pop("measured")
    sampled = {name: dict(e) for name, e in errors.items()}
    certification = None
    if certify:
        certification = _certified(everything, per_of, target, precision, errors, cycles, architectures, error_key,
                                   constant, floor, log)

    rows, fronts, verdicts = [], {}, {}
    for a in architectures:
        by_name = cycles.get(a, {})
        fronts[a] = {}
        for per in ("pixel", "material"):
            candidates_ = [dict(name=m.name, cycles=by_name[m.name], **errors[m.name]) for m in forms
                           if per_of[m.name][1] == per and m.name in by_name
                           and (max_cycles is None or by_name[m.name] <= max_cycles)
                           and errors[m.name][error_key] < constant]
            fronts[a][per] = [r["name"] for r in front(candidates_, error_key, floor)]
        on_front = set(fronts[a]["pixel"]) | set(fronts[a]["material"])
        for m in everything:
            if m.name not in by_name or (m.kind == "found" and m.name not in on_front):
                continue
            rows.append(dict(architecture=a, kind=m.kind, name=m.name, family=m.family,
                             expression=_text(m, record, target), cycles=by_name[m.name],
                             cycles_predicted=None, max_abs_error=errors[m.name]["max_abs_error"],
                             max_rel_error=errors[m.name]["max_rel_error"], on_front=m.name in on_front,
                             source=m.source, range=target.range_text(), parameter_per=per_of[m.name][1]
                             if target.parameter is not None else "",
                             max_abs_error_real=real[m.name]["max_abs_error"],
                             max_rel_error_real=real[m.name]["max_rel_error"], precision=precision,
                             **_certified_columns(m.name, certification, sampled, error_key)))
        pixel_front = [r for r in rows if r["architecture"] == a and r["name"] in fronts[a]["pixel"]]
        verdicts[a] = {m.name: dict(cycles=by_name[m.name], error=errors[m.name][error_key],
                                    **verdict(by_name[m.name], errors[m.name][error_key], pixel_front,
                                                     error_key, floor))
                       for m in anchors if m.name in by_name}
    elapsed = time.perf_counter() - started
    log(f"done in {elapsed:.0f} s")
    members = {}
    for m in everything:
        if m.kind == "found" and not any(m.name in fr[p] for fr in fronts.values() for p in fr):
            continue
        members[m.name] = dict(kind=m.kind, family=m.family, source=m.source, converged=True,
                               expression=_text(m, record, target), **errors[m.name],
                               max_abs_error_real=real[m.name]["max_abs_error"],
                               max_rel_error_real=real[m.name]["max_rel_error"],
                               **_certified_columns(m.name, certification, sampled, error_key),
                               **(dict(parameter_per=per_of[m.name][1] if target.parameter is not None else "")
                                  | record.get(m.name, {}).get("formulas", {})))
    return dict(target=dict(name=target.name, expression=target.expression, variable=target.variable,
                            variables=[dataclasses.asdict(a) for a in target.variables],
                            parameter=dataclasses.asdict(target.parameter) if target.parameter else None,
                            domain=[[a.lo, a.hi] for a in target.axes], metric=target.metric, floor=target.floor,
                            description=target.description,
                            anchors=[dict(name=a.name, expression=a.expression, source=a.source) for a in target.anchors]),
                architectures=architectures, missing=missing, coverage=coverage,
                families=sorted({m.family for m in forms if m.family != "grammar"}),
                family_members=[m.name for m in forms if m.family != "grammar"],
                fronts={a: fr["pixel"] + [n for n in fr["material"] if n not in fr["pixel"]] for a, fr in fronts.items()},
                fronts_by_parameter=fronts, verdicts=verdicts, rows=rows, error=error_key, constant_error=constant,
                rounding_floor=floor, precision=precision, execution=execution, cost_tables={}, contract=contract,
                **({"certification": certification} if certification is not None else {}),
                seconds=round(elapsed, 1), estimated_seconds=None,
                members=members, forms={m.name: m for m in everything}, cycles=cycles)


def _budget(budget):
    from ...symbolic import budgets

    from .options import DEFAULT_SECONDS

    return budgets.Budget(DEFAULT_SECONDS) if budget is None else budget
