"""`derive` for targets of several variables and a per-material parameter: the height-correlated
Smith-GGX visibility V(NoV, NoL; alpha) (`registry`), or any `ParametricTarget` of up to three
variables and parameter (in Python: `pipeline.derive(ParametricTarget(...))`).

A target (`ParametricTarget`) has variables computed per pixel (NoV, NoL), each with its range, and
at most one parameter with its range (alpha, roughness, n), which a material sets, or a texture per
pixel. Its error is the largest over the whole box, variables and parameter
(`optics.brdf.largest_error`: a grid, refined where the error peaks).

1. Templates: forms in the variables whose constants are left free:
   - the families linear in their constants under an outer function: a polynomial and the
     reciprocal of a polynomial, of total degree 1 and 2 and bilinear, each with and without its
     constant term, in symmetric monomials (x + y, x y, x^2 + y^2) where the target is symmetric in
     its two variables (checked on the fitting grid);
   - the grammar's forms in the variables, found by the ladder of grammars (`symbolic.ladder`) at the
     parameter's middle value.
2. Per value: each template's constants fitted by minimax (`minimax.slp_points`) at every value of
   the parameter's grid (`PARAMETER_VALUES` Chebyshev values and the values halfway between them,
   where the worst value is checked), each start from the neighbour's constants. The largest of
   these errors is the template's per-value optimum: no formula of the parameter does better, so a
   template whose optimum is no better than the best constant's error goes no further (no form at
   that error is on a front).
3. Formulas: each constant a formula of the parameter p (`KINDS`: a line, a quadratic, a + b p + c / p
   where p's range excludes 0, and cheaper mixes: `formula_variants`), fitted by least squares to
   the grid's values, then all the formulas' coefficients polished together by minimax on the points
   of every value, the box's worst point added and polished again (`EXCHANGES` times); the error
   measured over the whole box. A reciprocal template's pixel form is also written with one
   single-term formula's factor in the numerator (`_scaled`: the same function, cheaper on NVIDIA).
   With `formula_complexity` > 0, the templates on the per-value front also take formulas the
   symbolic regression finds from each constant's values and from their residual from their line
   (`corrected`, as the paper found coef(n)).
4. Per pixel: the grammar's forms in the variables and the parameter together, by the ladder; and
   each anchor's own form with its decimal numbers refitted by minimax on the box
   (`refitted_anchors`: the same operations, so mostly the same cost).
5. Costs: every form compiled for each architecture, a fragment shader with one input per variable
   and the parameter (`isa.machine_code.form_cycles`, net of the shader writing the variables the
   form reads): `parameter_per = "material"`, the constants push constants that
   the CPU computes once per material from the formulas; `pixel`, the formulas compiled into the
   shader with the parameter per pixel (textured roughness), the parameter's read paid by the form. The fronts are read off per
   architecture and per `parameter_per`; the anchors, which engines evaluate with the parameter per
   pixel, are pixel rows, held against the pixel front (`engine.verdict`).
"""

from __future__ import annotations

import dataclasses
import functools
import itertools
import math
import time

import numpy as np

from ..engine import expressions
from ..isa.shaders import FORM_CONSTANTS
from ..optics.roles import role_fault
from . import minimax
from .forms import Form, free_numbers, gpu_form
from .targets import METRICS, Anchor, DeriveError, paper_lobes, parse

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


# ---- templates ----------------------------------------------------------------------------------

@dataclasses.dataclass
class Template:
    """A form in the variables with free constants k_0 ... k_{m-1} (sympy), its family, and the
    constants it starts from at the parameter's middle value (None: a linear start)."""

    name: str
    family: str
    expression: object
    count: int
    source: str
    start: np.ndarray | None = None
    outer: str = "identity"          # the families' outer function: identity or reciprocal
    basis: tuple = ()                # ... and their monomials, for the linear start


def kept_symbols(target) -> list:
    """Every symbol a found form may hold: the target's, the push constants c0, c1, ... and the
    template constants k_0, k_1, ... (real, as the forms make them)."""
    import sympy as sp

    return (target.symbols() + [sp.Symbol(f"c{i}", real=True) for i in range(PUSH_CONSTANTS)]
            + constant_symbols(MAX_CONSTANTS))


def constant_symbols(count: int) -> list:
    import sympy as sp

    return [sp.Symbol(f"k_{i}", real=True) for i in range(count)]


def _monomials(symbols, degree: int, bilinear: bool, symmetric: bool) -> list:
    """The monomials of total degree <= degree (or, `bilinear`, of degree <= 1 in each variable), the
    constant 1 first; in two symmetric variables, their symmetric sums (x + y, x y, x^2 + y^2)."""
    import sympy as sp

    powers = [p for p in itertools.product(range(degree + 1), repeat=len(symbols))
              if (max(p) <= 1 if bilinear else sum(p) <= degree)]
    powers.sort(key=lambda p: (sum(p), p[::-1]))
    out = []
    for p in powers:
        term = sp.Mul(*(s ** k for s, k in zip(symbols, p)))
        if symmetric:
            term = sp.expand(term + term.subs({symbols[0]: symbols[1], symbols[1]: symbols[0]}, simultaneous=True))
            term = term.as_coeff_Mul()[1]          # (2 x y is x y, 2 is 1)
        if term not in out:
            out.append(term)
    return out


# (label, total degree, bilinear) of the monomial bases, by the number of variables
BASES = {1: (("degree1", 1, False), ("degree2", 2, False), ("degree3", 3, False), ("degree4", 4, False)),
         2: (("degree1", 1, False), ("bilinear", 1, True), ("degree2", 2, False)),
         3: (("degree1", 1, False),)}
OUTERS = {"identity": "polynomial", "reciprocal": "reciprocal_polynomial", "exp2": "exp2_polynomial"}


def family_templates(target: ParametricTarget, symmetric: bool, positive: bool = False) -> list[Template]:
    """The linear families of the module docstring, step 1 (exp2 of a polynomial where the target is
    `positive` on the box)."""
    import sympy as sp

    symbols = target.symbols()[:len(target.variables)]
    out, seen = [], set()
    for outer, family in OUTERS.items():
        if outer == "exp2" and not positive:
            continue
        for label, degree, bilinear in BASES[len(symbols)]:
            if degree > target.max_degree:
                continue
            full = _monomials(symbols, degree, bilinear, symmetric)
            for basis, constant in ((full, True), (full[1:], False)):
                key = (outer, tuple(basis))
                if key in seen or len(basis) < 1 or len(basis) > MAX_CONSTANTS:
                    continue
                seen.add(key)
                k = constant_symbols(len(basis))
                inner = sum((ki * b for ki, b in zip(k, basis)), sp.Integer(0))
                expression = {"identity": inner, "reciprocal": 1 / inner, "exp2": sp.Pow(2, inner)}[outer]
                name = f"{family}_{label}" + ("" if constant else "_no_constant") + ("_symmetric" if symmetric else "")
                out.append(Template(name, family, expression, len(basis),
                                    f"{dict(reciprocal='1 / ', exp2='exp2 of ').get(outer, '')}a sum of "
                                    f"{', '.join(str(b) for b in basis)} with constants per value",
                                    outer=outer, basis=tuple(basis)))
    return out


def grammar_templates(target: ParametricTarget, f, seconds: float, max_complexity: int, log) -> tuple[list, dict]:
    """The grammar's forms in the variables at the parameter's middle value (the ladder's front, the
    SEARCH_TEMPLATES most accurate), as templates; and the search's coverage."""
    from ..symbolic import grammar, ladder

    value = _middle(target.parameter)
    x = variables_at(target, SEARCH_AXIS_POINTS, value)
    y = f(*x, value)
    loss = _loss(target)
    candidates, rungs, _ = ladder.run(np.stack(x), y, max_complexity, grammar.TEN, seconds, loss,
                                      log=lambda s: log("templates: " + s))
    symbols = target.symbols()[:len(target.variables)]
    chosen = sorted((c for c in candidates if 1 <= grammar.constants(c[0]) <= MAX_CONSTANTS and np.isfinite(c[2])),
                    key=lambda c: c[2])[:SEARCH_TEMPLATES]
    out = []
    for i, (tree, c, _, _, engine, _) in enumerate(chosen):
        k = constant_symbols(grammar.constants(tree))
        out.append(Template(f"grammar_{i + 1}", "grammar", grammar.substitute(tree, k, symbols, sympy_functions()),
                            len(k), f"grammar ({engine}): {grammar.show(tree, [s.name for s in symbols])}",
                            start=np.asarray(c, dtype=float)))
    return out, dict(rungs=[r.row() for r in rungs], points=int(y.size), loss=loss)


def sympy_functions():
    """The grammar's functions as sympy's (`symbolic.grammar.substitute` into sympy)."""
    import sympy as sp

    return {"exp": sp.exp, "log": sp.log, "sqrt": sp.sqrt, "sin": sp.sin, "cos": sp.cos, "abs": sp.Abs}


