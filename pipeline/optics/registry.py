"""The lobe registry: every lobe the pipeline knows, each declared once, here.

A lobe is a function of t = cos x (R.V for the Phong form, N.H for the Blinn form) and of the
exponent n it stands in for. Each entry says:

- `key`: its one name (the paper's where it has one: f_b = cos^n, f_2, f_Q, f_Q2). Results fields,
  tables, figure legends and code call it by this name alone;
- `formula`: the lobe in t and n, as text, with the run's parameters as `{slope:g}`-style fields
  (`formula_of` fills them in);
- `shape` and `parameter`: the family of `pipeline.optics.lobes.SHAPES` that evaluates it (one
  compiled program per family) and that family's parameter per n, written once for numpy, JAX and
  sympy (`parameter(m, n, p)`, m the math module: `np`, `jax.numpy` or `SYMPY`, p the run's
  `Parameters`);
- `depends_on`: the run parameters it reads: "Q" (the level of f_Q) and "line" (k = a n + b);
- `glsl`: its per-pixel GLSL body, a function of t with the per-material uniforms n, k and rate
  (`pipeline.optics.spirv` compiles it and counts its instructions); for the family
  (k (t - 1) + 1)^m it is None and `glsl_of` writes the power out in multiplies
  (`linear_power_glsl`);
- `follows_power`: whether the lobe takes the run's power m (`lobe.power`; f_Q, f_Q2) or keeps 2
  (f_2, the original cosine-quadratic lobe);
- `style`: its line style in the figures;
- `energy`: (form, normalization key of `pipeline.optics.normalizations`) pairs: the normalizations
  an engine pairs it with, which the comparison's energy table evaluates;
- `sampler`: the family of its closed-form importance sampler (`pipeline.optics.sampling`, the
  Mitsuba plugin, the exported shader), or None.

Adding a lobe is adding one entry to `LOBES` (or calling `register`): the lobe comparison, its figure,
the report's tables and the shader-cost stage iterate the registry. Nothing here imports JAX or
sympy at import time, so the figure process can read names and styles cheaply.

The sources: f_b, Phong 1975 and Blinn 1977; f_2, Romanyuk & Lyashenko 2010 (Lyon 1993 with
exponent 2); f_Q and f_Q2, the paper; Schlick, Graphics Gems IV (1994); SG, a spherical Gaussian;
SG_Lagarde, Lagarde 2012 (fitted to cos^n).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping
from types import MappingProxyType
from typing import Any, NamedTuple

SG_LAGARDE_SHIFT = 0.775
FORMS = ("phong", "blinn")


class Parameters(NamedTuple):
    """The run's values a lobe or a normalization may read: Q of f_Q, the line k = slope n +
    intercept of f_Q2, and the run's coef(n) = coef_scale (coef_offset + n). What a caller does not
    set is NaN, so that a lobe reading it gives NaN rather than a silent default."""

    Q: float = float("nan")
    slope: float = float("nan")
    intercept: float = float("nan")
    coef_scale: float = float("nan")
    coef_offset: float = float("nan")
    power: int = 2


# The paper's published values (Q of f_Q, the line 0.448 n + 0.099, coef 0.214 (0.807 + n)): the
# stand-ins of the machine-code stage and the anchors of `pipeline derive`'s cos^n target.
PAPER = Parameters(Q=0.64, slope=0.448, intercept=0.099, coef_scale=0.214, coef_offset=0.807)


class _SympyMath:
    """The few functions `parameter` uses, for sympy (which has no expm1)."""

    def __getattr__(self, name):
        import sympy as sp

        if name == "expm1":
            return lambda x: sp.exp(x) - 1
        return getattr(sp, name)


SYMPY = _SympyMath()


def k_2(n):
    """Coefficient k of f_2: n / 2 (matches the curvature of cos^n at x = 0)."""
    return n / 2.0


def k_Q(n, Q, m, power: int = 2):
    """Coefficient k of f_Q for Q in (0, 1), the lobe (k (t - 1) + 1)^power that equals cos^n where
    cos^n = Q: (Q^(1/power) - 1) / (Q^(1/n) - 1) (the paper's (sqrt(Q) - 1) / (Q^(1/n) - 1) at
    power 2); expm1 keeps precision where ln(Q)/n is small. `m` is the math module (numpy,
    jax.numpy or `SYMPY`)."""
    return m.expm1(m.log(Q) / power) / m.expm1(m.log(Q) / n)


def k_Q2(n, slope, intercept):
    """Coefficient k of f_Q2: the line slope * n + intercept (paper: 0.448 n + 0.099)."""
    return slope * n + intercept


def power_steps(base: str, power: int) -> tuple[list[tuple[str, str]], str]:
    """base^power by squarings and multiplies, never a pow: ([(name, expression), ...], result).

    The squarings b2 = b * b, b4 = b2 * b2, ... up to the highest bit of the power, then one
    multiply per further set bit: floor(log2 m) + popcount(m) - 1 multiplies (m = 8: 3, m = 7: 4).
    """
    if power < 1:
        raise ValueError(f"power must be a positive integer, got {power!r}")
    squares, steps, value = [base], [], 1
    while 2 * value <= power:
        value *= 2
        name = f"{base}{value}"
        steps.append((name, f"{squares[-1]} * {squares[-1]}"))
        squares.append(name)
    factors = [squares[i] for i in range(len(squares)) if power >> i & 1]
    result = factors[-1]
    for factor in reversed(factors[:-1]):
        name = f"{base}{power}" if factor == factors[0] else f"{result}_{factor}"
        steps.append((name, f"{result} * {factor}"))
        result = name
    return steps, result


def multiplies(power: int) -> int:
    """The multiplies of `power_steps`."""
    return len(power_steps("b", power)[0])


def linear_power_glsl(power: int) -> str:
    """The family's lobe (k (t - 1) + 1)^power without pow: one multiply-add for the base, a max for
    the clamp, then `power_steps`. The exported shader (`pipeline.publish.shader`) uses the same
    body."""
    steps, result = power_steps("b", power)
    lines = ["float b = max(k * t + (1.0 - k), 0.0);   // k (t - 1) + 1, clamped at the zero crossing"]
    lines += [f"float {name} = {expression};" for name, expression in steps]
    lines.append(f"return {result};" + ("                              // no pow: squarings and multiplies"
                                        if power > 1 else ""))
    return "\n    ".join(lines)


def family_name(power: int) -> str:
    """The paper's name of the fitted lobe at power m: f_Q2 for m = 2, then f_Q3, f_Q4, ..."""
    return f"f_Q{int(power)}"


