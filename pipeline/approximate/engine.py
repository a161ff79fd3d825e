"""`derive`: the cheapest accurate forms of a target (`targets`), ranked by compiled cycles per GPU
architecture.

1. Families fitted by minimax directly (`families`), and each anchor's own form with its decimal
   numbers refitted by minimax (`refitted_anchors`: the same operations, so mostly the same cost).
2. The grammar's forms (`symbolic.grammar`, the ten operations), by the ladder of grammars within
   the budget (`symbolic.ladder`: every form of + - * / as deep as it reaches, then of the ten
   operations and of those the target suggests, by `symbolic.search`, loss max or max-relative on
   `SEARCH_POINTS` Chebyshev points; pyoperon to `max_complexity` in the rest). Each architecture's cost table
   (`symbolic.gpu_costs`, fitted to `CALIBRATION` compiled forms) predicts every form's cycles;
   the forms on some architecture's front of predicted cycles against error go on.
3. Every form, and each anchor and the exact target, measured over the whole domain
   (`measure.max_error`), compiled for every architecture (`isa.machine_code`, each shader kept
   on disk), and the front per architecture read off: the forms no other beats at equal or fewer
   compiled cycles. The grammar's front members are then polished on the whole interval
   (`minimax.slp`), measured and compiled again, and the fronts read off again.
4. Each anchor's verdict per architecture, by `verdict`: beaten, matched or missed.
"""

from __future__ import annotations

import math
import time

import numpy as np

from . import bounds, executed, families, measure, minimax, representable
from .forms import Form, free_numbers, glsl, predicted_cycles
from .targets import DeriveError, check, numpy_function

SEARCH_POINTS = 129
DEFAULT_SECONDS = 60.0
MAX_COMPLEXITY = 12
CALIBRATION = 200               # forms compiled per architecture to fit its cost table
PER_ARCHITECTURE = 24           # grammar forms taken from each architecture's predicted front, at most
MATCH = 0.01                    # an error within 1 % of an anchor's matches it
TIE = 1e-6                      # errors within this (relative) are equal on a front
NEGLIGIBLE = 1e-9               # a constant below this share of a form's largest is tried without it
# Times measured on this 2-core machine, for the time a run announces: the families' fits (about 10 s
# per target), the forms measured and polished (about 6 s), the command's start (its imports, 6 s).
FAMILY_SECONDS = 12.0
MEASURE_SECONDS = 6.0
START_SECONDS = 6.0
EXECUTE_SECONDS = {"fp32": 10.0, "fp16": 2.0}     # every form executed (about 60 forms; fp32: 5 M inputs)


def constant_error(target, f) -> float:
    """The error of the best constant (minimax, on the measuring grid): a form worth a cycle beats it.
    abs: (max f - min f) / 2; rel (f of one sign): (max |f| - min |f|) / (max |f| + min |f|), the
    floor raising min |f|."""
    return measure.best_constant_error(f(measure.grid(*target.domain)), target.metric, target.floor)


def available_architectures() -> list[str]:
    """Every architecture whose compiler runs here."""
    from ..isa.architectures import ARCHITECTURES, CompilerMissing
    from ..isa.machine_code import backend

    out = []
    for name in ARCHITECTURES:
        try:
            backend(name).check()
        except (CompilerMissing, OSError, RuntimeError):
            continue
        out.append(name)
    return out


FLOAT32 = 2.0 ** -23        # float32's rounding: errors below it (of the target's range, or relative) are equal


def rounding_floor(target, constant: float, precision: str = "fp32") -> float:
    """The error below which two forms are equal in a shader (the format's rounding): its unit
    (`executed.UNIT`: float32 2^-23, float16 2^-10) of the target's range (abs; the range is twice the
    best constant's error), or the unit itself (rel)."""
    from .executed import UNIT

    return UNIT[precision] * (2 * constant if target.metric == "abs" else 1.0)


