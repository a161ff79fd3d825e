"""`derive`: the cheapest accurate forms of a target (`targets`), ranked by compiled cycles per GPU
architecture.

1. Families fitted by minimax directly (`families`), and each anchor's own form with its decimal
   numbers refitted by minimax (`anchor_refits`: the same operations, so mostly the same cost).
2. The grammar's forms (`symbolic.grammar`, the ten operations), by the ladder of grammars within
   the budget (`symbolic.ladder`: every form of + - * / as deep as it reaches, then of the ten
   operations and of those the target suggests, by `symbolic.search`, loss max or max-relative on
   Chebyshev points; pyoperon to `max_complexity` in the rest). Each architecture's cost table
   (`symbolic.gpu_costs`, fitted to `CALIBRATION` compiled forms) predicts every form's cycles;
   the forms on some architecture's front of predicted cycles against error go on. Steps 1 and 2
   are kept between runs (`grammar_search`).
3. Every form, and each anchor and the exact target, measured over the whole domain
   (`measure.max_error`), compiled for every architecture (`isa.machine_code`, each shader kept
   on disk), and the front per architecture read off (`fronts.front`): the forms no other beats at
   equal or fewer compiled cycles. The grammar's front members are then polished on the whole
   interval (`minimax.slp`), measured and compiled again, and the fronts read off again.
4. Each anchor's verdict per architecture, by `fronts.verdict`: beaten, matched or missed.
"""

from __future__ import annotations

import math
import time

import numpy as np

from ..forms import Form, glsl, not_printed, predicted_cycles
from ..measures import bounds, executed
from ..measures.fronts import constant_error, front, rounding_floor, verdict
from ..search import anchor_refits, families, grammar_search, representable
from ..targets import DeriveError
from .options import checked_options, DEFAULT_SECONDS, MAX_COMPLEXITY

CALIBRATION = 200               # forms compiled per architecture to fit its cost table
# Times measured on this 2-core machine, for the time a run announces: the families' fits (about 10 s
# per target), the forms measured, polished and their constants chosen (3.4 s for schlick on three
# architectures), the command's start, its renders and files (about 6 s).
FAMILY_SECONDS = 12.0
MEASURE_SECONDS = 4.0
START_SECONDS = 6.0
EXECUTE_SECONDS = {"fp32": 6.0, "fp16": 2.0}     # every form executed (58 forms, 5 M inputs in fp32: 4.8 to 6.5 s)


def _compile(forms: list[Form], architectures, log, precision: str = "fp32", contract: str = "allowed") -> tuple[dict, dict]:
    """({architecture: {form name: cycles}}, {what: why not}) of every form, by `derive`'s one
    costing (`isa.machine_code.form_cycles`: a shader reading t, net of the shader writing it, in
    `precision`, its numbers the format's); the exact target per vendor, left out where a vendor's
    lowering lacks one of its functions. `contract` "never": each value declared `precise`
    (`shaders.precise_body`), the cycles those of that shader."""
    from ...isa.architectures import ARCHITECTURES, vendor_groups
    from ...isa.machine_code import form_cycles
    from ...isa.shaders import precise_body

    def statements(text):
        return precise_body(f"return {text};", precision) if contract == "never" else f"return {text};"

    plain = {m.name: (statements(glsl(m.expression, 't', precision)), ["t"]) for m in forms if m.kind != "exact"}
    cycles, missing, _ = (form_cycles(plain, ["t"], architectures, precision) if plain
                          else ({a: {} for a in architectures}, {}, {}))
    for a in architectures:
        if plain and not cycles[a]:
            missing[ARCHITECTURES[a].vendor] = "its compiler did not run"
    for m in (m for m in forms if m.kind == "exact"):
        try:
            text = glsl(m.expression, "t", precision)
        except Exception as e:          # a function sympy's GLSL printer does not know
            missing["exact"] = f"{m.expression}: {not_printed(e)}"
            continue
        for vendor, names in vendor_groups(list(architectures)):
            try:
                found, failed, _ = form_cycles({m.name: (statements(text), ["t"])}, ["t"], names, precision)
            except Exception as e:      # (no back end of this vendor runs here)
                missing[f"exact on {vendor}"] = str(e).splitlines()[0][:200]
                continue
            if failed:                  # (an operation the vendor's lowering lacks)
                missing[f"exact on {vendor}"] = next(iter(failed.values()))
            for a, values in found.items():
                cycles[a].update(values)
    return cycles, missing


