"""The parametric engine's search, kept between runs: the family templates' and the grammar's fits
and the anchors' refits (`_searched`) as records of forms, each part kept in the derive cache by
target, budget and code; the parts not kept (a pair's two targets' together: `searched`) computed
at once in worker processes, one per core."""

from __future__ import annotations

import dataclasses
import time

import numpy as np

from ..forms import Form
from .anchor_refits import refitted_box_anchors
from .formulas import formula_expressions, material_forms, measure_box
from .settings import PIXEL_SHARE
from ..targets import AXIS_POINTS, is_symmetric, mesh, middle, PARAMETER_VALUES, SEARCH_AXIS_POINTS
from .templates import _loss, constant_symbols, family_templates, grammar_templates, kept_symbols


def _text(m: Form, record: dict, target) -> str:
    """A row's expression: the form; a material form's with its constants' formulas."""
    import sympy as sp

    if m.kind == "exact":
        return target.expression
    if m.name in record and "formulas" in record[m.name] and record[m.name]["per"] == "material":
        return (sp.sstr(m.expression) + "; " +
                ", ".join(f"c{i} = {c}" for i, c in enumerate(record[m.name]["formulas"]["constants"])))
    return sp.sstr(sp.N(m.expression, 9))


PARTS = {"families": "families' fits", "grammar": "grammar's search", "anchors": "anchors' refits"}


@dataclasses.dataclass(frozen=True)
class Search:
    """What `_searched` computes for one target: its three parts (`PARTS`; the families only for a
    target with a parameter), each kept in the derive cache under `key(part)`."""

    target: object
    budget: object              # (a `symbolic.budgets.Budget`)
    max_complexity: int
    formula_complexity: int = 0

    def parts(self) -> list[str]:
        return [p for p in PARTS if p != "families" or self.target.parameter is not None]

    def key(self, part: str) -> list:
        return {"families": [repr(self.target), "families", self.formula_complexity],
                "grammar": [repr(self.target), "grammar", self.budget.key(), self.max_complexity,
                            self.formula_complexity],
                "anchors": [repr(self.target), "anchors"]}[part]

    def compute(self, part: str, f, log) -> tuple[list[dict], dict]:
        if part == "families":
            return _family_search(self.target, f, log, self.formula_complexity)
        if part == "grammar":
            return _grammar_search(self.target, f, self.budget, self.max_complexity, log, self.formula_complexity)
        return refitted_box_anchors(self.target, f, log)


def _kept_file(search: Search, part: str):
    import hashlib
    import json

    from ...engine import paths
    from . import grammar_search

    text = json.dumps([grammar_search.code_version(), *search.key(part)])
    return paths.DERIVE_CACHE / f"{hashlib.sha256(text.encode()).hexdigest()[:32]}.json"


def _read_kept(search: Search, part: str, log) -> tuple[list[dict], dict] | None:
    """The part's (records, coverage) kept by an earlier run under its key and this code; None where
    there is none, or it cannot be read (said)."""
    from . import kept as keeping

    what = PARTS[part]
    symbols = {s.name: s for s in kept_symbols(search.target)}
    kept = _kept_file(search, part)
    entry = keeping.read(kept, log)
    try:
        if entry is not None:
            found = [r | dict(expression=keeping.expression(r["expression"], symbols)) for r in entry["found"]]
            log(f"the {what} of an earlier run, kept in {kept.parent}")
            return found, entry["coverage"] | dict(kept=True)
    except keeping.Unusable as e:
        log(f"the kept {what} {kept.name} is not used ({e}): computed again")
    except (ValueError, KeyError, TypeError) as e:
        log(f"the kept {what} {kept.name} is not readable ({type(e).__name__}): computed again")
    return None


def _keep(search: Search, part: str, found: list[dict], coverage: dict, log) -> tuple[list[dict], dict]:
    """Keeps a computed part in the derive cache; returns it marked not kept."""
    from . import kept as keeping

    symbols = {s.name: s for s in kept_symbols(search.target)}
    try:
        texts = [keeping.text(r["expression"], symbols) for r in found]
    except keeping.Unusable as e:
        log(f"the {PARTS[part]} are not kept ({e})")
    else:
        keeping.write(_kept_file(search, part), dict(found=[r | dict(expression=t) for r, t in zip(found, texts)],
                                                     coverage=coverage))
    return found, coverage | dict(kept=False)