def front(rows: list[dict], error: str, floor: float = 0.0) -> list[dict]:
    """The rows no other beats at equal or fewer cycles: sorted by cycles, each with an error below
    every cheaper row's by more than TIE (relative); errors below `floor` count as `floor` (float32
    rounding: a form exact to 1e-15 and the exact one are equal). Rows of equal cycles and errors
    equal to 6 significant digits are a tie, kept by the row listed first (the same function written
    twice differs in its last bits). The fronts of `pipeline derive` and of the lobe search."""
    ordered = sorted((r for r in rows if np.isfinite(r[error]) and r["cycles"] is not None),
                     key=lambda r: (r["cycles"], float(f"{max(r[error], floor):.6g}")))
    out, best = [], math.inf
    for r in ordered:
        if max(r[error], floor) < best * (1.0 - TIE):
            out.append(r)
            best = max(r[error], floor)
    return out


def verdict(anchor_cycles: float, anchor_error: float, found: list[dict], error: str, floor: float = 0.0) -> dict:
    """How the found front places an anchor: the most accurate found form at no more cycles, and
    `beaten` (its error below the anchor's by more than MATCH), `matched` (within MATCH) or
    `missed` (none as accurate at no more cycles; `ratio` says by how much), `by` that form and
    `by_cycles` its cycles; errors below `floor` count as `floor`."""
    cheaper = [r for r in found if r["cycles"] <= anchor_cycles and np.isfinite(r[error])]
    if not cheaper:
        return dict(verdict="missed", ratio=math.inf, by=None, by_cycles=None)
    best = min(cheaper, key=lambda r: r[error])
    ratio = max(best[error], floor) / max(anchor_error, floor) if max(anchor_error, floor) > 0 else 1.0
    word = "beaten" if ratio < 1 - MATCH else "matched" if ratio <= 1 + MATCH else "missed"
    return dict(verdict=word, ratio=float(ratio), by=best["name"], by_cycles=best["cycles"])


def _grammar_search(target, f, seconds: float, max_complexity: int, log) -> tuple[list, list, np.ndarray, dict]:
    """The grammar's forms (module docstring, step 2): (trees, constants, search losses, the
    search's coverage)."""
    from ..symbolic import grammar, ladder

    lo, hi = target.domain
    x = minimax.chebyshev_points(lo, hi, SEARCH_POINTS)
    y = f(x)
    loss = "max-relative" if target.metric == "rel" and target.floor == 0 else "max"
    ops = grammar.TEN
    started = time.perf_counter()
    candidates, rungs, fitted = ladder.run(x[None], y, max_complexity, ops, seconds, loss,
                                           log=lambda s: log("grammar: " + s))
    whole = [r.complexity for r in rungs if r.engine == "exhaustive" and set(r.operations) == set(ops)]
    operon = [r for r in rungs if r.engine == "operon"]
    coverage = dict(operations=list(ops), loss=loss, points=int(y.size), exhaustive_complexity=int(max(whole, default=0)),
                    exhaustive_forms=int(sum(r.forms for r in rungs if r.engine == "exhaustive")),
                    operon_seconds=round(operon[0].seconds, 1) if operon else 0.0,
                    operon_models=int(operon[0].forms) if operon else 0, max_complexity=int(max_complexity),
                    rungs=[r.row() for r in rungs], seconds=round(time.perf_counter() - started, 1))
    # every form the exhaustive rungs fitted (a form off the complexity front may be cheap in cycles)
    # and pyoperon's
    others = [c for c in candidates if c[4] == "operon"]
    trees = list(fitted["forms"]) + [c[0] for c in others]
    constants = [np.asarray(c, dtype=float) for c in fitted["constants"]] + [np.asarray(c[1], dtype=float) for c in others]
    return trees, constants, np.array(list(fitted["loss"]) + [c[2] for c in others], dtype=float), coverage


def _code_version() -> str:
    import hashlib
    from pathlib import Path

    here = Path(__file__).parent
    files = sorted(here.glob("*.py")) + sorted((here.parent / "symbolic").glob("*.py"))
    return hashlib.sha256(b"".join(f.read_bytes() for f in files)).hexdigest()


