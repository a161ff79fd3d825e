"""pyoperon (genetic programming, Burlacu et al.) as a second engine of `pipeline regress`, for where
the exhaustive search does not reach: every variable, any complexity, in about a minute.

Its Pareto front (RMS against length) is read back into the grammar of `pipeline.symbolic.grammar`:
each model's text parsed (its numbers as constants), constant-only subtrees folded to one constant
(`fold_constants`: pyoperon writes scale and offset terms and products of constants), its complexity
recomputed TuringBot's way, and its constants polished in float64 by the pipeline's own fit from
pyoperon's values (pyoperon 0.6.2 fits in float32: its `fit` fails on float64 input).

pyoperon weighs every variable (0.58 * X1) and wraps every model in a scale and an offset, so that a
model of its length 9 reads back at complexity 24: most of its front lies beyond the complexity
asked for. Each model is therefore also read back with some of these constants dropped (fewest
first, `variants`; the float64 polish refits the rest): on 400 points of (1 - x)^5, x1 x2 / (x1 +
x3) and 0.7 sqrt(x1^2 + x2^2), measured in 10-20 s runs, 2-3 models within complexity 10 came back
and none exact; with the variants, 33-100 and all three exact. Its settings otherwise are its
own (population 1000, Levenberg-Marquardt on the constants of every offspring): population 500 or
2000, 1 to 50 optimizer iterations, the offspring generator 'os' and the objective r2 did no
better on those laws and on t / (n - n t + t). That law came back exactly from one seed of four
(with + - * /): where the budget allows, several seeds run (`SEED_SECONDS` each at least).

A run is fixed by its seed, its generations and its evaluations, never by the clock: its models
depend on them alone (the same for one thread as for two: pyoperon seeds each individual's random
numbers from the run's), so that a plan (`ladder.make_plan`) gives the same models on any machine.
"""

from __future__ import annotations

import numpy as np

from . import grammar

# pyoperon's settings: objectives RMS and length, Levenberg-Marquardt on the constants of every
# offspring (optimizer_iterations > 0: its default 0 never tunes a constant), one thread per core.
GENERATIONS = 300
MAX_GENERATIONS = 100_000       # a plan's generations per seed, at most
POPULATION = 1000
EVALUATIONS = 10**7             # pyoperon's evaluation budget, per seed
THREADS = 2
GENERATION_POINTS = 250         # a generation costs as much as evaluating this many points more (`generation_units`)
OPTIMIZER_ITERATIONS = 10
SEED_SECONDS = 20.0     # a budget runs one seed per this many seconds (at most MAX_SEEDS)
MAX_SEEDS = 4
VARIANTS = 16           # forms read back from one model with constants dropped, at most
POLISH_STARTS = 4
# pyoperon's symbol of each operation; it has no cube (pow reaches it where pow is given) nor inv
# (div reaches it where / is given), and writes square(a) as a ^ 2, read back as square (and a ^ 3
# as cube).
SYMBOLS = {"+": "add", "-": "sub", "*": "mul", "/": "div", "exp": "exp", "log": "log", "sqrt": "sqrt",
           "square": "square", "pow": "pow", "sin": "sin", "cos": "cos", "abs": "abs"}


def _integer_powers(tree, values, ops):
    """(tree, values) with a ^ 2 and a ^ 3 (a literal exponent, as pyoperon writes square) written
    square(a) and cube(a) where those are among `ops`."""
    values = list(values)
    out_values = []
    position = [0]

    def build(node):
        if node == grammar.C:
            out_values.append(values[position[0]])
            position[0] += 1
            return node
        if len(node) == 1:
            return node
        if node[0] == "pow" and node[2] == grammar.C:
            base = build(node[1])
            exponent = values[position[0]]
            name = {2.0: "square", 3.0: "cube"}.get(exponent)
            if name in ops:
                position[0] += 1
                return (name, base)
            out_values.append(exponent)
            position[0] += 1
            return ("pow", base, node[2])
        return (node[0],) + tuple(build(a) for a in node[1:])

    return build(tree), out_values