def _in_worker(search: Search, part: str, xla_cache: str | None) -> tuple[list[dict], dict, list[str]]:
    """A part computed in a worker process (its compiled XLA programs kept in the run's folder
    `xla_cache`, if any): (records, coverage, the lines it logged)."""
    if xla_cache:
        from ...optics.numerics import use_compilation_cache
        use_compilation_cache(xla_cache)
    lines: list[str] = []
    found, coverage = search.compute(part, search.target.numpy(), lines.append)
    return found, coverage, lines


def worker_count(parts: int) -> int:
    """Worker processes for `parts` parts to compute: one per core, at most one per part; 0 (all
    computed in this process) where that is one, or where this process may not start children (a
    Dask worker)."""
    from ...engine import workers

    count = min(parts, workers.cores())
    return count if count > 1 and workers.may_start_processes() else 0


def searched(searches: list[Search], functions: list, logs: list, log) -> list[tuple[list[dict], dict]]:
    """Each search's (records, coverage): every part kept by an earlier run read, the others computed,
    in `worker_count` spawned processes where that is more than one (a part of each search per core
    at a time: each is numpy's and HiGHS's work in one thread), each part's lines then logged by its
    search's `logs[i]` in order; otherwise here, with `functions[i]` (the target's numpy function)."""
    from concurrent.futures import wait
    from concurrent.futures.process import BrokenProcessPool

    from ...engine import faults, workers

    parts = {(i, part): _read_kept(s, part, logs[i]) for i, s in enumerate(searches) for part in s.parts()}
    missing = [key for key, value in parts.items() if value is None]
    count = worker_count(len(missing))
    if count:
        import jax

        log(f"searching: {len(missing)} parts ({', '.join(sorted({PARTS[p] for _, p in missing}))}) "
            f"in {count} processes")
        pool = workers.spawned_pool(count)
        xla_cache = jax.config.jax_compilation_cache_dir or None
        try:
            futures = {key: workers.submitted(pool, _in_worker, searches[key[0]], key[1], xla_cache) for key in missing}
            for (i, part), future in futures.items():
                while not future.done():
                    wait([future], timeout=0.5)
                    faults.check_interrupted()
                found, coverage, lines = future.result()
                for line in lines:
                    logs[i](line)
                parts[(i, part)] = _keep(searches[i], part, found, coverage, logs[i])
        except BrokenProcessPool:
            log("a search process died (killed, or out of memory): the rest is computed in this process")
        except BaseException:           # (an interrupt, or a part's error: the other parts are not wanted)
            workers.stop(pool)
            raise
        finally:
            pool.shutdown(wait=False, cancel_futures=True)
    for (i, part), value in parts.items():
        if value is None:
            found, coverage = searches[i].compute(part, functions[i], logs[i])
            parts[(i, part)] = _keep(searches[i], part, found, coverage, logs[i])
    out = []
    for i, s in enumerate(searches):
        found, coverage = [], dict(max_complexity=int(s.max_complexity))
        for part in s.parts():
            records, coverage[part] = parts[(i, part)]
            found += records
        for part in PARTS:
            coverage.update({k: v for k, v in coverage.get(part, {}).items() if k != "kept"})
        coverage["kept"] = all(coverage.get(part, {}).get("kept", True) for part in PARTS)
        out.append((found, coverage))
    return out


def _searched(target, f, budget, max_complexity: int, log, formula_complexity: int = 0) -> tuple[list[dict], dict]:
    """(the found forms, each {name, family, expression (sympy), source, per (material or pixel),
    errors, and for a template's, formulas: {formula, per_value_error, per_value_worst, constants}},
    the coverage): steps 1 to 4 of the module docstring. The families' fits are kept by the target
    and this code, the grammar's forms also by the budget, so that a rerun with other --gpu or
    --max-cycles only compiles, and one with another budget only searches again."""
    (out,) = searched([Search(target, budget, max_complexity, formula_complexity)], [f], [log], log)
    return out


def _records(materials, target) -> list[dict]:
    """Each fitted template as two forms: its constants per material (push constants) and per pixel."""
    import sympy as sp

    parameter = target.symbols()[-1]
    out = []
    for m in materials:
        formulas = dict(formula=m.formula, per_value_error=float(m.per_value.errors.max()),
                        per_value_worst=float(m.per_value.values[int(np.argmax(m.per_value.errors))]),
                        constants=[sp.sstr(sp.N(e, 7)) for e in m.constant_formulas(parameter)])
        for per, expr in (("material", m.material), ("pixel", m.pixel)):
            out.append(dict(name=f"{m.name}_{per}", family=m.template.family, expression=expr,
                            source=m.template.source, per=per, errors=m.errors,
                            formulas=formulas | dict(parameter_per=per)))
        scaled = _scaled(m, parameter)
        if scaled is not None:
            out.append(dict(name=f"{m.name}_scaled_pixel", family=m.template.family, expression=scaled,
                            source=m.template.source + "; written with one formula's factor in the numerator",
                            per="pixel", errors=m.errors, formulas=formulas | dict(parameter_per="pixel")))
    return out