def _loss(target) -> str:
    return "max-relative" if target.metric == "rel" and target.floor == 0 else "max"


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


def fit_per_value(template: Template, target: ParametricTarget, f) -> PerValue | None:
    """Step 2 of the module docstring (`minimax.along`: from the middle value outward, each value from
    its neighbour's constants, and from the template's own start where that leads astray; the halfway
    values from the grid value below them): None where the template has no finite fit at some value
    of the parameter."""
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
    constants[up], errors[up] = minimax.along([problems[j] for j in up], own(middle), lambda i: own(up[i]))
    constants[down], errors[down] = minimax.along([problems[j] for j in down], constants[middle],
                                                  lambda i: own(down[i]), errors[middle])
    for i in range(halfway.size):
        j = grid.size + i
        constants[[j]], errors[[j]] = minimax.along([problems[j]], constants[i], lambda _, j=j: own(j), errors[i])
    if not np.all(np.isfinite(errors)):
        return None
    return PerValue(values, constants, errors, on_grid)


@dataclasses.dataclass
class Fitted:
    """A template with its constants as formulas (coefficients, lowest power first) of the
    parameter, polished on the whole box, and its errors."""

    template: Template
    formula: str
    coefficients: np.ndarray        # (count, degree + 1)
    per_value: PerValue
    errors: dict                    # max_abs_error, max_rel_error over the box
    pixel: object                   # sympy: the formulas substituted (the parameter per pixel)
    material: object                # sympy: the constants as push constants c0, c1, ...
    formulas: tuple | None = None   # sympy, per constant, where not the coefficients' (`corrected`)

    @property
    def name(self) -> str:
        return f"{self.template.name}_{self.formula}"

    def constant_formulas(self, parameter) -> list:
        return list(self.formulas) if self.formulas is not None else formula_expressions(self.coefficients, parameter)


# Each constant's formula in the parameter p: its powers of p (`laurent`, a + b p + c / p, where the
# parameter's range excludes 0: GGX's D in alpha^2 has such constants, pi / alpha^2 among them).
KINDS = {"constant": (0,), "proportional": (1,), "line": (0, 1), "quadratic": (0, 1, 2), "laurent": (-1, 0, 1)}
TAGS = {"constant": "c", "proportional": "p", "line": "l", "quadratic": "q", "laurent": "i"}
POWERS = (-1, 0, 1, 2)      # the coefficients' columns, in this order


def formula_name(kinds) -> str:
    """`line` or `quadratic` where every constant has that formula, else one letter per constant
    (c constant, p proportional, l line, q quadratic): `formulas_pl`."""
    if len(set(kinds)) == 1 and kinds[0] in ("line", "quadratic", "laurent"):
        return kinds[0]
    return "formulas_" + "".join(TAGS[k] for k in kinds)


def formula_variants(count: int, reduce: bool, laurent: bool = False) -> list[tuple]:
    """The formulas tried for a template of `count` constants: every constant a line, every one a
    quadratic, every one a + b p + c / p (`laurent`: a parameter range without 0); with `reduce`,
    also each constant alone a proportion or a constant (the others lines), and every constant a
    proportion or a constant, whichever fits its values (`None` there: chosen by `_cheapest`)."""
    out = [("line",) * count, ("quadratic",) * count] + ([("laurent",) * count] if laurent else [])
    if reduce:
        for i in range(count):
            for kind in ("proportional", "constant"):
                out.append(tuple(kind if j == i else "line" for j in range(count)))
        if count > 1:
            out.append(None)
    return out


def formula_expressions(coefficients, parameter) -> list:
    """Each constant's formula as sympy in the parameter's symbol (a polynomial in Horner form), from
    its coefficients of the POWERS of p (zero where the formula has no such term)."""
    import sympy as sp

    out = []
    for row in coefficients:
        terms = sum(((sp.Integer(1) if a == 1 else sp.Float(float(a), 17)) * parameter ** j
                     for j, a in zip(POWERS, row) if a != 0), sp.Integer(0))
        polynomial = terms.is_Add and row[POWERS.index(-1)] == 0
        out.append(sp.horner(terms, parameter) if polynomial else terms)
    return out


def _start_coefficients(per_value: PerValue, kinds) -> np.ndarray:
    """(count, len(POWERS)): each constant's formula fitted by least squares to its values on the grid."""
    grid = per_value.on_grid
    p = per_value.values[grid]
    out = np.zeros((len(kinds), len(POWERS)))
    for i, kind in enumerate(kinds):
        powers = KINDS[kind]
        A = np.power.outer(p, np.array(powers, dtype=float))
        solution, *_ = np.linalg.lstsq(A, per_value.constants[grid, i], rcond=None)
        out[i, [POWERS.index(k) for k in powers]] = solution
    return out


def _cheapest(per_value: PerValue, count: int) -> tuple:
    """Per constant, a proportion or a constant, whichever fits its values on the grid better (least
    squares)."""
    grid = per_value.on_grid
    p = per_value.values[grid]
    kinds = []
    for i in range(count):
        v = per_value.constants[grid, i]
        spread = {kind: float(np.sum((np.power.outer(p, np.array(KINDS[kind]))
                                       @ np.linalg.lstsq(np.power.outer(p, np.array(KINDS[kind])), v, rcond=None)[0]
                                       - v) ** 2)) for kind in ("proportional", "constant")}
        kinds.append(min(spread, key=spread.get))
    return tuple(kinds)


def polish_formulas(template: Template, per_value: PerValue, kinds, target: ParametricTarget, f, zero=None):
    """Step 3: (coefficients (count, len(POWERS)), error over the box) of the template's constants as
    the formulas `kinds` (one of KINDS per constant) of the parameter; the coefficients marked in
    `zero` (a boolean array of their shape) held at 0. A template may read the parameter itself
    (the lobe search's forms in w = n (1 - t))."""
    from ..optics import brdf

    coefficients = _start_coefficients(per_value, kinds)
    mask = np.zeros(coefficients.shape, dtype=bool)
    for i, kind in enumerate(kinds):
        mask[i, [POWERS.index(k) for k in KINDS[kind]]] = True
    if zero is not None:
        mask &= ~zero
        coefficients[zero] = 0.0
    symbols = target.symbols()
    reads_parameter = symbols[-1] in template.expression.free_symbols and target.parameter is not None
    variables = symbols if reads_parameter else symbols[:len(target.variables)]
    model = Model(template.expression, variables, constant_symbols(template.count))
    axes = slice(None) if reads_parameter else slice(0, -1)
    used = mask.any(axis=0)                 # (the powers some formula has: 1 / p only where one has it)
    powers = np.array(POWERS, dtype=float)[used]

    def full(a):
        A = np.zeros(coefficients.shape)
        A[mask] = a
        return A

    def joint(a, x):
        shape = np.shape(x[0])
        x = [np.ravel(c) for c in x]
        k = np.power.outer(x[-1], powers) @ full(a)[:, used].T        # (points, count)
        return model(list(k.T), x[axes]).reshape(shape)

    def jacobian(a, x):
        P = np.power.outer(x[-1], powers)
        J = model.jacobian(list((P @ full(a)[:, used].T).T), x[axes])  # (points, count)
        return (J[:, :, None] * P[:, None, :])[:, mask[:, used]]

    a, error = minimax_on_box(joint, jacobian, coefficients[mask], target, f, per_value.values)
    return full(a), error


def minimax_on_box(model, jacobian, a0, target, f, values) -> tuple[np.ndarray, float]:
    """(the constants, the error over the whole box) of `model(a, points)` (the points: the axes'
    columns) fitted by minimax on the variables' mesh at the parameter's `values`, the box's worst point
    added and fitted again (`EXCHANGES` times): the polish of every formula's constants together."""
    return minimax_on_box_parts([(model, jacobian, target, f)], a0, values)


def minimax_on_box_parts(parts, a0, values) -> tuple[np.ndarray, float]:
    """`minimax_on_box` for several outputs sharing their constants (a pair's A and B): `parts` are
    (model, jacobian, target, f) on one box; the error is the largest of the parts', each part's
    worst point added to every part's points."""
    from ..optics import brdf

    target = parts[0][2]
    points = mesh(target, AXIS_POINTS, values)
    lo, hi = _unit_box(target)
    a = np.asarray(a0, dtype=np.float64)
    best = None
    for _ in range(EXCHANGES + 1):
        ys = [part_f(*points) for _, _, _, part_f in parts]
        y = np.concatenate(ys)
        weight = np.concatenate([weight_of(t)(v) for (_, _, t, _), v in zip(parts, ys)])
        model = lambda c, x: np.concatenate([m(c, x) for m, *_ in parts])       # noqa: E731
        jacobian = lambda c, x: np.concatenate([j(c, x) for _, j, *_ in parts])  # noqa: E731
        a, on_points = minimax.slp_points(model, jacobian, a, y, weight, points)
        measured = [brdf.largest_error(lambda *s, m=m: m(a, _place(t, s)), lambda *s, t=t, g=g: g(*_place(t, s)), lo, hi,
                                       relative=t.metric == "rel", **MEASURE_GRID) for m, _, t, g in parts]
        e = max(err for err, _ in measured)
        if best is None or e < best[1]:
            best = (a.copy(), e)
        if not np.isfinite(e) or e <= on_points * (1 + 1e-9):
            break
        for _, where in measured:
            where = _place(target, [np.atleast_1d(w) for w in where])
            points = [np.r_[p, w] for p, w in zip(points, where)]
    return best


