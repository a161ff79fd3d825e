"""The functions `pipeline derive` approximates, each declared once: its exact expression (sympy
text, from which its numpy, JAX and sympy forms come), its variable and domain, its error measure,
and the hand approximations engines ship for it (anchors), each with its source.

A target's error measure is the largest error over its whole domain (`measure.max_error`):
`abs`, |a(x) - f(x)|, or `rel`, |a(x) - f(x)| / max(|f(x)|, floor) (with floor 0, the relative
error proper, which a target that reaches 0 cannot have).

A user's own target is an expression (`from_expression`: any function sympy knows, erf, atan,
besselj, ... even where no shader has it) or a TOML file (`from_file`):

    [target]
    name = "atan"
    expression = "atan(x)"
    variable = "x"
    domain = [0, 1]
    metric = "abs"          # or "rel"
    floor = 0.0             # rel only: |f| below floor counts as floor
    precision = "fp32"      # or "fp16": the format the shader computes in (`executed`)
    role = "fresnel"        # optional: where it enters a shading (`optics.roles`), rendered there
    [[anchor]]
    name = "mine"
    expression = "x * (0.97 - 0.19 * x * x)"
    source = "where it comes from"

Expressions are read by the one parser of outside text (`engine.expressions`: Python's syntax, ^ a
power, numbers, the variable, pi, E, + - * / ** and calls of sympy's elementary and special
functions by name, with exp2, log2, rsqrt, saturate, clamp and mix as a shader writes them); nothing
in a file is ever run.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np

from ..optics.roles import role_fault

METRICS = ("abs", "rel")
PRECISIONS = ("fp32", "fp16")   # the formats a shader computes in (`executed`)
CHECK_POINTS = 4097             # the domain's points on which a target must be finite


class DeriveError(ValueError):
    """Bad input to `pipeline derive` (one line naming what is wrong)."""


@dataclasses.dataclass(frozen=True)
class Anchor:
    """A hand approximation an engine ships: its name, its expression in the target's variable, and
    where it comes from."""

    name: str
    expression: str
    source: str


@dataclasses.dataclass(frozen=True)
class Target:
    """One function to approximate (module docstring)."""

    name: str
    expression: str
    variable: str = "x"
    domain: tuple[float, float] = (0.0, 1.0)
    metric: str = "abs"
    floor: float = 0.0
    anchors: tuple[Anchor, ...] = ()
    description: str = ""
    precision: str = "fp32"
    role: str = ""              # where it enters a shading (`optics.roles`): rendered there (`rendered`)

    def symbol(self):
        import sympy as sp

        return sp.Symbol(self.variable, real=True)

    def sympy(self):
        """The exact function as a sympy expression in `symbol()`."""
        return parse(self.expression, self.variable)

    def numpy(self):
        """The exact function as a numpy callable of an array of x (float64)."""
        return numpy_function(self.sympy(), self.symbol())

    def jax(self):
        """The exact function as a JAX callable (jax.numpy and jax.scipy.special)."""
        import sympy as sp

        from ..optics.numerics import jax
        import jax.numpy as jnp
        import jax.scipy.special as jsp

        return sp.lambdify(self.symbol(), self.sympy(), modules=[{"erf": jsp.erf, "erfc": jsp.erfc}, jnp])

    def anchor_expressions(self):
        """{anchor name: its sympy expression}."""
        return {a.name: parse(a.expression, self.variable, f"anchor {a.name!r}") for a in self.anchors}


def parse(text: str, variable="x", what: str = "expression"):
    """The sympy expression of `text` in the real symbol `variable` (or in several, given as a tuple of
    names), read by the one parser of outside text (`engine.expressions.parse`: nothing in it runs).
    Raises DeriveError naming what is wrong: text that does not parse, a name that is neither a
    variable nor a function, a construct outside the grammar, work beyond the parser's bounds."""
    from ..engine import expressions

    names = (variable,) if isinstance(variable, str) else tuple(variable)
    try:
        return expressions.parse(text, names, what=what)
    except expressions.ExpressionError as e:
        raise DeriveError(str(e)) from None


def numpy_function(expr, symbol):
    """A numpy callable of expr in symbol (float64; scipy's special functions where sympy names
    them), always returning an array the shape of x."""
    import sympy as sp

    function = sp.lambdify(symbol, expr, modules=["numpy", "scipy"])

    def value(x):
        x = np.asarray(x, dtype=np.float64)
        with np.errstate(all="ignore"):
            return np.broadcast_to(np.asarray(function(x), dtype=np.float64), x.shape).copy()

    return value


