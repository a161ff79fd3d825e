"""A target of several variables and a per-material parameter (`ParametricTarget`: its axes, its
exact function or table, its checks), the box it is measured on (the fits' grid, the parameter's
values, the weights), its range replaced (`with_range`), and a pair of targets a shader computes
together (`PairTarget`); the settings every part of the parametric engine shares."""

from __future__ import annotations

import dataclasses
import functools
import math

import numpy as np

from ..engine import expressions
from ..isa.shaders import FORM_CONSTANTS
from ..optics.roles import role_fault
from . import minimax
from .targets import Anchor, DeriveError, METRICS, parse


AXIS_POINTS = 13            # Chebyshev-Lobatto points per variable: the fits' grid
SEARCH_AXIS_POINTS = 9      # ... and the searches' (times PARAMETER_VALUES for the pixel search)
PARAMETER_VALUES = 9        # the parameter's grid (Chebyshev-Lobatto), and the 8 values halfway
EXCHANGES = 2               # the box's worst point joins the polish's points, and it polishes again
PRUNE = 1e-9                # a formula's coefficient below this share of the largest is dropped, where no worse
SEARCH_TEMPLATES = 8        # grammar forms (the ladder's front) taken as templates, the most accurate
PIXEL_SHARE = 0.5           # of the budget: the pixel search (the rest, the templates' search)
MAX_AXES = 3                # a shader's inputs, variables and the parameter (written with the form: a vec4)
MAX_CONSTANTS = 8           # constants of a template (push constants of a material form)
MAX_FORMULA_COMPLEXITY = 9  # of a constant's correction found by the symbolic regression
PUSH_CONSTANTS = 2 * MAX_CONSTANTS  # the shaders' push constants c0, c1, ... (a pair's two forms), and F0
assert PUSH_CONSTANTS <= FORM_CONSTANTS, "isa.shaders.form_shader's push constants hold a pair's"
SYMMETRY = 1e-12            # f(x, y) and f(y, x) agree to this (relative) on the grid: symmetric
MEASURE_GRID = dict(cells=24, chebyshev=13)     # the box's measuring grid per axis (`brdf.largest`)
CHECK_POINTS = 33           # per axis: the grid on which a target must be finite

@dataclasses.dataclass(frozen=True)
class Axis:
    """A variable or the parameter: its name and range. A variable's lower end may move with the
    parameter (`lo_of`, sympy text in the parameter's name: cos^n's epicenter zone, t >= L^(1/n); or,
    where it has no closed form, a hashable numpy function of the parameter's values, named by its
    str: Beckmann's zone); `lo` is then the lowest it reaches, for the checks."""

    name: str
    lo: float
    hi: float
    lo_of: object = ""

    def text(self) -> str:
        return f"{self.name} in [{str(self.lo_of).replace('**', '^') if self.lo_of else format(self.lo, 'g')}, {self.hi:g}]"