def measure_box(expression, target: ParametricTarget, f) -> dict:
    """{max_abs_error, max_rel_error} of a sympy expression in the axes over the whole box."""
    from ..optics import brdf

    exact = f
    approx = _numpy_of(expression, target.symbols())
    if any(a.lo_of for a in target.variables):          # (measured on the unit box: `_place`)
        approx = (lambda g: lambda *s: g(*_place(target, s)))(approx)
        f = lambda *s: exact(*_place(target, s))        # noqa: E731
    lo, hi = _unit_box(target)
    out = {}
    for key, relative in (("max_abs_error", False), ("max_rel_error", True)):
        if relative and target.floor > 0:
            floor = target.floor
            value, _ = brdf.largest(lambda *s: (approx(*s) - f(*s)) / np.maximum(np.abs(f(*s)), floor), lo, hi,
                                    **MEASURE_GRID)
        else:
            value, _ = brdf.largest_error(approx, f, lo, hi, relative=relative, **MEASURE_GRID)
        out[key] = float(value)
    return out


def material_forms(templates, target, f, log, formula_complexity: int = 0) -> list[Fitted]:
    """Steps 2 and 3 for every template: every template's constants as lines and quadratics; the
    templates no other of `templates` with as few constants beats per value (the front of constants
    against the per-value optimum) also with cheaper formulas (`formula_variants`) and, with
    `formula_complexity` > 0, with their lines corrected by the symbolic regression (`corrected`)."""
    import sympy as sp

    symbols = target.symbols()
    parameter = symbols[-1]
    uniforms = [sp.Symbol(f"c{i}", real=True) for i in range(MAX_CONSTANTS)]
    from . import engine

    constant = _constant_error(target, f)
    floor = engine.rounding_floor(target, constant)
    fits = []
    for template in templates:
        per_value = fit_per_value(template, target, f)
        if per_value is None:
            log(f"  {template.name}: no finite fit at some value of {target.parameter.name}; left out")
            continue
        fits.append((template, per_value))
    out = []
    for template, per_value in fits:
        if per_value.errors.max() >= constant:
            # no formula beats the per-value optimum, and no form at least the best constant's error is
            # on a front: nothing to fit
            log(f"  {template.name}: per value {per_value.errors.max():.4g}, no better than a constant "
                f"({constant:.4g}); no formulas")
            continue
        started = time.perf_counter()
        reduce = not any(other.count <= template.count and other_fit.errors.max() < per_value.errors.max()
                         for other, other_fit in fits if other is not template)
        k = constant_symbols(template.count)
        found = []
        for kinds in formula_variants(template.count, reduce, laurent=target.parameter.lo > 0):
            kinds = _cheapest(per_value, template.count) if kinds is None else kinds
            name = formula_name(kinds)
            if any(m.formula == name for m in found):
                continue
            coefficients, _ = polish_formulas(template, per_value, kinds, target, f)
            pixel = template.expression.xreplace(dict(zip(k, formula_expressions(coefficients, parameter))))
            errors = measure_box(pixel, target, f)
            pruned = np.where(np.abs(coefficients) < PRUNE * np.abs(coefficients).max(), 0.0, coefficients)
            if np.any(pruned != coefficients):
                # a coefficient at rounding's level (a term the target lacks) dropped and the others polished
                # again without it, where that costs nothing
                pruned, _ = polish_formulas(template, per_value, kinds, target, f, zero=(pruned == 0) & (coefficients != 0))
                trial = template.expression.xreplace(dict(zip(k, formula_expressions(pruned, parameter))))
                measured = measure_box(trial, target, f)
                key = _error_key(target)
                if measured[key] <= max(errors[key] * (1 + 1e-6), floor):     # (float32 rounding: equal)
                    coefficients, pixel, errors = pruned, trial, measured
            zero = {ki: 0 for ki, row in zip(k, coefficients) if not np.any(row)}
            material = template.expression.xreplace(zero).xreplace(dict(zip(k, uniforms)))
            found.append(Fitted(template, name, coefficients, per_value, errors, pixel, material))
        line = next((m for m in found if m.formula == "line"), None)
        if formula_complexity > 0 and reduce and line is not None:
            better = corrected(line, target, f, formula_complexity, log)
            if better is not None:
                found.append(better)
        out += found
        log(f"  {template.name}: per value {per_value.errors.max():.4g}; "
            + ", ".join(f"{m.formula} {m.errors[_error_key(target)]:.4g}" for m in found)
            + f" ({time.perf_counter() - started:.1f} s)")
    return out


FORMULA_OPERATIONS = "+,-,*,/,log,sqrt"     # of a constant's formula in the parameter (per material: any is free)


def corrected(line: Fitted, target, f, complexity: int, log) -> Fitted | None:
    """The template's constants as formulas the symbolic regression finds, as the paper found coef(n):
    each constant's values at the per-value optima searched (`symbolic.search`, FORMULA_OPERATIONS,
    up to `complexity`, least squares), and so is their residual from their least-squares line (a
    formula is then that line plus the member: a line with a small correction, c / p say, is found
    at the correction's complexity; the polished line of `line` is no base, minimax lines being many
    where one value sets the error); at each complexity level every constant takes the member of least RMS
    at or below it (its line, from `line`, where none holds its values better), the formulas'
    numbers are polished together by minimax on the box (`_polished`: equal numbers are one), the
    box's error is measured, and the level of least error is kept where it beats the lines. None
    where no level does."""
    import sympy as sp

    from ..symbolic import grammar, search

    parameter = target.symbols()[-1]
    values = line.per_value.values
    line_expressions = formula_expressions(line.coefficients, parameter)
    fronts = []
    for j in range(line.template.count):
        y = line.per_value.constants[:, j]
        slope, intercept = np.polyfit(values, y, 1)
        residual = y - (slope * values + intercept)
        line_rms = float(np.sqrt(np.mean(residual ** 2)))
        members = []
        for base, base_values in ((sp.Integer(0), 0.0),
                                  (sp.Float(float(slope), 17) * parameter + sp.Float(float(intercept), 17), y - residual)):
            found = search.search(values, y - base_values, int(complexity), FORMULA_OPERATIONS)
            # a member that holds the constant's values no better than its line leaves the line in place
            members += [(int(found["complexity"][i]), float(found["rms"][i]),
                         base + grammar.substitute(found["forms"][i],
                                                   [sp.Float(float(c), 17) for c in
                                                    found["constants"][i][:grammar.constants(found["forms"][i])]],
                                                   [parameter], sympy_functions()))
                        for i in found["front"] if found["rms"][i] < line_rms]
        fronts.append(members)
    k = constant_symbols(line.template.count)
    key = _error_key(target)
    best = None
    for level in sorted({c for front in fronts for c, _, _ in front}):
        formulas = [expression if not any(c <= level for c, _, _ in front) else
                    min((m for m in front if m[0] <= level), key=lambda m: m[1])[2]
                    for expression, front in zip(line_expressions, fronts)]
        pixel, polished = _polished(line.template.expression.xreplace(dict(zip(k, formulas))), target, f, values)
        formulas = [e.xreplace(polished) for e in formulas]
        errors = measure_box(pixel, target, f)
        if errors[key] < (best.errors[key] if best else line.errors[key] * (1 - 1e-6)):
            best = dataclasses.replace(line, formula=f"found{level}", pixel=pixel, errors=errors,
                                       formulas=tuple(formulas))
    log(f"  {line.template.name}: lines {line.errors[key]:.4g}, formulas found "
        + (f"{best.errors[key]:.4g} ({best.formula})" if best else "no better"))
    return best


def _polished(expression, target, f, values):
    """(the expression (in the axes) with its numbers polished together by minimax on the box
    (`minimax_on_box`, from their values), {each number: its polished value})."""
    import sympy as sp

    (free,), q, numbers = free_numbers(expression)
    model = Model(free, target.symbols(), q)
    a, _ = minimax_on_box(model, model.jacobian, [float(v) for v in numbers], target, f, values)
    polished = {v: sp.Float(x, 17) for v, x in zip(numbers, a)}
    return free.xreplace(dict(zip(q, polished.values()))), polished