def check(target: Target) -> Target:
    """The target itself, checked: a known metric, a finite domain lo < hi, a variable's name that the
    grammar allows (`expressions.name_fault`, not c), an expression in its variable that is finite
    (and, for `rel` with floor 0, nonzero) over the domain. Raises DeriveError naming the first
    fault."""
    from ..engine import expressions

    if target.metric not in METRICS:
        raise DeriveError(f"--metric {target.metric!r}: give one of {', '.join(METRICS)}")
    if target.precision not in PRECISIONS:
        raise DeriveError(f"precision {target.precision!r}: give one of {', '.join(PRECISIONS)}")
    lo, hi = target.domain
    if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
        raise DeriveError(f"domain [{lo}, {hi}]: give finite numbers lo < hi")
    if not (math.isfinite(target.floor) and target.floor >= 0):
        raise DeriveError(f"floor {target.floor}: give a number >= 0")
    fault = expressions.name_fault(target.variable) or ("c names the constants" if target.variable == "c" else None)
    if fault:
        raise DeriveError(f"variable {target.variable!r}: {fault}")
    fault = role_fault(target.role, 1, False)
    if fault:
        raise DeriveError(f"{target.name}: {fault}")
    x = np.linspace(lo, hi, CHECK_POINTS)
    f = target.numpy()(x)
    bad = ~np.isfinite(f)
    if bad.any():
        raise DeriveError(f"{target.expression} is not finite at {target.variable} = {x[bad][0]:.6g} in the domain "
                          f"[{lo:g}, {hi:g}]: narrow the domain")
    if target.metric == "rel" and target.floor == 0 and np.any(f == 0):
        raise DeriveError(f"{target.expression} is 0 at {target.variable} = {x[f == 0][0]:.6g}: the relative error "
                          "divides by it; give a floor (--floor) or --metric abs")
    for anchor in target.anchors:
        parse(anchor.expression, target.variable, f"anchor {anchor.name!r}")
    return target


PAPER_LOBES = {"f_2": "Romanyuk & Lyashenko 2010 (the cosine-quadratic lobe)",
               "f_Q2": "the paper (k = 0.448 n + 0.099)",
               "Schlick": "Schlick 1994, Graphics Gems IV", "SG": "a spherical Gaussian exp(n (t - 1))",
               "SG_Lagarde": "Lagarde 2012 (spherical Gaussian fitted to cos^n)"}


def paper_lobes(n: float | None = None) -> tuple[Anchor, ...]:
    """The paper's and the engines' lobes of the registry (`PAPER_LOBES`), each one's sympy expression
    with the paper's constants (`optics.registry.PAPER`): in t and n, or, at a fixed n, in the variable
    x = cos."""
    import sympy as sp

    from ..optics import registry

    t, n_symbol = registry.symbols()
    names = {t: sp.Symbol("t", real=True), n_symbol: sp.Symbol("n", real=True)} if n is None else \
        {n_symbol: sp.Float(n), t: sp.Symbol("x", real=True)}
    return tuple(Anchor(key, sp.sstr(registry.LOBES[key].expression(registry.PAPER).xreplace(names)), source)
                 for key, source in PAPER_LOBES.items())


def registry() -> dict[str, Target]:
    """Every registered target by name."""
    return {
        "schlick": Target(
            "schlick", "(1 - x)**5", "x", (0.0, 1.0), "abs",
            anchors=(Anchor("Karis", "exp2((-5.55473*x - 6.98316)*x)",
                            "Karis 2013, Real Shading in Unreal Engine 4 (spherical Gaussian form of Schlick's Fresnel)"),),
            description="Schlick's Fresnel term (1 - x)^5, x = cos of the angle to the half vector", role="fresnel"),
        "acos": Target(
            "acos", "acos(x)", "x", (0.0, 1.0), "abs",
            anchors=(Anchor("Lagarde", "(-0.156583*x + pi/2)*sqrt(1 - x)",
                            "Lagarde 2014, Inverse trigonometric functions GPU optimization for AMD GCN architecture"),
                     Anchor("Eberly_1", "(1.5707963267948966 - 0.15658276442180141*x)*sqrt(1 - x)",
                            "Eberly, Geometric Tools, ACosEstimate degree 1"),
                     Anchor("Eberly_2", "(1.5707963267948966 + (-0.20347053865798365 + 0.046887774236182234*x)*x)"
                                        "*sqrt(1 - x)", "Eberly, Geometric Tools, ACosEstimate degree 2"),
                     Anchor("Eberly_3", "(1.5707963267948966 + (-0.21253291899190285 + (0.074773789639484223 "
                                        "- 0.018823635069382449*x)*x)*x)*sqrt(1 - x)",
                            "Eberly, Geometric Tools, ACosEstimate degree 3")),
            description="acos(x) on [0, 1] (the angle between two unit vectors from their dot product)"),
        "cos_n20": Target(
            "cos_n20", "x**20", "x", (0.0, 1.0), "abs", anchors=paper_lobes(20.0),
            description="Blinn-Phong's cos^n at n = 20 of x = cos; the paper's lobes at n = 20 as anchors, which were "
                        "fitted to another measure (the relative error where cos^n >= a level), not this one"),
    }


