"""The one-variable search of `pipeline derive` (`engines.one_variable`, steps 1 and 2), kept between runs: the
families fitted by minimax and the grammar's forms by the ladder of grammars within the budget, on
`SEARCH_POINTS` Chebyshev points; the forms each architecture's cost table puts on its predicted
front (`select`); a grammar form's constants polished on the whole interval (`polish`).
"""

from __future__ import annotations

import math
import time

import numpy as np

from . import families, minimax
from ..forms import Form

SEARCH_POINTS = 129
PER_ARCHITECTURE = 24           # grammar forms taken from each architecture's predicted front, at most


def loss_of(target) -> str:
    """The search's loss: the largest relative error for a relative metric without a floor, else the
    largest absolute error."""
    return "max-relative" if target.metric == "rel" and target.floor == 0 else "max"


def search(target, f, budget, max_complexity: int, log) -> tuple[list, list, np.ndarray, dict]:
    """The grammar's forms (`engines.one_variable`'s docstring, step 2) by the plan `budget` gives the search
    "grammar": (trees, constants, search losses, the search's coverage, its plan among them)."""
    from ...symbolic import grammar, ladder

    lo, hi = target.domain
    x = minimax.chebyshev_points(lo, hi, SEARCH_POINTS)
    y = f(x)
    loss = loss_of(target)
    ops = grammar.TEN
    plan = budget.plan("grammar", 1, y.size, max_complexity, ops, loss)
    started = time.perf_counter()
    candidates, rungs, fitted = ladder.run(x[None], y, max_complexity, ops, None, loss, plan=plan,
                                           log=lambda s: log("grammar: " + s))
    whole = [r.complexity for r in rungs if r.engine == "exhaustive" and set(r.operations) == set(ops)]
    operon = [r for r in rungs if r.engine == "operon"]
    coverage = dict(operations=list(ops), loss=loss, points=int(y.size), exhaustive_complexity=int(max(whole, default=0)),
                    exhaustive_forms=int(sum(r.forms for r in rungs if r.engine == "exhaustive")),
                    operon_seconds=round(operon[0].seconds, 1) if operon else 0.0,
                    operon_models=int(operon[0].forms) if operon else 0, max_complexity=int(max_complexity),
                    rungs=[r.row() for r in rungs], seconds=round(time.perf_counter() - started, 1),
                    forecast_seconds=round(sum(r.estimated_seconds for r in rungs), 1), **budget.record("grammar", plan))
    # every form the exhaustive rungs fitted (a form off the complexity front may be cheap in cycles)
    # and pyoperon's
    others = [c for c in candidates if c[4] == "operon"]
    trees = list(fitted["forms"]) + [c[0] for c in others]
    constants = [np.asarray(c, dtype=float) for c in fitted["constants"]] + [np.asarray(c[1], dtype=float) for c in others]
    return trees, constants, np.array(list(fitted["loss"]) + [c[2] for c in others], dtype=float), coverage


def code_version() -> str:
    import hashlib
    from pathlib import Path

    approximate = Path(__file__).parent.parent
    files = sorted(approximate.rglob("*.py")) + sorted((approximate.parent / "symbolic").glob("*.py"))
    return hashlib.sha256(b"".join(f.read_bytes() for f in files)).hexdigest()


def kept_file(target, budget, max_complexity: int):
    """The file that keeps the search of a target under a budget (`searched`)."""
    import hashlib
    import json

    from ...engine import paths

    key = json.dumps([code_version(), target.expression, target.variable, list(target.domain), target.metric,
                      target.floor, budget.key(), max_complexity])
    return paths.DERIVE_CACHE / f"{hashlib.sha256(key.encode()).hexdigest()[:32]}.json"


def searched(target, f, budget, max_complexity: int, log):
    """(the families' members, the grammar's trees, constants, losses and coverage): kept in
    `paths.DERIVE_CACHE` by the target, the budget and this code, so that a rerun (another --gpu,
    --max-cycles) skips the search; an entry that cannot be read is searched again."""
    from . import kept as keeping

    kept = kept_file(target, budget, max_complexity)
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
    trees, fitted, losses, coverage = search(target, f, budget, max_complexity, log)
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


def select(trees, losses, tables: dict) -> list[int]:
    """The forms on some architecture's front of predicted cycles (its cost table) against the
    search's loss, at most PER_ARCHITECTURE each."""
    from ...symbolic import gpu_costs

    from ...symbolic import grammar

    if not trees:
        return []
    counts = np.array([gpu_costs.operation_counts(t) for t in trees], dtype=float)
    variable = np.array([grammar.has_variable(t) for t in trees])
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


def polish(tree, c, target, f, weight) -> np.ndarray:
    """A grammar form's constants, minimax on the whole interval from c (finite differences)."""
    from ...symbolic import grammar

    lo, hi = target.domain

    def model(c_, s):
        return grammar.evaluate_numpy(tree, c_, s)

    if len(c) == 0:
        return np.asarray(c, dtype=float)
    polished, _ = minimax.slp(model, minimax.numerical_jacobian(model), np.asarray(c, dtype=float), f, weight, lo, hi,
                              steps=40, exchanges=2)
    return polished