def refitted_anchors(target: ParametricTarget, f, log) -> tuple[list[dict], dict]:
    """Each anchor's form with its decimal numbers refitted together by minimax on the box
    (`_polished`, from their own values, at the parameter's grid and halfway values), as a pixel form,
    where that lowers its error: the engines' own form at its own cost, with the numbers the exact
    function asks for. An anchor without decimal numbers has none. Returns (the forms as `_searched`'s
    records, the coverage)."""
    import sympy as sp

    values = None if target.parameter is None else np.sort(np.concatenate(parameter_values(target.parameter)))
    key = _error_key(target)
    out = []
    for anchor, expr in zip(target.anchors, target.anchor_expressions().values()):
        if not expr.atoms(sp.Float):
            continue
        before = measure_box(expr, target, f)[key]
        refit, _ = _polished(expr, target, f, values)
        errors = measure_box(refit, target, f)
        if np.isfinite(errors[key]) and errors[key] < before * (1 - 1e-6):
            log(f"{anchor.name} refitted: error {before:.3g} -> {errors[key]:.3g}")
            out.append(dict(name=f"{anchor.name}_refitted", family="anchor_refit", expression=refit,
                            source=f"{anchor.name}'s form, its numbers refitted by minimax on the box", per="pixel",
                            errors=errors))
    return out, dict(refitted_anchors=[r["name"] for r in out])


def _error_key(target) -> str:
    return "max_abs_error" if target.metric == "abs" else "max_rel_error"


# ---- costs --------------------------------------------------------------------------------------

def glsl_text(expr, precision: str | None = None) -> str:
    """A form as GLSL in its symbols' names (forms' printer: exp2, squarings, inversesqrt), with
    `precision` its numbers the format's (`forms.in_format`); in fp16 each push constant c0, c1, ...
    (float32, as a renderer sets them) converted to float16_t where it is read."""
    import re

    from .forms import _GLSL, printed

    text = printed(_GLSL(), expr, precision)
    return re.sub(r"\b(c\d+)\b", r"float16_t(\1)", text) if precision == "fp16" else text


def compile_forms(forms: dict, target: ParametricTarget, architectures, precision: str = "fp32") -> tuple[dict, dict]:
    """({architecture: {name: cycles}}, {what: why not}) of `forms` ({name: (sympy, parameter_per)}),
    by `isa.machine_code.form_cycles`: a material form reads the variables, a pixel form the parameter
    too (each only those its expression holds). Both are net of the shader that reads and writes the
    variables alone: a pixel form pays the read of its parameter (an interpolated input, where a
    renderer fetches a texture). Netted of its parameter's read too, a form whose arithmetic hides
    that read behind its own latency would cost less per pixel than per material (pow(t, n): 6
    cycles against 12 on RDNA3, both shaders 16). In fp16 the form computes in float16 (explicit
    16-bit types, `shaders.form_shader`)."""
    from ..isa.machine_code import form_cycles

    names = list(target.names)
    variables = names[:len(target.variables)]
    bodies, missing = {}, {}
    for name, (expr, per) in forms.items():
        try:
            text = glsl_text(expr, precision)
        except Exception as e:          # a function the GLSL printer does not know
            missing[name] = f"no GLSL form ({type(e).__name__})"
            continue
        read = {s.name for s in expr.free_symbols}
        used = [n for n in (names if per == "pixel" else variables) if n in read] or names[:1]
        bodies[name] = (f"return {text};", used, [n for n in used if n in variables] or used)
    cycles, more, _ = form_cycles(bodies, names, architectures, precision)
    return cycles, missing | more


# ---- the derivation -----------------------------------------------------------------------------

def execution_points(target, peaks=()) -> list[np.ndarray]:
    """Where a form of `target` is executed (`executed_box`), one array per axis (`target.names`'
    order): the box's measuring grid (`MEASURE_GRID` per axis of the unit box, placed in the box),
    then each peak (a point of the unit box)."""
    from ..optics import brdf

    lo, hi = _unit_box(target)
    axes = [brdf.axis_grid(a, b, **MEASURE_GRID) for a, b in zip(lo, hi)]
    columns = [g.ravel() for g in np.meshgrid(*axes, indexing="ij")]
    extra = [np.asarray(p, dtype=np.float64) for p in peaks if p is not None and np.all(np.isfinite(p))]
    if extra:
        columns = [np.concatenate([c, [p[i] for p in extra]]) for i, c in enumerate(columns)]
    return _place(target, columns)


def error_peaks(expression, target: ParametricTarget, f) -> list[np.ndarray]:
    """Where a form's float64 error in the target's measure peaks on the unit box (`brdf.largest_error`,
    as `measure_box` finds it)."""
    from ..optics import brdf

    approx, exact = _numpy_of(expression, target.symbols()), f
    if any(a.lo_of for a in target.variables):
        approx = (lambda g: lambda *s: g(*_place(target, s)))(approx)
        exact = lambda *s: f(*_place(target, s))        # noqa: E731
    lo, hi = _unit_box(target)
    if target.metric == "rel" and target.floor > 0:
        value, where = brdf.largest(lambda *s: (approx(*s) - exact(*s)) / np.maximum(np.abs(exact(*s)), target.floor),
                                    lo, hi, **MEASURE_GRID)
    else:
        value, where = brdf.largest_error(approx, exact, lo, hi, relative=target.metric == "rel", **MEASURE_GRID)
    return [np.asarray(where, dtype=np.float64)] if np.isfinite(value) else []


def _executed(everything, per_of, record, target, f, real, cycles, architectures, error_key, constant, floor,
              log, precision: str = "fp32") -> dict:
    """Every form executed in float32 (`executed_box`) at the box's grid and where the float64 error
    of each member of a float64 front, each anchor and the target itself peaks: dict(measured={name:
    its executed errors, NaN where not executed}, how, inputs, not_executed, peaks, seconds)."""
    from . import engine, executed_box

    started = time.perf_counter()
    provisional = set()
    for a in architectures:
        by_name = cycles.get(a, {})
        for per in ("pixel", "material"):
            rows = [dict(name=m.name, cycles=by_name[m.name], **real[m.name]) for m in everything
                    if m.kind == "found" and per_of[m.name][1] == per and m.name in by_name
                    and real[m.name][error_key] < constant]
            provisional |= {r["name"] for r in engine.front(rows, error_key, floor)}
    peaks = [where for m in everything if (m.name in provisional and per_of[m.name][1] == "pixel") or m.kind != "found"
             for where in error_peaks(m.expression, target, f)]
    bodies, not_printed = {}, {}
    for m in everything:
        try:
            bodies[m.name] = (glsl_text(m.expression, precision), record[m.name]["formulas"]["constants"]
                              if per_of[m.name][1] == "material" else None)
        except Exception as e:          # (a function the GLSL printer does not know)
            not_printed[m.name] = f"{m.name}: no GLSL form ({type(e).__name__})"
    log(f"executing {len(bodies)} forms in {precision} over the box")
    run = executed_box.measure(bodies, target.names, execution_points(target, peaks), target.numpy(),
                               target.floor if target.metric == "rel" else 0.0, precision)
    measured = {m.name: run["errors"].get(m.name) or executed_box.nan_errors() for m in everything}
    log(f"executed on {run['inputs']} points by {run['how']} in {time.perf_counter() - started:.1f} s")
    return dict(measured=measured, how=run["how"], inputs=run["inputs"], not_executed=run["not_executed"] | not_printed,
                peaks=len(peaks), seconds=round(time.perf_counter() - started, 1))