CHOSEN = " (constants chosen)"       # the name of a form's variant whose constants were chosen in the format


def _executed(forms: list[Form], target, precision: str, real: dict, log, chosen: dict | None = None) -> dict:
    """Every form executed in `precision` (`executed.measure`, around the extrema of its float64
    errors `real`), and each form of `chosen` ({name: the form with its constants chosen in the
    format, `representable.choose`}) as that variant too: dict(measured={name: its executed errors;
    NaN where it was not executed; a chosen variant under name + CHOSEN}, and how it was executed:
    how, inputs, truth, not_executed)."""
    bodies, unprinted = {}, {}
    variants = [(m.name, m.expression) for m in forms] + [(name + CHOSEN, e) for name, e in (chosen or {}).items()]
    for name, expression in variants:
        try:
            bodies[name] = glsl(expression, target.variable, precision)
        except Exception as e:          # (a function sympy's GLSL printer does not know)
            unprinted[name] = f"{name}: {not_printed(e)}"
    extrema = sorted({r[k] for r in real.values() for k in ("x_abs", "x_rel")})
    started = time.perf_counter()
    log(f"executing {len(bodies)} forms in {precision} over the domain")
    run = executed.measure(bodies, target, precision, extrema, log)
    nan = dict(max_abs_error=math.nan, max_rel_error=math.nan, x_abs=math.nan, x_rel=math.nan)
    measured = {name: run["errors"].get(name) or nan for name, _ in variants}
    log(f"executed on {run['inputs']} inputs by {run['how']} in {time.perf_counter() - started:.1f} s")
    return dict(measured={name: e for name, e in measured.items() if not name.endswith(CHOSEN)},
                errors_chosen={name.removesuffix(CHOSEN): e for name, e in measured.items() if name.endswith(CHOSEN)},
                how=run["how"], inputs=run["inputs"], truth=run["truth"],
                not_executed=run["not_executed"] | unprinted, seconds=round(time.perf_counter() - started, 1))


