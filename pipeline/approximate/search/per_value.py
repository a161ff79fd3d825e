"""A template's constants fitted by minimax at each value of the parameter (`fit_per_value`, the
parametric engine's step 2): its per-value optimum, which no formula of the parameter beats; the
fitting stops at the first value whose optimum is already no better than a bound (`Dropped`)."""

from __future__ import annotations

import dataclasses

import numpy as np

from . import minimax
from ..targets import AXIS_POINTS, parameter_values, Target, variables_at, weight_of
from .templates import constant_symbols, Template


class Model:
    """A template's value and its Jacobian in its constants, as numpy callables of (c, points)."""

    def __init__(self, expression, variables, constants):
        import sympy as sp

        self.value_of = sp.lambdify(variables + constants, expression, modules=["numpy", "scipy"])
        self.derivatives = [sp.lambdify(variables + constants, sp.diff(expression, k), modules=["numpy", "scipy"])
                            for k in constants]

    def __call__(self, c, x):
        with np.errstate(all="ignore"):
            return np.broadcast_to(np.asarray(self.value_of(*x, *c), dtype=np.float64), x[0].shape)

    def jacobian(self, c, x):
        with np.errstate(all="ignore"):
            return np.stack([np.broadcast_to(np.asarray(d(*x, *c), dtype=np.float64), x[0].shape)
                             for d in self.derivatives], axis=1)


def _linear_start(template: Template, x, y, w, symbols) -> np.ndarray:
    """The families' start: least squares of the inner sum to the outer function's inverse of y,
    weighted by the measure and the outer function's slope there."""
    import sympy as sp

    B = np.stack([np.broadcast_to(np.asarray(sp.lambdify(symbols, b, "numpy")(*x), dtype=np.float64), x[0].shape)
                  for b in template.basis], axis=1)
    if template.outer == "identity":
        u, slope = y, np.ones_like(y)
    elif template.outer == "reciprocal":
        u, slope = 1.0 / y, y * y
    else:                                   # exp2: its slope at log2 y is y ln 2
        u, slope = np.log2(y), y * np.log(2.0)
    weights = w * slope
    c, *_ = np.linalg.lstsq(B * weights[:, None], u * weights, rcond=None)
    return c


@dataclasses.dataclass
class PerValue:
    """A template fitted at every value: the values, their constants and errors on the points."""

    values: np.ndarray
    constants: np.ndarray           # (values, count)
    errors: np.ndarray
    on_grid: np.ndarray             # which values are the grid's (the others are halfway)


@dataclasses.dataclass
class Dropped:
    """A template whose optimum at `value` (the `fitted`-th value fitted) is `error`, no better than
    the bound it was fitted against: no formula of the parameter does better than that anywhere."""

    value: float
    error: float
    fitted: int


def fit_per_value(template: Template, target: Target, f,
                  give_up: float = np.inf) -> PerValue | Dropped | None:
    """Step 2 of the module docstring (`minimax.along`: from the middle value outward, each value from
    its neighbour's constants, and from the template's own start where that leads astray; the halfway
    values from the grid value below them): None where the template has no finite fit at some value
    of the parameter; Dropped at the first value fitted whose optimum is `give_up` or more (the others
    are not fitted)."""
    symbols = target.symbols()[:len(target.variables)]
    model = Model(template.expression, symbols, constant_symbols(template.count))
    weight = weight_of(target)
    grid, halfway = parameter_values(target.parameter)
    values = np.r_[grid, halfway]
    on_grid = np.r_[np.ones(grid.size, bool), np.zeros(halfway.size, bool)]
    problems = []
    for value in values:
        x = variables_at(target, AXIS_POINTS, value)
        y = f(*x, value)
        problems.append((model, model.jacobian, y, weight(y), x))

    def own(j):
        """The template's own start at value j: least squares where it is linear inside, else its start."""
        if not template.basis:
            return template.start
        _, _, y, w, x = problems[j]
        return _linear_start(template, x, y, w, symbols)

    middle = grid.size // 2
    constants = np.full((values.size, template.count), np.nan)
    errors = np.full(values.size, np.inf)
    up, down = list(range(middle, grid.size)), list(range(middle - 1, -1, -1))
    order = []                                          # the values in the order they are fitted

    def fitted(indices, found) -> Dropped | None:
        c, e = found
        constants[indices[:e.size]], errors[indices[:e.size]] = c, e
        order.extend(indices[:e.size])
        if e.size and np.isfinite(e[-1]) and e[-1] >= give_up:
            return Dropped(float(values[indices[e.size - 1]]), float(e[-1]), len(order))
        return None

    dropped = fitted(up, minimax.along([problems[j] for j in up], own(middle), lambda i: own(up[i]), give_up=give_up))
    if dropped is None:
        dropped = fitted(down, minimax.along([problems[j] for j in down], constants[middle], lambda i: own(down[i]),
                                             errors[middle], give_up=give_up))
    for i in range(halfway.size):
        if dropped is not None:
            break
        j = grid.size + i
        dropped = fitted([j], minimax.along([problems[j]], constants[i], lambda _, j=j: own(j), errors[i],
                                            give_up=give_up))
    if not np.all(np.isfinite(errors[order])):
        return None
    if dropped is not None:
        return dropped
    return PerValue(values, constants, errors, on_grid)
