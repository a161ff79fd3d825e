"""What `pipeline derive` writes into its folder, all at once (`engine.publishing`: a temporary
folder renamed into place, so that a failure leaves nothing half written):

- `front.csv`: per architecture, its front's forms (kind `found`), every anchor (`anchor`) and the
  target itself (`exact`) where it compiles: architecture, kind, name, family, expression,
  cycles, cycles_predicted, max_abs_error, max_rel_error (a one-variable target's: as its shader
  executes, in the run's `precision`), on_front, source, range (a parametric target's parameter and
  its range) and parameter_per (`material`: the constants' formulas, in the expression, computed once
  per material on the CPU; `pixel`: compiled into the shader), and, for a one-variable target,
  max_abs_error_real and max_rel_error_real (the form's mathematics in float64) and precision;
- `results.json`: the target, the search's coverage, the fronts, each anchor's verdict per
  architecture, the cost tables, the times (estimated and measured), the members' errors;
- `report.md`: the same in words and tables, every number a field of results.json;
- `report.html`: the same to explore, one file that works offline (`derive_page`): the fronts per
  GPU, each form's error curve, code, machine code and cycles, its shader running live in the page;
- `front.png`: error against compiled cycles, one panel per vendor (its first architecture);
- `renders.png` and `rendered_front.png`, for a target with a role in a shading (`rendered`): the
  forms rendered in its place and compared by FLIP, and the largest FLIP against cycles; front.csv's
  rows then carry flip_mean, flip_p99 and flip_max, results.json an object `rendered`;
- `derive.glsl`, `derive.hlsl`, `derive_twin.py`: each front member as a function of the
  target's variables (in fp16, GLSL's explicit float16_t and HLSL's half; every number the format's
  value that was executed) (a parametric target's pixel members of its parameter too, its material members
  of their constants c0, c1, ..., whose formulas the twin's `..._constants` computes), and its
  Python twin.
"""

from __future__ import annotations

import csv
import json
import math
import textwrap
from pathlib import Path

from ...engine import escape
from . import rendered_report
from ..measures.executed import GAP
from ..search.formulas import DROP_RULE
from .shader_export import (arguments_of, domain_text, exported, function_name, function_names,  # noqa: F401
                            GLSL_FLOAT16, member_functions, shader_sources, shader_text, TYPES)

COLUMNS = ("architecture", "kind", "name", "family", "expression", "cycles", "cycles_predicted", "max_abs_error",
           "max_rel_error", "on_front", "source", "range", "parameter_per")
def _number(v):
    if v is None:
        return ""
    if isinstance(v, float):
        return "inf" if math.isinf(v) else f"{v:.6g}"
    return v


CONTRACT_TEXT = {
    "never": "Every form was costed and is written with its value `precise` (`--contract never`: its operations "
             "decorated NoContraction, which a driver may neither fuse nor reorder), so these bounds hold for the "
             "shader as written.",
    "allowed": "These bounds assume the operations in the order written: a driver that fuses a multiply and an add "
               "rounds once where they allow two, and stays within them, but one that reorders operations is not "
               "covered; `--contract never` writes and costs every form `precise`, after which they hold.",
}


