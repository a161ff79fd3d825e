"""`pipeline regress`: symbolic regression of a researcher's own data, a CSV file with a header row:
one column against up to three others, within a time budget (`--seconds`): the ladder of grammars
(`pipeline.symbolic.ladder`: the exhaustive search of `pipeline.symbolic.search` on + - * / first
and deepest, then on the operations asked for and those the data suggest, then pyoperon), one front.

Writes `front.csv` (one front member per row), `front.png` and `plan.json` (the work the search
ran, `budgets`: `--plan plan.json` runs it again, the same front on any machine) into the output
folder, all at once (nothing is written if anything fails, and no lock file is left beside it). Bad input raises
`RegressError` naming the problem: a file that is not a table of numbers, a column of one repeated
value, values whose squares overflow float64.

Model selection: each front member's description length in nats, as exhaustive symbolic regression
counts it (Bartlett et al. 2022), to first order: the data given the model, SSE / (2 sigma^2) where
the noise level sigma is known (`noise`, or for data rounded to d decimals the rounding floor
10^-d / sqrt(12)), else (N / 2) ln(SSE / N); its p fitted constants, (p / 2) ln N; its form,
complexity x ln(the grammar's symbols: the operations, the variable and the constant). The member of
least description length is marked selected (front.csv's `selected` column, the figure).

Operations: + - * / and exp, log, sqrt, square, cube, pow by default (`DEFAULT_OPERATIONS`), as
TuringBot's and PySR's users find them: a law of physics or a shader is seldom rational; sin, cos,
abs and inv (1/a) where `--ops` names them (each more operation widens every complexity's forms:
with all fourteen, 35,114 one-variable forms up to complexity 8 against 18,610 with the ten). The
losses (`--loss`): rms (default), relative (the RMS of the relative error), max and max-relative
(minimax); the front, the selection and the printed table rank by it.
"""

from __future__ import annotations

import csv
import math
import re
import textwrap
from pathlib import Path

import numpy as np

from ..engine import escape
from ..isa.architectures import ARCHITECTURES
from . import grammar

MAX_COMPLEXITY = 16
ENGINES = ("auto", "exhaustive", "operon", "both")
DEFAULT_OPERATIONS = grammar.TEN
# The time budget `--engine auto|both|operon` plans for by default, by the number of variables (one,
# more) and the largest complexity asked (at most 12, more): the ladder of grammars shares it
# (`ladder`). Two variables reach + - * / to complexity 10 in about 30 s here, three to 9.
BUDGET_SECONDS = {(1, 12): 45.0, (1, MAX_COMPLEXITY): 100.0, (2, 12): 90.0, (2, MAX_COMPLEXITY): 200.0}
MIN_SECONDS, MAX_SECONDS = 10.0, 86_400.0
# Up to this complexity every form is enumerated before a search, to refuse too few points at once.
SHALLOW = 7
TITLE_WIDTH = 120       # characters of a line of the figure's title (what the rungs covered, wrapped)
# Squares of values beyond this overflow float64 sums (1e308) over any realistic number of points.
LARGEST_VALUE = 1e150
ROUNDING_DECIMALS_MAX = 8


class RegressError(ValueError):
    """A bad CSV file or argument of `pipeline regress`."""


def parse_operations(text: str) -> tuple:
    """'+,-,*,/,exp' (commas or spaces; "+-*/" alone also) -> ('+', '-', '*', '/', 'exp')."""
    try:
        return grammar.operations(text)
    except ValueError as e:
        raise RegressError(f"--ops {text!r}: {e}; give distinct operations from {', '.join(grammar.OPERATIONS)}, "
                           f"comma-separated (\"+,-,*,/,exp\")") from None


def budget_seconds(max_complexity: int, variables: int = 1) -> float:
    """The default budget of `--engine auto|both|operon` at this largest complexity."""
    return BUDGET_SECONDS[(min(variables, 2), 12 if max_complexity <= 12 else MAX_COMPLEXITY)]


