"""Exhaustive symbolic regression in up to three variables (the method of Bartlett et al. 2022).

Every distinct expression of `pipeline.symbolic.grammar` (fitted constants, the variables, +, -,
*, /) is enumerated up to a complexity; the constants of each are fitted by least squares, and the
Pareto front of complexity against RMS error is read off. The front is complete under the stated
complexity measure: no expression of the grammar at or below a complexity fits better than the
front's member there, within the fit's tolerance (the tests refit every expression from starts of
their own, and run the search over every tree of the unreduced grammar, as oracles).

The fit (`_fit_one`) is variable projection: the constants an expression is affine in are solved
by linear least squares in every step and only the others iterated, by Levenberg-Marquardt. Every
form is screened by a few steps from deterministic starts (the same for every form), again from
more starts where they disagree, and the best of each complexity refitted until the RMS no longer
improves. Every register program of a block runs at once (vmapped), on fixed block shapes, so that
a search compiles at most three XLA programs whatever its size (the forms with few constants get a
narrower one only where they are many enough to repay its compilation); the points are padded to
the next of a few sizes (`padded_points`, by copies of the first point at weight 0, which add exact
zeros), so that searches on different numbers of points share them too. The programs are padded
at the front with no-ops to one length; the rows are sorted by the length of their programs, and
each block starts at the first step one of its programs uses (`first_step`), so that short
programs skip their padding: the same values, in a third to a half less time on the usual searches.

Any number of points, in bounded memory: beyond `SCREEN_POINTS` points the screening runs on a
subsample that spans x (evenly spaced in the order of each variable), every form's screened
constants are evaluated on every point, the refits run on the subsample and the best of each
complexity once more on every point; the rows of a block shrink as the points grow (`_rows_for`),
so that no block holds more than about `BLOCK_VALUES` values.
"""

from __future__ import annotations

import time
from functools import partial

import numpy as np

from .grammar import (ADD, CONST, COST, CUBE, DIV, EXP, LOG, MUL, NOP, OPCODE, POW, SQRT, SQUARE, SUB, VAR, C, X,  # noqa: F401
                      apply, canonical, complexity, constants, enumerate_forms, evaluate_numpy, linear_constants,
                      opcodes, operations, operations_of, parse, programs, show, to_sympy)
from ..optics.numerics import jax
from . import rates
import jax.numpy as jnp  # noqa: E402

# Screening and polishing run on fixed block shapes, so that a search compiles a handful of
# programs whatever its size: rows per block (of the fits, and of the evaluation on every point),
# and the constant counts forms are padded to.
POLISH_ROWS = 256
BLOCK_ROWS = 1024
SMALL_CONSTANTS = 2     # forms with at most this many constants are screened in narrower blocks ...
NARROW_ROW_STEPS = 300_000  # ... where they fill at least this many rows x steps: a narrow program saves
                            # about 5 us per row and step against the full width and costs a compile of
                            # about 1.6 s (measured on one core: arithmetic, sin and the ten operations)
MIN_STEPS = 12      # programs are at least this long ...
MIN_WIDTH = 5       # ... and fits have at least this many constants: searches up to 12 share shapes
AGREE = 1e-3            # starts within this relative sum of squares of the best reached the same optimum;
SECOND_PASS = 2         # where only one did, SECOND_PASS x starts more starts
SCREEN_POINTS = 64      # screening subsample beyond this many points
PROGRESS_SECONDS = 10.0  # the screening says how far it is at most this often
BLOCK_VALUES = 2**22    # rows x points x program steps of one block, at most (about)


ARITHMETIC_OPCODES = (VAR, CONST, ADD, SUB, MUL, DIV)


NAME_OF = {code: name for name, code in OPCODE.items()}
JNP_FUNCTIONS = {"exp": jnp.exp, "log": jnp.log, "sqrt": jnp.sqrt, "sin": jnp.sin, "cos": jnp.cos, "abs": jnp.abs}


def _operation(code, a, b):
    """The value of opcode `code` on registers a (and b)."""
    return apply(NAME_OF[code], [a, b], JNP_FUNCTIONS)


def evaluate(program, c, x, codes=ARITHMETIC_OPCODES, first=0):
    """Value at the points of one register program with constants c; x is (variables, points).
    `codes`, the opcodes the program may use (static: each step computes only these). Outside an
    operation's domain the value is nan or infinite (the fit marks the form invalid). `first`: the
    step to start from; the no-ops before it are skipped (`first_step`: no step reads their registers)."""
    op, left, right, index = program

    def step(i, registers):
        a, b = registers[left[i]], registers[right[i]]
        cases = [(VAR, lambda: x[index[i]]), (CONST, lambda: jnp.broadcast_to(c[index[i]], x.shape[1:]))]
        shared = {}
        if POW in codes:
            # a ^ b = exp(b log a), sharing one log and one exp per step with log and exp (every
            # operation of the set is computed at every step): the same values, nan for a < 0
            # where b is not an integer, as a fitted exponent never is exactly
            log_a = jnp.log(a)
            exp_of = jnp.exp(jnp.where(op[i] == POW, b * log_a, a)) if EXP in codes else jnp.exp(b * log_a)
            shared = {LOG: lambda: log_a, POW: lambda: exp_of}
            if EXP in codes:
                shared[EXP] = lambda: exp_of
        cases += [(code, shared.get(code, lambda code=code: _operation(code, a, b)))
                  for code in codes if code not in (VAR, CONST)]
        value = jnp.select([op[i] == code for code, _ in cases], [f() for _, f in cases], 0.0)
        return registers.at[i].set(value)

    return jax.lax.fori_loop(first, op.shape[0], step, jnp.zeros((op.shape[0],) + x.shape[1:]))[-1]


