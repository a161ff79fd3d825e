"""Exhaustive symbolic regression in one variable (the method of Bartlett et al. 2022).

Every distinct expression of `pipeline.symbolic.grammar` (fitted constants, the variable, +, -, *, /)
is enumerated up to a complexity; the constants of each are fitted by least squares, and the
Pareto front of complexity against RMS error is read off. The front is complete under the stated
complexity measure: no expression of the grammar at or below a complexity fits better than the
front's member there, up to the constant fitting, which is local and restarted (the tests run the
same search over every tree of the grammar, unreduced, as an oracle).

Fitting runs every register program of a block at once (vmapped), on fixed block shapes, so that
a search compiles three XLA programs whatever its size: a cheap fixed-step Levenberg-Marquardt
screens every form, and optimistix's Levenberg-Marquardt refits the best of each complexity to
convergence.

Any number of points, in bounded memory: beyond `SCREEN_POINTS` points the screening runs on a
subsample that spans x (evenly spaced in x's order), the refits run on every point, and every
other form's screened constants are evaluated on every point; the rows of a block shrink as the
points grow (`_rows_for`), so that no block holds more than about `BLOCK_VALUES` values.
"""

from __future__ import annotations

import numpy as np

from .grammar import (ADD, CONST, COST, DIV, MUL, SUB, VAR, C, X, canonical, complexity, constants,  # noqa: F401
                          enumerate_forms, evaluate_numpy, parse, programs, show, to_sympy)
from ..optics.numerics import jax
import jax.numpy as jnp  # noqa: E402
import optimistix as optx  # noqa: E402

# Screening and polishing run on fixed block shapes, so that a search compiles a handful of
# programs whatever its size: rows per block, and the constant counts forms are padded to.
BLOCK_ROWS = 1024
POLISH_ROWS = 256
SMALL_CONSTANTS = 2
MIN_STEPS = 12      # programs are at least this long ...
MIN_WIDTH = 5       # ... and fits have at least this many constants: searches up to 12 share shapes
SCREEN_POINTS = 256     # screening subsample beyond this many points
BLOCK_VALUES = 2**22    # rows x points x program steps of one block, at most (about)


def evaluate(program, c, x):
    """Value at the points x of one register program with constants c."""
    op, left, right, index = program

    def step(i, registers):
        a, b = registers[left[i]], registers[right[i]]
        value = jnp.select([op[i] == VAR, op[i] == CONST, op[i] == ADD, op[i] == SUB, op[i] == MUL, op[i] == DIV],
                           [x, jnp.broadcast_to(c[index[i]], x.shape), a + b, a - b, a * b, a / b], 0.0)
        return registers.at[i].set(value)

    return jax.lax.fori_loop(0, op.shape[0], step, jnp.zeros((op.shape[0], x.shape[0])))[-1]


def _sum_of_squares(program, c, x, y):
    r = evaluate(program, c, x) - y
    s = jnp.sum(r * r)
    return jnp.where(jnp.isfinite(s), s, jnp.inf)


def _screen_one(program, c0, x, y, iterations):
    """A fixed number of Levenberg-Marquardt steps (Marquardt's diagonal scaling; a step is kept
    only if it lowers the sum of squares). Cheap and vectorizable: used to rank every form."""
    residual = lambda c: evaluate(program, c, x) - y

    def step(_, state):
        c, damping, current = state
        r, J = residual(c), jax.jacfwd(residual)(c)
        finite = jnp.all(jnp.isfinite(r)) & jnp.all(jnp.isfinite(J))
        r, J = jnp.where(finite, r, 0.0), jnp.where(finite, J, 0.0)
        H, g = J.T @ J, J.T @ r
        d = jnp.diag(H)
        regularized = H + damping * jnp.diag(d) + 1e-12 * (jnp.max(d) + 1.0) * jnp.eye(c.shape[0])
        trial = c - jnp.linalg.solve(regularized, g)
        trial_cost = _sum_of_squares(program, trial, x, y)
        better = trial_cost < current
        return (jnp.where(better, trial, c), jnp.where(better, damping / 3.0, damping * 4.0),
                jnp.where(better, trial_cost, current))

    c, _, s = jax.lax.fori_loop(0, iterations, step, (c0, jnp.asarray(1e-3), _sum_of_squares(program, c0, x, y)))
    return c, s


@jax.jit
def screen_block(block, c0, x, y, iterations):
    """(constants, sum of squares) of each program of `block` (rows, 4, steps) from c0 (rows, P)."""
    return jax.vmap(lambda p, c: _screen_one(p, c, x, y, iterations))(block, c0)


_LM = optx.LevenbergMarquardt(rtol=1e-10, atol=1e-12)


