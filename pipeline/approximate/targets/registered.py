"""The registered targets, by name: the functions of one variable (Schlick's Fresnel, acos, cos^n at
n = 20), of several variables and a parameter (the Smith-GGX visibility, the environment BRDF's
scale and bias as tables of the pipeline's quadrature, cos^n in its zone) and the pair a shader
computes together (the environment BRDF, F0 A + B); each with the hand approximations engines ship
(anchors) and their sources."""

from __future__ import annotations

import functools

from .box import chebyshev_points
from .target import Anchor, Axis, DeriveError, pair, Table, Target


X = (Axis("x", 0.0, 1.0),)     # the variable of the registered targets of one variable

PAPER_LOBES = {"f_2": "Romanyuk & Lyashenko 2010 (the cosine-quadratic lobe)",
               "f_Q2": "the paper (k = 0.448 n + 0.099)",
               "Schlick": "Schlick 1994, Graphics Gems IV", "SG": "a spherical Gaussian exp(n (t - 1))",
               "SG_Lagarde": "Lagarde 2012 (spherical Gaussian fitted to cos^n)"}


def paper_lobes(n: float | None = None) -> tuple[Anchor, ...]:
    """The paper's and the engines' lobes of the registry (`PAPER_LOBES`), each one's sympy expression
    with the paper's constants (`optics.registry.PAPER`): in t and n, or, at a fixed n, in the variable
    x = cos."""
    import sympy as sp

    from ...optics import registry

    t, n_symbol = registry.symbols()
    names = {t: sp.Symbol("t", real=True), n_symbol: sp.Symbol("n", real=True)} if n is None else \
        {n_symbol: sp.Float(n), t: sp.Symbol("x", real=True)}
    return tuple(Anchor(key, sp.sstr(registry.LOBES[key].expression(registry.PAPER).xreplace(names)), source)
                 for key, source in PAPER_LOBES.items())


def registry() -> dict[str, Target]:
    """Every registered target by name: of one variable, of several or a parameter, the pairs."""
    return one_variable_targets() | several_variable_targets() | pairs()


def one_variable_targets() -> dict[str, Target]:
    """The registered targets of one variable, by name."""
    return {
        "schlick": Target(
            "schlick", "(1 - x)**5", X, None, "abs",
            anchors=(Anchor("Karis", "exp2((-5.55473*x - 6.98316)*x)",
                            "Karis 2013, Real Shading in Unreal Engine 4 (spherical Gaussian form of Schlick's Fresnel)"),),
            description="Schlick's Fresnel term (1 - x)^5, x = cos of the angle to the half vector", role="fresnel"),
        "acos": Target(
            "acos", "acos(x)", X, None, "abs",
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
            "cos_n20", "x**20", X, None, "abs", anchors=paper_lobes(20.0),
            description="Blinn-Phong's cos^n at n = 20 of x = cos; the paper's lobes at n = 20 as anchors, which were "
                        "fitted to another measure (the relative error where cos^n >= a level), not this one"),
    }



COS_N_LEVEL = 0.5           # the registered cos_n's zone: cos^n at least half its peak (the lobe's half maximum)


def cos_n_target(level: float = COS_N_LEVEL, n: tuple[float, float] = (2.0, 1000.0)) -> Target:
    """cos^n over its epicenter zone {cos^n >= level} (t = cos in [level^(1/n), 1], a range that moves
    with n) and n per material, by the relative error (the paper's d): the lobe search's problem, which
    the `lobe_search` stage poses at the run's calibrated level. Anchors: the paper's and the
    engines' lobes of `optics.registry` with the paper's constants (`paper_lobes`). Its family
    templates go to degree 2 in t, as the lobe search's families do: at n = 1000 the zone is
    t in [0.9993, 1], where the monomials of degree 3 and 4 are nearly dependent and the formulas'
    polish does not converge (a reciprocal cubic fits each n closely, and errs above 1 with every
    formula in n)."""
    if not 0.0 < level < 1.0:
        raise DeriveError(f"cos_n: the zone's level {level}: give a number in (0, 1)")
    lowest = level ** (1.0 / n[0])
    return Target(
        "cos_n", "t**n", (Axis("t", lowest, 1.0, lo_of=f"{level!r}**(1/n)"),), Axis("n", float(n[0]), float(n[1])),
        "rel", anchors=paper_lobes(), max_degree=2,
        description=f"cos^n in its epicenter zone cos^n >= {level:g} (the paper's lobe search), n the Phong exponent",
        role="lobe")


def several_variable_targets() -> dict[str, Target]:
    """The registered targets of several variables or a parameter, by name."""
    from ...optics import brdf

    unit = (0.01, 1.0)
    return {
        "smith_ggx_visibility": Target(
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
    from ...optics import brdf

    axes = [chebyshev_points(a.lo, a.hi, ENV_BRDF_POINTS) for a in ENV_BRDF_BOX]
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


def env_brdf_targets() -> dict[str, Target]:
    """The environment BRDF's scale A and bias B (`optics.brdf.env_brdf`) over NoV and the roughness
    (per material, or per pixel from a texture), absolute error, Karis's and Lazarov's fits as anchors
    (`pipeline derive --target env_brdf` derives both and pairs them: `derive_pair`)."""
    from ...optics import brdf

    out = {}
    for part, (name, what) in enumerate((("env_brdf_scale", "A, the scale of F0"), ("env_brdf_bias", "B, the bias"))):
        out[name] = Target(
            name, name, (ENV_BRDF_BOX[0],), ENV_BRDF_BOX[1], "abs",
            anchors=tuple(Anchor(a, pair[part], brdf.KARIS_2014 if a == "Karis" else brdf.LAZAROV_2013)
                          for a, pair in ENV_BRDF_ANCHORS.items()),
            description=f"the split-sum environment BRDF of GGX (alpha = roughness^2, Schlick-Smith k = alpha / 2), {what}: "
                        "a table by the pipeline's quadrature",
            table=_LazyTable(part))
    return out


def pairs() -> dict[str, Target]:
    """The registered pairs of outputs a shader computes together, by name."""
    targets = env_brdf_targets()
    return {"env_brdf": pair("env_brdf", targets["env_brdf_scale"], targets["env_brdf_bias"],
                                   "the split-sum environment BRDF of GGX: its scale A and bias B together, "
                                   "as a shader computes F0 A + B", role="env_brdf")}