class Table:
    """A target given by its values on a grid: one increasing array per axis (variables, then the
    parameter) and the values (one array axis per axis), interpolated between the grid's points by
    cubic splines (scipy: `CubicSpline` on one axis, `RectBivariateSpline` on two,
    `RegularGridInterpolator` on three). Its text names it by a digest of its numbers."""

    def __init__(self, axes, values, source: str):
        import hashlib

        self.axes = tuple(np.asarray(a, dtype=np.float64) for a in axes)
        self.values = np.asarray(values, dtype=np.float64)
        self.source = source
        if self.values.shape != tuple(a.size for a in self.axes):
            raise DeriveError(f"{source}: the values' shape {self.values.shape} is not the grid's "
                              f"{tuple(a.size for a in self.axes)}")
        for i, a in enumerate(self.axes):
            if a.size < 4 or not np.all(np.diff(a) > 0):
                raise DeriveError(f"{source}: axis {i + 1} needs at least 4 increasing values (has {a.size})")
        if not np.all(np.isfinite(self.values)):
            raise DeriveError(f"{source}: a value is not finite")
        digest = hashlib.sha256(b"".join(a.tobytes() for a in self.axes) + self.values.tobytes()).hexdigest()[:16]
        self.text = f"table {source} ({' x '.join(str(a.size) for a in self.axes)} values, {digest})"
        self._spline = None

    def __repr__(self) -> str:
        return self.text

    def __eq__(self, other) -> bool:
        return isinstance(other, Table) and other.text == self.text

    def __hash__(self) -> int:
        return hash(self.text)

    def __getstate__(self) -> dict:         # (sent to a worker process: its spline is built there again)
        return self.__dict__ | dict(_spline=None)

    def __call__(self, *columns):
        from scipy.interpolate import CubicSpline, RectBivariateSpline, RegularGridInterpolator

        if self._spline is None:
            if len(self.axes) == 1:
                self._spline = CubicSpline(self.axes[0], self.values)
            elif len(self.axes) == 2:
                spline = RectBivariateSpline(*self.axes, self.values, kx=3, ky=3, s=0)
                self._spline = lambda x, y: spline.ev(x, y)
            else:
                grid = RegularGridInterpolator(self.axes, self.values, method="cubic")
                self._spline = lambda *x: grid(np.stack(x, axis=-1))
        columns = np.broadcast_arrays(*(np.asarray(c, dtype=np.float64) for c in columns))
        inside = [np.clip(c, a[0], a[-1]) for c, a in zip(columns, self.axes)]   # (rounding at the box's faces)
        return np.asarray(self._spline(*inside), dtype=np.float64).reshape(columns[0].shape)


@dataclasses.dataclass(frozen=True)
class ParametricTarget:
    """A function of `variables` (per pixel) and at most one `parameter` (per material): the
    expression sympy text in their names, or (`table`) values on a grid, the expression then only
    its name (module docstring)."""

    name: str
    expression: str
    variables: tuple[Axis, ...]
    parameter: Axis | None = None
    metric: str = "rel"
    floor: float = 0.0
    anchors: tuple[Anchor, ...] = ()
    description: str = ""
    table: Table | None = None
    max_degree: int = 4         # the family templates' largest total degree
    role: str = ""              # where it enters a shading (`optics.roles`): rendered there (`rendered`)

    @property
    def axes(self) -> tuple[Axis, ...]:
        return self.variables + ((self.parameter,) if self.parameter else ())

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(a.name for a in self.axes)

    @property
    def variable(self) -> str:          # (what the one-variable engine's pages name)
        return ", ".join(self.names)

    @property
    def domain(self):
        return [[a.lo, a.hi] for a in self.axes]

    def symbols(self) -> list:
        import sympy as sp

        return [sp.Symbol(n, real=True) for n in self.names]

    def sympy(self):
        if self.table is not None:
            raise DeriveError(f"{self.name} is a table: it has no expression")
        return parse(self.expression, self.names)

    def numpy(self):
        """The exact function as a numpy callable of one array per axis (variables, then the parameter)."""
        return self.table if self.table is not None else _numpy_of(self.sympy(), self.symbols())

    def range_text(self) -> str:
        return self.parameter.text() if self.parameter else ""

    def anchor_expressions(self) -> dict:
        return {a.name: parse(a.expression, self.names, f"anchor {a.name!r}") for a in self.anchors}


def _numpy_of(expr, symbols):
    import sympy as sp

    function = sp.lambdify(symbols, expr, modules=["numpy", "scipy"])

    def value(*columns):
        columns = [np.asarray(c, dtype=np.float64) for c in columns]
        shape = np.broadcast_shapes(*(c.shape for c in columns))
        with np.errstate(all="ignore"):
            return np.broadcast_to(np.asarray(function(*columns), dtype=np.float64), shape).copy()

    return value


