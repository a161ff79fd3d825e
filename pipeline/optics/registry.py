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
  (`pipeline.optics.spirv` compiles it and counts its instructions);
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


def k_Q(n, Q, m):
    """Coefficient k of f_Q for Q in (0, 1), the lobe that equals cos^n where cos^n = Q:
    (sqrt(Q) - 1) / (Q^(1/n) - 1); expm1 keeps precision where ln(Q)/n is small. `m` is the math
    module (numpy, jax.numpy or `SYMPY`)."""
    return (m.sqrt(Q) - 1.0) / m.expm1(m.log(Q) / n)


def k_Q2(n, slope, intercept):
    """Coefficient k of f_Q2: the line slope * n + intercept (paper: 0.448 n + 0.099)."""
    return slope * n + intercept


# The quadratic lobe without pow: one multiply-add for the base, a max for the clamp, one multiply
# to square. The exported shader (`pipeline.publish.shader`) uses the same body.
QUADRATIC_GLSL = ("float b = max(k * t + (1.0 - k), 0.0);   // k (t - 1) + 1, clamped at the zero crossing\n"
                  "    return b * b;                             // squared with a multiply: no pow")


@dataclasses.dataclass(frozen=True)
class Lobe:
    """One lobe of the registry (the module's docstring says what each field means)."""

    key: str
    formula: str
    shape: str
    parameter: Callable[[Any, Any, Parameters], Any]
    glsl: str
    style: Mapping[str, Any]
    depends_on: tuple[str, ...] = ()
    energy: tuple[tuple[str, str], ...] = ()
    sampler: str | None = None

    def label(self, p: Parameters | None = None) -> str:
        """Its name as figures and tables print it (f_Q with its Q)."""
        if self.key == "f_b":
            return "f_b = cos^n"
        if "Q" in self.depends_on and p is not None:
            return f"{self.key}, Q = {p.Q:.4g}"
        return self.key

    def formula_of(self, p: Parameters) -> str:
        """The formula with the run's parameters filled in."""
        return self.formula.format(**p._asdict())

    def expression(self, p: Parameters):
        """The lobe as a sympy expression in t and n (symbols of `symbols()`), written as a shader
        computes it: per-material constants (functions of n) marked as units, so that their
        operations are counted once per material (`pipeline.optics.operations`)."""
        import sympy as sp

        t, n = symbols()
        value = self.parameter(SYMPY, n, p)
        unit = sp.UnevaluatedExpr
        if self.shape == "quadratic":        # k t + (1 - k), both per material
            return sp.Max(unit(value) * t + unit(1 - value), 0) ** 2
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
                    [list(e) for e in lobe.energy], lobe.sampler, code.co_code.hex(), repr(code.co_consts),
                    list(code.co_names)])
    return out


def unregister(key: str) -> None:
    """Removes a lobe (for tests that register a lobe of their own)."""
    del _LOBES[key]


# The shape families of `pipeline.optics.lobes.SHAPES`, by name (that module holds their JAX code).
SHAPE_NAMES = ("quadratic", "power", "schlick", "exp")
PHONG_COS_N = "phong_cos_n"     # (n + 2) / (2 pi): cos^n's own normalization, which a replacement of pow keeps

LOBES: Mapping[str, Lobe] = MappingProxyType(_LOBES)

register(Lobe("f_b", "t^n", "power", lambda m, n, p: n, "return pow(t, n);",
              dict(color="black", ls="-", lw=2.2),
              energy=(("phong", PHONG_COS_N), ("blinn", "giesen"), ("blinn", "blinn_approximate"), ("blinn", "gotanda")),
              sampler="power"))
register(Lobe("f_2", "((n/2)(t - 1) + 1)^2", "quadratic", lambda m, n, p: k_2(n), QUADRATIC_GLSL,
              dict(color="C1", ls="-"), energy=(("phong", PHONG_COS_N),), sampler="quadratic"))
register(Lobe("f_Q", "(k_Q(n)(t - 1) + 1)^2, k_Q(n) = (sqrt(Q) - 1) / (Q^(1/n) - 1)", "quadratic",
              lambda m, n, p: k_Q(n, p.Q, m), QUADRATIC_GLSL, dict(color="C2", ls=":", lw=1.8), depends_on=("Q",),
              energy=(("phong", PHONG_COS_N),), sampler="quadratic"))
register(Lobe("f_Q2", "(({slope:g} n + {intercept:g})(t - 1) + 1)^2", "quadratic", lambda m, n, p: k_Q2(n, p.slope, p.intercept),
              QUADRATIC_GLSL, dict(color="C0", ls="-", lw=2.2), depends_on=("line",),
              energy=(("phong", "run_coef"), ("phong", "exact_phong"), ("phong", "asymptotic_phong"),
                      ("blinn", "exact_blinn"), ("blinn", "asymptotic_blinn")),
              sampler="quadratic"))
register(Lobe("Schlick", "t / (n - n t + t)", "schlick", lambda m, n, p: n, "return t / (n - n * t + t);",
              dict(color="C4", ls="-"), energy=(("phong", PHONG_COS_N),)))
register(Lobe("SG", "exp(n (t - 1))", "exp", lambda m, n, p: n, "return exp(n * (t - 1.0));",
              dict(color="C3", ls="-"), energy=(("phong", PHONG_COS_N),)))
register(Lobe("SG_Lagarde", f"exp((n + {SG_LAGARDE_SHIFT}) (t - 1))", "exp", lambda m, n, p: n + SG_LAGARDE_SHIFT,
              "return exp(rate * (t - 1.0));   // rate = n + 0.775 per material",
              dict(color="C5", ls="--"), energy=(("phong", PHONG_COS_N),)))

# The reference every other lobe is measured against.
REFERENCE = "f_b"