def certification_lines(results: dict) -> list[str]:
    """report.md's lines on what its errors are: maxima over every input (`--certify`), or of the inputs
    tried."""
    c = results.get("certification")
    if c is None:
        return ["- The largest errors are those of the inputs tried (a sample of the domain): `--certify` takes "
                "them over every input of the domain."] if results.get("execution", {}).get("truth") else []
    if not c["certified"]:
        return ["- Certified: none (" + "; ".join(escape.markdown(f"{n}: {w}") for n, w in c["not_certified"].items())
                + ")."]
    if "bounds" in c:
        return box_certification_lines(results)
    how = {h: sorted(n for n, k in c["how"].items() if k == h) for h in sorted(set(c["how"].values()))}
    out = [f"- Certified (`certified` = exhaustive in front.csv): the largest errors as executed of {len(c['certified'])} "
           f"forms ({', '.join(escape.markdown(n) for n in sorted(c['certified']))}) are the maxima over every one of "
           f"the {c['inputs']:,} {results['precision']} values of the domain, "
           + "; ".join(f"{len(v)} by {'the per-operation emulation (bit for bit what lavapipe computes)' if h == 'emulation' else 'lavapipe'}"
                       for h, v in how.items())
           + f", against the target in {c['truth']['computed_by']} (its largest difference from mpmath on "
           f"{c['truth']['checked']:,} inputs: {c['truth']['float64_difference']:.3g}, the margin of each maximum), "
           f"in {c['seconds']:.0f} s. The sampled maxima are beside them (`max_abs_error_sampled`, "
           "`max_rel_error_sampled`); the fronts and verdicts read the certified ones. A GPU other than lavapipe "
           "may round otherwise where Vulkan allows it."]
    if c.get("spec"):
        from ..measures import certified_box

        vendors = sorted({v for bounds in c["spec"].values() for v in bounds if v != "vulkan"})
        key = results["error"]
        statuses = [b["status"] for bounds in c["spec"].values() for b in bounds.values()]
        out += [f"- The worst a conforming driver may give (`{key}_spec`"
                + "".join(f", `{key}_spec_{v}`" for v in vendors) + "): each certified form's operations in the order "
                "written, each result allowed Vulkan's minimum (+ - * either neighbour, division 2.5 ulp, sqrt 4.5, "
                "exp2 3 + 2|x| ulp, log2, inversesqrt, pow as exp2(y log2 x): "
                f"{escape.markdown(certified_box.vulkan(results['precision']).source)})"
                + "".join(f", or {v.upper()}'s documented figures ({escape.markdown(certified_box.vendor(v, results['precision']).source)})"
                          for v in vendors)
                + f", proven by interval arithmetic ({methods_text(b for bounds in c['spec'].values() for b in bounds.values())}) "
                f"over the domain split into boxes: {statuses.count('proven')} "
                f"of {len(statuses)} bounds within {certified_box.RATIO_ONE}x of the largest pointwise bound found, "
                f"{statuses.count('budget')} stopped at their budget, {statuses.count('not bounded')} "
                "not bounded (a driver's function without a lowering here: none stated). "
                + CONTRACT_TEXT[results.get("contract", "allowed")]]
    if c["not_certified"]:
        out += ["- Not certified (their errors sampled): " + "; ".join(
            escape.markdown(f"{n}: {w}") for n, w in c["not_certified"].items()) + "."]
    return out


def methods_text(bounds) -> str:
    """Which interval arithmetic proved the bounds, and each method's budget of boxes a form."""
    from ..measures import certified_arrays, certified_box

    methods = [b.get("method", "arb") for b in bounds if b.get("status") != "not bounded"]
    parts = []
    if "intervals" in methods:
        parts.append(f"float64 intervals with outward rounding for {methods.count('intervals')} "
                     f"(at most {certified_arrays.WORK:,} boxes a form)")
    if "arb" in methods:
        parts.append(f"arb's balls for {methods.count('arb')} (at most {certified_box.WORK:,} boxes a form)")
    return ", ".join(parts) or "none bounded"