def _first_steps(block) -> np.ndarray:
    """Each program's first step that is not a no-op (the programs of `block` (programs, 4, steps)
    are padded at the front); `steps` for a row of no-ops alone (a padding row)."""
    real = block[:, 0, :] != NOP
    return np.where(real.any(axis=1), np.argmax(real, axis=1), block.shape[-1])


def first_step(block) -> int:
    """The first step of `block` that a program of it uses: the interpreter starts there, so that a
    block of short programs runs only their steps (padding rows do not count)."""
    return int(np.min(_first_steps(block), initial=block.shape[-1]))


def _sum_of_squares(program, c, x, y, w, codes, first=0):
    r = (evaluate(program, c, x, codes, first) - y) * w
    s = jnp.sum(r * r)
    return jnp.where(jnp.isfinite(s), s, jnp.inf)


def _solve(H, g):
    """H^-1 g for a symmetric positive semi-definite H, scaled to a unit diagonal first (Jacobi), so
    that constants of very different scales (1/x against x = 1000) are solved alike."""
    d = jnp.sqrt(jnp.maximum(jnp.diag(H), 1e-300))
    scaled = H / d[:, None] / d[None, :] + 1e-13 * jnp.eye(H.shape[0])
    return jnp.linalg.solve(scaled, g / d) / d


def _residual_and_jacobian(program, c, x, y, w, codes, first=0):
    def r(c_):
        value = (evaluate(program, c_, x, codes, first) - y) * w
        return value, value         # the residual and, as the aux output, its value: one evaluation
    J, value = jax.jacfwd(r, has_aux=True)(c)
    finite = jnp.all(jnp.isfinite(value)) & jnp.all(jnp.isfinite(J))
    return jnp.where(finite, value, 0.0), jnp.where(finite, J, 0.0), finite


def _project(program, linear, c, x, y, w, refine, codes, first=0):
    """The constants that enter linearly (`linear`, a 0/1 mask) solved exactly for the others
    (variable projection: a Gauss-Newton step is exact, the expression being affine in them, and a
    second one from the residual evaluated afresh, where `refine`, removes the rounding of the
    first, large where the start was far); returns (constants, residual after, Jacobian, sum of squares after)."""
    r, J, finite = _residual_and_jacobian(program, c, x, y, w, codes, first)
    Jl = J * linear
    G = Jl.T @ Jl + jnp.diag(1.0 - linear)
    step = -_solve(G, Jl.T @ r) * linear
    # (refine: an unbatched flag, so that under vmap the screening skips the second evaluation)
    c, r, step = jax.lax.cond(refine, lambda: (c + step, (evaluate(program, c + step, x, codes, first) - y) * w, step),
                              lambda: (c, r, step))
    step = jax.lax.cond(refine, lambda: -_solve(G, Jl.T @ r) * linear, lambda: step)
    r = r + Jl @ step
    s = jnp.where(finite, jnp.sum(r * r), jnp.inf)
    return c + step, r, J, jnp.where(jnp.isfinite(s), s, jnp.inf)


def _fit_one(program, linear, c0, x, y, w, iterations, tail, refine, codes, first=0):
    """Levenberg-Marquardt on the nonlinear constants with the linear ones projected out (Kaufman's
    variable projection: the joint Gauss-Newton system, damped on the nonlinear constants only,
    then the linear constants solved exactly at the trial point); a step is kept only if it lowers
    the sum of squares. With `tail` = 0 (the screening), `iterations` steps. Else at most
    `iterations`, stopping once `tail` steps in a row have not lowered the sum of squares by more
    than 1e-9 relative: converged (the objective is judged, not the constants, so that a
    degenerate optimum, a double pole say, is kept). The residuals are weighted by w (the sum of
    squares is of (value - y) w). Returns (constants, sum of squares, converged)."""
    nonlinear = 1.0 - linear

    def step(state):
        i, c, damping, r, J, current, reference, since = state
        H, g = J.T @ J, J.T @ r
        d = jnp.diag(H) * nonlinear
        trial = c - _solve(H + damping * jnp.diag(d) + 1e-12 * (jnp.max(d) + 1.0) * jnp.diag(nonlinear), g) * nonlinear
        trial, r_t, J_t, cost = _project(program, linear, trial, x, y, w, refine, codes, first)
        better = cost < current
        keep = lambda new, old: jnp.where(better, new, old)
        current = keep(cost, current)
        gained = current < reference * (1.0 - 1e-9)
        return (i + 1, keep(trial, c), jnp.where(better, damping / 3.0, jnp.minimum(damping * 4.0, 1e30)),
                keep(r_t, r), keep(J_t, J), current, jnp.where(gained, current, reference),
                jnp.where(gained, 0, since + 1))

    def going(state):
        i, since = state[0], state[-1]
        return (i <= iterations) & ~((tail > 0) & (since >= tail))

    # Step 0 from a zero Jacobian is the projection of c0 itself (one traced copy of the step).
    start = (jnp.asarray(0), c0, jnp.asarray(1e-3), jnp.zeros_like(y), jnp.zeros(y.shape + c0.shape),
             jnp.asarray(jnp.inf), jnp.asarray(jnp.inf), jnp.asarray(0))
    _, c, _, _, _, s, _, since = jax.lax.while_loop(going, step, start)
    return c, s, since >= tail