@dataclasses.dataclass(frozen=True)
class Lobe:
    """One lobe of the registry (the module's docstring says what each field means)."""

    key: str
    formula: str
    shape: str
    parameter: Callable[[Any, Any, Parameters], Any]
    glsl: str | None
    style: Mapping[str, Any]
    depends_on: tuple[str, ...] = ()
    energy: tuple[tuple[str, str], ...] = ()
    sampler: str | None = None
    follows_power: bool = False

    def power_of(self, p: Parameters | None) -> int:
        """The power m of a lobe of the family: the run's for f_Q and f_Q2, 2 for f_2."""
        return int(p.power) if self.follows_power and p is not None else 2

    def name(self, p: Parameters | None = None) -> str:
        """Its name at the run's power: the key, except f_Q2, which is f_Q3, f_Q4, ... at m = 3, 4."""
        return family_name(self.power_of(p)) if self.key == "f_Q2" else self.key

    def label(self, p: Parameters | None = None) -> str:
        """Its name as figures and tables print it (f_Q with its Q, and its power where not 2)."""
        if self.key == "f_b":
            return "f_b = cos^n"
        power = self.power_of(p)
        suffix = f" (m = {power})" if self.key == "f_Q" and power != 2 else ""
        if "Q" in self.depends_on and p is not None:
            return f"{self.key}{suffix}, Q = {p.Q:.4g}"
        return self.name(p)

    def formula_of(self, p: Parameters) -> str:
        """The formula with the run's parameters filled in."""
        return self.formula.format(**(p._asdict() | dict(power=self.power_of(p))))

    def glsl_of(self, p: Parameters | None = None) -> str:
        """Its per-pixel GLSL body (the family's written out for its power)."""
        if self.shape == "linear_power" and self.glsl is None:
            return linear_power_glsl(self.power_of(p))
        return self.glsl

    def expression(self, p: Parameters):
        """The lobe as a sympy expression in t and n (symbols of `symbols()`), written as a shader
        computes it: per-material constants (functions of n) marked as units, so that their
        operations are counted once per material (`pipeline.optics.operations`)."""
        import sympy as sp

        t, n = symbols()
        value = self.parameter(SYMPY, n, p)
        unit = sp.UnevaluatedExpr
        if self.shape == "linear_power":     # k t + (1 - k), both per material
            return sp.Max(unit(value) * t + unit(1 - value), 0) ** self.power_of(p)
        if self.shape == "power":
            return t ** value
        if self.shape == "schlick":
            return t / (unit(value) - unit(value - 1) * t)
        if self.shape == "exp":
            return sp.exp(unit(value) * t - unit(value))
        raise ValueError(f"lobe {self.key!r}: no sympy form for shape {self.shape!r}")