def box_certification_lines(results: dict) -> list[str]:
    """report.md's lines on a target of several variables' certified errors (`--certify`)."""
    from ..measures import certified_box

    c, key = results["certification"], results["error"]
    short = key.removeprefix("max_").removesuffix("_error")
    bounds = c["bounds"]
    proven = sorted(n for n, b in bounds.items() if b["status"] == "proven")
    budget = sorted(n for n, b in bounds.items() if b["status"] == "budget")
    flagged = sorted(n for n, b in bounds.items() if b["sampled"] > 0 and b["bound"] > certified_box.RATIO * b["sampled"])
    missed = sorted((n for n, b in bounds.items() if b["sampled"] > 0 and b["found"] > b["sampled"]),
                    key=lambda n: -bounds[n]["found"] / bounds[n]["sampled"])
    missed_text = ", ".join(f"{escape.markdown(n)} ({bounds[n]['found'] / bounds[n]['sampled']:.3g}x)"
                            for n in missed) or "nowhere"
    out = [f"- Certified (`certified_{short}_error` in front.csv, the error the fronts and verdicts read): each form's "
           f"largest error as lavapipe rounds it, proven over the whole box by interval arithmetic ("
           f"{methods_text(bounds.values())}; the mean-value form of its error, its rounding carried through its "
           f"operations) in boxes split where their bound is largest: {len(proven)} of {len(bounds)} proven within "
           f"{certified_box.RATIO}x of the largest error found (each box's centre and corners executed by the emulation), "
           f"{len(budget)} stopped at their budget with the bound reached "
           f"({', '.join(escape.markdown(n) for n in budget) or 'none'}); in {c['seconds']:.0f} s. `certified_ratio` is "
           f"the bound over the sampled error; above {certified_box.RATIO}x: "
           f"{', '.join(escape.markdown(n) for n in flagged) or 'none'}. Where the sampling missed the largest error "
           f"(the largest found above the sampled one): "
           f"{missed_text}."]
    for name, b in sorted(bounds.items()):
        where = ", ".join(f"{v:.4g}" for v in b["at"])
        out.append(f"  - {escape.markdown(name)}: {b['status']}, bound {b['bound']:.4g}, sampled {b['sampled']:.4g}, "
                   f"largest found {b['found']:.4g}" + (f" at ({where})" if where else "") + f", {b['boxes']:,} boxes")
    if c["spec"]:
        vendors = sorted({v for bounds_ in c["spec"].values() for v in bounds_ if v != "vulkan"})
        out.append(f"- The worst a conforming driver may give (`{key}_spec`" + "".join(f", `{key}_spec_{v}`" for v in vendors)
                   + "): the same proof with each operation allowed Vulkan's minimum ("
                   + escape.markdown(certified_box.vulkan(results["precision"]).source) + ")"
                   + "".join(f", or {v.upper()}'s documented figures" for v in vendors)
                   + ". " + CONTRACT_TEXT[results.get("contract", "allowed")])
    if c["not_certified"]:
        out += ["- Not certified (their errors sampled): " + "; ".join(
            escape.markdown(f"{n}: {w}") for n, w in c["not_certified"].items()) + "."]
    return out