def derive(target, gpu=None, budget=None, max_cycles: float | None = None,
           max_complexity: int = MAX_COMPLEXITY, log=print, precision: str = "fp32", certify: bool = False,
           contract: str = "allowed") -> dict:
    """The derivation of the module docstring for a checked `target` on the architectures `gpu`
    (names; default every one whose compiler runs here), every form costed and executed in
    `precision` (fp32 or fp16, `executed`), the search's work planned by `budget` (a
    `symbolic.budgets.Budget`; default DEFAULT_SECONDS). With `certify`, every front member, anchor
    and the exact target executed at every input of the domain in the format (`certified`), the
    fronts and verdicts read off those errors. Returns the results (`results.json`'s content) with
    the forms' rows."""
    from ...isa.machine_code import estimate_seconds
    from ...symbolic import budgets, gpu_costs, grammar, ladder
    from ...symbolic.grammar import TEN

    budget = budgets.Budget(DEFAULT_SECONDS) if budget is None else budget

    try:
        executed.check_precision(precision)
    except executed.ExecutedError as e:
        raise DeriveError(str(e)) from None
    architectures = checked_options(gpu, budget, max_cycles, max_complexity)
    started = time.perf_counter()
    f = target.numpy()
    # The time announced: the families' and the search's (none where an earlier run kept them), the
    # calibration's shaders that no run kept and about three architectures' fronts compiled, the
    # forms measured and polished, and the command's start (its imports).
    search_estimate = 0.0
    plan = budget.plan("grammar", 1, grammar_search.SEARCH_POINTS, max_complexity, TEN, grammar_search.loss_of(target))
    if not grammar_search.kept_file(target, budget, max_complexity).is_file():
        search_estimate = FAMILY_SECONDS + ladder.forecast(plan)
    calibration = gpu_costs.not_kept(gpu_costs.calibration_expressions(CALIBRATION)[1], architectures)
    compile_estimate = estimate_seconds(CALIBRATION * calibration + 3 * grammar_search.PER_ARCHITECTURE, architectures)
    estimate = START_SECONDS + search_estimate + compile_estimate + MEASURE_SECONDS + EXECUTE_SECONDS[precision]
    log(f"{target.name}: {target.expression} on [{target.domain[0]:g}, {target.domain[1]:g}], error {target.metric}; "
        f"{len(architectures)} architecture{'s' * (len(architectures) > 1)}, {precision}; about {estimate:.0f} s")

    log(f"the search's plan (" + (f"{budget.seconds:g} s at the reference rates" if budget.recorded is None
                                  else "recorded") + f"): {ladder.covered_text(plan)}")
    found, trees, fitted, losses, coverage = grammar_search.searched(target, f, budget, max_complexity, log)
    found = [anchor_refits.without_negligible(m, target, f) for m in found]
    found += anchor_refits.refitted_anchors(target, f, log)
    log(f"cost tables: {CALIBRATION} forms compiled per architecture")
    tables = gpu_costs.operation_costs(CALIBRATION, architectures)["tables"]
    chosen = grammar_search.select(trees, losses, tables)
    symbol = target.symbol()
    grammar_forms = {}
    for k, i in enumerate(chosen):
        name = f"grammar_{k + 1}"
        grammar_forms[name] = (trees[i], np.asarray(fitted[i], dtype=float))
        found.append(Form(name, "found", "grammar", grammar.to_sympy(trees[i], fitted[i], symbol),
                          f"grammar: {grammar.show(trees[i], target.variable)}"))
    anchors = [Form(a.name, "anchor", "anchor", expr, a.source)
               for a, expr in zip(target.anchors, target.anchor_expressions().values())]
    exact = Form("exact", "exact", "exact", target.sympy(), "the target itself")
    everything = found + anchors + [exact]
    log(f"measuring {len(everything)} forms over the whole domain and compiling them for {len(architectures)} "
        "architectures")
    errors = {m.name: anchor_refits.measured(m, target, f) for m in everything}          # in float64 (the mathematics)
    cycles, missing = _compile(everything, architectures, log, precision, contract)
    error_key = "max_abs_error" if target.metric == "abs" else "max_rel_error"

    baseline = constant_error(target, f)
    floor = rounding_floor(target, baseline, precision)

    def rows_of(a, measured):
        return [dict(name=m.name, cycles=cycles[a].get(m.name), **measured[m.name]) for m in found
                if m.name in cycles[a] and (max_cycles is None or cycles[a][m.name] <= max_cycles)
                and measured[m.name][error_key] < baseline]

    # the grammar's front members (of the float64 errors) polished on the whole interval, measured and
    # compiled again
    on_fronts = {r["name"] for a in architectures for r in front(rows_of(a, errors), error_key, floor)}
    weight = families.weight_of(target, f)
    polished = []
    for m in found:
        if m.family == "grammar" and m.name in on_fronts:
            tree, c = grammar_forms[m.name]
            better = grammar_search.polish(tree, c, target, f, weight)
            candidate = Form(m.name, "found", "grammar", grammar.to_sympy(tree, better, symbol), m.source)
            measured = anchor_refits.measured(candidate, target, f)
            if measured[error_key] < errors[m.name][error_key]:
                errors[m.name] = measured
                m.expression = candidate.expression
                polished.append(m)
    if polished:
        again, _ = _compile(polished, architectures, log, precision, contract)
        for a in architectures:
            cycles[a].update(again.get(a, {}))
    log(f"polished {len(polished)} grammar front members on the whole interval")
    # each found form's constants chosen among the format's values (`representable`), executed beside
    # the rounded ones, kept where the error as executed drops
    chosen, searches = {}, {}
    for m in found:
        expression, searches[m.name] = representable.choose(m.expression, target, f, precision)
        if searches[m.name]["chosen_error"] < searches[m.name]["rounded_error"]:
            chosen[m.name] = expression
    log(f"constants chosen in {precision} for {len(chosen)} of {len(found)} forms (the rest: rounded)")
    run = _executed(everything, target, precision, errors, log, chosen)
    real, errors, variants = errors, run.pop("measured"), run.pop("errors_chosen")
    kept = []
    for m in found:
        rounded, better = errors[m.name][error_key], variants.get(m.name, {}).get(error_key, math.nan)
        searches[m.name] |= dict(executed_rounded_error=rounded, executed_chosen_error=better if m.name in chosen else None,
                                 kept=False)
        if m.name in chosen and better < rounded:
            m.expression = chosen[m.name]
            errors[m.name] = variants[m.name]
            searches[m.name]["kept"] = True
            kept.append(m)
    if kept:            # (a chosen constant may cost otherwise: 1.0, 0.5, an inline constant)
        again, _ = _compile(kept, architectures, log, precision, contract)
        for a in architectures:
            cycles[a].update(again.get(a, {}))
    log(f"kept the chosen constants of {len(kept)} forms (their error as executed lower)")

    forms_by_name = {m.name: m for m in everything}
    sampled = {name: dict(e) for name, e in errors.items()}
    certification = None
    if certify:
        def needed(current):
            on = {r["name"] for a in architectures for r in front(rows_of(a, current), error_key, floor)}
            return on | {m.name for m in anchors + [exact] if any(m.name in cycles[a] for a in architectures)}
        from ...isa.architectures import ARCHITECTURES

        vendors = {ARCHITECTURES[a].vendor for a in architectures}
        certification = certified(needed, forms_by_name, target, precision, errors, error_key, log, vendors)
        certification["error_key"] = error_key
    rows, fronts, verdicts = [], {}, {}
    for a in architectures:
        table = tables.get(a, {})
        best = front(rows_of(a, errors), error_key, floor)
        fronts[a] = [r["name"] for r in best]
        for m in everything:
            if m.name not in cycles[a]:
                continue
            if m.kind == "found" and m.name not in fronts[a]:
                continue
            rows.append(dict(architecture=a, kind=m.kind, name=m.name, family=m.family, expression=_text(m, target),
                             cycles=cycles[a][m.name], cycles_predicted=_predicted(m, table),
                             max_abs_error=errors[m.name]["max_abs_error"], max_rel_error=errors[m.name]["max_rel_error"],
                             on_front=m.name in fronts[a], source=m.source, range="", parameter_per="",
                             max_abs_error_real=real[m.name]["max_abs_error"],
                             max_rel_error_real=real[m.name]["max_rel_error"], precision=precision,
                             **_certified_columns(m.name, certification, sampled)))
        # each anchor's verdict, and the exact target's as the driver executes it (its own functions)
        judged = anchors + [exact]
        verdicts[a] = {m.name: dict(cycles=cycles[a][m.name], error=errors[m.name][error_key],
                                    **verdict(cycles[a][m.name], errors[m.name][error_key], best, error_key, floor))
                       for m in judged if m.name in cycles[a] and math.isfinite(errors[m.name][error_key])}
    bound_columns(rows, forms_by_name, target, f, precision, error_key)
    # why each row's executed error exceeds its float64 one by more than executed.GAP (the members of
    # some front, the anchors, the exact target)
    causes = {}
    for r in rows:
        m = forms_by_name[r["name"]]
        if r["name"] in causes or not (math.isfinite(r[error_key])
                                       and r[error_key] > executed.GAP * max(r[error_key + "_real"], floor)):
            continue
        causes[r["name"]] = executed.gap_cause(m.expression, glsl(m.expression, target.variable, precision), target,
                                               precision, r[error_key], error_key)
    elapsed = time.perf_counter() - started
    log(f"done in {elapsed:.0f} s (estimated {estimate:.0f} s)")
    return dict(target=dict(name=target.name, expression=target.expression, variable=target.variable,
                            domain=list(target.domain), metric=target.metric, floor=target.floor,
                            description=target.description,
                            anchors=[dict(name=a.name, expression=a.expression, source=a.source) for a in target.anchors]),
                architectures=architectures, missing=missing, coverage=coverage,
                families=sorted({m.family for m in found if m.family != "grammar"}),
                family_members=[m.name for m in found if m.family != "grammar"],
                fronts=fronts, verdicts=verdicts, rows=rows, error=error_key,
                constant_error=baseline, rounding_floor=floor, precision=precision, execution=run, contract=contract,
                **({"certification": certification} if certification is not None else {}),
                special_functions=special_functions(rows, forms_by_name, precision), cost_tables=tables,
                seconds=round(elapsed, 1), estimated_seconds=round(estimate, 1),
                members={m.name: dict(kind=m.kind, family=m.family, source=m.source, converged=m.converged,
                                      expression=_text(m, target), **errors[m.name],
                                      max_abs_error_real=real[m.name]["max_abs_error"],
                                      max_rel_error_real=real[m.name]["max_rel_error"],
                                      **_certified_columns(m.name, certification, sampled),
                                      **({"gap": causes[m.name]} if m.name in causes else {}),
                                      **({"constants": searches[m.name]} if m.name in searches else {}))
                         for m in everything if m.kind != "found" or any(m.name in fr for fr in fronts.values())},
                forms=forms_by_name, cycles=cycles)