def _kept_search(target, seconds: float, max_complexity: int):
    """The file that keeps the search of a target under a budget (`_searched`)."""
    import hashlib
    import json

    from ..engine import paths

    key = json.dumps([_code_version(), target.expression, target.variable, list(target.domain), target.metric,
                      target.floor, seconds, max_complexity])
    return paths.DERIVE_CACHE / f"{hashlib.sha256(key.encode()).hexdigest()[:32]}.json"


def _searched(target, f, seconds: float, max_complexity: int, log):
    """(the families' members, the grammar's trees, constants, losses and coverage): kept in
    `paths.DERIVE_CACHE` by the target, the budget and this code, so that a rerun (another --gpu,
    --max-cycles) skips the search; an entry that cannot be read is searched again."""
    from . import kept as keeping

    kept = _kept_search(target, seconds, max_complexity)
    symbols = {target.variable: target.symbol()}
    entry = keeping.read(kept, log)
    try:
        if entry is not None:
            found = [Form(m["name"], m["kind"], m["family"], keeping.expression(m["expression"], symbols),
                          m["source"], m["converged"]) for m in entry["families"]]

            def tree(node):
                return tuple(tree(a) if isinstance(a, list) else a for a in node)

            trees = [tree(t) for t in entry["trees"]]
            fitted = [np.array(c, dtype=float) for c in entry["constants"]]
            losses = np.array([float(v) for v in entry["losses"]], dtype=float)
            log(f"the search of an earlier run, kept in {kept.parent} (families, grammar to complexity "
                f"{entry['coverage']['exhaustive_complexity']})")
            return found, trees, fitted, losses, entry["coverage"] | dict(kept=True)
    except keeping.Unusable as e:
        log(f"the kept search {kept.name} is not used ({e}): searched again")
    except (ValueError, KeyError, TypeError) as e:
        log(f"the kept search {kept.name} is not readable ({type(e).__name__}): searched again")
    log("families (minimax):")
    found = families.fit_families(target, f, lambda s: log(s))
    trees, fitted, losses, coverage = _grammar_search(target, f, seconds, max_complexity, log)
    try:
        texts = [keeping.text(m.expression, symbols) for m in found]
    except keeping.Unusable as e:
        log(f"the search is not kept ({e})")
    else:
        keeping.write(kept, dict(families=[dict(name=m.name, kind=m.kind, family=m.family, expression=text,
                                                source=m.source, converged=m.converged) for m, text in zip(found, texts)],
                                 trees=trees, constants=[np.asarray(c, dtype=float).tolist() for c in fitted],
                                 losses=[repr(float(v)) for v in losses], coverage=coverage))
    return found, trees, fitted, losses, coverage | dict(kept=False)


def _select(trees, losses, tables: dict) -> list[int]:
    """The forms on some architecture's front of predicted cycles (its cost table) against the
    search's loss, at most PER_ARCHITECTURE each."""
    from ..symbolic import gpu_costs

    from ..symbolic import grammar

    if not trees:
        return []
    counts = np.array([gpu_costs.operation_counts(t) for t in trees], dtype=float)
    variable = np.array([grammar.X in _leaves(t) for t in trees])       # (a constant approximates nothing)
    chosen: set[int] = set()
    for table in tables.values():
        cost = counts @ np.array([table[op] for op in gpu_costs.OPERATIONS])
        order = np.lexsort((losses, cost))
        best, picked = math.inf, []
        for i in order:
            if variable[i] and np.isfinite(losses[i]) and losses[i] < best * (1 - 1e-9):
                picked.append(int(i))
                best = losses[i]
        chosen.update(picked[-PER_ARCHITECTURE:])        # (the most accurate end)
    return sorted(chosen)


def _leaves(tree) -> set:
    return {tree} if len(tree) == 1 else set().union(*(_leaves(a) for a in tree[1:]))


def _polish(tree, c, target, f, weight) -> np.ndarray:
    """A grammar form's constants, minimax on the whole interval from c (finite differences)."""
    from ..symbolic import grammar

    lo, hi = target.domain

    def model(c_, s):
        return grammar.evaluate_numpy(tree, c_, s)

    if len(c) == 0:
        return np.asarray(c, dtype=float)
    polished, _ = minimax.slp(model, minimax.numerical_jacobian(model), np.asarray(c, dtype=float), f, weight, lo, hi,
                              steps=40, exchanges=2)
    return polished