def write_csv(path: Path, rows) -> None:
    """COLUMNS, then any other key of the rows (a pair's errors of each output)."""
    columns = list(COLUMNS) + [k for k in dict.fromkeys(k for r in rows for k in r) if k not in COLUMNS]
    with open(path, "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(columns)
        for r in rows:
            writer.writerow([_number(r.get(c)) for c in columns])


def _json_value(v):
    if isinstance(v, float) and not math.isfinite(v):
        return None if math.isnan(v) else ("inf" if v > 0 else "-inf")
    if isinstance(v, dict):
        return {k: _json_value(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_json_value(x) for x in v]
    return v


def results_json(results) -> dict:
    """results.json's content: the results without the sympy forms (their text is in `members`), the
    rendered images (`rendered`: in renders.png) and every form's cycles (`cycles`: front.csv has the
    front members' and the anchors')."""
    return _json_value({k: v for k, v in results.items() if k not in ("forms", "renders", "cycles")})


def _error_text(v) -> str:
    return "inf" if v is None or isinstance(v, str) or math.isinf(v) else f"{v:.3g}"


def _rungs_text(rungs) -> str:
    return "; ".join((f"{r['name']} ({r['operations']}): every form to complexity {r['complexity']} not fitted before "
                      f"({r['forms']} forms)" if r["engine"] == "exhaustive" else
                      f"pyoperon to complexity {r['complexity']} ({r['forms']} models)")
                     + f", {r['seconds']} s (forecast {r['estimated_seconds']} s)" for r in rungs)



def _parametric_coverage(results) -> list[str]:
    """The coverage lines of a parametric target (`engines.several_variables`)."""
    t, c = results["target"], results["coverage"]
    lines = []
    if t.get("parameter"):
        p = t["parameter"]["name"]
        lines += [f"- Templates, their constants fitted by minimax at {c['parameter_values']} values of {p} (a grid and "
                  f"the values halfway), then each constant a formula of {p}, all polished together over the whole box: "
                  f"{', '.join(results['families'])}"
                  + (" (in symmetric monomials: the target is symmetric in its two variables)" if c.get("symmetric") else "")
                  + f"; {c['family_templates']} family templates ({c['family_seconds']} s), {c['templates']['count']} "
                  f"of the grammar ({c['templates']['seconds']} s).",
                  f"- The grammar's templates, at {p} = {c['templates']['at']:g} on {c['templates']['points']} points, "
                  f"loss {c['templates']['loss']}: " + _rungs_text(c["templates"]["rungs"]) + "."]
        dropped = c.get("families_dropped", []) + c["templates"].get("dropped", [])
        if dropped:
            lines.append(f"- Dropped before their formulas ({DROP_RULE}; the best constant errs "
                         f"{dropped[0]['constant_error']:.4g}): "
                         + ", ".join(f"{d['template']} ({d['per_value_error']:.4g} at {p} = {d['at']:.4g}, "
                                     f"value {d['values_fitted']} of {c['parameter_values']})" for d in dropped) + ".")
    s = c["pixel_search"]
    lines += [f"- The grammar over every variable{' and the parameter' if t.get('parameter') else ''} "
              f"(per pixel), on {s['points']} points, loss {s['loss']}: " + _rungs_text(s["rungs"])
              + f". Not searched: min, max and saturate, and forms above complexity {c['max_complexity']}."]
    return lines


def cause_text(gap: dict, precision: str) -> str:
    """A gap's cause (`executed.gap_cause`) in words, with its numbers."""
    if gap["cause"] == "constants":
        return (f"its constants rounded to {precision}: with them, computed in float64, it errs "
                f"{_error_text(gap['constants_error'])}")
    if gap["cause"] == "function":
        emulated = ("; with numpy's functions in the format it errs "
                    f"{_error_text(gap['emulated_error'])}" if gap["emulated_error"] is not None else
                    " (which the per-operation emulation does not compute)")
        return f"the driver's {', '.join(gap['functions'])}{emulated}"
    return (f"the arithmetic in {precision} (each operation's rounding, a cancellation): with the format's constants, "
            f"computed in float64, it errs {_error_text(gap['constants_error'])}")


def _gaps_text(results) -> list[str]:
    error, precision = results["error"], results.get("precision")
    members = [(name, m) for name, m in results["members"].items() if m.get("gap")]
    if not members:
        return []
    lines = [f"## Where the executed error exceeds the float64 one more than {GAP:g} times", ""]
    for name, m in members:
        lines.append(f"- {escape.markdown(name)}: {_error_text(m[error])} as executed in {precision}, "
                     f"{_error_text(m[error + '_real'])} in float64; the cause: {cause_text(m['gap'], precision)}.")
    return lines + [""]


def _special_text(results) -> list[str]:
    """The documented accuracy of every special function a row calls, per architecture."""
    special = results.get("special_functions") or {}
    if not any(special.values()):
        return []
    lines = ["## The special functions' documented accuracy", "",
             f"What each special function a row calls may err in {results['precision']} on each architecture: the "
             "vendor's own figure where it publishes one, else Vulkan's minimum. The column `bound` of each "
             "architecture's table (`max_error_bound`) is the executed error plus these, propagated to first order "
             "through the form.", "", "| architecture | function | accuracy | source |", "|---|---|---|---|"]
    for a, functions in special.items():
        for entry in functions:
            lines.append(f"| {a} | {entry['function']} | {entry['accuracy']} | {escape.markdown(entry['source'])} |")
    mesa = sorted({a for a, functions in special.items() if any(e["mesa"] for e in functions)})
    if mesa:
        lines += ["", f"On {', '.join(mesa)}, acos, asin and atan are Mesa's lowering (a polynomial times a square "
                  "root), the same in lavapipe, which executed the forms: their error is in the executed one, and "
                  "the bound adds nothing for them there."]
    return lines + [""]


def _executed_text(results) -> str:
    run = results["execution"]
    return (f"as each form's shader executes in {results['precision']} ({escape.markdown(run['how'])}, "
            f"{run['inputs']} inputs of the domain)")


def not_compiled_text(results) -> str:
    """What was not compiled, and why, as the report and the command's output say it ("" where
    everything was)."""
    if not results["missing"]:
        return ""
    return "Not compiled: " + "; ".join(f"{k}: {v}" for k, v in results["missing"].items()) + "."


def no_verdict_text(results) -> str:
    """Why a run has no verdict at all: no anchor, and its exact form not compiled (where, and why) or
    not judged (several variables)."""
    return ("No verdict: the target has no hand fit to compare with (a target file's `[[anchor]]` tables add "
            "them), and its exact form "
            + ("was not compiled on any architecture (" + "; ".join(f"{k}: {v}" for k, v in results["missing"].items())
               + ")." if results["missing"] else "is not judged for a target of several variables."))


def report(results) -> str:
    """report.md: every number from `results` (results.json's fields)."""
    from ...isa.architectures import ARCHITECTURES
    from ...isa.machine_code import backend

    t, c = results["target"], results["coverage"]
    error = results["error"]
    measure = "largest absolute error" if error == "max_abs_error" else "largest relative error"
    lines = [f"# pipeline derive: {escape.markdown(t['name'])}", "",
             f"Target: {escape.code(t['expression'])} for {domain_text(t)}"
             + (f" ({escape.markdown(t['description'])})" if t["description"] else "") + f"; ranked by the {measure} "
             + (_executed_text(results) if results.get("execution") else
                "over the whole domain (float64, grid and refinement)")
             + ", against cycles compiled for each architecture.", "",
             "## What the search covered", ""]
    if "pairs" in c:            # a pair: each part's coverage, then the pairs
        for part in ("scale", "bias"):
            lines += [f"{part}:"] + _parametric_coverage(dict(target=t, coverage=c[part],
                                                               families=results["families"]))
        lines += [f"- Pairs: every pair of the two fronts' members per architecture, and each anchor's two parts, "
                  f"compiled as one shader computing F0 A + B: {c['pairs']} pairs. A pair's error is the larger of its "
                  "two."]
    lines += [] if "pairs" in c else _parametric_coverage(results) if t.get("variables") else [
             f"- Families fitted by minimax on the whole interval: {', '.join(results['families'])} "
             f"({len(results['family_members'])} members: "
             f"{', '.join(escape.markdown(m) for m in results['family_members'])}).",
             f"- The grammar's ten operations ({' '.join(c['operations'])}), loss {c['loss']} on {c['points']} points, "
             "by the ladder of grammars: " + _rungs_text(c["rungs"])
             + ("" if any(r["engine"] == "operon" for r in c["rungs"]) or c["exhaustive_complexity"] >= c["max_complexity"]
                else "; pyoperon did not run (the budget left less than its minimum)")
             + f"; {c['seconds']} s. Not searched: min, max and saturate, and forms above complexity "
             f"{c['max_complexity']}."]
    if results.get("plan", {}).get("searches"):
        from ...symbolic import budgets

        lines += [f"- The plan: {escape.markdown(budgets.plan_text(results['plan']))}."]
    lines += [f"- Time: {results['seconds']} s measured"
              + (f", {results['estimated_seconds']} s forecast before the start." if results["estimated_seconds"]
                 else "."), ""]
    if results["missing"]:
        lines += [not_compiled_text(results), ""]
    lines += ["## The anchors", ""]
    if not any(results["verdicts"].values()):
        # (no table with a header and no rows: what is missing, and why)
        lines += [no_verdict_text(results)]
    else:
        lines += ["| architecture | anchor | cycles | error | verdict | by | error ratio |", "|---|---|---|---|---|---|---|"]
    for a, verdicts in results["verdicts"].items():
        for name, v in verdicts.items():
            ratio = "-" if v["ratio"] is None or math.isinf(v["ratio"]) else f"{v['ratio']:.3g}"
            by = (f"{escape.markdown(v['by'])}: {escape.code(results['members'][v['by']]['expression'])}"
                  if v["by"] else "-")
            lines.append(f"| {a} | {escape.markdown(name)} | {v['cycles']:g} | {_error_text(v['error'])} | {v['verdict']} | {by} | "
                         f"{ratio} |")
    parametric = bool(t.get("parameter"))
    sources = {r["name"]: r.get("source", "") for r in results["rows"] if r["kind"] == "anchor"}
    lines += ["", "The anchors' sources: " + "; ".join(f"{escape.markdown(name)}: {escape.markdown(source)}"
                                                     for name, source in sources.items()) + "."] if sources else []
    lines += ["", "A verdict compares the anchor with the most accurate found form at no more cycles on that "
              "architecture" + (" among the forms with the parameter per pixel (as engines evaluate the anchors)"
                                if parametric else "")
              + ": beaten (its error lower by more than 1 %), matched (within 1 %), missed.", ""]
    if parametric:
        lines += [f"With `parameter_per` material, the constants c0, c1, ... are push constants the CPU computes once "
                  f"per material from their formulas in {t['parameter']['name']}; with pixel, the formulas are "
                  "compiled into the shader. The per-value optimum is the template's error with its constants fitted "
                  "at each value alone: no formula does better.", ""]
    for a in results["architectures"]:
        rows = [r for r in results["rows"] if r["architecture"] == a]
        unit = backend(a).UNIT
        lines += [f"## {a} ({ARCHITECTURES[a].title}): {unit}", ""]
        if parametric:
            lines += ["| kind | per | name | cycles | max abs error | max rel error | per-value optimum | expression |",
                      "|---|---|---|---|---|---|---|---|"]
        elif results.get("execution"):
            lines += [f"| kind | name | cycles | predicted | max abs error ({results['precision']}) | max rel error "
                      f"({results['precision']}) | max abs error (float64) | max rel error (float64) | bound on {a} | "
                      "expression |", "|---|---|---|---|---|---|---|---|---|---|"]
        else:
            lines += ["| kind | name | cycles | predicted | max abs error | max rel error | expression |",
                      "|---|---|---|---|---|---|---|"]
        for r in sorted(rows, key=lambda r: (r["cycles"], r[error])):
            if parametric:
                optimum = results["members"].get(r["name"], {}).get("per_value_error")
                lines.append(f"| {r['kind']} | {r['parameter_per']} | {escape.markdown(r['name'])} | {r['cycles']:g} | "
                             f"{_error_text(r['max_abs_error'])} | {_error_text(r['max_rel_error'])} | "
                             f"{'-' if optimum is None else _error_text(optimum)} | {escape.code(r['expression'])} |")
                continue
            predicted = "-" if r["cycles_predicted"] is None else f"{r['cycles_predicted']:g}"
            real = (f"{_error_text(r['max_abs_error_real'])} | {_error_text(r['max_rel_error_real'])} | "
                    f"{_error_text(r.get('max_error_bound'))} | " if "max_abs_error_real" in r else "")
            lines.append(f"| {r['kind']} | {escape.markdown(r['name'])} | {r['cycles']:g} | {predicted} | "
                         f"{_error_text(r['max_abs_error'])} | {_error_text(r['max_rel_error'])} | {real}"
                         f"{escape.code(r['expression'])} |")
        lines.append("")
    lines += _gaps_text(results)
    lines += _special_text(results)
    lines += rendered_report.report_lines(results)
    lines += ["## Limits", ""]
    if results.get("execution"):
        run = results["execution"]
        truth = (f"{run['truth']['computed_by']} (float64 checked against mpmath on {run['truth']['checked']} inputs: "
                 f"largest difference {run['truth']['float64_difference']:.3g})" if "truth" in run else
                 "float64 at the same points (the box's measuring grid and the float64 errors' peaks)")
        lines += [f"- Errors are those of each form's shader executed in {results['precision']} ({run['how']}) at "
                  f"{run['inputs']} inputs of the domain, against the target in {truth}; "
                  + ("the float64 columns are each form's mathematics" if "truth" in run else
                     "`max_abs_error_real` and `max_rel_error_real` in front.csv keep each form's mathematics in "
                     "float64")
                  + f". On the fronts and in the verdicts, errors below {results['rounding_floor']:.3g} "
                  f"({results['precision']}'s rounding of the target's range) count as equal."]
        if run["not_executed"]:
            lines += ["- Not executed: " + "; ".join(escape.markdown(v) for v in run["not_executed"].values()) + "."]
        lines += certification_lines(results)
    else:
        lines += ["- Errors are those of each expression in float64; a shader computes in float32, whose rounding "
                  "(about 1e-7 relative) is not included; on the fronts and in the verdicts, errors below "
                  f"{results['rounding_floor']:.3g} (float32's rounding of the target's range) count as equal."]
    lines += [
              "- Cycles are each vendor's cost model of the machine code Mesa's, NVIDIA's or Intel's compilers "
              "make here, net of a shader returning the variable; `cycles_predicted` sums the architecture's "
              "cost table over the form's operations.", ""]
    return "\n".join(lines)


def gaps(results, architecture: str) -> list[dict]:
    """The rows of `architecture` whose executed error exceeds GAP times their float64 error (and the
    format's rounding floor: below it both are the format's rounding)."""
    error, floor = results["error"], results["rounding_floor"]
    return [r for r in results["rows"] if r["architecture"] == architecture and r.get(error + "_real") is not None
            and math.isfinite(r[error]) and r[error] > GAP * max(r[error + "_real"], floor)]


def figure(path: Path, results) -> None:
    """front.png: per vendor (its first architecture), error against cycles, log error axis: the
    found front joined, each anchor labelled, the exact target as a dashed line at its cycles (and
    its executed error as a diamond); errors below the format's rounding (`fronts.rounding_floor`)
    drawn at it, the line drawn; a row whose executed error exceeds GAP times its float64 one with
    its float64 error beside it, joined (`gaps`)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from ...isa.architectures import vendor_groups
    from ...isa.machine_code import backend

    error = results["error"]
    floor = results["rounding_floor"]
    shown = [names[0] for _, names in vendor_groups(results["architectures"])]
    columns = min(3, len(shown))
    lines = math.ceil(len(shown) / columns)
    fig, axes = plt.subplots(lines, columns, figsize=(5.0 * columns, 3.9 * lines + 0.6), squeeze=False)
    t = results["target"]
    for ax in axes.flat[len(shown):]:
        ax.axis("off")
    for ax, a in zip(axes.flat, shown):
        rows = [r for r in results["rows"] if r["architecture"] == a]
        fronts = (("pixel", "C0", "found, parameter per pixel: the front"),
                  ("material", "C2", "found, parameter per material: the front")) if t.get("parameter") else \
            (("", "C0", "found: the front"),)
        for per, colour, label in fronts:
            found = sorted((r for r in rows if r["kind"] == "found" and r.get("parameter_per", "") == per
                            and math.isfinite(r[error])), key=lambda r: r["cycles"])
            values = [max(r[error], floor) for r in found]
            ax.step([r["cycles"] for r in found], values, where="post", color=colour, lw=1.2, alpha=0.6)
            ax.plot([r["cycles"] for r in found], values, "o", color=colour, ms=5, label=label)
        anchors: dict = {}          # anchors at one point share one label (Lagarde's is Eberly's degree 1)
        for r in (r for r in rows if r["kind"] == "anchor"):
            anchors.setdefault((r["cycles"], float(f"{max(r[error], floor):.3g}")), []).append(r["name"])
        for k, ((cycles, value), names) in enumerate(anchors.items()):
            ax.plot(cycles, value, "s", color="C3", ms=7, label="anchors: the engines' fits" if k == 0 else None)
            ax.annotate(escape.mathtext(" = ".join(names)), (cycles, value), textcoords="offset points", xytext=(6, 4), fontsize=8,
                        color="C3")
        for r in (r for r in rows if r["kind"] == "exact"):
            ax.axvline(r["cycles"], color="0.4", ls="--", lw=1, label="the target itself (its cycles)")
            if math.isfinite(r[error]):
                ax.plot(r["cycles"], max(r[error], floor), "D", color="0.3", ms=6,
                        label="the target itself as executed (its own functions)")
        for r in gaps(results, a):      # (executed more than GAP times its float64 error: both, joined)
            real = max(r[error + "_real"], floor)
            ax.plot([r["cycles"], r["cycles"]], [real, max(r[error], floor)], color="C1", lw=1)
            ax.plot(r["cycles"], real, "o", mfc="none", color="C1", ms=6,
                    label=f"its float64 error, where executed is > {GAP:g}x it")
        smallest = min((max(r[error], floor) for r in rows if r[error] is not None and math.isfinite(r[error])),
                       default=floor)
        precision = results.get("precision", "fp32")
        if smallest < 100 * floor or results.get("execution"):
            # (drawn where an error comes near it, or where every error is executed: it is the format's floor)
            ax.axhline(floor, color="0.5", lw=0.9, ls=":", label=f"{precision} rounding of the range (smaller errors "
                       "drawn here)" if error == "max_abs_error" else f"{precision} rounding (smaller errors drawn here)")
        ax.set_yscale("log")
        ax.set_xlabel(f"{a}: {backend(a).UNIT}")
        ax.set_ylabel("largest absolute error" if error == "max_abs_error" else "largest relative error")
        ax.grid(alpha=0.3, which="major")
    handles = {}
    for ax in axes.flat:
        for h, label in zip(*ax.get_legend_handles_labels()):
            handles.setdefault(label, h)
    ncol = 4 if columns > 2 else columns    # (two panels are too narrow for four long labels a row, one for two)
    fig.legend(handles.values(), handles.keys(), loc="lower center", ncol=ncol, fontsize=9, frameon=False)
    measured = f"error as executed in {results['precision']}" if results.get("execution") else "error"
    title = (escape.mathtext(f"{t['name']} for {domain_text(t)}") + f": {measured} against compiled cycles, one panel "
             "per vendor")
    fig.suptitle("\n".join(textwrap.wrap(title, width=55 * columns)), fontsize=11)
    legend_rows = -(-len(handles) // ncol)
    fig.tight_layout(rect=(0, min(0.3, 0.25 * legend_rows / (3.9 * lines + 0.6)), 1, 1))
    fig.savefig(path, dpi=110)
    plt.close(fig)


def write(out: Path, results, log=print) -> list[Path]:
    """Every file of the module docstring into `out`, published whole."""
    from ...engine.cache import digest
    from ...engine.publishing import publish
    from ...engine.web_page import assets_digest

    publish(out, digest("derive", json.dumps(results_json(results), sort_keys=True), assets_digest()), lambda s: None,
            lambda tmp: write_into(tmp, results, out))
    return [out / n for n in file_names(results)]


def file_names(results) -> list[str]:
    return ["front.csv", "results.json", "report.md", "report.html", "front.png", "derive.glsl", "derive.hlsl",
            "derive_twin.py"] + (["renders.png", "rendered_front.png"] if results.get("renders") else [])


WRITTEN = ".written"      # in a derivation's folder: the digest of what it was written from (`write_kept`)


def folder_digest(results) -> str:
    """What a derivation's folder is written from: its results (results.json's, every form's cycles and
    expression, its renders), the page's assets and this package's code."""
    from ...engine import web_page
    from ...engine.cache import digest

    code = b"".join(f.read_bytes() for f in sorted(Path(__file__).parent.glob("*.py")))
    forms = {name: str(getattr(f, "expression", f)) for name, f in (results.get("forms") or {}).items()}
    renders = results.get("renders")
    return digest("derive folder", json.dumps(results_json(results), sort_keys=True, default=str),
                  json.dumps(results.get("cycles"), sort_keys=True, default=str), json.dumps(forms, sort_keys=True),
                  repr(renders) if renders is not None else "", web_page.assets_digest(), code.hex())


def write_kept(folder: Path, results, shown: Path) -> str:
    """`write_into`, or where `shown` already holds every file written from the same results and code
    (its `WRITTEN` digest: a rerun with nothing changed), those files copied into `folder`."""
    import shutil

    key = folder_digest(results)
    kept = shown / WRITTEN
    if kept.is_file() and kept.read_text() == key and all((shown / n).is_file() for n in file_names(results)):
        shutil.copytree(shown, folder, dirs_exist_ok=True)
        return "kept"
    written = write_into(folder, results, shown)
    (folder / WRITTEN).write_text(key)
    return written


def write_into(folder: Path, results, shown: Path) -> str:
    """Every file of the module docstring written into `folder` (a temporary folder being published
    as `shown`, which an error names)."""
    from ...engine import faults

    from . import derive_page

    folder.mkdir(parents=True, exist_ok=True)
    writers = [("front.csv", lambda p: write_csv(p, results["rows"])),
               ("results.json", lambda p: p.write_text(json.dumps(results_json(results), indent=1))),
               ("report.md", lambda p: p.write_text(report(results))), ("front.png", lambda p: figure(p, results))]
    if results.get("renders"):
        writers += [("renders.png", lambda p: rendered_report.figure_renders(p, results)),
                    ("rendered_front.png", lambda p: rendered_report.figure_front(p, results))]
    writers.append(("report.html", lambda p: derive_page.write(p, results)))    # (after renders.png, which it embeds)
    writers += [(name, lambda p, text=text: p.write_text(text)) for name, text in shader_sources(results).items()]
    for name, write_file in writers:
        with faults.writing(shown / name):
            write_file(folder / name)
    return f"{len(results['rows'])} rows"
