"""The ladder of grammars: a budget planned as work before anything runs (`make_plan`), then that plan
run to completion (`run`): the exhaustive search of narrower grammars first and deeper, then wider
ones, then pyoperon, their fronts merged by the loss (`pipeline regress`, `pipeline derive`).

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

import math
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
PLAN_VERSION = 1
# the fits' settings a plan records (`search.search`): starts, screening steps, forms refitted per
# complexity, their starts
FIT = dict(starts=2, iterations=7, refine=8, polish_starts=4)


class PlanError(ValueError):
    """A recorded plan that does not fit the search it is given to (other data, operations, loss or
    complexity), or that this version of the search does not execute the same way."""


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
          searched=(), floor: int = 0, kept: dict | None = None) -> tuple[int, list, float]:
    """(complexity, forms, estimated seconds): the deepest complexity up to `max_complexity` whose new
    forms' fits are estimated to take at most `seconds` (compilation apart) at the rates `kept` (of
    every kind; default the reference rates, `rates.DEFAULTS`), with those forms; at least `floor`
    whatever the time. A complexity is not enumerated where the growth of the last two predicts it is
    out of reach (enumerating it alone takes long)."""
    kept = rates.DEFAULTS if kept is None else kept
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


def polish_estimate(models: int, points: int, kind: str, kept: dict | None = None) -> float:
    """About how long the float64 polish of `models` of pyoperon's models takes at the rates `kept`
    (default this machine's; `operon.polished`, its rate `polish_s`), compilation included."""
    from . import operon, search

    rate = (rates.load() if kept is None else kept)[kind]
    return 0.5 * rate["compile_s"] + search.polish_units(models, points, operon.POLISH_STARTS) * rate["polish_s"]


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


def make_plan(variables: int, points: int, max_complexity: int, ops, seconds: float | None, loss: str = "rms",
              operon: str = "auto", seed: int = 0, fit: dict | None = None) -> dict:
    """The work a budget of `seconds` buys (module docstring), planned at the reference rates before any
    search: a plain dict (JSON) that `run` executes. `operon`: "auto" (pyoperon where the exhaustive
    rungs do not search the operations whole and its share of the budget is at least
    OPERON_MIN_SECONDS), "always", "never" or "only" (pyoperon alone, for the whole budget);
    `seconds` None: every form to `max_complexity`, one rung, however long. `fit`: the fits'
    settings (default FIT)."""
    from . import operon as pyoperon

    ops = grammar.operations(ops)
    kind = rates.kind(grammar.operation_codes(ops), loss)
    reference = rates.DEFAULTS
    rate = reference[kind]
    out = dict(version=PLAN_VERSION, variables=int(variables), points=int(points), max_complexity=int(max_complexity),
               operations=list(ops), loss=loss, seconds=seconds, seed=int(seed), rates=dict(rate),
               fit=dict(FIT if fit is None else fit), rungs=[])
    rungs, searched = out["rungs"], []
    spent = [0.0]               # the reference seconds of the rungs planned so far, compilation apart

    def fixed(name, rung_ops, depth, forms, estimate):
        if forms:
            rungs.append(dict(name=name, engine="exhaustive", operations=list(rung_ops), complexity=int(depth),
                              forms=len(forms), reference_seconds=estimate))
            searched.append((tuple(rung_ops), depth))
            spent[0] += estimate

    if seconds is None:
        forms = [e for k in range(1, max_complexity + 1) for e in new_forms(ops, variables, k, points)]
        fixed("exhaustive", ops, max_complexity, forms,
              estimate_seconds(len(forms), max_complexity, points, kind, reference, compiling=False))
        return out
    # the shares are of the budget less the compilation (paid once, by the first rung)
    fits = max(seconds - rate["compile_s"], 0.0)
    whole = False
    if operon != "only":
        depth, forms, estimate = reach(ops, variables, points, max_complexity, EXHAUSTIVE_SHARE * fits, kind)
        whole = depth >= max_complexity
        if whole:
            fixed("wide", ops, depth, forms, estimate)
        else:
            arithmetic = tuple(op for op in ops if op in grammar.ARITHMETIC)
            if arithmetic and arithmetic != ops:
                fixed("arithmetic", arithmetic,
                      *reach(arithmetic, variables, points, max_complexity, ARITHMETIC_SHARE * fits, kind, searched))
            # (at least its own share, however long the arithmetic rung)
            wide = max((ARITHMETIC_SHARE + WIDE_SHARE) * fits - spent[0], WIDE_SHARE * fits, 0.0)
            fixed("wide", ops, *reach(ops, variables, points, max_complexity, wide, kind, searched, FLOOR))
            whole = any(set(o) == set(ops) and d >= max_complexity for o, d in searched)
            work = max(EXHAUSTIVE_SHARE * fits - spent[0], 0.0)
            if not whole and work > 0:
                # its operations are the data's: + - * / with those the front so far suggests (`_suggested`)
                rungs.append(dict(name="suggested", engine="exhaustive", operations=None, complexity=None, forms=None,
                                  reference_seconds=work))
                spent[0] += work
    if operon == "never" or operon == "auto" and whole:
        return out
    # pyoperon's share: what is left, less its models' polish (about MODELS_PER_SEED per seed) and its start
    left = seconds if operon == "only" else seconds - rate["compile_s"] - spent[0]
    seeds = pyoperon.seeds_in(left)
    polish = polish_estimate(seeds * MODELS_PER_SEED, points, kind, reference)
    budget = left if operon == "only" else left - polish - OPERON_SLACK_S
    if operon == "auto" and budget < OPERON_MIN_SECONDS:
        out["operon_not_run"] = (f"of the {max(left, 0):.0f} s left, its models' polish and start would take "
                                 f"{polish + OPERON_SLACK_S:.0f} s, leaving {max(budget, 0):.0f} s for its search "
                                 f"(less than {OPERON_MIN_SECONDS:.0f} s)")
        return out
    budget = max(budget, OPERON_MIN_SECONDS)
    generations = pyoperon.generations_in(budget / seeds, points, rate["operon_s"])
    rungs.append(dict(name="pyoperon", engine="operon", operations=list(ops), complexity=int(max_complexity),
                      seeds=[int(seed) + k for k in range(seeds)], generations=generations,
                      population=pyoperon.POPULATION, evaluations=pyoperon.EVALUATIONS, threads=pyoperon.THREADS,
                      polish_starts=pyoperon.POLISH_STARTS, unless_whole=operon == "auto",
                      reference_seconds=budget + polish))
    return out


def check(plan: dict, variables: int, points: int, max_complexity: int, ops, loss: str) -> dict:
    """`plan` if it is a plan of this version for a search of these data, operations, loss and
    complexity; else PlanError naming what differs."""
    if not isinstance(plan, dict) or plan.get("version") != PLAN_VERSION:
        raise PlanError(f"not a plan of this version ({PLAN_VERSION}): "
                        f"{plan.get('version') if isinstance(plan, dict) else type(plan).__name__!r}")
    wanted = dict(variables=int(variables), points=int(points), max_complexity=int(max_complexity),
                  operations=list(grammar.operations(ops)), loss=loss)
    for key, value in wanted.items():
        if plan.get(key) != value:
            raise PlanError(f"the plan was made for {key} {plan.get(key)!r}; this search has {value!r}")
    try:
        fit = {k: int(plan["fit"][k]) for k in FIT}
        numbers = [float(plan["rates"][k]) for k in rates.DEFAULTS["arithmetic/squares"]]
        int(plan["seed"])
        for r in plan["rungs"]:
            if r["engine"] == "operon":
                [int(s) for s in r["seeds"]], int(r["generations"]), int(r["population"]), int(r["evaluations"])
            elif r["engine"] == "exhaustive":
                if r["operations"] is not None:
                    grammar.operations(r["operations"]), int(r["complexity"]), int(r["forms"])
                float(r["reference_seconds"])
            else:
                raise PlanError(f"the plan's rung {r.get('name')!r} has the engine {r['engine']!r}; "
                                "give exhaustive or operon")
    except (KeyError, TypeError, ValueError) as e:
        if isinstance(e, PlanError):
            raise
        raise PlanError(f"the plan is incomplete or malformed ({type(e).__name__}: {e})") from None
    if min(fit.values()) < 1 or not all(math.isfinite(v) and v > 0 for v in numbers):
        raise PlanError("the plan's fits' settings must be positive integers and its rates positive numbers")
    return plan


def forecast(plan: dict, kept: dict | None = None) -> float:
    """About how long `plan` takes here: each rung's work at this machine's kept rates (`kept`,
    default `rates.load()`), with the compilation where this process has not compiled its kind."""
    from . import operon as pyoperon

    kept = rates.load() if kept is None else kept
    kind = rates.kind(grammar.operation_codes(plan["operations"]), plan["loss"])
    rate, points = kept[kind], plan["points"]
    total = compile_estimate(kind)
    for r in plan["rungs"]:
        if r["engine"] == "operon":
            total += (len(r["seeds"]) * pyoperon.generation_units(r["generations"], points) * rate["operon_s"]
                      + polish_estimate(len(r["seeds"]) * MODELS_PER_SEED, points, kind, kept) + OPERON_SLACK_S)
        elif r["operations"] is None:
            total += r["reference_seconds"] * rate["screen_s"] / plan["rates"]["screen_s"]
        else:
            total += estimate_seconds(r["forms"], r["complexity"], points, kind, kept, compiling=False)
    return total


def covered_text(plan: dict) -> str:
    """What a plan covers, in a line: each rung's grammar and depth, pyoperon's seeds and generations."""
    out = []
    for r in plan["rungs"]:
        if r["engine"] == "operon":
            out.append(f"pyoperon, {len(r['seeds'])} seed{'s' * (len(r['seeds']) > 1)} x {r['generations']} "
                       f"generations of {r['population']}")
        elif r["operations"] is None:
            out.append(f"suggested: the data's operations, {r['reference_seconds']:.1f} reference s of fits")
        else:
            ops = r["operations"]
            out.append(f"{r['name']}: {' '.join(ops) if len(ops) < 10 else 'the ten operations'} to complexity "
                       f"{r['complexity']} ({r['forms']} forms)")
    if plan.get("operon_not_run"):
        out.append("pyoperon not run: " + plan["operon_not_run"])
    return "; ".join(out)


def run(x, y, max_complexity: int, ops, seconds: float | None, loss: str = "rms", cost=None, seed: int = 0,
        starts: int = 2, iterations: int = 7, refine: int = 8, polish_starts: int = 4, operon: str = "auto",
        log=print, plan: dict | None = None):
    """The ladder (module docstring) on x (variables, points) and y: `plan` executed to its end (a
    recorded plan, `check`ed against these data), or where none is given the plan of a budget of
    `seconds` (`make_plan` with `operon`, `seed` and the fits' settings).

    Returns (candidates, rungs, fitted): candidates (tree, constants, loss, converged, engine, rung)
    of every rung's front; the rungs (`Rung`, each with this machine's forecast and the time it
    took); fitted, every form fitted by an exhaustive rung (forms, constants, complexity under
    `cost`, loss)."""
    from . import operon as pyoperon
    from . import search

    x = np.atleast_2d(np.asarray(x, dtype=np.float64))
    ops = grammar.operations(ops)
    variables, points = x.shape[0], y.size
    if plan is None:
        plan = make_plan(variables, points, max_complexity, ops, seconds, loss, operon, seed,
                         dict(starts=starts, iterations=iterations, refine=refine, polish_starts=polish_starts))
    else:
        check(plan, variables, points, max_complexity, ops, loss)
    fit, seed = plan["fit"], plan["seed"]
    codes = grammar.operation_codes(ops)
    kind = rates.kind(codes, loss)
    planned_rates = {kind: plan["rates"]}
    candidates, rungs, searched = [], [], []
    fitted = dict(forms=[], constants=[], complexity=[], loss=[])

    def exhaustive(name, rung_ops, forms, depth):
        forecast_s = estimate_seconds(len(forms), depth, points, kind)
        log(f"{name}: every form of {' '.join(rung_ops)} to complexity {depth} not fitted before "
            f"({len(forms)} forms), about {forecast_s:.0f} s here")
        rung = Rung(name, tuple(rung_ops), depth, len(forms), forecast_s)
        clock = time.perf_counter()
        found = search.search(x, y, depth, rung_ops, fit["starts"], fit["iterations"], fit["refine"],
                              fit["polish_starts"], seed, progress=lambda s: log("  " + s), forms=forms, loss=loss,
                              cost=cost, codes=codes)
        rates.learn(found["timing"])
        rung.seconds = time.perf_counter() - clock
        rungs.append(rung)
        log(f"{name}: {rung.seconds:.0f} s (about {rung.estimated_seconds:.0f} s forecast)")
        searched.append((tuple(rung_ops), depth))
        for i in found["front"]:
            candidates.append((found["forms"][i], found["constants"][i][:found["constant_count"][i]],
                               float(found["loss"][i]), found["converged"].get(i, False), "exhaustive", name))
        fitted["forms"] += list(found["forms"])
        fitted["constants"] += [c[:k] for c, k in zip(found["constants"], found["constant_count"])]
        fitted["complexity"] += list(found["complexity"])
        fitted["loss"] += list(found["loss"])

    for planned in plan["rungs"]:
        if planned["engine"] == "exhaustive" and planned["operations"] is None:
            arithmetic = tuple(op for op in ops if op in grammar.ARITHMETIC)
            suggested = arithmetic + _suggested(candidates, arithmetic) if arithmetic and candidates else ops
            if len(suggested) == len(arithmetic):
                suggested = ops         # nothing suggested: the wide grammar deeper
            depth, forms, _ = reach(suggested, variables, points, max_complexity, planned["reference_seconds"], kind,
                                    searched, 0, planned_rates)
            if forms:
                exhaustive("suggested" if suggested != ops else "wide, deeper", suggested, forms, depth)
        elif planned["engine"] == "exhaustive":
            rung_ops, depth = grammar.operations(planned["operations"]), int(planned["complexity"])
            forms = [e for k in range(1, depth + 1) for e in new_forms(rung_ops, variables, k, points, searched)]
            if len(forms) != planned["forms"]:
                raise PlanError(f"the plan's rung {planned['name']!r} lists {planned['forms']} forms of "
                                f"{' '.join(rung_ops)} to complexity {depth}; this version enumerates {len(forms)}")
            exhaustive(planned["name"], rung_ops, forms, depth)
        else:
            whole = any(set(o) == set(ops) and d >= max_complexity for o, d in searched)
            if planned.get("unless_whole") and whole:
                log(f"pyoperon: not run: the exhaustive rungs searched {' '.join(ops)} to complexity {max_complexity}")
                continue
            seeds, generations = [int(s) for s in planned["seeds"]], int(planned["generations"])
            forecast_s = (len(seeds) * pyoperon.generation_units(generations, points) * rates.load()[kind]["operon_s"]
                          + polish_estimate(len(seeds) * MODELS_PER_SEED, points, kind))
            log(f"pyoperon: {' '.join(ops)} to complexity {max_complexity}, {len(seeds)} seed"
                f"{'s' * (len(seeds) > 1)} x {generations} generations, about {forecast_s:.0f} s here")
            rung = Rung("pyoperon", ops, max_complexity, 0, forecast_s, engine="operon")
            clock = time.perf_counter()
            models = pyoperon.seeded_models(x, y, max_complexity, ops, seeds, generations, log,
                                            population=int(planned["population"]),
                                            evaluations=int(planned["evaluations"]))
            rates.record(kind, operon=(len(seeds) * pyoperon.generation_units(generations, points),
                                       time.perf_counter() - clock))
            for tree, c, value, ok in pyoperon.polished(models, x, y, seed, loss=loss, codes=codes):
                candidates.append((tree, c, float(value), ok, "operon", "pyoperon"))
            rung.forms, rung.seconds = len(models), time.perf_counter() - clock
            rungs.append(rung)
            log(f"pyoperon: {len(models)} models on its front within complexity {max_complexity}, polished in float64")
    if plan.get("operon_not_run"):
        log("pyoperon: not run: " + plan["operon_not_run"])
    return candidates, rungs, fitted