def check(target: ParametricTarget) -> ParametricTarget:
    """The target itself, checked: a known metric, finite ranges lo < hi, distinct names, an expression
    finite (and, for `rel` with floor 0, nonzero) on a grid of the box, anchors that parse. Raises
    DeriveError naming the first fault."""
    if target.metric not in METRICS:
        raise DeriveError(f"--metric {target.metric!r}: give one of {', '.join(METRICS)}")
    if not target.variables:
        raise DeriveError(f"{target.name}: give at least one variable")
    if len(target.axes) > MAX_AXES:
        raise DeriveError(f"{target.name}: {len(target.axes)} variables and parameter; at most {MAX_AXES}")
    names = target.names
    if len(set(names)) != len(names):
        raise DeriveError(f"{target.name}: the names {', '.join(names)} repeat one")
    for a in target.axes:
        fault = expressions.name_fault(a.name) or (
            "c, c0, c1, ... and k_... name the constants" if a.name == "c" or a.name.startswith("k_")
            or (a.name[0] == "c" and a.name[1:].isdigit()) else None)
        if fault:
            raise DeriveError(f"variable {a.name!r}: {fault}")
        if not (math.isfinite(a.lo) and math.isfinite(a.hi) and a.lo < a.hi):
            raise DeriveError(f"{a.name} in [{a.lo}, {a.hi}]: give finite numbers lo < hi")
    if not (math.isfinite(target.floor) and target.floor >= 0):
        raise DeriveError(f"floor {target.floor}: give a number >= 0")
    if target.table is not None:
        if len(target.table.axes) != len(target.axes):
            raise DeriveError(f"{target.name}: the table has {len(target.table.axes)} axes, the target "
                              f"{len(target.axes)}")
        for a, grid in zip(target.axes, target.table.axes):
            if a.lo < grid[0] or a.hi > grid[-1]:
                raise DeriveError(f"{a.name} in [{a.lo:g}, {a.hi:g}]: the table covers [{grid[0]:g}, {grid[-1]:g}]")
    for a in target.variables:
        if a.lo_of:
            if target.parameter is None:
                raise DeriveError(f"{a.name}: its range moves with the parameter ({a.lo_of}), and there is none")
            ends = _lower_end(a, target.parameter)(np.linspace(target.parameter.lo, target.parameter.hi, CHECK_POINTS))
            if not (np.all(np.isfinite(ends)) and np.all(ends < a.hi)):
                raise DeriveError(f"{a.name} in [{a.lo_of}, {a.hi:g}]: give a lower end below {a.hi:g} for every "
                                  f"{target.parameter.name} of its range")
    unit = _unit_box(target)
    mesh = _place(target, [m.ravel() for m in np.meshgrid(*(np.linspace(lo, hi, CHECK_POINTS) for lo, hi in zip(*unit)),
                                                          indexing="ij")])
    f = target.numpy()(*mesh)
    for bad, why in ((~np.isfinite(f), "is not finite"),
                     ((f == 0) if target.metric == "rel" and target.floor == 0 else np.zeros(f.shape, bool),
                      "is 0 (the relative error divides by it; give a floor or metric abs)")):
        if bad.any():
            at = ", ".join(f"{a.name} = {m[bad][0]:.6g}" for a, m in zip(target.axes, mesh))
            raise DeriveError(f"{target.expression} {why} at {at}: narrow the ranges")
    for anchor in target.anchors:
        parse(anchor.expression, names, f"anchor {anchor.name!r}")
    fault = role_fault(target.role, len(target.variables), target.parameter is not None)
    if fault:
        raise DeriveError(f"{target.name}: {fault}")
    return target


def _middle(parameter: Axis | None) -> float:
    return 0.5 * (parameter.lo + parameter.hi)


def _chebyshev(lo: float, hi: float, count: int) -> np.ndarray:
    return minimax.chebyshev_points(lo, hi, count)


def _mesh(axes, count: int) -> list[np.ndarray]:
    """The flattened Chebyshev mesh of `axes`, one array per axis."""
    grids = np.meshgrid(*(_chebyshev(a.lo, a.hi, count) for a in axes), indexing="ij")
    return [g.ravel() for g in grids]


@functools.lru_cache(maxsize=64)
def _lower_end(axis: Axis, parameter: Axis):
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


def _unit_box(target) -> tuple[list, list]:
    """(lo, hi) of the box the measures run on: a variable whose range moves with the parameter as its
    share s in [0, 1] of that range (`_place` maps it back), the others as they are."""
    return ([0.0 if a.lo_of else a.lo for a in target.axes], [1.0 if a.lo_of else a.hi for a in target.axes])


