"""The ladder of grammars: one time budget shared by the exhaustive search of narrower grammars
first and deeper, then wider ones, then pyoperon, their fronts merged by the loss (`pipeline
regress`, `pipeline derive`).

A wider grammar holds more forms at each complexity, so the exhaustive search of it reaches less
deep in the same time: the ten operations reach complexity 7 in two variables where + - * / alone
reach 10, and a law of complexity 10 in + - * / is then lost to the wider default. The ladder runs,
for the operations W asked for:

1. `arithmetic`: W's + - * / (where W holds more), as deep as ARITHMETIC_SHARE of the budget reaches;
2. `wide`: W, as deep as WIDE_SHARE reaches (less the forms already fitted), at least to FLOOR;
3. `suggested`: + - * / with the operations the data's shape suggests: those in the members of the
   merged front so far that fit better than every member of the arithmetic grammar at or below their
   complexity (W itself where none is), as deep as what is left of EXHAUSTIVE_SHARE reaches, less the
   forms already fitted;
4. `pyoperon`: W to the requested complexity, for what is left of the budget (at least
   OPERON_MIN_SECONDS; not run when the exhaustive rungs searched W to the requested complexity).

Where every form of W to the requested complexity fits EXHAUSTIVE_SHARE, W is searched whole and
alone (it holds every narrower grammar's forms). The merged front keeps, at each complexity, the
best of every rung (a tie goes to the narrower rung): the ladder's front is never worse at any
complexity than any rung's front alone. How deep a rung reaches comes from the kept rates of this
machine (`rates`), which every rung updates.
"""

from __future__ import annotations

import time
from dataclasses import asdict, dataclass

import numpy as np

from . import grammar, rates

ARITHMETIC_SHARE = 0.50
WIDE_SHARE = 0.10
EXHAUSTIVE_SHARE = 0.70
FLOOR = 5                   # the wide rung searches every form to this complexity whatever the budget
                            # (the ten operations: 212 forms in one variable, 1,302 in three; a second)
OPERON_MIN_SECONDS = 10.0
OPERON_SLACK_S = 3.0        # pyoperon's start, within the budget (its models' polish: `polish_estimate`)
MODELS_PER_SEED = 50        # models a pyoperon run returns within the complexity asked, about (33 to 100)


@dataclass
class Rung:
    """What one rung covered: its operations, the complexity it searched to (pyoperon: the requested
    one), the forms it fitted (pyoperon: the models it returned), the time it was estimated to take
    and took."""
    name: str
    operations: tuple
    complexity: int
    forms: int
    estimated_seconds: float
    seconds: float = 0.0
    engine: str = "exhaustive"

    def row(self) -> dict:
        out = asdict(self)
        out["operations"] = " ".join(self.operations)
        out["estimated_seconds"], out["seconds"] = round(self.estimated_seconds, 1), round(self.seconds, 1)
        return out


def covered(e, searched, complexity=None) -> bool:
    """Whether an earlier rung fitted the form: searched holds (operations, complexity) per rung;
    `complexity`, the form's where the caller knows it."""
    if not searched:
        return False
    k = grammar.complexity(e) if complexity is None else complexity
    ops = grammar.operations_of(e)
    return any(k <= depth and ops <= set(o) for o, depth in searched)


def new_forms(ops, variables: int, complexity: int, points: int, searched=()) -> list:
    """The forms of `ops` of exactly this complexity that no earlier rung fitted and that have fewer
    constants than the data have points (the others cannot be fitted)."""
    return [e for e in grammar.forms_of(complexity, ops, variables)
            if grammar.constants(e) < points and not covered(e, searched, complexity)]


def reach(ops, variables: int, points: int, max_complexity: int, seconds: float, kind: str,
          searched=(), floor: int = 0) -> tuple[int, list, float]:
    """(complexity, forms, estimated seconds): the deepest complexity up to `max_complexity` whose new
    forms' fits are estimated to take at most `seconds` (compilation apart), with those forms; at
    least `floor` whatever the time. A complexity is not enumerated where the growth of the last two
    predicts it is out of reach (enumerating it alone takes long)."""
    kept = rates.load()
    depth, forms, counts, estimate = 0, [], [], 0.0
    for k in range(1, max_complexity + 1):
        if k > floor and len(counts) >= 2 and counts[-2] and counts[-1] > 50:
            guess = len(forms) + counts[-1] * counts[-1] / counts[-2]
            if estimate_seconds(int(guess), k, points, kind, kept, compiling=False) > 2 * seconds:
                break
        more = new_forms(ops, variables, k, points, searched)
        counts.append(len(more))
        cost = estimate_seconds(len(forms) + len(more), k, points, kind, kept, compiling=False)
        if cost > seconds and k > floor:
            break
        depth, estimate = k, cost
        forms = forms + more
    return depth, forms, estimate