def read_table(path: Path, columns: list[str], options: list[str]) -> list[np.ndarray]:
    """The named columns of a CSV file with a header row, as float arrays (`options` names the
    command-line option of each column, for the messages)."""
    if not path.is_file():
        raise RegressError(f"{path}: no such file")
    try:
        with open(path, newline="", encoding="utf-8") as f:
            rows = list(csv.reader(f))
    except UnicodeDecodeError as e:
        raise RegressError(f"{path}: not a UTF-8 text file ({e.reason} at byte {e.start})") from None
    rows = [r for r in rows if any(cell.strip() for cell in r)]
    if not rows:
        raise RegressError(f"{path}: the file is empty")
    header = [h.strip() for h in rows[0]]
    for name, option in zip(columns, options):
        if name not in header:
            raise RegressError(f"{path}: no column {name!r} ({option}); the header has " + ", ".join(repr(h) for h in header))
    for i, name in enumerate(columns):
        if name in columns[:i]:
            raise RegressError(f"{' and '.join(sorted(set([options[columns.index(name)], options[i]])))} name the "
                               f"same column {name!r} twice")
    out = []
    for name in columns:
        j, values = header.index(name), []
        for line, row in enumerate(rows[1:], start=2):
            cell = row[j].strip() if j < len(row) else ""
            try:
                v = float(cell)
            except ValueError:
                raise RegressError(f"{path}, line {line}, column {name!r}: {cell!r} is not a number") from None
            if not math.isfinite(v):
                raise RegressError(f"{path}, line {line}, column {name!r}: {cell!r} is not a finite number")
            values.append(v)
        out.append(np.array(values, dtype=np.float64))
    return out


def read_columns(path: Path, x_column: str, y_column: str) -> tuple[np.ndarray, np.ndarray]:
    """The two named columns of a CSV file as float arrays."""
    if x_column == y_column:
        raise RegressError(f"--x and --y name the same column {x_column!r}")
    x, y = read_table(path, [x_column, y_column], ["--x", "--y"])
    return x, y


def check_columns(path: Path, x, y, x_column: str, y_column: str) -> None:
    """Refuses what no search can fit: a column of one value, values whose squares overflow."""
    for values, name, option in ((x, x_column, "--x"), (y, y_column, "--y")):
        if values.size and np.all(values == values[0]):
            what = "there is nothing to fit against" if option == "--x" else "the fit is that constant: nothing to search"
            raise RegressError(f"{path}: column {name!r} ({option}) has the one value {values[0]:g} on every row: {what}")
        largest = float(np.max(np.abs(values))) if values.size else 0.0
        if largest > LARGEST_VALUE:
            row = int(np.argmax(np.abs(values)))
            raise RegressError(f"{path}: column {name!r} ({option}) holds {values[row]:g} (data row {row + 1}): values "
                               f"beyond {LARGEST_VALUE:g} overflow the sums of squares in float64; rescale the column")


def rounding_noise(y) -> float | None:
    """sigma = 10^-d / sqrt(12) if every y is a multiple of 10^-d for some d <= 8 (data rounded to d
    decimals), else None."""
    for d in range(ROUNDING_DECIMALS_MAX + 1):
        scaled = y * 10.0 ** d
        if np.all(np.abs(scaled - np.round(scaled)) <= 1e-9 * np.maximum(np.abs(scaled), 1.0)):
            return 10.0 ** -d / np.sqrt(12.0)
    return None