def _residual(c, args):
    program, x, y = args
    r = evaluate(program, c, x) - y
    return jnp.where(jnp.isfinite(r), r, 1e150)


@jax.jit
def polish_block(block, c0, x, y):
    """optimistix Levenberg-Marquardt from c0, each row on its own data x, y (rows, points):
    (constants, sum of squares, converged)."""
    def one(program, start, x_, y_):
        sol = optx.least_squares(_residual, _LM, start, args=(program, x_, y_), max_steps=200, throw=False)
        return sol.value, _sum_of_squares(program, sol.value, x_, y_), sol.result == optx.RESULTS.successful
    return jax.vmap(one)(block, c0, x, y)


def _blocks(rows: int, size: int):
    for start in range(0, rows, size):
        yield slice(start, min(start + size, rows)), min(start + size, rows) - start


def _pad(a, rows, value=0):
    return np.pad(a, [(0, rows - a.shape[0])] + [(0, 0)] * (a.ndim - 1), constant_values=value)


def _run(function, block, starts, x, y, rows, *extra):
    """`function` over fixed-size blocks of (programs, starts); unpadded numpy results. x and y are
    shared by every row (1-D) or given per row (2-D)."""
    out = []
    for part, count in _blocks(block.shape[0], rows):
        data = (x, y) if x.ndim == 1 else (_pad(x[part], rows, 1.0), _pad(y[part], rows))
        result = function(_pad(block[part], rows), _pad(starts[part], rows, 1.0), *data, *extra)
        out.append([np.asarray(r)[:count] for r in result])
    return [np.concatenate(parts) for parts in zip(*out)]


def spanning_subsample(x, size: int) -> np.ndarray:
    """Indices of `size` points evenly spaced in the order of x (its smallest and largest included)."""
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
    rows = _rows_for(BLOCK_ROWS, x.size, program.shape[-1])
    out = []
    for part, count in _blocks(program.shape[0], rows):
        out.append(np.asarray(_sse_block(_pad(program[part], rows), _pad(constants_[part], rows, 1.0), x, y))[:count])
    return np.concatenate(out) if out else np.zeros(0)