def operon_models(x, y, max_complexity: int, ops="+-*/", seed: int = 0, threads: int = THREADS,
                  generations: int | None = None, population: int | None = None,
                  evaluations: int = EVALUATIONS) -> list[tuple]:
    """pyoperon's Pareto front on x (variables, points) and y, as (tree, constants) in the grammar,
    constant-only subtrees folded; models above `max_complexity` or not in the grammar are left out.
    `generations` and `population` default to GENERATIONS and POPULATION; no time limit."""
    import warnings

    from pyoperon.sklearn import SymbolicRegressor

    x, y = np.atleast_2d(np.asarray(x, dtype=np.float64)), np.asarray(y, dtype=np.float64)
    ops = grammar.operations(ops)
    symbols = ",".join([SYMBOLS[op] for op in ops if op in SYMBOLS] + ["constant", "variable"])
    regressor = SymbolicRegressor(
        allowed_symbols=symbols, objectives=["rmse", "length"], optimizer_iterations=OPTIMIZER_ITERATIONS,
        max_length=2 * max_complexity, max_depth=max(4, max_complexity), generations=generations or GENERATIONS,
        population_size=population or POPULATION, max_evaluations=evaluations, max_time=None, n_threads=threads,
        random_state=seed)
    with warnings.catch_warnings():
        # pyoperon says it adds its scale and offset terms (the rmse objective needs them)
        warnings.simplefilter("ignore", UserWarning)
        regressor.fit(x.T.astype(np.float32), y.astype(np.float32))
    names = [f"X{k + 1}" for k in range(x.shape[0])]
    out, seen = [], set()
    for model in regressor.pareto_front_:
        values = []
        try:
            tree = grammar.parse(regressor.get_model_string(model["tree"], 17, names), names, values)
        except ValueError:
            continue            # a symbol outside the grammar
        tree, values = grammar.fold_constants(*_integer_powers(tree, values, ops))
        if not grammar.operations_of(tree) <= set(ops) or not np.all(np.isfinite(values)):
            continue            # (pyoperon's a ^ 2 where square is given but not pow)
        for form, c in variants(tree, values, max_complexity):
            if repr(form) not in seen:
                seen.add(repr(form))
                out.append((form, np.array(c)))
    return out


def _droppable(e) -> list[tuple]:
    """Paths of the nodes whose constant pyoperon adds and a law may not need: its variables' weights
    (c * x), the offset at the top (c + a) and the scale under it (c * a)."""
    out = []

    def walk(node, path):
        if len(node) == 1:
            return
        if node[0] == "*" and node[1] == grammar.C and grammar.is_variable(node[2]):
            out.append(path)
            return
        for i, a in enumerate(node[1:], 1):
            walk(a, path + (i,))

    walk(e, ())
    if len(e) == 3 and e[0] == "+" and e[1] == grammar.C:
        out.append(())
        if len(e[2]) == 3 and e[2][0] == "*" and e[2][1] == grammar.C:
            out.append((2,))
    return out


def _dropped(e, values, drops):
    """(e, values) with the constants at the paths `drops` (of `_droppable`) removed: c * a and c + a
    become a."""
    remaining, out = iter(values), []

    def build(node, path):
        if node == grammar.C:
            out.append(next(remaining))
            return node
        if len(node) == 1:
            return node
        if path in drops:
            next(remaining)     # (the constant is node[1], the first in order of appearance)
            return build(node[2], path + (2,))
        return (node[0],) + tuple(build(a, path + (i,)) for i, a in enumerate(node[1:], 1))

    return build(e, ()), out