def derive(target: ParametricTarget, gpu=None, seconds: float = 60.0, max_cycles: float | None = None,
           max_complexity: int = 12, log=print, formula_complexity: int = 0, precision: str = "fp32") -> dict:
    """The derivation of the module docstring for `target` on the architectures `gpu` (names;
    default every one whose compiler runs here), with `formula_complexity` > 0 the lines of the best
    templates also corrected by the symbolic regression (`corrected`). Returns the results
    (results.json's content) with the rows of front.csv."""
    from . import engine

    check(target)
    architectures = engine.checked_options(gpu, seconds, max_cycles, max_complexity)
    started = time.perf_counter()
    f = target.numpy()
    error_key = _error_key(target)
    log(f"{target.name}: {target.expression} for {', '.join(a.text() for a in target.axes)}, error {target.metric}; "
        f"{len(architectures)} architecture{'s' * (len(architectures) > 1)}")

    if not (isinstance(formula_complexity, int) and 0 <= formula_complexity <= MAX_FORMULA_COMPLEXITY):
        raise DeriveError(f"--formula-complexity {formula_complexity}: give an integer in [0, {MAX_FORMULA_COMPLEXITY}]")
    if formula_complexity and target.parameter is None:
        raise DeriveError(f"{target.name} has no parameter: --formula-complexity applies to targets with one")
    found, coverage = _searched(target, f, seconds, max_complexity, log, formula_complexity)
    forms = [Form(r["name"], "found", r["family"], r["expression"], r["source"]) for r in found]
    per_of = {r["name"]: (r["expression"], r["per"]) for r in found}
    record = {r["name"]: r for r in found}
    anchors = [Form(a.name, "anchor", "anchor", expr, a.source)
               for a, expr in zip(target.anchors, target.anchor_expressions().values())]
    # (a table's own cost is a texture fetch, which these shaders do not measure)
    exact = [] if target.table is not None else [Form("exact", "exact", "exact", target.sympy(), "the target itself")]
    for m in anchors + exact:
        per_of[m.name] = (m.expression, "pixel")
    everything = forms + anchors + exact
    log(f"measuring {len(everything)} forms over the whole box and compiling them for {len(architectures)} "
        "architectures")
    errors = {m.name: record[m.name]["errors"] if m.name in record else measure_box(m.expression, target, f)
              for m in everything}
    cycles, missing = compile_forms(per_of, target, architectures, precision)
    constant = _constant_error(target, f)
    floor = engine.rounding_floor(target, constant, precision)
    real = errors
    execution = _executed(everything, per_of, record, target, f, real, cycles, architectures, error_key, constant,
                          floor, log, precision)
    errors = execution.pop("measured")

    rows, fronts, verdicts = [], {}, {}
    for a in architectures:
        by_name = cycles.get(a, {})
        fronts[a] = {}
        for per in ("pixel", "material"):
            candidates_ = [dict(name=m.name, cycles=by_name[m.name], **errors[m.name]) for m in forms
                           if per_of[m.name][1] == per and m.name in by_name
                           and (max_cycles is None or by_name[m.name] <= max_cycles)
                           and errors[m.name][error_key] < constant]
            fronts[a][per] = [r["name"] for r in engine.front(candidates_, error_key, floor)]
        on_front = set(fronts[a]["pixel"]) | set(fronts[a]["material"])
        for m in everything:
            if m.name not in by_name or (m.kind == "found" and m.name not in on_front):
                continue
            rows.append(dict(architecture=a, kind=m.kind, name=m.name, family=m.family,
                             expression=_text(m, record, target), cycles=by_name[m.name],
                             cycles_predicted=None, max_abs_error=errors[m.name]["max_abs_error"],
                             max_rel_error=errors[m.name]["max_rel_error"], on_front=m.name in on_front,
                             source=m.source, range=target.range_text(), parameter_per=per_of[m.name][1]
                             if target.parameter is not None else "",
                             max_abs_error_real=real[m.name]["max_abs_error"],
                             max_rel_error_real=real[m.name]["max_rel_error"], precision=precision))
        pixel_front = [r for r in rows if r["architecture"] == a and r["name"] in fronts[a]["pixel"]]
        verdicts[a] = {m.name: dict(cycles=by_name[m.name], error=errors[m.name][error_key],
                                    **engine.verdict(by_name[m.name], errors[m.name][error_key], pixel_front,
                                                     error_key, floor))
                       for m in anchors if m.name in by_name}
    elapsed = time.perf_counter() - started
    log(f"done in {elapsed:.0f} s")
    members = {}
    for m in everything:
        if m.kind == "found" and not any(m.name in fr[p] for fr in fronts.values() for p in fr):
            continue
        members[m.name] = dict(kind=m.kind, family=m.family, source=m.source, converged=True,
                               expression=_text(m, record, target), **errors[m.name],
                               max_abs_error_real=real[m.name]["max_abs_error"],
                               max_rel_error_real=real[m.name]["max_rel_error"],
                               **(dict(parameter_per=per_of[m.name][1] if target.parameter is not None else "")
                                  | record.get(m.name, {}).get("formulas", {})))
    return dict(target=dict(name=target.name, expression=target.expression, variable=target.variable,
                            variables=[dataclasses.asdict(a) for a in target.variables],
                            parameter=dataclasses.asdict(target.parameter) if target.parameter else None,
                            domain=target.domain, metric=target.metric, floor=target.floor,
                            description=target.description,
                            anchors=[dict(name=a.name, expression=a.expression, source=a.source) for a in target.anchors]),
                architectures=architectures, missing=missing, coverage=coverage,
                families=sorted({m.family for m in forms if m.family != "grammar"}),
                family_members=[m.name for m in forms if m.family != "grammar"],
                fronts={a: fr["pixel"] + [n for n in fr["material"] if n not in fr["pixel"]] for a, fr in fronts.items()},
                fronts_by_parameter=fronts, verdicts=verdicts, rows=rows, error=error_key, constant_error=constant,
                rounding_floor=floor, precision=precision, execution=execution, cost_tables={},
                seconds=round(elapsed, 1), estimated_seconds=None,
                members=members, forms={m.name: m for m in everything})


COS_N_LEVEL = 0.5           # the registered cos_n's zone: cos^n at least half its peak (the lobe's half maximum)


def cos_n_target(level: float = COS_N_LEVEL, n: tuple[float, float] = (2.0, 1000.0)) -> ParametricTarget:
    """cos^n over its epicenter zone {cos^n >= level} (t = cos in [level^(1/n), 1], a range that moves
    with n) and n per material, by the relative error (the paper's d): the lobe search's problem, which
    the `lobe_search` stage poses at the run's calibrated level. Anchors: the paper's and the
    engines' lobes of `optics.registry` with the paper's constants (`targets.paper_lobes`). Its family
    templates go to degree 2 in t, as the lobe search's families do: at n = 1000 the zone is
    t in [0.9993, 1], where the monomials of degree 3 and 4 are nearly dependent and the formulas'
    polish does not converge (a reciprocal cubic fits each n closely, and errs above 1 with every
    formula in n)."""
    if not 0.0 < level < 1.0:
        raise DeriveError(f"cos_n: the zone's level {level}: give a number in (0, 1)")
    lowest = level ** (1.0 / n[0])
    return ParametricTarget(
        "cos_n", "t**n", (Axis("t", lowest, 1.0, lo_of=f"{level!r}**(1/n)"),), Axis("n", float(n[0]), float(n[1])),
        "rel", anchors=paper_lobes(), max_degree=2,
        description=f"cos^n in its epicenter zone cos^n >= {level:g} (the paper's lobe search), n the Phong exponent",
        role="lobe")


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


def registry() -> dict[str, ParametricTarget]:
    """The registered targets of several variables or a parameter, by name."""
    from ..optics import brdf

    unit = (0.01, 1.0)
    return {
        "smith_ggx_visibility": ParametricTarget(
            "smith_ggx_visibility",
            "0.5/(NoL*sqrt(NoV**2*(1 - alpha**2) + alpha**2) + NoV*sqrt(NoL**2*(1 - alpha**2) + alpha**2))",
            (Axis("NoV", *unit), Axis("NoL", *unit)), Axis("alpha", 0.02, 1.0), "rel",
            anchors=(Anchor("Hammon", "0.5/(2*NoL*NoV*(1 - alpha) + (NoL + NoV)*alpha)", brdf.HAMMON_2017),
                     Anchor("Filament_fast", "0.5/(NoV*(NoL*(1 - alpha) + alpha) + NoL*(NoV*(1 - alpha) + alpha))",
                            brdf.FILAMENT_2018)),
            description="the height-correlated Smith-GGX visibility V = G2 / (4 NoV NoL) (Heitz 2014), alpha the "
                        "GGX roughness", role="visibility"),
        **env_brdf_targets(),
        "cos_n": cos_n_target(),
    }


ENV_BRDF_POINTS = 65        # the table's Chebyshev-Lobatto points per axis (cubic splines between: within 2e-6)
ENV_BRDF_BOX = (Axis("NoV", 0.02, 1.0), Axis("roughness", 0.05, 1.0))
# (A, B) of Karis's EnvBRDFApprox and Lazarov's fit (optics.brdf), in the targets' names
ENV_BRDF_ANCHORS = {
    "Karis": ("-1.04*(min((1 - roughness)**2, exp2(-9.28*NoV))*(1 - roughness) + 0.0425 - 0.0275*roughness) "
              "+ 1.04 - 0.572*roughness",
              "1.04*(min((1 - roughness)**2, exp2(-9.28*NoV))*(1 - roughness) + 0.0425 - 0.0275*roughness) "
              "- 0.04 + 0.022*roughness"),
    "Lazarov": ("0.25*(1 - roughness) + 0.75 - ((1 - roughness)/0.96*min(0.475*(1 - roughness), exp2(-9.28*NoV)) "
                "+ (0.0275 - 0.25*0.04)/0.96*(1 - roughness) + (0.015 - 0.75*0.04)/0.96)",
                "(1 - roughness)/0.96*min(0.475*(1 - roughness), exp2(-9.28*NoV)) "
                "+ (0.0275 - 0.25*0.04)/0.96*(1 - roughness) + (0.015 - 0.75*0.04)/0.96"),
}


@functools.cache
def env_brdf_table() -> tuple[Table, Table]:
    """(A, B) of the split-sum environment BRDF of GGX (`optics.brdf.env_brdf`, its quadrature) on
    ENV_BRDF_POINTS x ENV_BRDF_POINTS Chebyshev points of NoV and roughness, as tables."""
    from ..optics import brdf

    axes = [_chebyshev(a.lo, a.hi, ENV_BRDF_POINTS) for a in ENV_BRDF_BOX]
    A, B = brdf.env_brdf_table(*axes)
    return (Table(axes, A, "env_brdf A (optics.brdf.env_brdf)"), Table(axes, B, "env_brdf B (optics.brdf.env_brdf)"))