@partial(jax.jit, static_argnames="codes")
def fit_block(block, linear, c0, x, y, w, iterations, tail, refine, codes=ARITHMETIC_OPCODES, first=0):
    """(constants, sum of squares, converged) of each program of `block` (rows, 4, steps), its linear
    constants `linear` (rows, P) projected out, from c0 (rows, P); x (variables, points), y and the
    weights w (points) shared by every row, or given per row (rows, variables, points) and (rows,
    points); `codes`, the opcodes the programs use; `first`, the block's `first_step` (traced)."""
    if y.ndim == 1:
        return jax.vmap(lambda p, m, c: _fit_one(p, m, c, x, y, w, iterations, tail, refine, codes, first))(
            block, linear, c0)
    return jax.vmap(lambda p, m, c, x_, y_, w_: _fit_one(p, m, c, x_, y_, w_, iterations, tail, refine, codes, first))(
        block, linear, c0, x, y, w)


def _blocks(rows: int, size: int):
    for start in range(0, rows, size):
        yield slice(start, min(start + size, rows)), min(start + size, rows) - start


def _pad(a, rows, value=0):
    return np.pad(a, [(0, rows - a.shape[0])] + [(0, 0)] * (a.ndim - 1), constant_values=value)


def padded_points(points: int) -> int:
    """The number of points the compiled programs see: `points` rounded up to the next of 8, 12, 16,
    24, 32, 48, ... (a power of two or 1.5 times one), so that searches on different numbers of
    points share traced and compiled programs (tracing one costs about a second, the search itself
    often less), at most 1.5x the work."""
    size = 8
    while size < points:
        size = size * 3 // 2 if size & (size - 1) == 0 else size * 4 // 3
    return size


def _pad_points(x, y, w):
    """x, y and w with their points (last axis) padded to `padded_points`: copies of the first
    point at weight 0, so that each adds an exact zero to every residual, Jacobian and sum of
    squares (and is finite wherever the first point is)."""
    extra = padded_points(y.shape[-1]) - y.shape[-1]
    if extra == 0:
        return x, y, w
    copies = lambda a: np.concatenate([a, np.repeat(a[..., :1], extra, axis=-1)], axis=-1)
    return copies(x), copies(y), np.concatenate([w, np.zeros(w.shape[:-1] + (extra,))], axis=-1)


def _fit(block, linear, starts, x, y, rows, iterations, tail, w=None, codes=ARITHMETIC_OPCODES, tick=None):
    # the screening (no tail) tracks the linear solve's residual; refits evaluate it afresh
    """`fit_block` over fixed-size blocks of (programs, linear masks, starts); unpadded numpy
    results. x (variables, points), y and w (points; w default 1) are shared by every row, or given
    per row. `tick(rows)` is called after each block with the rows it fitted."""
    w = np.ones(y.shape[-1]) if w is None else w
    w = np.broadcast_to(w, y.shape)
    # The rows in order of their programs' length, so that each block holds programs of about one
    # length and runs only their steps (`first_step`); every row's fit is its own.
    order = np.argsort(_first_steps(block), kind="stable")
    out = []
    for part, count in _blocks(block.shape[0], rows):
        part = order[part]
        data = (x, y, w) if y.ndim == 1 else (_pad(x[part], rows, 1.0), _pad(y[part], rows), _pad(w[part], rows, 1.0))
        result = fit_block(_pad(block[part], rows), _pad(linear[part], rows), _pad(starts[part], rows, 1.0),
                           *_pad_points(*data),
                           iterations, tail, tail > 0, codes=codes, first=first_step(block[part]))
        out.append([np.asarray(r)[:count] for r in result])
        if tick:
            tick(count)
    unsorted = np.empty_like(order)
    unsorted[order] = np.arange(order.size)
    return [np.concatenate(parts)[unsorted] for parts in zip(*out)]


def start_constants(count: int, width: int, x, seed: int = 0) -> np.ndarray:
    """`count` starts for the nonlinear constants, the same for every form (so that a form's fit does
    not depend on what else is searched): values of unit size and of x's size, each constant of a
    start a different one of them; beyond the first eight, uniform in [-2, 2] from `seed`."""
    scale = max(float(np.max(np.abs(x))), 1e-6)
    pool = np.array([1.0, -1.0, -0.5 * scale, 2.0, -0.5, scale, 0.5, -2.0])
    k, j = np.arange(count)[:, None], np.arange(width)[None, :]
    out = pool[(k + 3 * j) % pool.size]
    extra = np.random.default_rng(seed).uniform(-2.0, 2.0, (count, width))
    return np.where(k < pool.size, out, extra)


def linear_masks(forms, width: int) -> np.ndarray:
    """(forms, width): 1 where a constant enters linearly (`grammar.linear_constants`), else 0."""
    out = np.zeros((len(forms), width))
    for i, e in enumerate(forms):
        mask = linear_constants(e)
        out[i, :len(mask)] = mask
    return out