def refitted_anchors(target, f, log) -> list[Form]:
    """Each anchor's form with its decimal numbers refitted together by minimax over the domain (from
    their own values, `minimax.slp`), where that lowers its error: the engines' own form at its own
    cost, with the numbers the exact function asks for. An anchor without decimal numbers has none."""
    import sympy as sp

    lo, hi = target.domain
    key = "max_abs_error" if target.metric == "abs" else "max_rel_error"
    weight = families.weight_of(target, f)
    symbol = target.symbol()
    out = []
    for anchor, expr in zip(target.anchors, target.anchor_expressions().values()):
        (free,), q, numbers = free_numbers(expr)
        if not numbers:
            continue
        g = sp.lambdify([q, symbol], free, "numpy")

        def model(c, s, g=g):
            with np.errstate(all="ignore"):
                return np.broadcast_to(np.asarray(g(c, s), dtype=np.float64), np.shape(s))

        c, _ = minimax.slp(model, minimax.numerical_jacobian(model), [float(v) for v in numbers], f, weight, lo, hi,
                           steps=40, exchanges=2)
        refit = Form(f"{anchor.name}_refitted", "found", "anchor_refit",
                     free.xreplace({qi: sp.Float(float(ci), 17) for qi, ci in zip(q, c)}),
                     f"{anchor.name}'s form, its numbers refitted by minimax")
        before, after = _measure(Form(anchor.name, "anchor", "anchor", expr, ""), target, f)[key], \
            _measure(refit, target, f)[key]
        if np.isfinite(after) and after < before * (1 - 1e-6):
            log(f"{anchor.name} refitted: error {before:.3g} -> {after:.3g}")
            out.append(refit)
    return out


def without_negligible(form: Form, target, f) -> Form:
    """`form` with its constants at rounding's level (below NEGLIGIBLE times its largest constant's
    magnitude, e.g. exp2(3.5e-18 - 1.44 x)) set to 0 where its float64 error does not rise; else the
    form as it is. Every output then writes the form without them."""
    import dataclasses

    import sympy as sp

    numbers = [a for a in form.expression.atoms(sp.Float) if a != 0]
    if len(numbers) < 2:
        return form
    largest = max(abs(float(a)) for a in numbers)
    tiny = {a: sp.Integer(0) for a in numbers if abs(float(a)) < NEGLIGIBLE * largest}
    if not tiny:
        return form
    key = "max_abs_error" if target.metric == "abs" else "max_rel_error"
    candidate = dataclasses.replace(form, expression=form.expression.xreplace(tiny))
    before, after = _measure(form, target, f)[key], _measure(candidate, target, f)[key]
    return candidate if after <= before else form


def _measure(form: Form, target, f) -> dict:
    lo, hi = target.domain
    return measure.max_error(numpy_function(form.expression, target.symbol()), f, lo, hi, target.floor)


def _compile(forms: list[Form], architectures, log, precision: str = "fp32") -> tuple[dict, dict]:
    """({architecture: {form name: cycles}}, {what: why not}) of every form, by `derive`'s one
    costing (`isa.machine_code.form_cycles`: a shader reading t, net of the shader writing it, in
    `precision`, its numbers the format's); the exact target per vendor, left out where a vendor's
    lowering lacks one of its functions."""
    from ..isa.architectures import ARCHITECTURES, vendor_groups
    from ..isa.machine_code import form_cycles

    plain = {m.name: (f"return {glsl(m.expression, 't', precision)};", ["t"]) for m in forms if m.kind != "exact"}
    cycles, missing, _ = (form_cycles(plain, ["t"], architectures, precision) if plain
                          else ({a: {} for a in architectures}, {}, {}))
    for a in architectures:
        if plain and not cycles[a]:
            missing[ARCHITECTURES[a].vendor] = "its compiler did not run"
    for m in (m for m in forms if m.kind == "exact"):
        try:
            text = glsl(m.expression, "t", precision)
        except Exception as e:          # a function sympy's GLSL printer does not know
            missing["exact"] = f"{m.expression} has no GLSL form ({type(e).__name__})"
            continue
        for vendor, names in vendor_groups(list(architectures)):
            try:
                found, failed, _ = form_cycles({m.name: (f"return {text};", ["t"])}, ["t"], names, precision)
            except Exception as e:      # (no back end of this vendor runs here)
                missing[f"exact on {vendor}"] = str(e).splitlines()[0][:200]
                continue
            if failed:                  # (an operation the vendor's lowering lacks)
                missing[f"exact on {vendor}"] = next(iter(failed.values()))
            for a, values in found.items():
                cycles[a].update(values)
    return cycles, missing