def select(front, n_points: int, noise: float | None, symbols: int, loss: str = "rms") -> int:
    """Adds `description_length` (nats) to each member and returns the index of the least. The data
    term is the loss's likelihood: Gaussian errors for rms and relative (m["loss"], the RMS of the
    error or of the relative error), uniform errors for the max losses (N ln(2 max), the minimax
    fit being their maximum likelihood). The form's term counts its structure (the default
    complexity, `structure`), times ln(symbols): the operations, the variables and the constant."""
    for m in front:
        value = m.get("loss", m["rms"])
        if loss.startswith("max"):
            data = n_points * np.log(max(2.0 * value, 1e-300))
        else:
            sse = n_points * value ** 2
            data = sse / (2.0 * noise ** 2) if noise else 0.5 * n_points * np.log(max(sse / n_points, 1e-300))
        m["description_length"] = float(data + 0.5 * m["constants"] * np.log(n_points)
                                        + m.get("structure", m["complexity"]) * np.log(symbols))
    best = int(np.argmin([m["description_length"] for m in front]))
    for i, m in enumerate(front):
        m["selected"] = i == best
    return best


def variable_names(columns: list[str]) -> list[str]:
    """Each column's name where it can name a variable in an expression (and they differ), else x,
    x1, x2."""
    ok = all(re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", c) and c != "c" for c in columns) and len(set(columns)) == len(columns)
    return list(columns) if ok else ["x"] + [f"x{k}" for k in range(1, len(columns))]


def _member(tree, c, value, converged, names, engine, x, y, cost=None):
    import sympy as sp

    symbols = [sp.Symbol(n) for n in names]
    rms = float(np.sqrt(np.mean((grammar.evaluate_numpy(tree, c, x) - y) ** 2)))
    size = grammar.complexity(tree, cost)
    return dict(complexity=int(size) if float(size).is_integer() else float(size), rms=rms if np.isfinite(rms) else np.inf,
                loss=float(value), form=grammar.show(tree, names),
                expression=grammar.show(tree, names, c),
                canonical=grammar.canonical(grammar.to_sympy(tree, c, symbols), symbols if len(names) > 1 else symbols[0]),
                converged=bool(converged), constants=int(len(c)), engine=engine)


def regress(path: Path, x_column, y_column: str, out: Path, max_complexity: int = 12, ops=DEFAULT_OPERATIONS,
            starts: int = 2, iterations: int = 7, refine: int = 8, polish_starts: int = 4, seed: int = 0,
            log=print, noise: float | None = None, engine: str = "auto", loss: str = "rms", cost=None,
            gpu: str | None = None, seconds: float | None = None, plan=None) -> list[dict]:
    """Runs the search of y on the file's x column(s) (a name, or a list of up to 3); writes
    out/front.csv and out/front.png; returns the front, its selected member marked (`select`;
    `noise` the data's standard deviation if known).

    `engine`: "exhaustive" (every form up to max_complexity, however long), "operon" (pyoperon alone,
    for `seconds`), "auto" (the ladder of grammars within `seconds`, `ladder`: narrower grammars first
    and deeper, then the operations the data suggest, then pyoperon; the operations `ops` searched
    whole and alone where they reach max_complexity) or "both" (the ladder, pyoperon always).
    `seconds`: the budget (default `budget_seconds`), planned as work before the search
    (`ladder.make_plan`); `plan` (a plan file's path, or a `budgets.Budget` of recorded plans) runs
    its "regress" plan instead (the engine, seconds and seed then the plan's). `loss` ranks (`search.LOSSES`); `cost`,
    a TOML file of costs per operation (`grammar.read_cost_table`), ranks by its complexity instead
    of the default count.
    `gpu` (an architecture of `isa.architectures`: rdna3, ..., sm_120; one variable only): every front
    member compiled for that architecture, its cycles in the member's `cycles`
    (`gpu_costs.expression_cycles`)."""
    from .search import LOSSES, loss_weights

    ops = grammar.operations(ops)
    x_columns = [c.strip() for c in x_column.split(",")] if isinstance(x_column, str) else list(x_column)
    if not 1 <= len(x_columns) <= grammar.VARIABLES_MAX or not all(x_columns):
        raise RegressError(f"--x {','.join(x_columns)!r}: give 1 to {grammar.VARIABLES_MAX} column names, comma-separated")
    if engine not in ENGINES:
        raise RegressError(f"--engine {engine!r}: give one of {', '.join(ENGINES)}")
    if loss not in LOSSES:
        raise RegressError(f"--loss {loss!r}: give one of {', '.join(LOSSES)}")
    if not 1 <= max_complexity <= MAX_COMPLEXITY:
        raise RegressError(f"--max-complexity {max_complexity}: give an integer in [1, {MAX_COMPLEXITY}]")
    if seconds is not None and not (math.isfinite(seconds) and MIN_SECONDS <= seconds <= MAX_SECONDS):
        raise RegressError(f"--seconds {seconds:g}: give a time budget in [{MIN_SECONDS:g}, {MAX_SECONDS:g}] seconds")
    if noise is not None and not (math.isfinite(noise) and noise > 0):
        raise RegressError(f"--noise {noise}: give the data's noise level, a number > 0")
    if y_column in x_columns:
        raise RegressError(f"--x and --y name the same column {y_column!r}")
    if gpu is not None and gpu not in GPUS:
        raise RegressError(f"--gpu {gpu!r}: give one of {', '.join(GPUS)}")
    if gpu is not None and len(x_columns) > 1:
        raise RegressError(f"--gpu compiles forms of one variable (a lobe's t); --x names {len(x_columns)}")
    table = None
    if cost is not None:
        try:
            table = grammar.read_cost_table(cost, ops)
        except ValueError as e:
            raise RegressError(f"--cost {e}") from None
    *xs, y = read_table(Path(path), x_columns + [y_column], ["--x"] * len(x_columns) + ["--y"])
    for values, name in zip(xs, x_columns):
        check_columns(Path(path), values, y, name, y_column)
    try:
        weights = loss_weights(y, loss)
    except ValueError as e:
        raise RegressError(f"{path}: --loss {loss}: {e}") from None
    x = np.stack(xs)
    names = variable_names(x_columns)
    budget = budget_seconds(max_complexity, len(names)) if seconds is None else seconds
    shallow = min(max_complexity, SHALLOW)
    forms = grammar.enumerate_forms(shallow, ops, len(names))
    if not forms:
        raise RegressError(f"no expression of complexity <= {shallow} uses only the operations {' '.join(ops)}")
    most = max(grammar.constants(e) for e in forms)
    if engine != "operon" and y.size <= most:
        raise RegressError(f"{path}: {y.size} data points, but expressions up to complexity {shallow} have up "
                           f"to {most} constants; give at least {most + 1} points or a lower --max-complexity")
    from . import budgets, ladder, search

    fit = dict(starts=starts, iterations=iterations, refine=refine, polish_starts=polish_starts)
    if plan is not None:
        try:
            if not isinstance(plan, budgets.Budget):
                plan = budgets.recorded(plan)
            planned = plan.plan("regress", len(names), y.size, max_complexity, ops, loss)
        except ladder.PlanError as e:
            raise RegressError(f"--plan: {e}") from None
    else:
        operon = dict(auto="auto", both="always", operon="only").get(engine)
        planned = ladder.make_plan(len(names), y.size, max_complexity, ops, None if engine == "exhaustive" else budget,
                                   loss, operon or "never", seed, fit)
    log(f"{path}: {y.size} points, {len(names)} variable{'s' * (len(names) > 1)}; searching expressions up to "
        f"complexity {max_complexity} with operations {' '.join(ops)}, loss {loss}; the plan"
        + (f" of {planned['seconds']:g} s at the reference rates" if planned["seconds"] is not None else "")
        + f": {ladder.covered_text(planned)}; about {ladder.forecast(planned):.0f} s here")
    log(f"fitting on JAX's default device: {search.jax.devices()[0].platform.upper()}")
    candidates, rungs, fitted = ladder.run(x, y, max_complexity, ops, None, loss, table, log=log, plan=planned)
    log("covered: " + "; ".join(f"{r.name} ({' '.join(r.operations)}) to complexity {r.complexity}, "
                                 f"{r.forms} {'models' if r.engine == 'operon' else 'forms'}, {r.seconds:.0f} s "
                                 f"(forecast {r.estimated_seconds:.0f} s)" for r in rungs))
    front, fits = _merged_front(candidates, names, x, y, weights, table)
    rows, share = dominating_rows(fits, x, y)
    if rows:
        where = ", ".join(f"data row {i + 1} ({', '.join(f'{n}={v:g}' for n, v in zip(x_columns, x[:, i]))}, "
                          f"{y_column}={y[i]:g})" for i in rows)
        log(f"warning: {where} hold{'s' * (len(rows) == 1)} more than half the squared error of {share} of the "
            f"front members without a pole among the data: an outlier dominates the fit; check that row")
    sigma = noise if noise is not None else rounding_noise(y) if loss == "rms" else None
    best = select(front, y.size, sigma, len(ops) + 1 + len(names), loss)
    how = (f"noise {sigma:.3g} given" if noise is not None else
           f"noise {sigma:.3g}, the rounding floor of y" if sigma else "noise unknown")
    log(f"selected by description length ({how}, loss {loss}): complexity {front[best]['complexity']}, "
        f"{front[best]['expression']}")
    # every expression fitted, for the figure: the exhaustive rungs' forms and pyoperon's polished models
    others = [m for m in candidates if m[4] != "exhaustive"]
    everything = dict(complexity=np.array(list(fitted["complexity"]) + [grammar.complexity(t, table) for t, *_ in others],
                                          dtype=float),
                      rms=np.array(list(fitted["loss"]) + [m[2] for m in others], dtype=float),
                      forms=list(fitted["forms"]) + [t for t, *_ in others])
    if gpu is not None:
        compiled_cycles(front, fits, gpu, log)
    covered = "; ".join(f"{r.name}: {' '.join(r.operations) if len(r.operations) < 10 else 'the ten operations'} to "
                        f"{r.complexity}" for r in rungs)
    _write(Path(out), front, escape.mathtext(f"{Path(path).name}: {y_column} against {', '.join(x_columns)}") + "\n"
           + textwrap.fill(f"({covered})", TITLE_WIDTH), x, y, everything, loss, table is not None,
           dict(seconds=planned["seconds"], searches={"regress": planned}))
    return front


GPUS = tuple(ARCHITECTURES)


def compiled_cycles(front, fits, gpu: str, log=print) -> None:
    """Adds `cycles` to each front member: its cycles compiled for the architecture `gpu` (by its
    vendor's back end and cost model)."""
    from ..isa.machine_code import CompilerMissing
    from ..optics.spirv import ToolMissing
    from .gpu_costs import expression_cycles

    try:
        measured = expression_cycles({str(i): grammar.glsl(tree, c) for i, (tree, c) in enumerate(fits)}, (gpu,))[gpu]
    except (CompilerMissing, ToolMissing) as e:
        raise RegressError(f"--gpu {gpu}: the GPU compiler cannot run here: {e}") from None
    for i, m in enumerate(front):
        m["cycles"] = measured[str(i)]
    a = ARCHITECTURES[gpu]
    log(f"compiled every front member for {gpu} ({a.title}, {a.backend}): cycles in front.csv")


def pole_in_range(tree, c, x) -> bool:
    """Whether a member of one variable has a pole within the range of x (a real root of its
    denominator, by sympy)."""
    import sympy as sp

    if x.shape[0] != 1:
        return False
    t = sp.Symbol("t")
    _, den = sp.fraction(sp.cancel(sp.together(grammar.to_sympy(tree, c, t))))
    if t not in den.free_symbols:
        return False
    if not den.is_polynomial(t):
        # (a denominator with functions: a sign change or a zero on a dense grid over the data's range)
        grid = np.linspace(x.min(), x.max(), 4001)
        with np.errstate(all="ignore"):
            values = np.broadcast_to(sp.lambdify(t, den, "numpy")(grid), grid.shape)
        finite = values[np.isfinite(values)]
        return bool(np.any(finite == 0) or np.any(np.sign(finite[1:]) * np.sign(finite[:-1]) < 0))
    roots = [complex(r) for r in sp.Poly(den, t).nroots()]
    return any(abs(r.imag) <= 1e-9 * max(abs(r), 1.0) and x.min() <= r.real <= x.max() for r in roots)


def dominating_rows(fits, x, y, share: float = 0.5) -> tuple[list[int], int]:
    """The data rows (at most 3) that hold more than `share` of the squared error of most front
    members (fits: (tree, constants) per member), and of how many: an outlier that dominates the
    fit. A member with a pole within the data's range is not asked (a rational member puts its pole
    on the outlier)."""
    fits = [(tree, c) for tree, c in fits if not pole_in_range(tree, c, x)]
    rows, count, flagged = [], 0, {}
    for tree, c in fits:
        r2 = (grammar.evaluate_numpy(tree, c, x) - y) ** 2
        total = float(np.sum(r2))
        if not total > 0 or not np.isfinite(total):
            continue
        top = np.argsort(r2)[::-1][:3]
        needed = int(np.searchsorted(np.cumsum(r2[top]), share * total, side="right"))   # rows past the share
        if needed < top.size:
            key = tuple(sorted(int(i) for i in top[:needed + 1]))
            flagged[key] = flagged.get(key, 0) + 1
    if flagged:
        key, count = max(flagged.items(), key=lambda kv: kv[1])
        if count > len(fits) / 2:
            rows = list(key)
    return rows, count


def _merged_front(candidates, names, x, y, weights, cost=None):
    """The Pareto front of complexity (under `cost`) against the loss over every engine's
    candidates, and each member's (tree, constants); a member's `engine` says which engine found it
    ("both" where both reached its loss within 1e-6 at its complexity)."""
    from .search import pareto_front

    size = np.array([grammar.complexity(t, cost) for t, *_ in candidates])
    value = np.array([r if np.isfinite(r) else np.inf for _, _, r, *_ in candidates])
    # the exhaustive rungs' candidates first, in the ladder's order (narrower first), so that a tie
    # is the narrower grammar's member
    order = np.array(sorted(range(len(candidates)), key=lambda k: candidates[k][4] != "exhaustive"))
    front, fits = [], []
    scaled = y * weights
    for i in pareto_front(size[order], value[order], 1e-12 * (np.std(scaled) + np.max(np.abs(scaled)))):
        k = order[i]
        tree, c, r, ok, engine, _ = candidates[k]
        both = any(candidates[j][4] != engine and size[j] <= size[k] and value[j] <= r * (1 + 1e-6) + 1e-300
                   for j in range(len(candidates)))
        member = _member(tree, c, r, ok, names, "both" if both else engine, x, y, cost)
        member["structure"] = int(grammar.complexity(tree))
        member["rung"] = candidates[k][5]
        front.append(member)
        fits.append((tree, c))
    return front, fits


def _write(out: Path, front, title, x, y, found, loss="rms", costed=False, plan=None) -> None:
    """front.csv, front.png and plan.json (the plan the search ran, `budgets`), published together
    (`pipeline.engine.publishing`: a temporary folder renamed into place under a lock, so a failure
    or a second writer leaves nothing half written)."""
    import json

    from ..engine.cache import digest
    from ..engine.publishing import publish

    def write(tmp: Path) -> str:
        write_front_csv(tmp / "front.csv", front)
        symbolic_front_figure(tmp / "front.png", front, found, title, loss, costed)
        (tmp / "plan.json").write_text(json.dumps(dict(plan=plan), indent=1) + "\n")
        return f"{len(front)} front members"

    publish(out, digest("regress", title, x, y, front, json.dumps(plan, sort_keys=True)), lambda s: None, write)


FRONT_COLUMNS = ("complexity", "cycles", "structure", "loss", "rms", "form", "expression", "canonical", "max_rel_to_exact",
                 "max_energy_excess", "equivalent_to_exact", "constants", "description_length", "selected", "engine",
                 "rung")


def write_front_csv(path, front) -> None:
    """A symbolic-regression front as CSV, one member per row; columns a member lacks are left out."""
    columns = [c for c in FRONT_COLUMNS if all(c in m for m in front)]
    with open(path, "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(columns)
        for m in front:
            writer.writerow([f"{m[c]:.10g}" if isinstance(m[c], float) else m[c] for c in columns])


LOSS_LABELS = {"rms": "RMS error", "relative": "RMS of the relative error", "max": "largest absolute error",
               "max-relative": "largest relative error"}


def symbolic_front_figure(path, front, found, title, loss="rms", costed=False) -> None:
    """The front of `pipeline regress`: the loss against complexity, every complexity's best in grey
    (found["rms"] holds each expression's loss)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(10, 5))
    sizes = sorted(set(float(k) for k in found["complexity"]))
    # (an exact member drawn at 1e-16 of the front's worst loss; a huge finite loss of a form far off,
    # exp near overflow, must not set the scale)
    floor = 1e-16 * max(max(m.get("loss", m["rms"]) for m in front), 1e-300)
    best = [max(float(np.min(found["rms"][found["complexity"] == k])), floor) for k in sizes]
    ax.plot(sizes, best, "o", color="0.75", ms=5, label=f"best expression at each complexity ({len(found['forms'])} fitted)")
    xs, ys = [m["complexity"] for m in front], [max(m.get("loss", m["rms"]), floor) for m in front]
    ax.step(xs + [sizes[-1] + 1], ys + [ys[-1]], where="post", color="C0", label="front")
    for engine, color, label in (("exhaustive", "C0", "found by the exhaustive search"), ("operon", "C1", "found by pyoperon"),
                                 ("both", "C2", "found by both engines")):
        at = [(x_, y_) for m, x_, y_ in zip(front, xs, ys) if m.get("engine", "exhaustive") == engine]
        if at and (engine != "exhaustive" or any(m.get("engine") != "exhaustive" for m in front)):
            ax.plot(*zip(*at), "o", color=color, ms=7, label=label)
        elif at:
            ax.plot(*zip(*at), "o", color=color, ms=7)
    chosen = [(x_, y_) for m, x_, y_ in zip(front, xs, ys) if m.get("selected")]
    if chosen:
        ax.plot(*chosen[0], "o", ms=15, mfc="none", mec="C3", mew=2, label="selected (least description length)")
    lines = [f"front (complexity, {LOSS_LABELS[loss]}, sympy's canonical form):"]
    lines += [f"{m['complexity']:>2}  {m.get('loss', m['rms']):.3g}  "
              f"{escape.mathtext(m['canonical'].replace('**', '^').replace('*', ' '))}" for m in front]
    ax.text(0.98, 0.97, "\n".join(lines), transform=ax.transAxes, fontsize=7.5, family="monospace", va="top",
            ha="right", multialignment="left", bbox=dict(facecolor="white", edgecolor="0.8", alpha=0.9))
    positive = [v for v in best if v > 0]
    ax.set(yscale="log" if positive and max(positive) / min(positive) > 20 else "linear",
           xlabel=("complexity (the cost table given)" if costed else
                   "complexity (constants, variables, +, -, x, square, cube count 1; /, exp, log, sqrt, pow 2)"),
           ylabel=LOSS_LABELS[loss],
           xlim=(0, sizes[-1] + 1.5))
    ax.set_title(title, fontsize=10)
    ax.legend(fontsize=8, loc="lower left")
    ax.grid(alpha=0.3, which="both")
    fig.tight_layout()
    fig.set_layout_engine(None)     # laid out: savefig need not draw it once more for tight_layout's placeholder
    fig.savefig(path, dpi=110, pil_kwargs={"compress_level": 1})
    plt.close(fig)