def spanning_subsample(x, size: int) -> np.ndarray:
    """Indices of about `size` points evenly spaced in the order of x (its smallest and largest
    included); for several variables (rows of x), of each variable in turn, together."""
    x = np.asarray(x)
    if x.ndim == 2:
        share = max(size // x.shape[0], 2)
        return np.unique(np.concatenate([spanning_subsample(row, share) for row in x]))
    order = np.argsort(x, kind="stable")
    return np.unique(order[np.round(np.linspace(0, x.size - 1, size)).astype(int)])


def _rows_for(rows: int, points: int, steps: int) -> int:
    """Rows of a block: `rows`, or fewer (a power of two) where the points would overflow BLOCK_VALUES."""
    while rows > 8 and rows * points * steps > BLOCK_VALUES:
        rows //= 2
    return rows


@partial(jax.jit, static_argnames="codes")
def _sse_block(block, c, x, y, w, codes=ARITHMETIC_OPCODES, first=0):
    return jax.vmap(lambda p, c_: _sum_of_squares(p, c_, x, y, w, codes, first))(block, c)


def sums_of_squares(program, constants_, x, y, w=None, codes=ARITHMETIC_OPCODES) -> np.ndarray:
    """The (weighted) sum of squares of each program with its constants on every point, in blocks."""
    w = np.ones(y.shape[-1]) if w is None else w
    x, y, w = _pad_points(x, y, np.asarray(w, dtype=np.float64))
    rows = _rows_for(BLOCK_ROWS, x.shape[-1], program.shape[-1])
    out = []
    for part, count in _blocks(program.shape[0], rows):
        out.append(np.asarray(_sse_block(_pad(program[part], rows), _pad(constants_[part], rows, 1.0), x, y, w,
                                         codes=codes, first=first_step(program[part])))[:count])
    return np.concatenate(out) if out else np.zeros(0)


def _best_per_form(form_of_row, s, forms: int):
    """Index of each form's best row (least sum of squares; -1 for a form with no row)."""
    order = np.lexsort((s, form_of_row))
    leading = np.ones(order.size, bool)
    leading[1:] = form_of_row[order][1:] != form_of_row[order][:-1]
    best = np.full(forms, -1)
    best[form_of_row[order][leading]] = order[leading]
    return best


LOSSES = ("rms", "relative", "max", "max-relative")
CURVED = {"exp", "log", "sqrt", "pow", "sin", "cos"}
FUNCTION_STEPS = 2      # forms with these are screened with FUNCTION_STEPS x the steps
LAWSON_ROUNDS = 8       # reweightings of a minimax refit (Lawson's algorithm), its start ...
SLP_STEPS = 40          # ... and the sequential linear programming steps that finish it


def loss_weights(y, loss: str) -> np.ndarray:
    """The weights of the residuals under `loss`: 1, or 1/|y| for the relative losses (y must not
    be 0 there)."""
    if loss not in LOSSES:
        raise ValueError(f"loss {loss!r}: give one of {', '.join(LOSSES)}")
    if loss.endswith("relative"):
        if np.any(y == 0):
            raise ValueError(f"a relative loss divides by y, and y is 0 at {int(np.sum(y == 0))} point(s)")
        return 1.0 / np.abs(y)
    return np.ones_like(y)


def search(x, y, max_complexity: int, ops="+-*/", starts: int = 2, iterations: int = 7,
           refine: int = 8, polish_starts: int = 4, seed: int = 0, progress=None, forms=None,
           polish_iterations: int = 100, loss: str = "rms", cost=None, codes=None):
    """The exhaustive search: every kept form up to `max_complexity` screened with `iterations`
    steps of the variable-projection fit (`_fit_one`), from one start if all its constants enter
    linearly, else from `starts` starts and, where only one start reached the best (several
    optima), from `SECOND_PASS x starts` more; the best `refine` forms of each complexity then
    refitted to convergence from their screened constants and `polish_starts - 1` other starts. x
    is one variable's points, or (variables, points). `ops`: the operations (`grammar.operations`).

    `loss` ranks the forms: "rms", "relative" (the RMS of the relative error), "max" or
    "max-relative" (the largest absolute or relative error). Every form is fitted by least squares
    (of the relative error for the relative losses); for the max losses the refitted forms are then
    fitted by minimax, by Lawson's iteratively reweighted least squares (LAWSON_ROUNDS rounds, the
    best round kept), the others ranked by the largest error of their least-squares fit. `cost`, a
    cost table (`grammar.read_cost_table`), ranks by its complexity; the forms enumerated are the
    default count's up to `max_complexity`. `codes`: the opcodes to compile for (default the
    forms' own; a superset lets searches over different operations share compiled programs).

    Returns a dict: forms, complexity (under `cost`), rms (per form, of the least-squares fit:
    refitted where refitted; the relative error's for the relative losses), loss (the ranking
    loss), constants, converged (refitted forms: the objective no longer improving), and front
    (indices of the forms on the Pareto front of complexity against loss, by complexity)."""
    watch = rates.Stopwatch()
    x, y = np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64)
    x = x[None] if x.ndim == 1 else x
    forms = enumerate_forms(max_complexity, ops, x.shape[0]) if forms is None else list(forms)
    if not forms:
        raise ValueError(f"no expression of complexity <= {max_complexity} uses only the operations {ops!r}")
    base = loss_weights(y, loss)
    codes = opcodes(forms) if codes is None else tuple(codes)
    size = np.array([complexity(e, cost) for e in forms])
    structure = np.array([complexity(e) for e in forms])
    count = np.array([constants(e) for e in forms])
    if count.max() >= y.size:
        raise ValueError(f"{y.size} points cannot fit forms with up to {count.max()} constants; "
                         f"lower the maximum complexity or give more points")
    program = programs(forms, max(max_complexity, MIN_STEPS))
    width = max(count.max(), MIN_WIDTH)
    linear = linear_masks(forms, width)
    nonlinear_count = count - linear.sum(axis=1).astype(int)
    # forms with a nonlinear constant inside exp, log, sqrt, pow, sin or cos travel farther from the starts
    curved = np.array([bool(operations_of(e) & CURVED) for e in forms]) & (nonlinear_count > 0)
    start = start_constants(8 * starts + polish_starts, width, x, seed)
    # Screening on a subsample that spans x where the points are many (then re-evaluated on all).
    sub = spanning_subsample(x, SCREEN_POINTS) if y.size > SCREEN_POINTS else np.arange(y.size)
    x_s, y_s, w_s = x[:, sub], y[sub], base[sub]
    sum_sq = np.full(len(forms), np.inf)
    fitted = np.ones((len(forms), width))

    def screen(index, first_start, count_, label):
        """Screens the forms `index` from starts first_start .. first_start + count_ - 1 (one start for a form
        whose constants are all linear); keeps each form's best. Says every PROGRESS_SECONDS how far
        it is and how long the rest takes at the rate so far."""
        total = int(np.where(nonlinear_count[index] > 0, count_, 1).sum())
        done, began, said = [0], rates.Stopwatch(), [time.perf_counter()]

        def tick(rows_):
            done[0] += rows_
            now = time.perf_counter()
            if progress and now - said[0] >= PROGRESS_SECONDS and done[0] < total:
                said[0] = now
                seconds, compiling = began.elapsed()
                progress(f"{label}: {done[0]} of {total} fits, about "
                         f"{(seconds - compiling) / done[0] * (total - done[0]):.0f} s left at the rate so far")
        out = []
        small = count[index] <= SMALL_CONSTANTS
        for group, w, steps in ((index[small & ~curved[index]], SMALL_CONSTANTS, iterations),
                                (index[small & curved[index]], SMALL_CONSTANTS, FUNCTION_STEPS * iterations),
                                (index[~small & ~curved[index]], width, iterations),
                                (index[~small & curved[index]], width, FUNCTION_STEPS * iterations)):
            if group.size == 0:
                continue
            repeats = np.where(nonlinear_count[group] > 0, count_, 1)
            rows = np.repeat(group, repeats)
            if rows.size * steps < NARROW_ROW_STEPS:
                w = width           # too few for a program of their own: the full width's
            k = first_start + np.concatenate([np.arange(r) for r in repeats])
            # (data per row, as in the refits, so that the widest screening and the refits share one
            # compiled program)
            c, s, _ = _fit(program[rows], linear[rows, :w], start[k, :w], np.broadcast_to(x_s, (rows.size,) + x_s.shape),
                           np.broadcast_to(y_s, (rows.size,) + y_s.shape), POLISH_ROWS, steps, 0, w_s, codes, tick)
            s = np.where(np.isfinite(s), s, np.inf)
            best = _best_per_form(rows, s, len(forms))[group]
            better = s[best] < sum_sq[group]
            sum_sq[group[better]] = s[best[better]]
            fitted[group[better], :w] = c[best[better], :w]
            out.append((rows, s))
        return np.concatenate([r for r, _ in out]), np.concatenate([s for _, s in out])

    rows, s = screen(np.arange(len(forms)), 0, starts, f"screening {len(forms)} forms")
    # a form whose best was reached from one start only has several optima: more starts
    with np.errstate(over="ignore"):        # (a sum of squares near the largest float64)
        near = s <= sum_sq[rows] * (1 + AGREE) + 1e-300
    agree = np.bincount(rows, near, len(forms)) > 1
    agree |= nonlinear_count == 0
    if progress:
        progress(f"screened {len(forms)} forms" + (f" on {sub.size} of the {y.size} points" if sub.size < y.size else ""))
    if starts > 1 and not agree.all():
        again = np.flatnonzero(~agree)
        screen(again, starts, SECOND_PASS * starts, f"screening {again.size} forms again")
        if progress:
            progress(f"screened {again.size} forms with several optima from {SECOND_PASS * starts} more starts")
    subsampled = sub.size < y.size
    if subsampled:              # every form's screened constants on every point
        sum_sq = sums_of_squares(program, fitted, x, y, base, codes)
        sum_sq = np.where(np.isfinite(sum_sq), sum_sq, np.inf)
    screened = watch.lap()
    chosen = np.concatenate([np.flatnonzero(structure == k)[np.argsort(sum_sq[structure == k], kind="stable")[:refine]]
                             for k in np.unique(structure)])
    rows = np.repeat(chosen, polish_starts)
    c0 = np.tile(start[4 * starts:4 * starts + polish_starts], (chosen.size, 1))
    c0[::polish_starts] = fitted[chosen]
    # Refits: on the subsample where there is one (then each complexity's best once more on every
    # point, below), else on every point.
    # (data given per row, so that this compiled fit also serves `fit_forms`)
    c, s, ok = _fit(program[rows], linear[rows], c0, np.broadcast_to(x_s, (rows.size,) + x_s.shape),
                    np.broadcast_to(y_s, (rows.size,) + y_s.shape), POLISH_ROWS, polish_iterations, 20, w_s, codes)
    s = np.where(np.isfinite(s), s, np.inf)
    best = _best_per_form(rows, s, len(forms))[chosen]
    polished, candidate, done = s[best], c[best], ok[best]
    if subsampled:
        polished = np.where(np.isfinite(polished), sums_of_squares(program[chosen], candidate, x, y, base, codes), np.inf)
    improved = polished <= sum_sq[chosen]
    sum_sq[chosen] = np.where(improved, polished, sum_sq[chosen])
    fitted[chosen] = np.where(improved[:, None], candidate, fitted[chosen])
    converged = {int(i): bool(good and np.isfinite(p)) for i, p, good in zip(chosen, polished, done)}
    if subsampled:
        # Each complexity's best refitted on every point, in small blocks (memory: rows x points).
        tops = np.array([np.flatnonzero(structure == k)[np.argmin(sum_sq[structure == k])] for k in np.unique(structure)])
        c, s, ok = _fit(program[tops], linear[tops], fitted[tops], np.broadcast_to(x, (tops.size,) + x.shape),
                        np.broadcast_to(y, (tops.size,) + y.shape), _rows_for(POLISH_ROWS, y.size, 4 * program.shape[-1]),
                        polish_iterations, 20, base, codes)
        s = np.where(np.isfinite(s), s, np.inf)
        better = s <= sum_sq[tops]
        sum_sq[tops] = np.where(better, s, sum_sq[tops])
        fitted[tops] = np.where(better[:, None], c, fitted[tops])
        converged |= {int(i): bool(good and np.isfinite(v)) for i, v, good in zip(tops, s, ok)}
    rms = np.sqrt(sum_sq / y.size)
    value = rms
    if loss.startswith("max"):
        value = largest_errors(program, fitted, x, y, base, codes)
        fitted[chosen], value[chosen], done = minimax(program[chosen], linear[chosen], fitted[chosen], x, y, base, codes,
                                                      polish_iterations)
        converged |= {int(i): bool(good and np.isfinite(v)) for i, v, good in zip(chosen, value[chosen], done)}
        if progress:
            progress(f"refitted {chosen.size} forms by minimax ({LAWSON_ROUNDS} rounds of Lawson's reweighting)")
    refitted = watch.lap()
    floor = 1e-12 * (np.std(y * base) + np.max(np.abs(y * base)))
    timing = dict(kind=rates.kind(codes, loss), screen_units=screen_units(len(forms), y.size),
                  refit_units=refit_units(np.unique(structure).size, y.size, refine, polish_starts),
                  screen_seconds=screened[0] - screened[1], refit_seconds=refitted[0] - refitted[1],
                  compile_seconds=screened[1] + refitted[1])
    return dict(forms=forms, complexity=size, constant_count=count, rms=rms, loss=value, loss_name=loss,
                constants=fitted, converged=converged, front=pareto_front(size, value, floor),
                width=width, linear_count=count - nonlinear_count, timing=timing)


