"""`derive` for a pair of outputs a shader computes together, F0 A + B (the split-sum environment
BRDF's scale A and bias B): each part derived by the engine of several variables, then per
architecture and per `parameter_per` every pair of their front members (and each anchor's two parts)
compiled as one shader, and each anchor's two parts refitted together."""

from __future__ import annotations

import itertools
import time

import numpy as np

from ..forms import Form, free_numbers
from ..targets import PAIR_PARTS, Target
from ..search.box_search import Search, searched
from ..search.formulas import _error_key, measure_box, minimax_on_box_parts
from ..search.per_value import Model
from ..targets import parameter_values
from .several_variables import _budget, _checked, _headline, compile_forms, derive


def _renumbered(expr, offset: int):
    """expr with its push constants c0, c1, ... renamed c(offset), c(offset + 1), ..."""
    import sympy as sp

    symbols = {s for s in expr.free_symbols if s.name[:1] == "c" and s.name[1:].isdigit()}
    return expr.xreplace({s: sp.Symbol(f"c{int(s.name[1:]) + offset}", real=True) for s in symbols})


def refitted_pair_anchors(target: Target, log) -> list[dict]:
    """Each anchor's two parts with their decimal numbers refitted together by minimax on the box
    (`minimax_on_box_parts`: a number both parts hold stays one number, as the anchor shares it), where
    that lowers the pair's error: [{name, scale, bias (sympy), errors: {scale, bias}}]."""
    import sympy as sp

    scale, bias = target.scale, target.bias
    key = _error_key(scale)
    values = np.sort(np.concatenate(parameter_values(scale.parameter)))
    fs = (scale.numpy(), bias.numpy())
    b_anchors = bias.anchor_expressions()
    out = []
    for name, a_expr in scale.anchor_expressions().items():
        if name not in b_anchors:
            continue
        exprs = (a_expr, b_anchors[name])
        free, q, numbers = free_numbers(*exprs)
        if not numbers:
            continue
        models = [Model(e, t.symbols(), q) for e, t in zip(free, (scale, bias))]
        a, _ = minimax_on_box_parts([(m, m.jacobian, t, g) for m, t, g in zip(models, (scale, bias), fs)],
                                    [float(v) for v in numbers], values)
        refit = [e.xreplace({qi: sp.Float(float(ai), 17) for qi, ai in zip(q, a)}) for e in free]
        before = max(measure_box(e, t, g)[key] for e, t, g in zip(exprs, (scale, bias), fs))
        errors = {part: measure_box(e, t, g) for part, e, t, g in zip(PAIR_PARTS, refit, (scale, bias), fs)}
        after = max(e[key] for e in errors.values())
        if np.isfinite(after) and after < before * (1 - 1e-6):
            log(f"{name} refitted (both parts together): error {before:.3g} -> {after:.3g}")
            out.append(dict(name=f"{name}_refitted", scale=refit[0], bias=refit[1], errors=errors))
    return out


