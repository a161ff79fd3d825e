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
a search compiles three XLA programs whatever its size.

Any number of points, in bounded memory: beyond `SCREEN_POINTS` points the screening runs on a
subsample that spans x (evenly spaced in the order of each variable), every form's screened
constants are evaluated on every point, the refits run on the subsample and the best of each
complexity once more on every point; the rows of a block shrink as the points grow (`_rows_for`),
so that no block holds more than about `BLOCK_VALUES` values.
"""

from __future__ import annotations

import numpy as np

from .grammar import (ADD, CONST, COST, DIV, MUL, SUB, VAR, C, X, canonical, complexity, constants,  # noqa: F401
                      enumerate_forms, evaluate_numpy, linear_constants, parse, programs, show, to_sympy)
from ..optics.numerics import jax
import jax.numpy as jnp  # noqa: E402

# Screening and polishing run on fixed block shapes, so that a search compiles a handful of
# programs whatever its size: rows per block (of the fits, and of the evaluation on every point),
# and the constant counts forms are padded to.
POLISH_ROWS = 256
BLOCK_ROWS = 1024
SMALL_CONSTANTS = 2     # forms with at most this many constants are screened in narrower blocks
MIN_STEPS = 12      # programs are at least this long ...
MIN_WIDTH = 5       # ... and fits have at least this many constants: searches up to 12 share shapes
AGREE = 1e-3            # starts within this relative sum of squares of the best reached the same optimum;
SECOND_PASS = 2         # where only one did, SECOND_PASS x starts more starts
SCREEN_POINTS = 64      # screening subsample beyond this many points
BLOCK_VALUES = 2**22    # rows x points x program steps of one block, at most (about)


def evaluate(program, c, x):
    """Value at the points of one register program with constants c; x is (variables, points)."""
    op, left, right, index = program

    def step(i, registers):
        a, b = registers[left[i]], registers[right[i]]
        value = jnp.select([op[i] == VAR, op[i] == CONST, op[i] == ADD, op[i] == SUB, op[i] == MUL, op[i] == DIV],
                           [x[index[i]], jnp.broadcast_to(c[index[i]], x.shape[1:]), a + b, a - b, a * b, a / b], 0.0)
        return registers.at[i].set(value)

    return jax.lax.fori_loop(0, op.shape[0], step, jnp.zeros((op.shape[0],) + x.shape[1:]))[-1]


def _sum_of_squares(program, c, x, y):
    r = evaluate(program, c, x) - y
    s = jnp.sum(r * r)
    return jnp.where(jnp.isfinite(s), s, jnp.inf)


def _solve(H, g):
    """H^-1 g for a symmetric positive semi-definite H, scaled to a unit diagonal first (Jacobi), so
    that constants of very different scales (1/x against x = 1000) are solved alike."""
    d = jnp.sqrt(jnp.maximum(jnp.diag(H), 1e-300))
    scaled = H / d[:, None] / d[None, :] + 1e-13 * jnp.eye(H.shape[0])
    return jnp.linalg.solve(scaled, g / d) / d


def _residual_and_jacobian(program, c, x, y):
    r = lambda c_: evaluate(program, c_, x) - y
    J, value = jax.jacfwd(lambda c_: (r(c_), r(c_)), has_aux=True)(c)
    finite = jnp.all(jnp.isfinite(value)) & jnp.all(jnp.isfinite(J))
    return jnp.where(finite, value, 0.0), jnp.where(finite, J, 0.0), finite


def _project(program, linear, c, x, y, refine):
    """The constants that enter linearly (`linear`, a 0/1 mask) solved exactly for the others
    (variable projection: a Gauss-Newton step is exact, the expression being affine in them, and a
    second one from the residual evaluated afresh, where `refine`, removes the rounding of the
    first, large where the start was far); returns (constants, residual after, Jacobian, sum of squares after)."""
    r, J, finite = _residual_and_jacobian(program, c, x, y)
    Jl = J * linear
    G = Jl.T @ Jl + jnp.diag(1.0 - linear)
    step = -_solve(G, Jl.T @ r) * linear
    # (refine: an unbatched flag, so that under vmap the screening skips the second evaluation)
    c, r, step = jax.lax.cond(refine, lambda: (c + step, evaluate(program, c + step, x) - y, step),
                              lambda: (c, r, step))
    step = jax.lax.cond(refine, lambda: -_solve(G, Jl.T @ r) * linear, lambda: step)
    r = r + Jl @ step
    s = jnp.where(finite, jnp.sum(r * r), jnp.inf)
    return c + step, r, J, jnp.where(jnp.isfinite(s), s, jnp.inf)


def _fit_one(program, linear, c0, x, y, iterations, tail, refine):
    """Levenberg-Marquardt on the nonlinear constants with the linear ones projected out (Kaufman's
    variable projection: the joint Gauss-Newton system, damped on the nonlinear constants only,
    then the linear constants solved exactly at the trial point); a step is kept only if it lowers
    the sum of squares. With `tail` = 0 (the screening), `iterations` steps. Else at most
    `iterations`, stopping once `tail` steps in a row have not lowered the sum of squares by more
    than 1e-9 relative: converged (the objective is judged, not the constants, so that a
    degenerate optimum, a double pole say, is kept). Returns (constants, sum of squares,
    converged)."""
    nonlinear = 1.0 - linear

    def step(state):
        i, c, damping, r, J, current, reference, since = state
        H, g = J.T @ J, J.T @ r
        d = jnp.diag(H) * nonlinear
        trial = c - _solve(H + damping * jnp.diag(d) + 1e-12 * (jnp.max(d) + 1.0) * jnp.diag(nonlinear), g) * nonlinear
        trial, r_t, J_t, cost = _project(program, linear, trial, x, y, refine)
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


@jax.jit
def fit_block(block, linear, c0, x, y, iterations, tail, refine):
    """(constants, sum of squares, converged) of each program of `block` (rows, 4, steps), its linear
    constants `linear` (rows, P) projected out, from c0 (rows, P); x (variables, points) and y
    (points) shared by every row, or given per row (rows, variables, points) and (rows, points)."""
    if y.ndim == 1:
        return jax.vmap(lambda p, m, c: _fit_one(p, m, c, x, y, iterations, tail, refine))(block, linear, c0)
    return jax.vmap(lambda p, m, c, x_, y_: _fit_one(p, m, c, x_, y_, iterations, tail, refine))(block, linear, c0,
                                                                                                 x, y)


def _blocks(rows: int, size: int):
    for start in range(0, rows, size):
        yield slice(start, min(start + size, rows)), min(start + size, rows) - start


def _pad(a, rows, value=0):
    return np.pad(a, [(0, rows - a.shape[0])] + [(0, 0)] * (a.ndim - 1), constant_values=value)


def _fit(block, linear, starts, x, y, rows, iterations, tail):
    # the screening (no tail) tracks the linear solve's residual; refits evaluate it afresh
    """`fit_block` over fixed-size blocks of (programs, linear masks, starts); unpadded numpy
    results. x (variables, points) and y (points) are shared by every row, or given per row."""
    out = []
    for part, count in _blocks(block.shape[0], rows):
        data = (x, y) if y.ndim == 1 else (_pad(x[part], rows, 1.0), _pad(y[part], rows))
        result = fit_block(_pad(block[part], rows), _pad(linear[part], rows), _pad(starts[part], rows, 1.0), *data,
                           iterations, tail, tail > 0)
        out.append([np.asarray(r)[:count] for r in result])
    return [np.concatenate(parts) for parts in zip(*out)]


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


@jax.jit
def _sse_block(block, c, x, y):
    return jax.vmap(lambda p, c_: _sum_of_squares(p, c_, x, y))(block, c)


def sums_of_squares(program, constants_, x, y) -> np.ndarray:
    """The sum of squares of each program with its constants on every point, in blocks."""
    rows = _rows_for(BLOCK_ROWS, x.shape[-1], program.shape[-1])
    out = []
    for part, count in _blocks(program.shape[0], rows):
        out.append(np.asarray(_sse_block(_pad(program[part], rows), _pad(constants_[part], rows, 1.0), x, y))[:count])
    return np.concatenate(out) if out else np.zeros(0)


def _best_per_form(form_of_row, s, forms: int):
    """Index of each form's best row (least sum of squares; -1 for a form with no row)."""
    order = np.lexsort((s, form_of_row))
    first = np.ones(order.size, bool)
    first[1:] = form_of_row[order][1:] != form_of_row[order][:-1]
    best = np.full(forms, -1)
    best[form_of_row[order][first]] = order[first]
    return best