def screen_units(forms: int, points: int) -> float:
    """Screened form-points of a search of `forms` forms on `points` points (`rates`): every form on the
    screened points (padded), and once on every point where the screening is subsampled."""
    units = forms * padded_points(min(points, SCREEN_POINTS))
    if points > SCREEN_POINTS:
        units += forms * padded_points(points) / 16     # every form once on every point
    return float(units)


def refit_units(complexities: int, points: int, refine: int = 8, polish_starts: int = 4) -> float:
    """Refitted row-points of a search whose forms span `complexities` complexities: the refits of the
    best `refine` forms of each from `polish_starts` starts, in blocks of `search.POLISH_ROWS` rows
    (a block costs its rows whether filled or not), and where the screening was subsampled, each
    complexity's best on every point (one block)."""
    rows = -(-complexities * refine * polish_starts // POLISH_ROWS) * POLISH_ROWS
    units = rows * padded_points(min(points, SCREEN_POINTS))
    if points > SCREEN_POINTS:
        units += _rows_for(POLISH_ROWS, padded_points(points), 48) * padded_points(points)
    return float(units)


def polish_units(models: int, points: int, starts: int = 4) -> float:
    """Polished row-points of pyoperon's `models` (`operon.polished`): from `starts` starts each on
    the points, or beyond SCREEN_POINTS on the subsample, then from one start on every point (rows
    in blocks of `POLISH_ROWS`)."""
    blocks = lambda rows: -(-rows // POLISH_ROWS) * POLISH_ROWS
    if points <= SCREEN_POINTS:
        return float(blocks(starts * models) * padded_points(points))
    return float(blocks(starts * models) * padded_points(SCREEN_POINTS) + blocks(models) * padded_points(points))


@partial(jax.jit, static_argnames="codes")
def _residual_block(block, c, x, y, w, codes=ARITHMETIC_OPCODES, first=0):
    return jax.vmap(lambda p, c_: (evaluate(p, c_, x, codes, first) - y) * w)(block, c)


def weighted_residuals(program, constants_, x, y, w, codes=ARITHMETIC_OPCODES) -> np.ndarray:
    """(value - y) w of each program with its constants at every point, (programs, points)."""
    points = y.size
    x, y, w = _pad_points(x, y, np.broadcast_to(np.asarray(w, dtype=np.float64), y.shape))
    rows = _rows_for(BLOCK_ROWS, x.shape[-1], program.shape[-1])
    out = []
    for part, count in _blocks(program.shape[0], rows):
        out.append(np.asarray(_residual_block(_pad(program[part], rows), _pad(constants_[part], rows, 1.0), x, y, w,
                                              codes=codes, first=first_step(program[part])))[:count, :points])
    return np.concatenate(out) if out else np.zeros((0, points))


def largest_errors(program, constants_, x, y, w, codes=ARITHMETIC_OPCODES) -> np.ndarray:
    """max |value - y| w of each program with its constants (inf where not finite)."""
    r = np.abs(weighted_residuals(program, constants_, x, y, w, codes))
    return np.where(np.all(np.isfinite(r), axis=1), np.max(r, axis=1, initial=0.0), np.inf)


@partial(jax.jit, static_argnames="codes")
def _jacobian_block(block, c, x, y, w, codes=ARITHMETIC_OPCODES, first=0):
    return jax.vmap(lambda p, c_: _residual_and_jacobian(p, c_, x, y, w, codes, first))(block, c)


def minimax(program, linear, c0, x, y, w, codes, iterations: int = 100, block_rows: int | None = None):
    """Minimax fits of the programs from c0: first Lawson's algorithm (LAWSON_ROUNDS weighted
    least-squares fits whose weights, one per point, are multiplied by each point's error after
    every fit: a start near the minimax), then sequential linear programming (each step minimizes
    the largest linearized error max |r + J d| within a trust region |d| <= radius,
    `optics.minimax_lp`; a step is kept where the true largest error falls, the radius doubled, else quartered).
    Returns (constants, largest |value - y| w, converged: the trust region shrank below 1e-12 of
    the constants or a step gained less than 1e-12 relative). `block_rows`: the rows of the compiled
    blocks (default the search's)."""
    from ..optics.minimax_lp import linear_minimax

    rows, points = program.shape[0], y.size
    u = np.full((rows, points), 1.0 / points)
    best_c, best = c0.copy(), largest_errors(program, c0, x, y, w, codes)
    c = c0
    for _ in range(LAWSON_ROUNDS):
        weight = w * np.sqrt(u * points)
        c, _, _ = _fit(program, linear, c, np.broadcast_to(x, (rows,) + x.shape), np.broadcast_to(y, (rows, points)),
                       _rows_for(block_rows or POLISH_ROWS, points, 4 * program.shape[-1]), iterations, 20, weight, codes)
        r = np.abs(weighted_residuals(program, c, x, y, w, codes))
        largest = np.where(np.all(np.isfinite(r), axis=1), np.max(r, axis=1), np.inf)
        better = largest < best
        best_c[better], best[better] = c[better], largest[better]
        r = np.where(np.isfinite(r), r, 0.0)
        u = u * np.maximum(r, 1e-12 * np.max(r, axis=1, keepdims=True) + 1e-300)
        u /= np.sum(u, axis=1, keepdims=True)
    # sequential linear programming from Lawson's best
    width = c0.shape[1]
    radius = 0.1 * (np.abs(best_c) + 1e-3)
    active = np.isfinite(best)
    done = np.zeros(rows, bool)
    x_p, y_p, w_p = _pad_points(x, y, np.broadcast_to(np.asarray(w, dtype=np.float64), y.shape))
    rows_per_block = _rows_for(block_rows or BLOCK_ROWS, y_p.size, program.shape[-1])
    for _ in range(SLP_STEPS):
        index = np.flatnonzero(active & ~done)
        if index.size == 0:
            break
        r, J = [], []
        for part, count in _blocks(index.size, rows_per_block):
            rr, jj, _ = _jacobian_block(_pad(program[index[part]], rows_per_block), _pad(best_c[index[part]], rows_per_block, 1.0),
                                        x_p, y_p, w_p, codes=codes, first=first_step(program[index[part]]))
            r.append(np.asarray(rr)[:count, :points])
            J.append(np.asarray(jj)[:count, :points])
        r, J = np.concatenate(r), np.concatenate(J)
        trials = np.array(best_c[index])
        for k, i in enumerate(index):
            solved = linear_minimax(J[k], r[k], radius[i])
            if solved is not None:
                trials[k] = best_c[i] + solved[1]
        largest = largest_errors(program[index], trials, x, y, w, codes)
        better = largest < best[index]
        gained = better & (best[index] - largest <= 1e-12 * best[index])
        best_c[index[better]], best[index[better]] = trials[better], largest[better]
        radius[index] *= np.where(better, 2.0, 0.25)[:, None]
        done[index] |= gained | np.all(radius[index] <= 1e-12 * (np.abs(best_c[index]) + 1e-12), axis=1)
    return best_c, best, done | ~active


def pareto_front(size, rms, floor: float = 0.0, margin: float = 1e-6) -> list[int]:
    """Indices of the forms that fit better than every form of lower complexity, by more than a
    relative `margin` (so that fitting noise between equivalent forms makes no member); an RMS
    below `floor` (rounding error of an exact fit) counts as `floor`."""
    front, best = [], np.inf
    rms = np.maximum(rms, floor)
    for k in np.unique(size):
        index = np.flatnonzero(size == k)
        i = index[np.argmin(rms[index])]
        if rms[i] < best * (1.0 - margin):
            front.append(int(i))
            best = rms[i]
    return front


def fit_forms(forms, x, y, starts: int = 8, seed: int = 0, steps: int = MIN_STEPS, width: int = MIN_WIDTH,
              iterations: int = 200, initial=None, loss: str = "rms", codes=None, block_rows: int | None = None):
    """(constants, rms, converged) of each given form, by the same fit as the front's refits (programs
    of `steps` steps and `width` constants, so that the search's compiled fit serves), from
    `starts` starts. y is one sample's points, x its variable's points or (variables, points); with
    y of shape (samples, points) and x (samples, points) or (samples, variables, points), every
    form is fitted on every sample in one batch and the result is a list per sample. `initial`
    (one array of constants per form) replaces each form's first start. With `loss` other than
    "rms" (one sample only), the second value is that loss (`search`), the fit the same as there.
    `codes`: the opcodes to compile the fit for (default the forms' own; a superset lets calls on
    different forms share one compiled program). `block_rows`: the rows of its compiled blocks (by
    default the search's, whose compiled fit then serves; many calls of a few fits each, or a few
    fits on many points, run faster in a smaller block of their own)."""
    x, y = np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64)
    if loss != "rms":
        return _fit_forms_for_loss(forms, x, y, starts, seed, iterations, initial, loss, block_rows, codes)
    if y.ndim == 1:
        return fit_forms(forms, x[None], y[None], starts, seed, steps, width, iterations, initial, codes=codes,
                         block_rows=block_rows)[0]
    x = x[:, None] if x.ndim == 2 else x
    steps = max([steps, MIN_STEPS] + [complexity(e) for e in forms])
    width = max([width, MIN_WIDTH] + [constants(e) for e in forms])
    samples, per_sample = y.shape[0], len(forms) * starts
    block = np.tile(np.repeat(programs(forms, steps), starts, axis=0), (samples, 1, 1))
    linear = np.tile(np.repeat(linear_masks(forms, width), starts, axis=0), (samples, 1))
    c0 = np.tile(start_constants(starts, width, x, seed), (samples * len(forms), 1))
    if initial is not None:
        given = np.ones((len(forms), width))
        for i, values in enumerate(initial):
            given[i, :len(values)] = values
        c0.reshape(samples, len(forms), starts, width)[:, :, 0] = given
    rows_x, rows_y = np.repeat(x, per_sample, axis=0), np.repeat(y, per_sample, axis=0)
    c, s, ok = _fit(block, linear, c0, rows_x, rows_y, _rows_for(block_rows or POLISH_ROWS, y.shape[1], 4 * steps),
                    iterations, 20, codes=opcodes(forms) if codes is None else tuple(codes))
    s = np.where(np.isfinite(s), s, np.inf).reshape(samples, len(forms), starts)
    c, ok = c.reshape(samples, len(forms), starts, width), ok.reshape(samples, len(forms), starts)
    out = []
    for j in range(samples):
        row = []
        for i, e in enumerate(forms):
            best = int(np.argmin(s[j, i]))
            row.append((c[j, i, best, :constants(e)], float(np.sqrt(s[j, i, best] / y.shape[1])),
                        bool(np.isfinite(s[j, i, best]) and ok[j, i, best])))
        out.append(row)
    return out


def _fit_forms_for_loss(forms, x, y, starts, seed, iterations, initial, loss, block_rows=None, codes=None):
    """`fit_forms` of one sample under a loss other than "rms": least squares of the weighted
    residuals from every start (the best kept), then minimax (`minimax`) for the max losses."""
    base = loss_weights(y, loss)
    x = x[None] if x.ndim == 1 else x
    width = max([MIN_WIDTH] + [constants(e) for e in forms])
    steps = max([MIN_STEPS] + [complexity(e) for e in forms])
    program, linear = programs(forms, steps), linear_masks(forms, width)
    codes = opcodes(forms) if codes is None else tuple(codes)
    c0 = np.tile(start_constants(starts, width, x, seed), (len(forms), 1))
    if initial is not None:
        for i, values in enumerate(initial):
            c0[i * starts, :len(values)] = values
    rows = np.repeat(np.arange(len(forms)), starts)
    c, s, ok = _fit(program[rows], linear[rows], c0, np.broadcast_to(x, (rows.size,) + x.shape),
                    np.broadcast_to(y, (rows.size, y.size)), _rows_for(block_rows or POLISH_ROWS, y.size, 4 * steps),
                    iterations, 20, base, codes)
    best = _best_per_form(rows, np.where(np.isfinite(s), s, np.inf), len(forms))
    c, value, ok = c[best], np.sqrt(s[best] / y.size), ok[best]
    if loss.startswith("max"):
        c, value, ok = minimax(program, linear, c, x, y, base, codes, iterations, block_rows)
    return [(c[i, :constants(e)], float(value[i]), bool(np.isfinite(value[i]) and ok[i])) for i, e in enumerate(forms)]
