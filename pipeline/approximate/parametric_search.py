"""The parametric engine's search, kept between runs: the family templates' and the grammar's fits
(`_searched`) as records of forms, each kept in the derive cache by target, budget and code."""

from __future__ import annotations

import time

import numpy as np

from .forms import Form
from .anchor_refits import refitted_box_anchors
from .formulas import formula_expressions, material_forms, measure_box
from .parametric_targets import (
    _middle, AXIS_POINTS, is_symmetric, mesh, PARAMETER_VALUES, PIXEL_SHARE, SEARCH_AXIS_POINTS)
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


def _kept(key: list, compute, log, what: str, target):
    """compute() -> (records, coverage), kept in `paths.DERIVE_CACHE` under `key` and this code; an
    entry that cannot be read is computed again."""
    import hashlib
    import json

    from ..engine import paths
    from . import grammar_search
    from . import kept as keeping

    text = json.dumps([grammar_search.code_version(), *key])
    symbols = {s.name: s for s in kept_symbols(target)}
    kept = paths.DERIVE_CACHE / f"{hashlib.sha256(text.encode()).hexdigest()[:32]}.json"
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
    found, coverage = compute()
    try:
        texts = [keeping.text(r["expression"], symbols) for r in found]
    except keeping.Unusable as e:
        log(f"the {what} are not kept ({e})")
    else:
        keeping.write(kept, dict(found=[r | dict(expression=t) for r, t in zip(found, texts)], coverage=coverage))
    return found, coverage | dict(kept=False)


def _searched(target, f, seconds: float, max_complexity: int, log, formula_complexity: int = 0) -> tuple[list[dict], dict]:
    """(the found forms, each {name, family, expression (sympy), source, per (material or pixel),
    errors, and for a template's, formulas: {formula, per_value_error, per_value_worst, constants}},
    the coverage): steps 1 to 4 of the module docstring. The families' fits are kept by the target
    and this code, the grammar's forms also by the budget, so that a rerun with other --gpu or
    --max-cycles only compiles, and one with another budget only searches again."""
    found, coverage = [], dict(max_complexity=int(max_complexity))
    if target.parameter is not None:
        families, coverage["families"] = _kept([repr(target), "families", formula_complexity],
                                               lambda: _family_search(target, f, log, formula_complexity),
                                               log, "families' fits", target)
        found += families
    grammar_found, coverage["grammar"] = _kept([repr(target), "grammar", seconds, max_complexity, formula_complexity],
                                               lambda: _grammar_search(target, f, seconds, max_complexity, log,
                                                                       formula_complexity),
                                               log, "grammar's search", target)
    found += grammar_found
    refits, coverage["anchors"] = _kept([repr(target), "anchors"], lambda: refitted_box_anchors(target, f, log), log,
                                        "anchors' refits", target)
    found += refits
    for part in ("families", "grammar", "anchors"):
        coverage.update({k: v for k, v in coverage.get(part, {}).items() if k != "kept"})
    coverage["kept"] = all(coverage.get(part, {}).get("kept", True) for part in ("families", "grammar", "anchors"))
    return found, coverage


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


def _grammar_search(target, f, seconds: float, max_complexity: int, log, formula_complexity: int = 0) -> tuple[list[dict], dict]:
    """The grammar's templates fitted (steps 1 to 3) and the pixel search (step 4)."""
    from ..symbolic import grammar, ladder

    symbols = target.symbols()
    found: list[dict] = []
    coverage: dict = {}
    if target.parameter is not None:
        templates, coverage["templates"] = grammar_templates(target, f, seconds * (1 - PIXEL_SHARE),
                                                             max_complexity, log)
        log(f"{len(templates)} grammar templates: constants fitted per value of {target.parameter.name}, then as "
            "formulas")
        started = time.perf_counter()
        dropped: list[dict] = []
        found += _records(material_forms(templates, target, f, log, formula_complexity, dropped), target)
        coverage["templates"].update(count=len(templates), seconds=round(time.perf_counter() - started, 1),
                                     at=_middle(target.parameter), dropped=dropped)
    # the pixel search: the grammar in the variables and the parameter together
    x = mesh(target, SEARCH_AXIS_POINTS)
    y = f(*x)
    loss = _loss(target)
    share = seconds * (PIXEL_SHARE if target.parameter is not None else 1.0)
    candidates, rungs, _ = ladder.run(np.stack(x), y, max_complexity, grammar.TEN, share, loss,
                                      log=lambda s: log("pixel search: " + s))
    coverage["pixel_search"] = dict(rungs=[r.row() for r in rungs], points=int(y.size), loss=loss)
    for i, (tree, c, loss_value, *_) in enumerate(sorted(candidates, key=lambda c: grammar.complexity(c[0]))):
        if not np.isfinite(loss_value) or not grammar.has_variable(tree):
            continue                # (a constant approximates nothing)
        expr = grammar.to_sympy(tree, c, symbols)
        found.append(dict(name=f"search_{i + 1}", family="grammar", expression=expr,
                          source=f"grammar: {grammar.show(tree, list(target.names))}", per="pixel",
                          errors=measure_box(expr, target, f)))
    return found, coverage