def _scaled(m, parameter):
    """A reciprocal template's pixel form with one constant's factor moved to the numerator,
    a / (k0 b0 + k1 b1) = (a / c) / ((k0 / c) b0 + p^j b1) where k1 = c p^j is one term (a proportion or
    a constant): the same function, one multiply fewer where the compiler cannot fold the factor
    (a multiply-add takes one immediate on NVIDIA). None for another template."""
    import sympy as sp

    if m.template.outer != "reciprocal" or m.formulas is not None:
        return None
    single = [i for i, row in enumerate(m.coefficients) if np.count_nonzero(row) == 1]
    if not single:
        return None
    j = single[0]
    factor = float(m.coefficients[j][np.flatnonzero(m.coefficients[j])[0]])
    k = constant_symbols(m.template.count)
    coefficients = m.coefficients / factor
    coefficients[j] = np.where(coefficients[j] != 0, 1.0, 0.0)       # (exactly 1: no multiply)
    formulas = formula_expressions(coefficients, parameter)
    return sp.Float(1 / factor, 17) * m.template.expression.xreplace(dict(zip(k, formulas)))


def _family_search(target, f, log, formula_complexity: int = 0) -> tuple[list[dict], dict]:
    """The families' templates fitted (steps 2 and 3)."""
    symmetric = is_symmetric(target, f)
    positive = bool(np.all(f(*mesh(target, AXIS_POINTS)) > 0))
    templates = family_templates(target, symmetric, positive)
    log(f"{len(templates)} family templates{' (the target is symmetric in its two variables)' if symmetric else ''}: "
        f"constants fitted at {2 * PARAMETER_VALUES - 1} values of {target.parameter.name}, then as formulas")
    started = time.perf_counter()
    dropped: list[dict] = []
    materials = material_forms(templates, target, f, log, formula_complexity, dropped)
    return _records(materials, target), dict(parameter_values=2 * PARAMETER_VALUES - 1, symmetric=symmetric,
                                             family_templates=len(templates), families_dropped=dropped,
                                             family_seconds=round(time.perf_counter() - started, 1))


def _grammar_search(target, f, budget, max_complexity: int, log, formula_complexity: int = 0) -> tuple[list[dict], dict]:
    """The grammar's templates fitted (steps 1 to 3) and the pixel search (step 4), by the plans
    `budget` gives the searches "templates" and "pixel search"."""
    from ...symbolic import grammar, ladder

    symbols = target.symbols()
    found: list[dict] = []
    coverage: dict = {}
    if target.parameter is not None:
        templates, coverage["templates"] = grammar_templates(target, f, budget.share(1 - PIXEL_SHARE),
                                                             max_complexity, log)
        log(f"{len(templates)} grammar templates: constants fitted per value of {target.parameter.name}, then as "
            "formulas")
        started = time.perf_counter()
        dropped: list[dict] = []
        found += _records(material_forms(templates, target, f, log, formula_complexity, dropped), target)
        coverage["templates"].update(count=len(templates), seconds=round(time.perf_counter() - started, 1),
                                     at=middle(target.parameter), dropped=dropped)
    # the pixel search: the grammar in the variables and the parameter together
    x = mesh(target, SEARCH_AXIS_POINTS)
    y = f(*x)
    loss = _loss(target)
    share = budget.share(PIXEL_SHARE if target.parameter is not None else 1.0)
    plan = share.plan("pixel search", len(x), y.size, max_complexity, grammar.TEN, loss)
    candidates, rungs, _ = ladder.run(np.stack(x), y, max_complexity, grammar.TEN, None, loss, plan=plan,
                                      log=lambda s: log("pixel search: " + s))
    coverage["pixel_search"] = dict(rungs=[r.row() for r in rungs], points=int(y.size), loss=loss,
                                    **share.record("pixel search", plan))
    for i, (tree, c, loss_value, *_) in enumerate(sorted(candidates, key=lambda c: grammar.complexity(c[0]))):
        if not np.isfinite(loss_value) or not grammar.has_variable(tree):
            continue                # (a constant approximates nothing)
        expr = grammar.to_sympy(tree, c, symbols)
        found.append(dict(name=f"search_{i + 1}", family="grammar", expression=expr,
                          source=f"grammar: {grammar.show(tree, list(target.names))}", per="pixel",
                          errors=measure_box(expr, target, f)))
    return found, coverage