def certified(needed, forms_by_name: dict, target, precision: str, errors: dict, error_key: str, log,
              vendors=()) -> dict:
    """Each form `needed(errors)` names executed at every input of the domain (`exhaustive.certify`),
    its errors in `errors` replaced by those maxima, until every form needed (the fronts' members read
    off the errors as they now stand, the anchors, the exact target) is certified or cannot be: a
    form's sampled error is at most its true one, so a form the certified members dominate by its
    sampled error is dominated by its true one too. Then each certified form's worst under Vulkan's
    allowances and each of `vendors`' documented figures (`certified_box.spec_bounds`, over the
    domain). Returns dict(names certified, not_certified={name: why}, how={name: emulation or
    lavapipe}, inputs, truth, passes, spec={name: {vulkan, amd, ...: {bound, status}}}, seconds)."""
    import time

    from ..measures import certified_box, exhaustive
    from .certification import box_bounds, until_certified

    out = dict(how={}, inputs=None, truth=None, spec={}, seconds=0.0)

    def certify_names(names):
        run = exhaustive.certify({n: glsl(forms_by_name[n].expression, target.variable, precision) for n in names},
                                 target, precision, log)
        out["how"].update(run["how"])
        out.update(inputs=run["inputs"], truth=run["truth"], seconds=round(out["seconds"] + run["seconds"], 1))
        return {n: (run["errors"][n], None) if n in run["errors"] else (None, run["not_certified"].get(n, "not run"))
                for n in names}

    out |= until_certified(needed, errors, error_key, certify_names, log)
    started = time.perf_counter()
    metric = "rel" if error_key == "max_rel_error" else "abs"
    floor = target.floor if metric == "rel" else 0.0
    roundings = ["vulkan"] + sorted(v for v in set(vendors) if (v, precision) in _documented())
    jobs = [(name, rounding, glsl(forms_by_name[name].expression, target.variable, precision), [target.variable],
             target.sympy(), [target.symbol()], [target.domain], precision, metric, floor,
             errors[name][error_key] if rounding == "vulkan" else 0.0,   # (lavapipe is a conforming driver)
             certified_box.RATIO_ONE, name == "exact") for name in out["certified"] for rounding in roundings]
    for (name, rounding), c in box_bounds(jobs).items():
        out["spec"].setdefault(name, {})[rounding] = dict(bound=c.bound, status=c.status, reason=c.reason,
                                                          method=c.method)
    log(f"the worst a conforming driver may give, {len(out['certified'])} forms ({time.perf_counter() - started:.0f} s)")
    out["seconds"] = round(out["seconds"] + time.perf_counter() - started, 1)
    return out


