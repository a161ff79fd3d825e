"""The box a target is measured on: its Chebyshev grids (the fits', the searches', the parameter's
values and the values halfway between them), a variable whose range moves with the parameter placed
by its share of that range (`unit_box`, `place`), the symmetry of two variables, the measure's
weights."""

from __future__ import annotations

import functools

import numpy as np

from .target import Axis, parse, Target


AXIS_POINTS = 13            # Chebyshev-Lobatto points per variable: the fits' grid
SEARCH_AXIS_POINTS = 9      # ... and the searches' (times PARAMETER_VALUES for the pixel search)
PARAMETER_VALUES = 9        # the parameter's grid (Chebyshev-Lobatto), and the 8 values halfway
SYMMETRY = 1e-12            # f(x, y) and f(y, x) agree to this (relative) on the grid: symmetric
MEASURE_GRID = dict(cells=24, chebyshev=13)     # the box's measuring grid per axis (`brdf.largest`)


def chebyshev_points(lo: float, hi: float, count: int) -> np.ndarray:
    """`count` Chebyshev-Lobatto points of [lo, hi], in increasing order (both ends among them)."""
    k = np.arange(count)
    return lo + (hi - lo) * (1 - np.cos(np.pi * k / (count - 1))) / 2


def middle(parameter: Axis | None) -> float:
    return 0.5 * (parameter.lo + parameter.hi)


def axes_mesh(axes, count: int) -> list[np.ndarray]:
    """The flattened Chebyshev mesh of `axes`, one array per axis."""
    grids = np.meshgrid(*(chebyshev_points(a.lo, a.hi, count) for a in axes), indexing="ij")
    return [g.ravel() for g in grids]


@functools.lru_cache(maxsize=64)
def lower_end(axis: Axis, parameter: Axis):
    """The variable's lower end as a numpy function of the parameter (`Axis.lo_of`; made once per
    axis: the measures place their points thousands of times)."""
    import sympy as sp

    if not isinstance(axis.lo_of, str):
        return lambda values: np.broadcast_to(np.asarray(axis.lo_of(np.asarray(values, dtype=np.float64)),
                                                         dtype=np.float64), np.shape(values))
    p = sp.Symbol(parameter.name, real=True)
    end = sp.lambdify([p], parse(axis.lo_of, (parameter.name,), f"{axis.name}'s lower end"), "numpy")
    return lambda values: np.broadcast_to(np.asarray(end(np.asarray(values, dtype=np.float64)), dtype=np.float64),
                                          np.shape(values))


def unit_box(target) -> tuple[list, list]:
    """(lo, hi) of the box the measures run on: a variable whose range moves with the parameter as its
    share s in [0, 1] of that range (`place` maps it back), the others as they are."""
    return ([0.0 if a.lo_of else a.lo for a in target.axes], [1.0 if a.lo_of else a.hi for a in target.axes])


def place(target, columns) -> list:
    """The axes' values of points given on `unit_box` (a moving variable's share of its range at the
    point's parameter); the identity where no range moves."""
    out = list(columns)
    for i, a in enumerate(target.variables):
        if a.lo_of:
            lo = lower_end(a, target.parameter)(columns[-1])
            out[i] = lo + np.asarray(columns[i]) * (a.hi - lo)
    return out


def mesh(target, count: int, values=None) -> list[np.ndarray]:
    """The flattened Chebyshev mesh of the target's axes, `count` points per variable (in its range at
    each value of the parameter) and per parameter (or its given `values`)."""
    lo, hi = unit_box(target)
    axes = [chebyshev_points(a, b, count) for a, b in zip(lo, hi)]
    if values is not None:
        axes[-1] = np.asarray(values, dtype=np.float64)
    return place(target, [g.ravel() for g in np.meshgrid(*axes, indexing="ij")])


def variables_at(target, count: int, value: float) -> list[np.ndarray]:
    """The variables' Chebyshev mesh (`count` per variable) at one value of the parameter."""
    return mesh(target, count, [value])[:-1] if target.parameter is not None else axes_mesh(target.variables, count)


def parameter_values(parameter: Axis) -> tuple[np.ndarray, np.ndarray]:
    """(the grid's PARAMETER_VALUES Chebyshev values, the values halfway between them)."""
    grid = chebyshev_points(parameter.lo, parameter.hi, PARAMETER_VALUES)
    return grid, 0.5 * (grid[1:] + grid[:-1])


def is_symmetric(target: Target, f) -> bool:
    """Whether f(x, y, ...) = f(y, x, ...) on the fitting grid (two variables of one range)."""
    first, second = target.variables[0], target.variables[-1]
    if len(target.variables) != 2 or (first.lo, first.hi, first.lo_of) != (second.lo, second.hi, second.lo_of):
        return False
    x = mesh(target, 7)
    a, b = f(*x), f(x[1], x[0], *x[2:])
    return bool(np.all(np.abs(a - b) <= SYMMETRY * np.maximum(np.abs(a), 1e-300)))


def weight_of(target):
    """The weight of the target's measure for values y: 1 (abs), 1 / max(|y|, floor) (rel)."""
    if target.metric == "abs":
        return lambda y: np.ones_like(y)
    return lambda y: 1.0 / np.maximum(np.abs(y), target.floor)