class _LazyTable(Table):
    """`env_brdf_table()[part]`, computed when first read (the registry is listed often)."""

    def __init__(self, part: int):                     # noqa: super().__init__ runs on first use
        self.part = part
        self.text = f"table env_brdf {'AB'[part]} (optics.brdf.env_brdf, {ENV_BRDF_POINTS} x {ENV_BRDF_POINTS} values)"

    def __repr__(self) -> str:          # (the computed table's digest: a kept search follows its numbers)
        return env_brdf_table()[self.part].text

    def __getattr__(self, name):
        if name in ("axes", "values", "source", "_spline"):
            table = env_brdf_table()[self.part]
            self.axes, self.values, self.source, self._spline = table.axes, table.values, table.source, None
            return getattr(self, name)
        raise AttributeError(name)


def env_brdf_targets() -> dict[str, ParametricTarget]:
    """The environment BRDF's scale A and bias B (`optics.brdf.env_brdf`) over NoV and the roughness
    (per material, or per pixel from a texture), absolute error, Karis's and Lazarov's fits as anchors
    (`pipeline derive --target env_brdf` derives both and pairs them: `derive_pair`)."""
    from ..optics import brdf

    out = {}
    for part, (name, what) in enumerate((("env_brdf_scale", "A, the scale of F0"), ("env_brdf_bias", "B, the bias"))):
        out[name] = ParametricTarget(
            name, name, (ENV_BRDF_BOX[0],), ENV_BRDF_BOX[1], "abs",
            anchors=tuple(Anchor(a, pair[part], brdf.KARIS_2014 if a == "Karis" else brdf.LAZAROV_2013)
                          for a, pair in ENV_BRDF_ANCHORS.items()),
            description=f"the split-sum environment BRDF of GGX (alpha = roughness^2, Schlick-Smith k = alpha / 2), {what}: "
                        "a table by the pipeline's quadrature",
            table=_LazyTable(part))
    return out


def _leaves(tree) -> list:
    return [tree] if len(tree) == 1 else [leaf for a in tree[1:] for leaf in _leaves(a)]


def _constant_error(target, f) -> float:
    """The error of the best constant over the measuring grid (a form worth a cycle beats it)."""
    values = f(*mesh(target, 17))
    if target.metric == "abs":
        return float(values.max() - values.min()) / 2
    if values.min() < 0 < values.max():
        return 1.0
    size = np.maximum(np.abs(values), target.floor)
    return float((size.max() - size.min()) / (size.max() + size.min()))


def _text(m: Form, record: dict, target) -> str:
    """A row's expression: the form; a material form's with its constants' formulas."""
    import sympy as sp

    if m.kind == "exact":
        return target.expression
    if m.name in record and "formulas" in record[m.name] and record[m.name]["per"] == "material":
        return (sp.sstr(m.expression) + "; " +
                ", ".join(f"c{i} = {c}" for i, c in enumerate(record[m.name]["formulas"]["constants"])))
    return sp.sstr(sp.N(m.expression, 9))


def _kept(key: list, compute, log, what: str, target):
    """compute() -> (records, coverage), kept in `paths.DERIVE_CACHE` under `key` and this code; an
    entry that cannot be read is computed again."""
    import hashlib
    import json

    from ..engine import paths
    from . import engine
    from . import kept as keeping

    text = json.dumps([engine._code_version(), *key])
    symbols = {s.name: s for s in kept_symbols(target)}
    kept = paths.DERIVE_CACHE / f"{hashlib.sha256(text.encode()).hexdigest()[:32]}.json"
    entry = keeping.read(kept, log)
    try:
        if entry is not None:
            found = [r | dict(expression=keeping.expression(r["expression"], symbols)) for r in entry["found"]]
            log(f"the {what} of an earlier run, kept in {kept.parent}")
            return found, entry["coverage"] | dict(kept=True)
    except keeping.Unusable as e:
        log(f"the kept {what} {kept.name} is not used ({e}): computed again")
    except (ValueError, KeyError, TypeError) as e:
        log(f"the kept {what} {kept.name} is not readable ({type(e).__name__}): computed again")
    found, coverage = compute()
    try:
        texts = [keeping.text(r["expression"], symbols) for r in found]
    except keeping.Unusable as e:
        log(f"the {what} are not kept ({e})")
    else:
        keeping.write(kept, dict(found=[r | dict(expression=t) for r, t in zip(found, texts)], coverage=coverage))
    return found, coverage | dict(kept=False)


def _searched(target, f, seconds: float, max_complexity: int, log, formula_complexity: int = 0) -> tuple[list[dict], dict]:
    """(the found forms, each {name, family, expression (sympy), source, per (material or pixel),
    errors, and for a template's, formulas: {formula, per_value_error, per_value_worst, constants}},
    the coverage): steps 1 to 4 of the module docstring. The families' fits are kept by the target
    and this code, the grammar's forms also by the budget, so that a rerun with other --gpu or
    --max-cycles only compiles, and one with another budget only searches again."""
    found, coverage = [], dict(max_complexity=int(max_complexity))
    if target.parameter is not None:
        families, coverage["families"] = _kept([repr(target), "families", formula_complexity],
                                               lambda: _family_search(target, f, log, formula_complexity),
                                               log, "families' fits", target)
        found += families
    grammar_found, coverage["grammar"] = _kept([repr(target), "grammar", seconds, max_complexity, formula_complexity],
                                               lambda: _grammar_search(target, f, seconds, max_complexity, log,
                                                                       formula_complexity),
                                               log, "grammar's search", target)
    found += grammar_found
    refits, coverage["anchors"] = _kept([repr(target), "anchors"], lambda: refitted_anchors(target, f, log), log,
                                        "anchors' refits", target)
    found += refits
    for part in ("families", "grammar", "anchors"):
        coverage.update({k: v for k, v in coverage.get(part, {}).items() if k != "kept"})
    coverage["kept"] = all(coverage.get(part, {}).get("kept", True) for part in ("families", "grammar", "anchors"))
    return found, coverage


def _records(materials, target) -> list[dict]:
    """Each fitted template as two forms: its constants per material (push constants) and per pixel."""
    import sympy as sp

    parameter = target.symbols()[-1]
    out = []
    for m in materials:
        formulas = dict(formula=m.formula, per_value_error=float(m.per_value.errors.max()),
                        per_value_worst=float(m.per_value.values[int(np.argmax(m.per_value.errors))]),
                        constants=[sp.sstr(sp.N(e, 7)) for e in m.constant_formulas(parameter)])
        for per, expr in (("material", m.material), ("pixel", m.pixel)):
            out.append(dict(name=f"{m.name}_{per}", family=m.template.family, expression=expr,
                            source=m.template.source, per=per, errors=m.errors,
                            formulas=formulas | dict(parameter_per=per)))
        scaled = _scaled(m, parameter)
        if scaled is not None:
            out.append(dict(name=f"{m.name}_scaled_pixel", family=m.template.family, expression=scaled,
                            source=m.template.source + "; written with one formula's factor in the numerator",
                            per="pixel", errors=m.errors, formulas=formulas | dict(parameter_per="pixel")))
    return out


def _scaled(m, parameter):
    """A reciprocal template's pixel form with one constant's factor moved to the numerator,
    a / (k0 b0 + k1 b1) = (a / c) / ((k0 / c) b0 + p^j b1) where k1 = c p^j is one term (a proportion or
    a constant): the same function, one multiply fewer where the compiler cannot fold the factor
    (a multiply-add takes one immediate on NVIDIA). None for another template."""
    import sympy as sp

    if m.template.outer != "reciprocal" or m.formulas is not None:
        return None
    single = [i for i, row in enumerate(m.coefficients) if np.count_nonzero(row) == 1]
    if not single:
        return None
    j = single[0]
    factor = float(m.coefficients[j][np.flatnonzero(m.coefficients[j])[0]])
    k = constant_symbols(m.template.count)
    coefficients = m.coefficients / factor
    coefficients[j] = np.where(coefficients[j] != 0, 1.0, 0.0)       # (exactly 1: no multiply)
    formulas = formula_expressions(coefficients, parameter)
    return sp.Float(1 / factor, 17) * m.template.expression.xreplace(dict(zip(k, formulas)))


def _family_search(target, f, log, formula_complexity: int = 0) -> tuple[list[dict], dict]:
    """The families' templates fitted (steps 2 and 3)."""
    symmetric = is_symmetric(target, f)
    positive = bool(np.all(f(*mesh(target, AXIS_POINTS)) > 0))
    templates = family_templates(target, symmetric, positive)
    log(f"{len(templates)} family templates{' (the target is symmetric in its two variables)' if symmetric else ''}: "
        f"constants fitted at {2 * PARAMETER_VALUES - 1} values of {target.parameter.name}, then as formulas")
    started = time.perf_counter()
    materials = material_forms(templates, target, f, log, formula_complexity)
    return _records(materials, target), dict(parameter_values=2 * PARAMETER_VALUES - 1, symmetric=symmetric,
                                             family_templates=len(templates),
                                             family_seconds=round(time.perf_counter() - started, 1))