def variants(e, values, max_complexity: int, cap: int = VARIANTS) -> list[tuple]:
    """e and its forms with some of pyoperon's own constants dropped (`_droppable`), fewest drops
    first, those within `max_complexity`, at most `cap`: (tree, values) each."""
    import itertools

    slots = _droppable(e)
    # (a drop saves at least 2: the constant and its operation)
    fewest = max(0, -(-(int(grammar.complexity(e)) - max_complexity) // 2))
    out = []
    for k in range(fewest, len(slots) + 1):
        for drops in itertools.combinations(slots, k):
            tree, c = grammar.fold_constants(*_dropped(e, list(values), set(drops)))
            if grammar.complexity(tree) <= max_complexity:
                out.append((tree, c))
            if len(out) >= cap:
                return out
    return out


def seeds_in(seconds: float) -> int:
    """The seeds a plan gives `seconds` of pyoperon: one per SEED_SECONDS, at least 1, at most MAX_SEEDS."""
    return int(min(MAX_SEEDS, max(1, seconds // SEED_SECONDS)))


def generation_units(generations: int, points: int) -> float:
    """The work of `generations` generations of a population of POPULATION on `points` points, in
    generation-points (`rates`' operon_s): a generation's own cost counts as GENERATION_POINTS points."""
    return float(generations) * (points + GENERATION_POINTS)


def generations_in(seconds: float, points: int, rate: float) -> int:
    """The generations `seconds` of one seed's evolution buy at `rate` seconds per generation-point,
    at least 1, at most MAX_GENERATIONS."""
    return int(min(MAX_GENERATIONS, max(1, seconds // (rate * generation_units(1, points)))))


def seeded_models(x, y, max_complexity: int, ops, seeds, generations: int, log=lambda s: None,
                  population: int | None = None, evaluations: int = EVALUATIONS) -> list[tuple]:
    """`operon_models` of each seed of `seeds` for `generations` generations, in that order; their
    models together, each form once (its first seed's constants)."""
    out, seen = [], set()
    for seed in seeds:
        for tree, c in operon_models(x, y, max_complexity, ops, seed, generations=generations, population=population,
                                     evaluations=evaluations):
            if repr(tree) not in seen:
                seen.add(repr(tree))
                out.append((tree, c))
        if len(seeds) > 1:
            log(f"pyoperon seed {seed}: {len(out)} models so far")
    return out


def polished(models, x, y, seed: int = 0, loss: str = "rms", codes=None):
    """(tree, constants, loss, converged) of each model, its constants refitted in float64 by the
    pipeline's fit under `loss` from pyoperon's values and from POLISH_STARTS - 1 more starts
    (`search.fit_forms`; beyond `search.SCREEN_POINTS` points, on the search's spanning subsample,
    then once more on every point from there), its time kept among the rates of this machine
    (`rates`);
    pyoperon's values themselves where they fit better (converged then False: not the fit's).
    `codes`: the opcodes to compile the fit for (`search.fit_forms`)."""
    from . import rates, search

    if not models:
        return []
    watch = rates.Stopwatch()
    forms = [tree for tree, _ in models]
    x = np.atleast_2d(np.asarray(x, dtype=np.float64))
    initial = [values for _, values in models]
    if y.size > search.SCREEN_POINTS:
        # on the search's spanning subsample from every start, then once more on every point from the
        # subsample's fit (the search's own way with many points)
        sub = search.spanning_subsample(x, search.SCREEN_POINTS)
        first = search.fit_forms(forms, x[:, sub], y[sub], starts=POLISH_STARTS, seed=seed, initial=initial,
                                 loss=loss, codes=codes)
        fits = search.fit_forms(forms, x, y, starts=1, seed=seed, initial=[c for c, _, _ in first], loss=loss,
                                codes=codes)
    else:
        fits = search.fit_forms(forms, x, y, starts=POLISH_STARTS, seed=seed, initial=initial, loss=loss, codes=codes)
    seconds, compiling = watch.elapsed()
    rates.record(rates.kind(search.opcodes(forms) if codes is None else codes, loss),
                 polish=(search.polish_units(len(models), np.size(y)), seconds - compiling))
    weights = search.loss_weights(y, loss)
    out = []
    for (tree, values), (c, value, ok) in zip(models, fits):
        # pyoperon's own constants, in float64, where the polish cannot start from them: a negative
        # base under a literal integer exponent ((0.8 x - 0.8) ^ 5) is real at that exponent only,
        # and the fit, which moves every exponent, finds it undefined
        with np.errstate(all="ignore"):
            r = (grammar.evaluate_numpy(tree, values, x) - y) * weights
        own = float(np.max(np.abs(r)) if loss.startswith("max") else np.sqrt(np.mean(r * r)))
        if np.isfinite(own) and not own >= value:
            c, value, ok = np.asarray(values, dtype=float), own, False
        out.append((tree, c, value, ok))
    return out