def checked_options(gpu, seconds: float, max_cycles: float | None, max_complexity: int) -> list[str]:
    """The architectures `gpu` names (default every one whose compiler runs here), the other options
    checked. Raises DeriveError naming a bad one, CompilerMissing where no compiler runs."""
    from ..isa.architectures import ARCHITECTURES
    from ..isa.machine_code import CompilerMissing
    from ..symbolic import regress

    if not (math.isfinite(seconds) and 5 <= seconds <= 3600):
        raise DeriveError(f"--seconds {seconds:g}: give a number in [5, 3600]")
    if max_cycles is not None and not (math.isfinite(max_cycles) and max_cycles > 0):
        raise DeriveError(f"--max-cycles {max_cycles:g}: give a number > 0")
    if not 1 <= max_complexity <= regress.MAX_COMPLEXITY:
        raise DeriveError(f"--max-complexity {max_complexity}: give an integer in [1, {regress.MAX_COMPLEXITY}]")
    if gpu is None:
        architectures = available_architectures()
        if not architectures:
            raise CompilerMissing("no GPU compiler runs here (make installs Mesa's RADV, NVIDIA's ptxas, Intel's ocloc)")
        return architectures
    unknown = [a for a in gpu if a not in ARCHITECTURES]
    if unknown or not gpu:
        raise DeriveError(f"--gpu {unknown[0] if unknown else ''!r}: give architectures among {', '.join(ARCHITECTURES)}")
    return list(dict.fromkeys(gpu))


CHOSEN = " (constants chosen)"       # the name of a form's variant whose constants were chosen in the format


def _executed(forms: list[Form], target, precision: str, real: dict, log, chosen: dict | None = None) -> dict:
    """Every form executed in `precision` (`executed.measure`, around the extrema of its float64
    errors `real`), and each form of `chosen` ({name: the form with its constants chosen in the
    format, `representable.choose`}) as that variant too: dict(measured={name: its executed errors;
    NaN where it was not executed; a chosen variant under name + CHOSEN}, and how it was executed:
    how, inputs, truth, not_executed)."""
    bodies, not_printed = {}, {}
    variants = [(m.name, m.expression) for m in forms] + [(name + CHOSEN, e) for name, e in (chosen or {}).items()]
    for name, expression in variants:
        try:
            bodies[name] = glsl(expression, target.variable, precision)
        except Exception as e:          # (a function sympy's GLSL printer does not know)
            not_printed[name] = f"{name}: no GLSL form ({type(e).__name__})"
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
                not_executed=run["not_executed"] | not_printed, seconds=round(time.perf_counter() - started, 1))