def estimate_seconds(forms: int, complexities: int, points: int, kind: str, kept: dict | None = None,
                     compiling: bool | None = None) -> float:
    """About how long an exhaustive search of `forms` forms over `complexities` complexities on
    `points` points takes here (`rates`), compilation included unless this process compiled its kind."""
    from . import search

    return rates.seconds(kind, search.screen_units(forms, points), search.refit_units(complexities, points),
                         not rates.compiled(kind) if compiling is None else compiling, kept)


def polish_estimate(models: int, points: int, kind: str) -> float:
    """About how long the float64 polish of `models` of pyoperon's models takes here
    (`operon.polished`, its rate `polish_s`), compilation included."""
    from . import operon, search

    kept = rates.load()[kind]
    return 0.5 * kept["compile_s"] + search.polish_units(models, points, operon.POLISH_STARTS) * kept["polish_s"]


def compile_estimate(kind: str) -> float:
    """The compilation a search of this kind is expected to need in this process (none once one ran)."""
    return 0.0 if rates.compiled(kind) else rates.load()[kind]["compile_s"]


def _suggested(candidates, arithmetic) -> tuple:
    """The operations outside + - * / of the merged front's members that fit better than every
    arithmetic member at or below their complexity."""
    from .search import pareto_front

    size = np.array([grammar.complexity(c[0]) for c in candidates])
    value = np.array([c[2] if np.isfinite(c[2]) else np.inf for c in candidates])
    plain = [(k, v) for k, v, c in zip(size, value, candidates) if grammar.operations_of(c[0]) <= set(arithmetic)]
    out = set()
    for i in pareto_front(size, value):
        best = min((v for k, v in plain if k <= size[i]), default=np.inf)
        if value[i] < best * (1 - 1e-6):
            out |= grammar.operations_of(candidates[i][0]) - set(arithmetic)
    return tuple(op for op in grammar.OPERATIONS if op in out)


