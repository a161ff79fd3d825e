"""pyoperon (genetic programming, Burlacu et al.) as a second engine of `pipeline regress`, for where
the exhaustive search does not reach: every variable, any complexity, in about a minute.

Its Pareto front (RMS against length) is read back into the grammar of `pipeline.symbolic.grammar`:
each model's text parsed (its numbers as constants), constant-only subtrees folded to one constant
(`fold_constants`: pyoperon writes scale and offset terms and products of constants), its complexity
recomputed TuringBot's way, and its constants polished in float64 by the pipeline's own fit from
pyoperon's values (pyoperon 0.6.2 fits in float32: its `fit` fails on float64 input).
"""

from __future__ import annotations

import numpy as np

from . import grammar

# pyoperon's settings: objectives RMS and length, Levenberg-Marquardt on the constants of every
# offspring (optimizer_iterations > 0: its default 0 never tunes a constant), one thread per core.
GENERATIONS = 300
GENERATIONS_TIMED = 100_000     # generations when a time budget is what stops it
POPULATION = 1000
SECONDS = 60            # pyoperon stops here if its generations are not done (many points)
OPTIMIZER_ITERATIONS = 10
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


def operon_models(x, y, max_complexity: int, ops="+-*/", seed: int = 0, threads: int = 2,
                  generations: int | None = None, population: int | None = None,
                  seconds: float | None = None) -> list[tuple]:
    """pyoperon's Pareto front on x (variables, points) and y, as (tree, constants) in the grammar,
    constant-only subtrees folded; models above `max_complexity` or not in the grammar are left out.
    `generations`, `population` and `seconds` default to GENERATIONS, POPULATION and SECONDS."""
    import warnings

    from pyoperon.sklearn import SymbolicRegressor

    x, y = np.atleast_2d(np.asarray(x, dtype=np.float64)), np.asarray(y, dtype=np.float64)
    ops = grammar.operations(ops)
    symbols = ",".join([SYMBOLS[op] for op in ops if op in SYMBOLS] + ["constant", "variable"])
    regressor = SymbolicRegressor(
        allowed_symbols=symbols, objectives=["rmse", "length"], optimizer_iterations=OPTIMIZER_ITERATIONS,
        max_length=2 * max_complexity, max_depth=max(4, max_complexity), generations=generations or GENERATIONS,
        population_size=population or POPULATION, max_evaluations=10**7, max_time=int(max(seconds or SECONDS, 1)), n_threads=threads, random_state=seed)
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
        if not grammar.operations_of(tree) <= set(ops):
            continue            # (pyoperon's a ^ 2 where square is given but not pow)
        if grammar.complexity(tree) <= max_complexity and repr(tree) not in seen and np.all(np.isfinite(values)):
            seen.add(repr(tree))
            out.append((tree, np.array(values)))
    return out


def polished(models, x, y, seed: int = 0, loss: str = "rms"):
    """(tree, constants, loss, converged) of each model, its constants refitted in float64 by the
    pipeline's fit under `loss` from pyoperon's values and from 3 more starts (`search.fit_forms`);
    pyoperon's values themselves where they fit better (converged then False: not the fit's)."""
    from . import search

    if not models:
        return []
    fits = search.fit_forms([tree for tree, _ in models], x, y, starts=4, seed=seed,
                            initial=[values for _, values in models], loss=loss)
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