def derive(target, gpu=None, seconds: float = DEFAULT_SECONDS, max_cycles: float | None = None,
           max_complexity: int = MAX_COMPLEXITY, log=print, precision: str = "fp32") -> dict:
    """The derivation of the module docstring for a checked `target` on the architectures `gpu`
    (names; default every one whose compiler runs here), every form costed and executed in
    `precision` (fp32 or fp16, `executed`). Returns the results (`results.json`'s content) with the
    forms' rows."""
    from ..isa.machine_code import estimate_seconds
    from ..symbolic import gpu_costs, grammar, ladder
    from ..symbolic.grammar import TEN

    check(target)
    try:
        executed.check_precision(precision)
    except executed.ExecutedError as e:
        raise DeriveError(str(e)) from None
    architectures = checked_options(gpu, seconds, max_cycles, max_complexity)
    started = time.perf_counter()
    f = target.numpy()
    # The time announced: the families' and the search's (none where an earlier run kept them), the
    # calibration's shaders that no run kept and about three architectures' fronts compiled, the
    # forms measured and polished, and the command's start (its imports).
    search_estimate = 0.0
    if not _kept_search(target, seconds, max_complexity).is_file():
        loss = "max-relative" if target.metric == "rel" and target.floor == 0 else "max"
        search_estimate = FAMILY_SECONDS + ladder.plan_seconds(1, SEARCH_POINTS, max_complexity, TEN, seconds, loss)
    calibration = gpu_costs.not_kept(gpu_costs.calibration_expressions(CALIBRATION)[1], architectures)
    compile_estimate = estimate_seconds(CALIBRATION * calibration + 3 * PER_ARCHITECTURE, architectures)
    estimate = START_SECONDS + search_estimate + compile_estimate + MEASURE_SECONDS + EXECUTE_SECONDS[precision]
    log(f"{target.name}: {target.expression} on [{target.domain[0]:g}, {target.domain[1]:g}], error {target.metric}; "
        f"{len(architectures)} architecture{'s' * (len(architectures) > 1)}, {precision}; about {estimate:.0f} s")

    found, trees, fitted, losses, coverage = _searched(target, f, seconds, max_complexity, log)
    found = [without_negligible(m, target, f) for m in found]
    found += refitted_anchors(target, f, log)
    log(f"cost tables: {CALIBRATION} forms compiled per architecture")
    tables = gpu_costs.operation_costs(CALIBRATION, architectures)["tables"]
    chosen = _select(trees, losses, tables)
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
    errors = {m.name: _measure(m, target, f) for m in everything}          # in float64 (the mathematics)
    cycles, missing = _compile(everything, architectures, log, precision)
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
            better = _polish(tree, c, target, f, weight)
            candidate = Form(m.name, "found", "grammar", grammar.to_sympy(tree, better, symbol), m.source)
            measured = _measure(candidate, target, f)
            if measured[error_key] < errors[m.name][error_key]:
                errors[m.name] = measured
                m.expression = candidate.expression
                polished.append(m)
    if polished:
        again, _ = _compile(polished, architectures, log, precision)
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
        again, _ = _compile(kept, architectures, log, precision)
        for a in architectures:
            cycles[a].update(again.get(a, {}))
    log(f"kept the chosen constants of {len(kept)} forms (their error as executed lower)")

    forms_by_name = {m.name: m for m in everything}
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
                             max_rel_error_real=real[m.name]["max_rel_error"], precision=precision))
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
                constant_error=baseline, rounding_floor=floor, precision=precision, execution=run,
                special_functions=special_functions(rows, forms_by_name, precision), cost_tables=tables, seconds=round(elapsed, 1), estimated_seconds=round(estimate, 1),
                members={m.name: dict(kind=m.kind, family=m.family, source=m.source, converged=m.converged,
                                      expression=_text(m, target), **errors[m.name],
                                      max_abs_error_real=real[m.name]["max_abs_error"],
                                      max_rel_error_real=real[m.name]["max_rel_error"],
                                      **({"gap": causes[m.name]} if m.name in causes else {}),
                                      **({"constants": searches[m.name]} if m.name in searches else {}))
                         for m in everything if m.kind != "found" or any(m.name in fr for fr in fronts.values())},
                forms=forms_by_name)


def bound_columns(rows: list[dict], forms_by_name: dict, target, f, precision: str, error_key: str) -> None:
    """Each row's `max_error_bound` (`bounds`): its executed error plus its special functions'
    documented accuracy on the row's architecture, propagated to first order."""
    from ..isa.architectures import ARCHITECTURES

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
    from ..isa import special_functions
    from ..isa.architectures import ARCHITECTURES

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