def symbols():
    """The symbols t = cos x and n of every lobe's sympy expression."""
    import sympy as sp

    return sp.symbols("t n", positive=True)


_LOBES: dict[str, Lobe] = {}


def register(lobe: Lobe) -> Lobe:
    """Adds a lobe to the registry (its key must be new); returns it."""
    if lobe.key in _LOBES:
        raise ValueError(f"lobe {lobe.key!r} is registered already")
    if lobe.shape not in SHAPE_NAMES:
        raise ValueError(f"lobe {lobe.key!r}: shape {lobe.shape!r} is not one of {', '.join(SHAPE_NAMES)}")
    for form, _ in lobe.energy:
        if form not in FORMS:
            raise ValueError(f"lobe {lobe.key!r}: form {form!r} is not one of {', '.join(FORMS)}")
    _LOBES[lobe.key] = lobe
    return lobe


def fingerprint() -> list:
    """Every entry's declaration as plain values (its parameter function by its compiled code), for
    the cache keys of the stages that iterate the registry."""
    out = []
    for lobe in _LOBES.values():
        code = lobe.parameter.__code__
        out.append([lobe.key, lobe.formula, lobe.shape, lobe.glsl, dict(lobe.style), list(lobe.depends_on),
                    [list(e) for e in lobe.energy], lobe.sampler, lobe.follows_power, code.co_code.hex(),
                    repr(code.co_consts), list(code.co_names)])
    return out


def unregister(key: str) -> None:
    """Removes a lobe (for tests that register a lobe of their own)."""
    del _LOBES[key]


# The shape families of `pipeline.optics.lobes.SHAPES`, by name (that module holds their JAX code).
SHAPE_NAMES = ("linear_power", "power", "schlick", "exp")
PHONG_COS_N = "phong_cos_n"     # (n + 2) / (2 pi): cos^n's own normalization, which a replacement of pow keeps

LOBES: Mapping[str, Lobe] = MappingProxyType(_LOBES)

register(Lobe("f_b", "t^n", "power", lambda m, n, p: n, "return pow(t, n);",
              dict(color="black", ls="-", lw=2.2),
              energy=(("phong", PHONG_COS_N), ("blinn", "giesen"), ("blinn", "blinn_approximate"), ("blinn", "gotanda")),
              sampler="power"))
register(Lobe("f_2", "((n/2)(t - 1) + 1)^2", "linear_power", lambda m, n, p: k_2(n), None,
              dict(color="C1", ls="-"), energy=(("phong", PHONG_COS_N),), sampler="linear_power"))
register(Lobe("f_Q", "(k_Q(n)(t - 1) + 1)^{power}, k_Q(n) = (Q^(1/{power}) - 1) / (Q^(1/n) - 1)", "linear_power",
              lambda m, n, p: k_Q(n, p.Q, m, p.power), None, dict(color="C2", ls=":", lw=1.8), depends_on=("Q",),
              energy=(("phong", PHONG_COS_N),), sampler="linear_power", follows_power=True))
register(Lobe("f_Q2", "(({slope:g} n + {intercept:g})(t - 1) + 1)^{power}", "linear_power",
              lambda m, n, p: k_Q2(n, p.slope, p.intercept),
              None, dict(color="C0", ls="-", lw=2.2), depends_on=("line",),
              energy=(("phong", "run_coef"), ("phong", "exact_phong"), ("phong", "asymptotic_phong"),
                      ("blinn", "exact_blinn"), ("blinn", "asymptotic_blinn")),
              sampler="linear_power", follows_power=True))
register(Lobe("Schlick", "t / (n - n t + t)", "schlick", lambda m, n, p: n, "return t / (n - n * t + t);",
              dict(color="C4", ls="-"), energy=(("phong", PHONG_COS_N),)))
register(Lobe("SG", "exp(n (t - 1))", "exp", lambda m, n, p: n, "return exp(n * (t - 1.0));",
              dict(color="C3", ls="-"), energy=(("phong", PHONG_COS_N),)))
register(Lobe("SG_Lagarde", f"exp((n + {SG_LAGARDE_SHIFT}) (t - 1))", "exp", lambda m, n, p: n + SG_LAGARDE_SHIFT,
              "return exp(rate * (t - 1.0));   // rate = n + 0.775 per material",
              dict(color="C5", ls="--"), energy=(("phong", PHONG_COS_N),)))

# The reference every other lobe is measured against.
REFERENCE = "f_b"
