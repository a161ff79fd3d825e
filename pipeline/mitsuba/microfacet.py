"""The lobe as the normal distribution D of a Cook-Torrance BSDF in Mitsuba 3: `cosquad_microfacet`.

f(wi, wo) = D(h) G(wi, wo, h) F / (4 cos(theta_i) cos(theta_o)), with D = coef lobe(n.h) the lobe
normalized as an NDF (int D (n.h) dw_h = 1: the Phong-form coef, `pipeline.optics.distributions`), F = 1
and Smith's G of the Beckmann distribution at roughness `alpha` (Mitsuba's own
`MicrofacetDistribution.G`), so that against Mitsuba's `roughconductor` with `distribution =
"beckmann"`, the same alpha and `material = "none"` (F = 1) the images differ by D alone.

Properties: those of `cosquad_lobe` (`pipeline.mitsuba.bsdf`: `shape`, `power`, `exponent`, `k`),
`form` = "blinn" (the half vector; the only one allowed), `alpha` (G's roughness), and `coef` (by
default the NDF normalization, computed by the pipeline's hemisphere quadrature). Sampling is the
lobe's own half-vector sampler (h drawn with density proportional to lobe(n.h), wo = wi reflected
about h), with its pdf: `cosquad_lobe`'s Blinn form, which passes Mitsuba's chi-square test.
"""

from __future__ import annotations

from ..engine.parsing import PARSING
from . import bsdf

NAME = "cosquad_microfacet"
_CLASSES: dict = {}


def register(variant: str | None = None) -> str:
    """Registers `cosquad_lobe` and this plugin for the variant; returns the variant."""
    variant = bsdf.register(variant)
    with PARSING:           # (`pipeline.engine.parsing`)
        import mitsuba as mi

        mi.register_bsdf(NAME, lambda props: plugin_class()(props))
    return variant


def plugin_class():
    import mitsuba as mi

    if mi.variant() not in _CLASSES:
        _CLASSES[mi.variant()] = _make_class()
    return _CLASSES[mi.variant()]


def _make_class():
    import drjit as dr
    import mitsuba as mi

    base = bsdf.plugin_class()

    class CosQuadMicrofacet(base):
        def __init__(self, props):
            if props.get("form", "blinn") != "blinn":
                raise ValueError(f"{NAME}: form = {props.get('form')!r}; a microfacet D is a lobe of the half "
                                 "vector: form must be 'blinn'")
            base.__init__(self, props)
            self.form = "blinn"
            if "alpha" not in props:
                raise ValueError(f"{NAME}: alpha (the roughness of Smith's G, Beckmann) is required")
            self.alpha = float(props["alpha"])
            if not self.alpha > 0:
                raise ValueError(f"{NAME}: alpha = {self.alpha} must be > 0")
            if "coef" not in props:     # the NDF normalization: the Phong form's (int D (n.h) dw_h = 1)
                self.coef = bsdf.normalization(self.shape, "phong", self.n,
                                               self.k if self.shape == "linear_power" else self.n, power=self.power)
            self.shadowing = mi.MicrofacetDistribution(mi.MicrofacetType.Beckmann, self.alpha, False)

        def eval(self, ctx, si, wo, active=True):
            cos_i, cos_o = mi.Frame3f.cos_theta(si.wi), mi.Frame3f.cos_theta(wo)
            h = dr.normalize(si.wi + wo)
            D = self.coef * self.lobe(h.z)
            G = self.shadowing.G(si.wi, wo, h)
            value = D * G / (4.0 * dr.maximum(cos_i, 1e-12))      # f cos(theta_o), F = 1
            return mi.Color3f(dr.select(active & (cos_i > 0.0) & (cos_o > 0.0) & (h.z > 0.0), value, 0.0))

        def to_string(self):
            return (f"CosQuadMicrofacet[shape={self.shape}, power={self.power}, n={self.n}, k={self.k}, "
                    f"coef={self.coef}, alpha={self.alpha}]")

    return CosQuadMicrofacet