NAMES = ("schlick", "acos", "cos_n20")


def named(name: str, others: dict | None = None):
    """A registered target, one of `others` (the parametric targets, `parametric.registry()`, which
    the caller passes), or a TOML file's (a path ending in .toml). Raises DeriveError."""
    if name.endswith(".toml"):
        return from_file(Path(name))
    targets = registry() | (others or {})
    if name not in targets:
        raise DeriveError(f"--target {name!r}: give one of {', '.join(targets)}, or a .toml file")
    return targets[name]


def parse_domain(text: str) -> tuple[str, tuple[float, float]]:
    """`--var x=LO:HI` as (name, (lo, hi)). Raises DeriveError."""
    try:
        name, rest = text.split("=", 1)
        lo, hi = (float(v) for v in rest.split(":"))
    except ValueError:
        raise DeriveError(f"--var {text!r}: give NAME=LO:HI, e.g. x=0:1") from None
    return name.strip(), (lo, hi)


def from_expression(expression: str, var: str = "x=0:1", metric: str = "abs", floor: float = 0.0,
                    name: str | None = None) -> Target:
    """A target from an expression and `--var NAME=LO:HI`, checked (`check`)."""
    variable, domain = parse_domain(var)
    return check(Target(name or expression.strip(), expression, variable, domain, metric, floor,
                        description=f"{expression} on [{domain[0]:g}, {domain[1]:g}]"))


TARGET_KEYS = {"name", "expression", "variable", "domain", "metric", "floor", "description", "precision", "role"}
ANCHOR_KEYS = {"name", "expression", "source"}


def from_file(path: Path) -> Target:
    """A target from a TOML file (module docstring), checked. Raises DeriveError naming a missing
    or unknown key or a bad value."""
    data = read_toml(path)
    unknown = sorted(set(data) - {"target", "anchor"})
    table = data.get("target")
    if unknown or not isinstance(table, dict):
        raise DeriveError(f"{path}: unknown table {unknown[0]!r}" if unknown else f"{path}: no [target] table")
    bad = sorted(set(table) - TARGET_KEYS)
    if bad:
        raise DeriveError(f"{path}: [target] has an unknown key {bad[0]!r} (keys: {', '.join(sorted(TARGET_KEYS))})")
    if "expression" not in table:
        raise DeriveError(f"{path}: [target] needs an expression")
    domain = table.get("domain", [0.0, 1.0])
    if not (isinstance(domain, list) and len(domain) == 2 and all(isinstance(v, (int, float)) for v in domain)):
        raise DeriveError(f"{path}: domain = {domain!r}: give [lo, hi]")
    return check(Target(str(table.get("name", path.stem)), str(table["expression"]), str(table.get("variable", "x")),
                        (float(domain[0]), float(domain[1])), str(table.get("metric", "abs")), read_floor(table, path),
                        read_anchors(data, path), str(table.get("description", "")), str(table.get("precision", "fp32")),
                        str(table.get("role", ""))))


def read_toml(path: Path) -> dict:
    """A target file's TOML (`engine.toml_files.read_toml`). Raises DeriveError naming the fault."""
    from ..engine.toml_files import read_toml as read

    return read(path, "target file", DeriveError)


def read_anchors(data: dict, path: Path) -> tuple[Anchor, ...]:
    """A target file's [[anchor]] tables (name, expression, source)."""
    anchors = []
    for i, a in enumerate(data.get("anchor", [])):
        if not isinstance(a, dict) or set(a) - ANCHOR_KEYS or not {"name", "expression"} <= set(a):
            raise DeriveError(f"{path}: [[anchor]] {i + 1}: give name, expression and source (only)")
        anchors.append(Anchor(str(a["name"]), str(a["expression"]), str(a.get("source", path.name))))
    return tuple(anchors)


def read_floor(table: dict, path: Path) -> float:
    """A target file's floor (a number >= 0, checked later by `check`)."""
    floor = table.get("floor", 0.0)
    if isinstance(floor, bool) or not isinstance(floor, (int, float)):
        raise DeriveError(f"{path}: floor = {floor!r}: give a number >= 0")
    return float(floor)