def _place(target, columns) -> list:
    """The axes' values of points given on `_unit_box` (a moving variable's share of its range at the
    point's parameter); the identity where no range moves."""
    out = list(columns)
    for i, a in enumerate(target.variables):
        if a.lo_of:
            lo = _lower_end(a, target.parameter)(columns[-1])
            out[i] = lo + np.asarray(columns[i]) * (a.hi - lo)
    return out


def mesh(target, count: int, values=None) -> list[np.ndarray]:
    """The flattened Chebyshev mesh of the target's axes, `count` points per variable (in its range at
    each value of the parameter) and per parameter (or its given `values`)."""
    lo, hi = _unit_box(target)
    axes = [_chebyshev(a, b, count) for a, b in zip(lo, hi)]
    if values is not None:
        axes[-1] = np.asarray(values, dtype=np.float64)
    return _place(target, [g.ravel() for g in np.meshgrid(*axes, indexing="ij")])


def variables_at(target, count: int, value: float) -> list[np.ndarray]:
    """The variables' Chebyshev mesh (`count` per variable) at one value of the parameter."""
    return mesh(target, count, [value])[:-1] if target.parameter is not None else _mesh(target.variables, count)


def parameter_values(parameter: Axis) -> tuple[np.ndarray, np.ndarray]:
    """(the grid's PARAMETER_VALUES Chebyshev values, the values halfway between them)."""
    grid = _chebyshev(parameter.lo, parameter.hi, PARAMETER_VALUES)
    return grid, 0.5 * (grid[1:] + grid[:-1])


def is_symmetric(target: ParametricTarget, f) -> bool:
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


def with_range(target, parameter_range):
    """The target (or a pair's two parts) with its parameter's range replaced: "LO:HI" or (lo, hi),
    checked (a variable whose range moves with the parameter keeps its formula, its lowest end
    recomputed). Raises DeriveError where the target has no parameter or the range is not two
    numbers lo < hi."""
    if isinstance(parameter_range, str):
        try:
            lo, hi = (float(v) for v in parameter_range.split(":"))
        except ValueError:
            raise DeriveError(f"--range {parameter_range!r}: give LO:HI, two numbers") from None
    else:
        lo, hi = (float(v) for v in parameter_range)
    if isinstance(target, PairTarget):
        return check_pair(dataclasses.replace(target, scale=with_range(target.scale, (lo, hi)),
                                              bias=with_range(target.bias, (lo, hi))))
    if not isinstance(target, ParametricTarget) or target.parameter is None:
        raise DeriveError(f"{target.name} has no parameter: --range applies to targets with one")
    parameter = dataclasses.replace(target.parameter, lo=lo, hi=hi)
    if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
        raise DeriveError(f"--range {lo:g}:{hi:g}: give finite numbers lo < hi")
    variables = []
    for a in target.variables:
        if a.lo_of:
            with np.errstate(all="ignore"):
                ends = _lower_end(a, parameter)(np.linspace(lo, hi, CHECK_POINTS))
            a = dataclasses.replace(a, lo=float(np.min(ends)) if np.all(np.isfinite(ends)) else a.lo)
        variables.append(a)
    return check(dataclasses.replace(target, variables=tuple(variables), parameter=parameter))


# ---- two outputs: the environment BRDF's scale and bias -------------------------------------------

@dataclasses.dataclass(frozen=True)
class PairTarget:
    """Two targets a shader computes together, as F0 A + B (the split-sum environment BRDF's scale A
    and bias B): each derived alone (`derive`), then their fronts' members paired."""

    name: str
    scale: ParametricTarget
    bias: ParametricTarget
    description: str = ""
    role: str = ""              # (`optics.roles`)

    @property
    def variable(self) -> str:
        return self.scale.variable


PAIR_PARTS = ("scale", "bias")


def check_pair(target: PairTarget) -> PairTarget:
    check(target.scale)
    check(target.bias)
    if target.scale.axes != target.bias.axes or target.scale.metric != target.bias.metric:
        raise DeriveError(f"{target.name}: its two targets need the same variables, parameter and metric")
    fault = role_fault(target.role, len(target.scale.variables), target.scale.parameter is not None)
    if fault:
        raise DeriveError(f"{target.name}: {fault}")
    return target