def search(x, y, max_complexity: int, ops: str = "+-*/", starts: int = 2, iterations: int = 7,
           refine: int = 8, polish_starts: int = 4, seed: int = 0, progress=None, forms=None,
           polish_iterations: int = 100):
    """The exhaustive search: every kept form up to `max_complexity` screened with `iterations`
    steps of the variable-projection fit (`_fit_one`), from one start if all its constants enter
    linearly, else from `starts` starts and, where only one start reached the best (several
    optima), from `SECOND_PASS x starts` more; the best `refine` forms of each complexity then
    refitted to convergence from their screened constants and `polish_starts - 1` other starts. x
    is one variable's points, or (variables, points).

    Returns a dict: forms, complexity, rms (per form: refitted where refitted), constants,
    converged (refitted forms: the objective no longer improving), and front (indices of the forms
    on the Pareto front of complexity against RMS, by complexity)."""
    x, y = np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64)
    x = x[None] if x.ndim == 1 else x
    forms = enumerate_forms(max_complexity, ops, x.shape[0]) if forms is None else list(forms)
    if not forms:
        raise ValueError(f"no expression of complexity <= {max_complexity} uses only the operations {ops!r}")
    size = np.array([complexity(e) for e in forms])
    count = np.array([constants(e) for e in forms])
    if count.max() >= y.size:
        raise ValueError(f"{y.size} points cannot fit forms with up to {count.max()} constants; "
                         f"lower the maximum complexity or give more points")
    program = programs(forms, max(max_complexity, MIN_STEPS))
    width = max(count.max(), MIN_WIDTH)
    linear = linear_masks(forms, width)
    nonlinear_count = count - linear.sum(axis=1).astype(int)
    start = start_constants(8 * starts + polish_starts, width, x, seed)
    # Screening on a subsample that spans x where the points are many (then re-evaluated on all).
    sub = spanning_subsample(x, SCREEN_POINTS) if y.size > SCREEN_POINTS else np.arange(y.size)
    x_s, y_s = x[:, sub], y[sub]
    sum_sq = np.full(len(forms), np.inf)
    fitted = np.ones((len(forms), width))

    def screen(index, first, count_):
        """Screens the forms `index` from starts first .. first + count_ - 1 (one start for a form
        whose constants are all linear); keeps each form's best."""
        out = []
        for group, w in ((index[count[index] <= SMALL_CONSTANTS], SMALL_CONSTANTS),
                         (index[count[index] > SMALL_CONSTANTS], width)):
            if group.size == 0:
                continue
            repeats = np.where(nonlinear_count[group] > 0, count_, 1)
            rows = np.repeat(group, repeats)
            k = first + np.concatenate([np.arange(r) for r in repeats])
            # (data per row, as in the refits, so that the widest screening and the refits share one
            # compiled program)
            c, s, _ = _fit(program[rows], linear[rows, :w], start[k, :w], np.broadcast_to(x_s, (rows.size,) + x_s.shape),
                           np.broadcast_to(y_s, (rows.size,) + y_s.shape), POLISH_ROWS, iterations, 0)
            s = np.where(np.isfinite(s), s, np.inf)
            best = _best_per_form(rows, s, len(forms))[group]
            better = s[best] < sum_sq[group]
            sum_sq[group[better]] = s[best[better]]
            fitted[group[better], :w] = c[best[better], :w]
            out.append((rows, s))
        return np.concatenate([r for r, _ in out]), np.concatenate([s for _, s in out])

    rows, s = screen(np.arange(len(forms)), 0, starts)
    # a form whose best was reached from one start only has several optima: more starts
    near = s <= sum_sq[rows] * (1 + AGREE) + 1e-300
    agree = np.bincount(rows, near, len(forms)) > 1
    agree |= nonlinear_count == 0
    if progress:
        progress(f"screened {len(forms)} forms" + (f" on {sub.size} of the {y.size} points" if sub.size < y.size else ""))
    if starts > 1 and not agree.all():
        again = np.flatnonzero(~agree)
        screen(again, starts, SECOND_PASS * starts)
        if progress:
            progress(f"screened {again.size} forms with several optima from {SECOND_PASS * starts} more starts")
    subsampled = sub.size < y.size
    if subsampled:              # every form's screened constants on every point
        sum_sq = sums_of_squares(program, fitted, x, y)
        sum_sq = np.where(np.isfinite(sum_sq), sum_sq, np.inf)
    chosen = np.concatenate([np.flatnonzero(size == k)[np.argsort(sum_sq[size == k], kind="stable")[:refine]]
                             for k in np.unique(size)])
    rows = np.repeat(chosen, polish_starts)
    c0 = np.tile(start[4 * starts:4 * starts + polish_starts], (chosen.size, 1))
    c0[::polish_starts] = fitted[chosen]
    # Refits: on the subsample where there is one (then each complexity's best once more on every
    # point, below), else on every point.
    # (data given per row, so that this compiled fit also serves `fit_forms`)
    c, s, ok = _fit(program[rows], linear[rows], c0, np.broadcast_to(x_s, (rows.size,) + x_s.shape),
                    np.broadcast_to(y_s, (rows.size,) + y_s.shape), POLISH_ROWS, polish_iterations, 20)
    s = np.where(np.isfinite(s), s, np.inf)
    best = _best_per_form(rows, s, len(forms))[chosen]
    polished, candidate, done = s[best], c[best], ok[best]
    if subsampled:
        polished = np.where(np.isfinite(polished), sums_of_squares(program[chosen], candidate, x, y), np.inf)
    improved = polished <= sum_sq[chosen]
    sum_sq[chosen] = np.where(improved, polished, sum_sq[chosen])
    fitted[chosen] = np.where(improved[:, None], candidate, fitted[chosen])
    converged = {int(i): bool(good and np.isfinite(p)) for i, p, good in zip(chosen, polished, done)}
    if subsampled:
        # Each complexity's best refitted on every point, in small blocks (memory: rows x points).
        tops = np.array([np.flatnonzero(size == k)[np.argmin(sum_sq[size == k])] for k in np.unique(size)])
        c, s, ok = _fit(program[tops], linear[tops], fitted[tops], np.broadcast_to(x, (tops.size,) + x.shape),
                        np.broadcast_to(y, (tops.size,) + y.shape), _rows_for(POLISH_ROWS, y.size, 4 * program.shape[-1]),
                        polish_iterations, 20)
        s = np.where(np.isfinite(s), s, np.inf)
        better = s <= sum_sq[tops]
        sum_sq[tops] = np.where(better, s, sum_sq[tops])
        fitted[tops] = np.where(better[:, None], c, fitted[tops])
        converged |= {int(i): bool(good and np.isfinite(v)) for i, v, good in zip(tops, s, ok)}
    rms = np.sqrt(sum_sq / y.size)
    return dict(forms=forms, complexity=size, constant_count=count, rms=rms, constants=fitted,
                converged=converged, front=pareto_front(size, rms, 1e-12 * (np.std(y) + np.max(np.abs(y)))),
                width=width, linear_count=count - nonlinear_count)


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
              iterations: int = 200, initial=None):
    """(constants, rms, converged) of each given form, by the same fit as the front's refits (programs
    of `steps` steps and `width` constants, so that the search's compiled fit serves), from
    `starts` starts. y is one sample's points, x its variable's points or (variables, points); with
    y of shape (samples, points) and x (samples, points) or (samples, variables, points), every
    form is fitted on every sample in one batch and the result is a list per sample. `initial`
    (one array of constants per form) replaces each form's first start."""
    x, y = np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64)
    if y.ndim == 1:
        return fit_forms(forms, x[None], y[None], starts, seed, steps, width, iterations, initial)[0]
    x = x[:, None] if x.ndim == 2 else x
    steps = max([steps, MIN_STEPS] + [complexity(e) for e in forms])
    width = max([width, MIN_WIDTH] + [constants(e) for e in forms])
    samples, per_sample = y.shape[0], len(forms) * starts
    block = np.tile(np.repeat(programs(forms, steps), starts, axis=0), (samples, 1, 1))
    linear = np.tile(np.repeat(linear_masks(forms, width), starts, axis=0), (samples, 1))
    c0 = np.tile(start_constants(starts, width, x, seed), (samples * len(forms), 1))
    if initial is not None:
        first = np.ones((len(forms), width))
        for i, values in enumerate(initial):
            first[i, :len(values)] = values
        c0.reshape(samples, len(forms), starts, width)[:, :, 0] = first
    rows_x, rows_y = np.repeat(x, per_sample, axis=0), np.repeat(y, per_sample, axis=0)
    c, s, ok = _fit(block, linear, c0, rows_x, rows_y, _rows_for(POLISH_ROWS, y.shape[1], 4 * steps), iterations, 20)
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
