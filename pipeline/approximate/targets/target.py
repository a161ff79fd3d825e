"""The one kind of target `pipeline derive` approximates (`Target`): its variables (one or more axes,
each with its range, a range that may move with the parameter), at most one material parameter, its
exact function (sympy text, from which its numpy, JAX and sympy forms come, or values on a grid, a
`Table`), one output or a pair of outputs a shader computes together (`parts`), its error measure,
the format it is computed in, where it enters a shading (its role) and the hand approximations
engines ship for it (anchors), each with its source. Its `shape` says which engine derives it.

A target's error measure is the largest error over its whole domain: `abs`, |a - f|, or `rel`,
|a - f| / max(|f|, floor) (with floor 0, the relative error proper, which a target that reaches 0
cannot have).

Expressions are read by the one parser of outside text (`engine.expressions`: Python's syntax, ^ a
power, numbers, the variables, pi, E, + - * / ** and calls of sympy's elementary and special
functions by name, with exp2, log2, rsqrt, saturate, clamp and mix as a shader writes them); nothing
in a file is ever run.
"""

from __future__ import annotations

import dataclasses
import hashlib

import numpy as np

METRICS = ("abs", "rel")
PRECISIONS = ("fp32", "fp16")   # the formats a shader computes in (`measures.executed`)
MAX_AXES = 3                    # a shader's inputs, variables and the parameter (written with the form: a vec4)
PAIR_PARTS = ("scale", "bias")  # a pair's two outputs, as a shader computes F0 A + B

# the engines, by the shape of the targets they derive (`Target.shape`)
ONE_VARIABLE = "one variable"           # one variable of a fixed range, an expression, one output
SEVERAL_VARIABLES = "several variables"  # variables and a parameter, an expression or a table, one output
PAIR = "pair"                           # two outputs of one box


class DeriveError(ValueError):
    """Bad input to `pipeline derive` (one line naming what is wrong)."""


@dataclasses.dataclass(frozen=True)
class Anchor:
    """A hand approximation an engine ships: its name, its expression in the target's variables (and
    parameter), and where it comes from."""

    name: str
    expression: str
    source: str


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


X_ON_UNIT = (Axis("x", 0.0, 1.0),)      # a target's variables where none are given: x in [0, 1]


@dataclasses.dataclass(frozen=True)
class Target:
    """One function to approximate (module docstring): a function of `variables` (per pixel) and at
    most one `parameter` (per material), the expression sympy text in their names, or (`table`)
    values on a grid, the expression then only its name; or (`parts`) two targets of one box a
    shader computes together, F0 A + B (the split-sum environment BRDF's scale A and bias B: `pair`).
    A function of one variable is a target with one axis and no parameter."""

    name: str
    expression: str
    variables: tuple[Axis, ...] = X_ON_UNIT
    parameter: Axis | None = None
    metric: str = "abs"
    floor: float = 0.0
    anchors: tuple[Anchor, ...] = ()
    description: str = ""
    table: Table | None = None
    precision: str = "fp32"
    role: str = ""              # where it enters a shading (`optics.roles`): rendered there (`measures.rendered`)
    max_degree: int = 4         # the family templates' largest total degree (several variables)
    parts: tuple = ()           # a pair's two targets (scale, bias), each of one output
    certify: bool = False       # its errors proven over the whole domain (`engines.derive`'s certify)

    @property
    def shape(self) -> str:
        """Which engine derives the target (ONE_VARIABLE, SEVERAL_VARIABLES, PAIR): the one place that
        says it."""
        if self.parts:
            return PAIR
        one = len(self.variables) == 1 and not self.variables[0].lo_of
        return ONE_VARIABLE if one and self.parameter is None and self.table is None else SEVERAL_VARIABLES

    @property
    def axes(self) -> tuple[Axis, ...]:
        return self.variables + ((self.parameter,) if self.parameter else ())

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(a.name for a in self.axes)

    @property
    def variable(self) -> str:
        """The variables' and parameter's names as a page names them (one variable: its name)."""
        return ", ".join(self.names)

    @property
    def domain(self) -> tuple[float, float]:
        """The range of a target of one variable."""
        return (self.variables[0].lo, self.variables[0].hi)

    @property
    def scale(self) -> Target:
        return self.parts[0]

    @property
    def bias(self) -> Target:
        return self.parts[1]

    def symbols(self) -> list:
        import sympy as sp

        return [sp.Symbol(n, real=True) for n in self.names]

    def symbol(self):
        """The symbol of a target of one variable."""
        return self.symbols()[0]

    def sympy(self):
        """The exact function as a sympy expression in `symbols()`."""
        if self.table is not None:
            raise DeriveError(f"{self.name} is a table: it has no expression")
        return parse(self.expression, self.names)

    def numpy(self):
        """The exact function as a numpy callable of one array per axis (variables, then the
        parameter; float64)."""
        return self.table if self.table is not None else numpy_function(self.sympy(), self.symbols())

    def jax(self):
        """The exact function as a JAX callable of one array per axis (jax.numpy and jax.scipy.special)."""
        import sympy as sp

        from ...optics.numerics import jax  # noqa: F401 (float64)
        import jax.numpy as jnp
        import jax.scipy.special as jsp

        return sp.lambdify(self.symbols(), self.sympy(), modules=[{"erf": jsp.erf, "erfc": jsp.erfc}, jnp])

    def range_text(self) -> str:
        return self.parameter.text() if self.parameter else ""

    def anchor_expressions(self) -> dict:
        """{anchor name: its sympy expression}."""
        return {a.name: parse(a.expression, self.names, f"anchor {a.name!r}") for a in self.anchors}


def pair(name: str, scale: Target, bias: Target, description: str = "", role: str = "") -> Target:
    """The target of two outputs a shader computes together as F0 A + B: `scale` A and `bias` B, two
    targets of one box and one metric (`reading.check` checks it)."""
    return Target(name, f"(A, B) = ({scale.name}, {bias.name})", scale.variables, scale.parameter, scale.metric,
                  scale.floor, description=description, role=role, parts=(scale, bias))


def parse(text: str, variable="x", what: str = "expression"):
    """The sympy expression of `text` in the real symbol `variable` (or in several, given as a tuple of
    names), read by the one parser of outside text (`engine.expressions.parse`: nothing in it runs).
    Raises DeriveError naming what is wrong: text that does not parse, a name that is neither a
    variable nor a function, a construct outside the grammar, work beyond the parser's bounds."""
    from ...engine import expressions

    names = (variable,) if isinstance(variable, str) else tuple(variable)
    try:
        return expressions.parse(text, names, what=what)
    except expressions.ExpressionError as e:
        raise DeriveError(str(e)) from None


def numpy_function(expr, symbols):
    """A numpy callable of expr in `symbols` (a symbol, or a list: one array argument each; float64,
    scipy's special functions where sympy names them), always returning an array of the arguments'
    broadcast shape."""
    import sympy as sp

    symbols = list(symbols) if isinstance(symbols, (list, tuple)) else [symbols]
    function = sp.lambdify(symbols, expr, modules=["numpy", "scipy"])

    def value(*columns):
        columns = [np.asarray(c, dtype=np.float64) for c in columns]
        shape = np.broadcast_shapes(*(c.shape for c in columns))
        with np.errstate(all="ignore"):
            return np.broadcast_to(np.asarray(function(*columns), dtype=np.float64), shape).copy()

    return value