def _documented() -> set:
    from ...isa import special_functions

    return set(special_functions.VENDOR)


def _certified_columns(name: str, certification: dict | None, sampled: dict) -> dict:
    """A row's `certified` (exhaustive, or sampled where it was not) and its sampled errors beside the
    certified ones, and the worst a conforming driver may give (`max_abs_error_spec` or `_rel_`, per
    vendor `..._spec_amd`; None where not bounded), with `--certify`; nothing without it."""
    if certification is None:
        return {}
    out = dict(certified="exhaustive" if name in certification["certified"] else "sampled",
               max_abs_error_sampled=sampled[name]["max_abs_error"],
               max_rel_error_sampled=sampled[name]["max_rel_error"])
    key = certification.get("error_key", "max_abs_error")
    for vendor, c in certification["spec"].get(name, {}).items():
        column = f"{key}_spec" if vendor == "vulkan" else f"{key}_spec_{vendor}"
        out[column] = c["bound"] if math.isfinite(c["bound"]) else None
    return out


def bound_columns(rows: list[dict], forms_by_name: dict, target, f, precision: str, error_key: str) -> None:
    """Each row's `max_error_bound` (`bounds`): its executed error plus its special functions'
    documented accuracy on the row's architecture, propagated to first order."""
    from ...isa.architectures import ARCHITECTURES

    x = bounds.grid(target)
    scale = bounds.scale_of(target, f, x)
    calls: dict = {}
    for r in rows:
        if r["name"] not in calls:
            calls[r["name"]] = bounds.sensitivities(forms_by_name[r["name"]].expression, target.symbol(), x)
        vendor = ARCHITECTURES[r["architecture"]].vendor
        r["max_error_bound"] = r[error_key] + bounds.propagated(calls[r["name"]], vendor, precision, scale)


def special_functions(rows: list[dict], forms_by_name: dict, precision: str) -> dict:
    """{architecture: [{function, accuracy, source, mesa}]} of every special function a row of that
    architecture calls (`isa.special_functions`)."""
    from ...isa import special_functions
    from ...isa.architectures import ARCHITECTURES

    out: dict = {}
    used = {name: bounds.functions_used(m.expression) for name, m in forms_by_name.items()
            if name in {r["name"] for r in rows}}
    for r in rows:
        listed = out.setdefault(r["architecture"], {})
        for function in used[r["name"]]:
            if function not in listed:
                a = special_functions.accuracy(function, ARCHITECTURES[r["architecture"]].vendor, precision)
                listed[function] = dict(function=function, accuracy=a.text(), source=a.source, mesa=a.mesa)
    return {a: list(functions.values()) for a, functions in out.items()}


def _text(m: Form, target) -> str:
    import sympy as sp

    return sp.sstr(sp.N(m.expression, 9)) if m.kind != "exact" else target.expression


def _predicted(m: Form, table) -> float | None:
    if not table:
        return None
    value = predicted_cycles(m.expression, table)
    return None if value is None else round(value, 2)