def _grammar_search(target, f, seconds: float, max_complexity: int, log, formula_complexity: int = 0) -> tuple[list[dict], dict]:
    """The grammar's templates fitted (steps 1 to 3) and the pixel search (step 4)."""
    from ..symbolic import grammar, ladder

    symbols = target.symbols()
    found: list[dict] = []
    coverage: dict = {}
    if target.parameter is not None:
        templates, coverage["templates"] = grammar_templates(target, f, seconds * (1 - PIXEL_SHARE),
                                                             max_complexity, log)
        log(f"{len(templates)} grammar templates: constants fitted per value of {target.parameter.name}, then as "
            "formulas")
        started = time.perf_counter()
        found += _records(material_forms(templates, target, f, log, formula_complexity), target)
        coverage["templates"].update(count=len(templates), seconds=round(time.perf_counter() - started, 1),
                                     at=_middle(target.parameter))
    # the pixel search: the grammar in the variables and the parameter together
    x = mesh(target, SEARCH_AXIS_POINTS)
    y = f(*x)
    loss = _loss(target)
    share = seconds * (PIXEL_SHARE if target.parameter is not None else 1.0)
    candidates, rungs, _ = ladder.run(np.stack(x), y, max_complexity, grammar.TEN, share, loss,
                                      log=lambda s: log("pixel search: " + s))
    coverage["pixel_search"] = dict(rungs=[r.row() for r in rungs], points=int(y.size), loss=loss)
    for i, (tree, c, loss_value, *_) in enumerate(sorted(candidates, key=lambda c: grammar.complexity(c[0]))):
        if not np.isfinite(loss_value) or not any(grammar.is_variable(leaf) for leaf in _leaves(tree)):
            continue                # (a constant approximates nothing)
        expr = grammar.to_sympy(tree, c, symbols)
        found.append(dict(name=f"search_{i + 1}", family="grammar", expression=expr,
                          source=f"grammar: {grammar.show(tree, list(target.names))}", per="pixel",
                          errors=measure_box(expr, target, f)))
    return found, coverage


# ---- a TOML file --------------------------------------------------------------------------------

AXIS_KEYS = {"name", "range"}


def from_file(path):
    """A target from a TOML file: with [[variable]] tables (name, range = [lo, hi]) and at most one
    [parameter] table, a ParametricTarget (its [target] table: name, expression, metric, floor,
    description; its [[anchor]] tables as one variable's file has them); without, the one-variable
    file of `targets.from_file`. Raises DeriveError naming a missing or unknown key or a bad value."""
    from pathlib import Path

    from . import targets

    path = Path(path)
    data = targets.read_toml(path)
    if "variable" not in data and "parameter" not in data:
        return targets.from_file(path)
    unknown = sorted(set(data) - {"target", "anchor", "variable", "parameter"})
    table = data.get("target")
    if unknown or not isinstance(table, dict):
        raise DeriveError(f"{path}: unknown table {unknown[0]!r}" if unknown else f"{path}: no [target] table")
    keys = {"name", "expression", "metric", "floor", "description", "role"}
    bad = sorted(set(table) - keys)
    if bad or "expression" not in table:
        raise DeriveError(f"{path}: [target] has an unknown key {bad[0]!r} (keys: {', '.join(sorted(keys))})" if bad
                          else f"{path}: [target] needs an expression")

    def axis(entry, where):
        if not isinstance(entry, dict) or set(entry) != AXIS_KEYS:
            raise DeriveError(f"{path}: {where}: give name and range = [lo, hi] (only)")
        lo_hi = entry["range"]
        if not (isinstance(lo_hi, list) and len(lo_hi) == 2 and all(isinstance(v, (int, float)) and not isinstance(v, bool)
                                                                      for v in lo_hi)):
            raise DeriveError(f"{path}: {where}: range = {lo_hi!r}: give [lo, hi]")
        return Axis(str(entry["name"]), float(lo_hi[0]), float(lo_hi[1]))

    variables = data.get("variable", [])
    if not isinstance(variables, list) or not variables:
        raise DeriveError(f"{path}: give the variables as [[variable]] tables")
    return check(ParametricTarget(
        str(table.get("name", path.stem)), str(table["expression"]),
        tuple(axis(v, f"[[variable]] {i + 1}") for i, v in enumerate(variables)),
        axis(data["parameter"], "[parameter]") if "parameter" in data else None,
        str(table.get("metric", "abs")), targets.read_floor(table, path), targets.read_anchors(data, path),
        str(table.get("description", "")), role=str(table.get("role", ""))))


# ---- a table in a CSV file ------------------------------------------------------------------------

def from_csv(path, variables, parameter: str | None = None, output: str | None = None, metric: str = "abs",
             floor: float = 0.0) -> ParametricTarget:
    """A table target from a CSV file: a header, then one row per point of a full grid of the
    `variables` (and the `parameter`) with the value in the column `output` (default: the one column
    left). Each axis's range is its values' span. Raises DeriveError naming a missing file or column,
    a value that is not a number, or rows that do not fill the grid."""
    import csv
    from pathlib import Path

    path = Path(path)
    if not path.is_file():
        raise DeriveError(f"{path}: no such file")
    try:
        with open(path, newline="", encoding="utf-8") as f:
            rows = list(csv.reader(f))
    except (UnicodeDecodeError, csv.Error) as e:
        raise DeriveError(f"{path}: not a CSV file ({e})") from None
    if len(rows) < 2:
        raise DeriveError(f"{path}: a header and at least one row are needed")
    header = [h.strip() for h in rows[0]]
    names = list(variables) + ([parameter] if parameter else [])
    missing = [n for n in names if n not in header]
    if missing:
        raise DeriveError(f"{path}: no column {missing[0]!r} (the columns: {', '.join(header)})")
    rest = [h for h in header if h not in names]
    if output is None:
        if len(rest) != 1:
            raise DeriveError(f"{path}: name the value's column (--output): the other columns are {', '.join(rest)}")
        output = rest[0]
    if output not in header:
        raise DeriveError(f"{path}: no column {output!r} (the columns: {', '.join(header)})")
    columns = [header.index(n) for n in names + [output]]
    data = np.empty((len(rows) - 1, len(columns)))
    for i, row in enumerate(rows[1:]):
        try:
            data[i] = [float(row[j]) for j in columns]
        except (ValueError, IndexError):
            raise DeriveError(f"{path}: row {i + 2}: {','.join(row)!r} has no number in every column named") from None
    axes = [np.unique(data[:, k]) for k in range(len(names))]
    shape = tuple(a.size for a in axes)
    if int(np.prod(shape)) != data.shape[0]:
        raise DeriveError(f"{path}: {data.shape[0]} rows do not fill the grid of {' x '.join(map(str, shape))} "
                          f"values of {', '.join(names)}")
    values = np.full(shape, np.nan)
    index = tuple(np.searchsorted(a, data[:, k]) for k, a in enumerate(axes))
    values[index] = data[:, -1]
    if np.isnan(values).any():
        raise DeriveError(f"{path}: a point of the grid of {', '.join(names)} repeats, another is missing")
    table = Table(axes, values, path.name)
    axis = [Axis(n, float(a[0]), float(a[-1])) for n, a in zip(names, axes)]
    return check(ParametricTarget(path.stem, f"{output} in {path.name}", tuple(axis[:len(variables)]),
                                  axis[-1] if parameter else None, metric, floor, table=table,
                                  description=f"the column {output} of {path.name}, interpolated by cubic splines"))


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


def pairs() -> dict[str, PairTarget]:
    targets = env_brdf_targets()
    return {"env_brdf": PairTarget("env_brdf", targets["env_brdf_scale"], targets["env_brdf_bias"],
                                   "the split-sum environment BRDF of GGX: its scale A and bias B together, "
                                   "as a shader computes F0 A + B", role="env_brdf")}


def check_pair(target: PairTarget) -> PairTarget:
    check(target.scale)
    check(target.bias)
    if target.scale.axes != target.bias.axes or target.scale.metric != target.bias.metric:
        raise DeriveError(f"{target.name}: its two targets need the same variables, parameter and metric")
    fault = role_fault(target.role, len(target.scale.variables), target.scale.parameter is not None)
    if fault:
        raise DeriveError(f"{target.name}: {fault}")
    return target


def _renumbered(expr, offset: int):
    """expr with its push constants c0, c1, ... renamed c(offset), c(offset + 1), ..."""
    import sympy as sp

    symbols = {s for s in expr.free_symbols if s.name[:1] == "c" and s.name[1:].isdigit()}
    return expr.xreplace({s: sp.Symbol(f"c{int(s.name[1:]) + offset}", real=True) for s in symbols})