def search(x, y, max_complexity: int, ops: str = "+-*/", starts: int = 1, iterations: int = 20,
           refine: int = 8, polish_starts: int = 4, seed: int = 0, progress=None, forms=None):
    """The exhaustive search: every kept form up to `max_complexity` screened from `starts` random
    starts with `iterations` cheap steps; the best `refine` forms of each complexity then polished
    with optimistix from their screened constants and `polish_starts - 1` fresh starts.

    Returns a dict: forms, complexity, rms (per form: polished where polished), constants
    (polished forms only, by form index), converged (polished forms), and front (indices of the
    forms on the Pareto front of complexity against RMS, by complexity)."""
    x, y = np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64)
    forms = enumerate_forms(max_complexity, ops) if forms is None else list(forms)
    if not forms:
        raise ValueError(f"no expression of complexity <= {max_complexity} uses only the operations {ops!r}")
    size = np.array([complexity(e) for e in forms])
    count = np.array([constants(e) for e in forms])
    if count.max() >= x.size:
        raise ValueError(f"{x.size} points cannot fit forms with up to {count.max()} constants; "
                         f"lower the maximum complexity or give more points")
    program = programs(forms, max(max_complexity, MIN_STEPS))
    rng = np.random.default_rng(seed)
    # Screening on a subsample that spans x where the points are many (then re-evaluated on all).
    sub = spanning_subsample(x, SCREEN_POINTS) if x.size > SCREEN_POINTS else np.arange(x.size)
    x_s, y_s = x[sub], y[sub]
    sum_sq = np.full(len(forms), np.inf)
    fitted = np.zeros((len(forms), max(count.max(), MIN_WIDTH)))
    groups = [(count <= SMALL_CONSTANTS, SMALL_CONSTANTS), (count > SMALL_CONSTANTS, fitted.shape[1])]
    for mask, width in groups:
        index = np.flatnonzero(mask)
        if index.size == 0:
            continue
        rows = np.repeat(index, starts)
        c0 = rng.uniform(-2.0, 2.0, (rows.size, width))
        c, s = _run(screen_block, program[rows], c0, x_s, y_s, BLOCK_ROWS, iterations)
        s = np.where(np.isfinite(s), s, np.inf).reshape(index.size, starts)
        best = np.argmin(s, axis=1)
        sum_sq[index] = s[np.arange(index.size), best]
        fitted[index, :width] = c.reshape(index.size, starts, width)[np.arange(index.size), best]
        if progress:
            progress(f"screened {index.size} forms with <= {width} constants"
                     + (f" on {sub.size} of the {x.size} points" if sub.size < x.size else ""))
    subsampled = sub.size < x.size
    if subsampled:              # every form's screened constants on every point
        sum_sq = sums_of_squares(program, fitted, x, y)
        sum_sq = np.where(np.isfinite(sum_sq), sum_sq, np.inf)
    chosen = np.concatenate([np.flatnonzero(size == k)[np.argsort(sum_sq[size == k], kind="stable")[:refine]]
                             for k in np.unique(size)])
    rows = np.repeat(chosen, polish_starts)
    c0 = rng.uniform(-2.0, 2.0, (rows.size, fitted.shape[1]))
    c0[::polish_starts] = fitted[chosen]
    # Refits: on the subsample where there is one (then each complexity's best once more on every
    # point, below), else on every point.
    c, s, ok = _run(polish_block, program[rows], c0, np.tile(x_s, (rows.size, 1)), np.tile(y_s, (rows.size, 1)),
                    POLISH_ROWS)
    s = np.where(np.isfinite(s) & ok, s, np.inf).reshape(chosen.size, polish_starts)
    best = np.argmin(s, axis=1)
    polished = s[np.arange(chosen.size), best]
    candidate = c.reshape(chosen.size, polish_starts, -1)[np.arange(chosen.size), best]
    if subsampled:
        polished = np.where(np.isfinite(polished), sums_of_squares(program[chosen], candidate, x, y), np.inf)
    improved = polished <= sum_sq[chosen]
    sum_sq[chosen] = np.where(improved, polished, sum_sq[chosen])
    fitted[chosen] = np.where(improved[:, None], candidate, fitted[chosen])
    converged = {int(i): bool(np.isfinite(p)) for i, p in zip(chosen, polished)}
    if subsampled:
        # Each complexity's best refitted on every point, in small blocks (memory: rows x points).
        tops = np.array([np.flatnonzero(size == k)[np.argmin(sum_sq[size == k])] for k in np.unique(size)])
        c, s, ok = _run(polish_block, program[tops], fitted[tops], np.tile(x, (tops.size, 1)),
                        np.tile(y, (tops.size, 1)), _rows_for(POLISH_ROWS, x.size, 4 * program.shape[-1]))
        s = np.where(np.isfinite(s) & ok, s, np.inf)
        better = s <= sum_sq[tops]
        sum_sq[tops] = np.where(better, s, sum_sq[tops])
        fitted[tops] = np.where(better[:, None], c, fitted[tops])
        converged |= {int(i): bool(good) or converged.get(int(i), False) for i, good in zip(tops, np.isfinite(s))}
    rms = np.sqrt(sum_sq / x.size)
    return dict(forms=forms, complexity=size, constant_count=count, rms=rms, constants=fitted,
                converged=converged, front=pareto_front(size, rms, 1e-12 * (np.std(y) + np.max(np.abs(y)))),
                width=fitted.shape[1])


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


def fit_forms(forms, x, y, starts: int = 8, seed: int = 0, steps: int = MIN_STEPS, width: int = MIN_WIDTH):
    """(constants, rms, converged) of each given form, by the same optimistix fit as the front's
    (programs of `steps` steps and `width` constants, so that the search's compiled fit serves).
    With x and y of shape (samples, points), every form is fitted on every sample in one batch and
    the result is a list per sample."""
    x, y = np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64)
    if x.ndim == 1:
        return fit_forms(forms, x[None], y[None], starts, seed, steps, width)[0]
    steps = max([steps, MIN_STEPS] + [complexity(e) for e in forms])
    width = max([width, MIN_WIDTH] + [constants(e) for e in forms])
    samples, per_sample = x.shape[0], len(forms) * starts
    block = np.tile(np.repeat(programs(forms, steps), starts, axis=0), (samples, 1, 1))
    c0 = np.tile(np.random.default_rng(seed).uniform(-2.0, 2.0, (per_sample, width)), (samples, 1))
    rows_x, rows_y = np.repeat(x, per_sample, axis=0), np.repeat(y, per_sample, axis=0)
    c, s, ok = _run(polish_block, block, c0, rows_x, rows_y, POLISH_ROWS)
    s = np.where(np.isfinite(s) & ok, s, np.inf).reshape(samples, len(forms), starts)
    c = c.reshape(samples, len(forms), starts, width)
    out = []
    for j in range(samples):
        row = []
        for i, e in enumerate(forms):
            best = int(np.argmin(s[j, i]))
            row.append((c[j, i, best, :constants(e)], float(np.sqrt(s[j, i, best] / x.shape[1])),
                        bool(np.isfinite(s[j, i, best]))))
        out.append(row)
    return out