def derive_pair(target: Target, gpu=None, budget=None, max_cycles: float | None = None,
                max_complexity: int = 12, log=print, formula_complexity: int = 0) -> dict:
    """Each of the pair's targets derived (`derive`, the whole `budget` each: its searches' plans
    named by the part, `budgets.Budget.within`), then per architecture
    and per `parameter_per` every pair of their front members (and each anchor's two parts)
    compiled as one shader computing F0 A + B (F0 a push constant): the shared subexpressions of
    the two count once, as the compiler makes them. A pair's error is the larger of its two (each
    also in its own column); the fronts and verdicts are read off as for one output."""
    import sympy as sp

    from ..measures.fronts import front, verdict

    budget = _budget(budget)
    started = time.perf_counter()
    pair_targets = (target.scale, target.bias)
    for t in pair_targets:
        architectures = _checked(t, gpu, budget, max_cycles, max_complexity, formula_complexity)
    for part, t in zip(PAIR_PARTS, pair_targets):
        log(f"{part}: {_headline(t, architectures)}")
    # both parts' searches at once (in worker processes where there are cores), then each part derived
    logs = [lambda s, part=part: log(f"  {part}: {s}") for part in PAIR_PARTS]
    searches = searched([Search(t, budget.within(part), max_complexity, formula_complexity)
                         for part, t in zip(PAIR_PARTS, pair_targets)],
                        [t.numpy() for t in pair_targets], logs, log)
    parts = {}
    for part, t, search in zip(PAIR_PARTS, pair_targets, searches):
        log(f"{part} ({t.name}):")
        parts[part] = derive(t, gpu, budget.within(part), max_cycles, max_complexity, log=lambda s: log("  " + s),
                             formula_complexity=formula_complexity, search=search)
    scale, bias = parts["scale"], parts["bias"]
    architectures = scale["architectures"]
    F0 = sp.Symbol("F0", real=True)
    error_key = scale["error"]
    forms, per_of, members, errors = {}, {}, {}, {}

    def pair(a_name, b_name, per, kind):
        a_form, b_form = scale["forms"][a_name], bias["forms"][b_name]
        offset = len(scale["members"][a_name].get("constants", []))
        expr = F0 * a_form.expression + _renumbered(b_form.expression, offset)
        name = a_name if kind == "anchor" else f"{a_name} + {b_name}"
        forms[name] = Form(name, kind, "pair" if kind == "found" else kind, expr,
                           f"scale: {a_form.source}; bias: {b_form.source}" if kind == "found" else a_form.source)
        per_of[name] = (expr, per)
        ea, eb = scale["members"][a_name], bias["members"][b_name]
        errors[name] = {key: max(ea[key], eb[key]) for key in ("max_abs_error", "max_rel_error")} | {
            f"{key}_{part}": e[key] for key in ("max_abs_error", "max_rel_error") for part, e in (("scale", ea), ("bias", eb))}
        members[name] = dict(kind=kind, family=forms[name].family, source=forms[name].source, converged=True,
                             expression=f"A = {ea['expression']}; B = {eb['expression']}", **errors[name],
                             parameter_per=per, constants=ea.get("constants", []) + eb.get("constants", []),
                             parts=[a_name, b_name])

    for a in architectures:
        for per in ("pixel", "material"):
            for a_name, b_name in itertools.product(scale["fronts_by_parameter"][a][per],
                                                    bias["fronts_by_parameter"][a][per]):
                if f"{a_name} + {b_name}" not in forms:
                    pair(a_name, b_name, per, "found")
    for anchor in target.scale.anchors:
        if anchor.name in bias["members"]:
            pair(anchor.name, anchor.name, "pixel", "anchor")
    for r in refitted_pair_anchors(target, log):
        name, expr = r["name"], F0 * r["scale"] + r["bias"]
        forms[name] = Form(name, "found", "anchor_refit", expr,
                           f"{name.removesuffix('_refitted')}'s A and B, their numbers refitted together by minimax")
        per_of[name] = (expr, "pixel")
        ea, eb = r["errors"]["scale"], r["errors"]["bias"]
        errors[name] = {key: max(ea[key], eb[key]) for key in ("max_abs_error", "max_rel_error")} | {
            f"{key}_{part}": e[key] for key in ("max_abs_error", "max_rel_error") for part, e in (("scale", ea), ("bias", eb))}
        members[name] = dict(kind="found", family="anchor_refit", source=forms[name].source, converged=True,
                             expression=f"A = {sp.sstr(sp.N(r['scale'], 9))}; B = {sp.sstr(sp.N(r['bias'], 9))}",
                             **errors[name], parameter_per="pixel", constants=[], parts=[])
    log(f"pairs: {len(forms)} compiled for {len(architectures)} architectures (F0 A + B)")
    cycles, missing = compile_forms(per_of, target.scale, architectures)
    constant = max(scale["constant_error"], bias["constant_error"])
    floor = max(scale["rounding_floor"], bias["rounding_floor"])
    rows, fronts, by_parameter, verdicts = [], {}, {}, {}
    for a in architectures:
        by_name = cycles.get(a, {})
        by_parameter[a] = {}
        for per in ("pixel", "material"):
            candidates = [dict(name=n, cycles=by_name[n], **errors[n]) for n, m in forms.items()
                          if m.kind == "found" and per_of[n][1] == per and n in by_name
                          and (max_cycles is None or by_name[n] <= max_cycles) and errors[n][error_key] < constant]
            by_parameter[a][per] = [r["name"] for r in front(candidates, error_key, floor)]
        fronts[a] = by_parameter[a]["pixel"] + [n for n in by_parameter[a]["material"] if n not in by_parameter[a]["pixel"]]
        for n, m in forms.items():
            if n not in by_name or (m.kind == "found" and n not in fronts[a]):
                continue
            rows.append(dict(architecture=a, kind=m.kind, name=n, family=m.family, expression=members[n]["expression"],
                             cycles=by_name[n], cycles_predicted=None, **errors[n], on_front=n in fronts[a],
                             source=m.source, range=target.scale.range_text(), parameter_per=per_of[n][1]))
        pixel_front = [r for r in rows if r["architecture"] == a and r["name"] in by_parameter[a]["pixel"]]
        verdicts[a] = {n: dict(cycles=by_name[n], error=errors[n][error_key],
                               **verdict(by_name[n], errors[n][error_key], pixel_front, error_key, floor))
                       for n, m in forms.items() if m.kind == "anchor" and n in by_name}
    kept = {n for fr in fronts.values() for n in fr} | {n for n, m in forms.items() if m.kind == "anchor"}
    elapsed = time.perf_counter() - started
    log(f"done in {elapsed:.0f} s")
    t = scale["target"]
    return dict(target=t | dict(name=target.name, expression=f"(A, B) = ({target.scale.name}, {target.bias.name})",
                                description=target.description, variable=", ".join(target.scale.names) + ", F0"),
                architectures=architectures, missing=missing | scale["missing"] | bias["missing"],
                coverage=dict(scale=scale["coverage"], bias=bias["coverage"], pairs=len(forms)),
                families=sorted(set(scale["families"]) | set(bias["families"])), family_members=[],
                fronts=fronts, fronts_by_parameter=by_parameter, verdicts=verdicts, rows=rows, error=error_key,
                constant_error=constant, rounding_floor=floor, cost_tables={}, seconds=round(elapsed, 1),
                estimated_seconds=None, members={n: members[n] for n in forms if n in kept},
                forms=forms, parts=dict(scale=publish_part(scale), bias=publish_part(bias)), cycles=cycles)


def publish_part(results: dict) -> dict:
    """A pair's part as results.json keeps it: its fronts, verdicts and coverage."""
    return {k: results[k] for k in ("fronts_by_parameter", "verdicts", "coverage", "seconds")}