def refitted_pair_anchors(target: PairTarget, log) -> list[dict]:
    """Each anchor's two parts with their decimal numbers refitted together by minimax on the box
    (`minimax_on_box_parts`: a number both parts hold stays one number, as the anchor shares it), where
    that lowers the pair's error: [{name, scale, bias (sympy), errors: {scale, bias}}]."""
    import sympy as sp

    scale, bias = target.scale, target.bias
    key = _error_key(scale)
    values = np.sort(np.concatenate(parameter_values(scale.parameter)))
    fs = (scale.numpy(), bias.numpy())
    b_anchors = bias.anchor_expressions()
    out = []
    for name, a_expr in scale.anchor_expressions().items():
        if name not in b_anchors:
            continue
        exprs = (a_expr, b_anchors[name])
        free, q, numbers = free_numbers(*exprs)
        if not numbers:
            continue
        models = [Model(e, t.symbols(), q) for e, t in zip(free, (scale, bias))]
        a, _ = minimax_on_box_parts([(m, m.jacobian, t, g) for m, t, g in zip(models, (scale, bias), fs)],
                                    [float(v) for v in numbers], values)
        refit = [e.xreplace({qi: sp.Float(float(ai), 17) for qi, ai in zip(q, a)}) for e in free]
        before = max(measure_box(e, t, g)[key] for e, t, g in zip(exprs, (scale, bias), fs))
        errors = {part: measure_box(e, t, g) for part, e, t, g in zip(PAIR_PARTS, refit, (scale, bias), fs)}
        after = max(e[key] for e in errors.values())
        if np.isfinite(after) and after < before * (1 - 1e-6):
            log(f"{name} refitted (both parts together): error {before:.3g} -> {after:.3g}")
            out.append(dict(name=f"{name}_refitted", scale=refit[0], bias=refit[1], errors=errors))
    return out


def derive_pair(target: PairTarget, gpu=None, seconds: float = 60.0, max_cycles: float | None = None,
                max_complexity: int = 12, log=print, formula_complexity: int = 0) -> dict:
    """Each of the pair's targets derived (`derive`, its budget `seconds` each), then per architecture
    and per `parameter_per` every pair of their front members (and each anchor's two parts)
    compiled as one shader computing F0 A + B (F0 a push constant): the shared subexpressions of
    the two count once, as the compiler makes them. A pair's error is the larger of its two (each
    also in its own column); the fronts and verdicts are read off as for one output."""
    import sympy as sp

    from . import engine

    check_pair(target)
    started = time.perf_counter()
    parts = {}
    for part, t in zip(PAIR_PARTS, (target.scale, target.bias)):
        log(f"{part} ({t.name}):")
        parts[part] = derive(t, gpu, seconds, max_cycles, max_complexity, log=lambda s: log("  " + s),
                             formula_complexity=formula_complexity)
    scale, bias = parts["scale"], parts["bias"]
    architectures = scale["architectures"]
    F0 = sp.Symbol("F0", real=True)
    error_key = scale["error"]
    forms, per_of, members, errors = {}, {}, {}, {}

    def pair(a_name, b_name, per, kind):
        a_form, b_form = scale["forms"][a_name], bias["forms"][b_name]
        offset = len(scale["members"][a_name].get("constants", []))
        expr = F0 * a_form.expression + _renumbered(b_form.expression, offset)
        name = a_name if kind == "anchor" else f"{a_name} + {b_name}"
        forms[name] = Form(name, kind, "pair" if kind == "found" else kind, expr,
                           f"scale: {a_form.source}; bias: {b_form.source}" if kind == "found" else a_form.source)
        per_of[name] = (expr, per)
        ea, eb = scale["members"][a_name], bias["members"][b_name]
        errors[name] = {key: max(ea[key], eb[key]) for key in ("max_abs_error", "max_rel_error")} | {
            f"{key}_{part}": e[key] for key in ("max_abs_error", "max_rel_error") for part, e in (("scale", ea), ("bias", eb))}
        members[name] = dict(kind=kind, family=forms[name].family, source=forms[name].source, converged=True,
                             expression=f"A = {ea['expression']}; B = {eb['expression']}", **errors[name],
                             parameter_per=per, constants=ea.get("constants", []) + eb.get("constants", []),
                             parts=[a_name, b_name])

    for a in architectures:
        for per in ("pixel", "material"):
            for a_name, b_name in itertools.product(scale["fronts_by_parameter"][a][per],
                                                    bias["fronts_by_parameter"][a][per]):
                if f"{a_name} + {b_name}" not in forms:
                    pair(a_name, b_name, per, "found")
    for anchor in target.scale.anchors:
        if anchor.name in bias["members"]:
            pair(anchor.name, anchor.name, "pixel", "anchor")
    for r in refitted_pair_anchors(target, log):
        name, expr = r["name"], F0 * r["scale"] + r["bias"]
        forms[name] = Form(name, "found", "anchor_refit", expr,
                           f"{name.removesuffix('_refitted')}'s A and B, their numbers refitted together by minimax")
        per_of[name] = (expr, "pixel")
        ea, eb = r["errors"]["scale"], r["errors"]["bias"]
        errors[name] = {key: max(ea[key], eb[key]) for key in ("max_abs_error", "max_rel_error")} | {
            f"{key}_{part}": e[key] for key in ("max_abs_error", "max_rel_error") for part, e in (("scale", ea), ("bias", eb))}
        members[name] = dict(kind="found", family="anchor_refit", source=forms[name].source, converged=True,
                             expression=f"A = {sp.sstr(sp.N(r['scale'], 9))}; B = {sp.sstr(sp.N(r['bias'], 9))}",
                             **errors[name], parameter_per="pixel", constants=[], parts=[])
    log(f"pairs: {len(forms)} compiled for {len(architectures)} architectures (F0 A + B)")
    cycles, missing = compile_forms(per_of, target.scale, architectures)
    constant = max(scale["constant_error"], bias["constant_error"])
    floor = max(scale["rounding_floor"], bias["rounding_floor"])
    rows, fronts, by_parameter, verdicts = [], {}, {}, {}
    for a in architectures:
        by_name = cycles.get(a, {})
        by_parameter[a] = {}
        for per in ("pixel", "material"):
            candidates = [dict(name=n, cycles=by_name[n], **errors[n]) for n, m in forms.items()
                          if m.kind == "found" and per_of[n][1] == per and n in by_name
                          and (max_cycles is None or by_name[n] <= max_cycles) and errors[n][error_key] < constant]
            by_parameter[a][per] = [r["name"] for r in engine.front(candidates, error_key, floor)]
        fronts[a] = by_parameter[a]["pixel"] + [n for n in by_parameter[a]["material"] if n not in by_parameter[a]["pixel"]]
        for n, m in forms.items():
            if n not in by_name or (m.kind == "found" and n not in fronts[a]):
                continue
            rows.append(dict(architecture=a, kind=m.kind, name=n, family=m.family, expression=members[n]["expression"],
                             cycles=by_name[n], cycles_predicted=None, **errors[n], on_front=n in fronts[a],
                             source=m.source, range=target.scale.range_text(), parameter_per=per_of[n][1]))
        pixel_front = [r for r in rows if r["architecture"] == a and r["name"] in by_parameter[a]["pixel"]]
        verdicts[a] = {n: dict(cycles=by_name[n], error=errors[n][error_key],
                               **engine.verdict(by_name[n], errors[n][error_key], pixel_front, error_key, floor))
                       for n, m in forms.items() if m.kind == "anchor" and n in by_name}
    kept = {n for fr in fronts.values() for n in fr} | {n for n, m in forms.items() if m.kind == "anchor"}
    elapsed = time.perf_counter() - started
    log(f"done in {elapsed:.0f} s")
    t = scale["target"]
    return dict(target=t | dict(name=target.name, expression=f"(A, B) = ({target.scale.name}, {target.bias.name})",
                                description=target.description, variable=", ".join(target.scale.names) + ", F0"),
                architectures=architectures, missing=missing | scale["missing"] | bias["missing"],
                coverage=dict(scale=scale["coverage"], bias=bias["coverage"], pairs=len(forms)),
                families=sorted(set(scale["families"]) | set(bias["families"])), family_members=[],
                fronts=fronts, fronts_by_parameter=by_parameter, verdicts=verdicts, rows=rows, error=error_key,
                constant_error=constant, rounding_floor=floor, cost_tables={}, seconds=round(elapsed, 1),
                estimated_seconds=None, members={n: members[n] for n in forms if n in kept},
                forms=forms, parts=dict(scale=publish_part(scale), bias=publish_part(bias)))


def publish_part(results: dict) -> dict:
    """A pair's part as results.json keeps it: its fronts, verdicts and coverage."""
    return {k: results[k] for k in ("fronts_by_parameter", "verdicts", "coverage", "seconds")}