def run(x, y, max_complexity: int, ops, seconds: float, loss: str = "rms", cost=None, seed: int = 0,
        starts: int = 2, iterations: int = 7, refine: int = 8, polish_starts: int = 4, operon: str = "auto",
        log=print):
    """The ladder (module docstring) on x (variables, points) and y under a budget of `seconds`.

    Returns (candidates, rungs, fitted): candidates (tree, constants, loss, converged, engine, rung)
    of every rung's front; the rungs (`Rung`); fitted, every form fitted by an exhaustive rung
    (forms, constants, complexity under `cost`, loss). `operon`: "auto" (pyoperon where the
    exhaustive rungs did not search W to the requested complexity), "always" or "never"."""
    from . import search

    x = np.atleast_2d(np.asarray(x, dtype=np.float64))
    ops = grammar.operations(ops)
    variables, points = x.shape[0], y.size
    codes = grammar.operation_codes(ops)
    kind = rates.kind(codes, loss)
    started = time.perf_counter()
    # the shares are of the budget less the compilation expected (paid once, by the first rung)
    compiling = compile_estimate(kind)
    fits = max(seconds - compiling, 0.0)
    candidates, rungs, searched = [], [], []
    fitted = dict(forms=[], constants=[], complexity=[], loss=[])
    spent = [0.0]               # seconds of the exhaustive rungs' fits, compilation apart

    def exhaustive(name, rung_ops, forms, depth, estimate):
        if not forms:
            return
        estimate += compiling if not rungs else 0.0
        log(f"{name}: every form of {' '.join(rung_ops)} to complexity {depth} not fitted before "
            f"({len(forms)} forms), about {estimate:.0f} s")
        rung = Rung(name, tuple(rung_ops), depth, len(forms), estimate)
        clock = time.perf_counter()
        found = search.search(x, y, depth, rung_ops, starts, iterations, refine, polish_starts, seed,
                              progress=lambda s: log("  " + s), forms=forms, loss=loss, cost=cost, codes=codes)
        rates.learn(found["timing"])
        rung.seconds = time.perf_counter() - clock
        spent[0] += rung.seconds - found["timing"]["compile_seconds"]
        rungs.append(rung)
        log(f"{name}: {rung.seconds:.0f} s (estimated {rung.estimated_seconds:.0f} s); "
            f"{max(seconds - (time.perf_counter() - started), 0):.0f} s of the {seconds:.0f} s budget left")
        searched.append((tuple(rung_ops), depth))
        for i in found["front"]:
            candidates.append((found["forms"][i], found["constants"][i][:found["constant_count"][i]],
                               float(found["loss"][i]), found["converged"].get(i, False), "exhaustive", name))
        fitted["forms"] += list(found["forms"])
        fitted["constants"] += [c[:k] for c, k in zip(found["constants"], found["constant_count"])]
        fitted["complexity"] += list(found["complexity"])
        fitted["loss"] += list(found["loss"])

    def reached(rung_ops, share, at_least=0.0, floor=0):
        depth, forms, estimate = reach(rung_ops, variables, points, max_complexity,
                                       max(share * fits - spent[0], at_least * fits, 0.0), kind, searched, floor)
        return forms, depth, estimate

    depth, forms, estimate = reach(ops, variables, points, max_complexity, EXHAUSTIVE_SHARE * fits, kind)
    whole = depth >= max_complexity
    if whole:
        exhaustive("wide", ops, forms, depth, estimate)
    else:
        arithmetic = tuple(op for op in ops if op in grammar.ARITHMETIC)
        if arithmetic and arithmetic != ops:
            exhaustive("arithmetic", arithmetic, *reached(arithmetic, ARITHMETIC_SHARE))
        # (its share even where the arithmetic rung took longer than estimated)
        exhaustive("wide", ops, *reached(ops, ARITHMETIC_SHARE + WIDE_SHARE, WIDE_SHARE, FLOOR))
        suggested = arithmetic + _suggested(candidates, arithmetic) if arithmetic and candidates else ops
        if len(suggested) == len(arithmetic):
            suggested = ops         # nothing suggested: the wide grammar deeper
        forms, depth, estimate = reached(suggested, EXHAUSTIVE_SHARE)
        exhaustive("suggested" if suggested != ops else "wide, deeper", suggested, forms, depth, estimate)
        whole = any(set(o) == set(ops) and d >= max_complexity for o, d in searched)
    # pyoperon's time: what is left, less its models' polish (about MODELS_PER_SEED per seed) and the rest
    from . import operon as pyoperon

    left = seconds - (time.perf_counter() - started)
    seeds = pyoperon.seeds_in(left)
    polish = polish_estimate(seeds * MODELS_PER_SEED, points, kind)
    budget = left - polish - OPERON_SLACK_S
    if operon == "auto" and not whole and budget < OPERON_MIN_SECONDS:
        log(f"pyoperon: not run: of the {max(left, 0):.0f} s left, its models' polish and start would take "
            f"{polish + OPERON_SLACK_S:.0f} s, leaving {max(budget, 0):.0f} s for its search (less than "
            f"{OPERON_MIN_SECONDS:.0f} s)")
    elif operon == "always" or operon == "auto" and not whole:
        budget = max(budget, OPERON_MIN_SECONDS)
        log(f"pyoperon: {' '.join(ops)} to complexity {max_complexity} for {budget:.0f} s")
        rung = Rung("pyoperon", ops, max_complexity, 0, budget + polish, engine="operon")
        clock = time.perf_counter()
        models = pyoperon.seeded_models(x, y, max_complexity, ops, seed, budget, log)
        for tree, c, value, ok in pyoperon.polished(models, x, y, seed, loss=loss, codes=codes):
            candidates.append((tree, c, float(value), ok, "operon", "pyoperon"))
        rung.forms, rung.seconds = len(models), time.perf_counter() - clock
        rungs.append(rung)
        log(f"pyoperon: {len(models)} models on its front within complexity {max_complexity}, polished in float64")
    return candidates, rungs, fitted


def plan_seconds(variables: int, points: int, max_complexity: int, ops, seconds: float, loss: str = "rms") -> float:
    """The time the ladder is expected to take: the exhaustive search of W alone where it reaches the
    requested complexity within EXHAUSTIVE_SHARE (its estimate), else the whole budget."""
    ops = grammar.operations(ops)
    kind = rates.kind(grammar.operation_codes(ops), loss)
    compiling = compile_estimate(kind)
    depth, _, estimate = reach(ops, variables, points, max_complexity, EXHAUSTIVE_SHARE * max(seconds - compiling, 0.0),
                               kind)
    return compiling + estimate if depth >= max_complexity else seconds
