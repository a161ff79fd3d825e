"""The lobes as Mitsuba 3 BSDF plugins: the reference cos^n and the family's lobe (f_2, f_Q2, f_Qm),
Phong and Blinn forms, each with its normalization, importance-sampled in closed form.

One plugin, `cosquad_lobe`, with properties
- `shape`: "power" (max(c, 0)^n, the reference f_b) or "linear_power" (max(k (c - 1) + 1, 0)^m);
- `power`: the family's integer power m (default 2, the paper's quadratic), evaluated by squarings
  and multiplies;
- `form`: "phong" (c = wo . R, R the mirror direction of wi) or "blinn" (c = N . h, h the half vector);
- `exponent` n, `k` (the family only), `coef` (the normalization: the BSDF is coef * lobe(c); by
  default the lobe's exact normalization at normal incidence, `normalization()`);
- `sampler`: "lobe" (the closed-form importance sampler of `pipeline.optics.sampling`, for cos^n its
  standard one c = xi^(1/(n+1))) or "cosine" (cosine-weighted hemisphere, for comparison).

Phong form: the axis cosine c is drawn around R and the direction returned with the lobe's pdf over
the whole sphere; a direction below the surface gets weight 0 and `pdf` returns 0 there, so the pdf
of what is returned with nonzero weight equals `pdf`. Blinn form: the half vector is drawn around
the normal the same way and wo is wi reflected about it, with pdf (pdf_h(h) + pdf_h(-h)) / (4 |wo . h|)
(both half vectors reflect wi to wo; the second is drawn only where the lobe reaches below the
horizon, k < 1).

Everything is vectorized Dr.Jit arithmetic (no per-sample Python): in an `llvm_ad_*` variant a call
on a million directions is one compiled kernel. Mitsuba is imported by `register()` only.
"""

from __future__ import annotations

import functools
import math
import os
import subprocess
import sys
import threading

from ..engine import toolchains
from ..engine.parsing import PARSING
from ..optics.registry import power_steps

NAME = "cosquad_lobe"
# Mitsuba's variant and Dr.Jit's state are process-wide, and two stage threads rendering at once
# were seen to livelock in Dr.Jit's reference counting: every stage that uses Mitsuba holds this
# lock for all of its Mitsuba work.
MITSUBA = threading.RLock()
FAST_VARIANT, FALLBACK_VARIANT = "llvm_ad_rgb", "scalar_rgb"

_PROBE = ("import mitsuba as mi\n"
          "mi.set_variant('llvm_ad_rgb')\n"
          "scene = mi.load_dict(mi.cornell_box())\n"
          "mi.render(scene, spp=1)\n")


@functools.cache
def normalization(shape: str, form: str, n: float, k: float, nodes: int = 96, power: int = 2) -> float:
    """The exact normalization of a lobe (`shape` "power" or "linear_power", the registry's families)
    at normal incidence: 1 over its albedo per unit coef there, by the pipeline's hemisphere
    quadrature (`pipeline.optics.albedo`)."""
    import numpy as np

    from ..optics.albedo import albedo_table

    if shape == "power":
        albedo = albedo_table(form, "power", n, n, 1.0, np.zeros(1), nodes)
    else:
        albedo = albedo_table(form, "linear_power", n, k, min(1.0 / k, 2.0), np.zeros(1), nodes, power)
    return 1.0 / float(albedo[0, 0])


@functools.cache
def choose_variant() -> str:
    """`llvm_ad_rgb` where Dr.Jit's LLVM back end renders with the LLVM that `toolchains` finds
    (probed in a child process, since a broken LLVM aborts the process), else `scalar_rgb`.
    `PIPELINE_MITSUBA_VARIANT` overrides."""
    forced = os.environ.get(toolchains.VARIANT_VARIABLE)
    if forced:
        return forced
    toolchains.prepare()            # the child inherits DRJIT_LIBLLVM_PATH
    probe = subprocess.run([sys.executable, "-c", _PROBE], capture_output=True, timeout=120, check=False)
    return FAST_VARIANT if probe.returncode == 0 else FALLBACK_VARIANT


def fallback_warning(variant: str) -> str:
    """One line where `variant` is the fallback although LLVM was found (it did not render), else ""."""
    found = toolchains.locate("llvm")
    if variant != FALLBACK_VARIANT or not found.found or os.environ.get(toolchains.VARIANT_VARIABLE):
        return ""
    return (f"warning: Dr.Jit's LLVM back end did not render with LLVM {found.version} ({found.path}): Mitsuba "
            f"renders with {FALLBACK_VARIANT} at mitsuba.fallback_spp samples per pixel, slower and with other "
            f"numbers; {toolchains.LLVM_INSTALL}")


def register(variant: str | None = None) -> str:
    """Sets the Mitsuba variant (chosen by `choose_variant` if not given) and registers the
    plugin; returns the variant."""
    variant = variant or choose_variant()
    toolchains.prepare()            # before Dr.Jit loads LLVM
    with PARSING:           # importing Mitsuba's integrators parses their source (`engine.parsing`)
        import mitsuba as mi

        mi.set_variant(variant)
        mi.register_bsdf(NAME, lambda props: plugin_class()(props))
    return variant


_CLASSES: dict = {}


def plugin_class():
    """The plugin's class for the current variant (made once per variant)."""
    import mitsuba as mi

    if mi.variant() not in _CLASSES:
        _CLASSES[mi.variant()] = _make_class()
    return _CLASSES[mi.variant()]


def _make_class():
    import drjit as dr
    import mitsuba as mi

    class CosQuadLobe(mi.BSDF):
        def __init__(self, props):
            mi.BSDF.__init__(self, props)
            self.shape = props.get("shape", "linear_power")
            self.power = int(props.get("power", 2))
            self.form = props.get("form", "phong")
            self.sampler = props.get("sampler", "lobe")
            self.n = float(props.get("exponent", 100.0))
            self.k = float(props.get("k", 1.0))
            self.coef = float(props["coef"]) if "coef" in props else normalization(
                self.shape, self.form, self.n, self.k if self.shape == "linear_power" else self.n, power=self.power)
            for name, value, allowed in (("shape", self.shape, ("power", "linear_power")),
                                         ("form", self.form, ("phong", "blinn")),
                                         ("sampler", self.sampler, ("lobe", "cosine"))):
                if value not in allowed:
                    raise ValueError(f"{NAME}: {name} = {value!r}; allowed: {', '.join(allowed)}")
            if self.shape == "linear_power" and not self.k > 0:
                raise ValueError(f"{NAME}: k = {self.k} must be > 0")
            if not 1 <= self.power <= 64:
                raise ValueError(f"{NAME}: power = {self.power} must be an integer in [1, 64]")
            flags = mi.BSDFFlags.GlossyReflection | mi.BSDFFlags.FrontSide
            self.m_components = [flags]
            self.m_flags = flags
            m1 = self.power + 1
            w0 = max(1.0 - 2.0 * self.k, 0.0) ** m1      # the family: w^(m+1) at c = -1 (0 unless k < 1/2)
            self.w0_power = w0
            self.z = 2.0 * math.pi * (1.0 - w0) / (m1 * self.k)

        def family_power(self, b):
            """b^m by squarings and multiplies (`registry.power_steps`), never a pow."""
            values = {"b": b}
            steps, result = power_steps("b", self.power)
            for name, expression in steps:
                left, right = (values[v.strip()] for v in expression.split("*"))
                values[name] = left * right
            return values[result]

        # The lobe and its sampler as functions of the axis cosine c.
        def lobe(self, c):
            if self.shape == "power":
                return dr.power(dr.maximum(c, 0.0), self.n)
            return self.family_power(dr.maximum(self.k * (c - 1.0) + 1.0, 0.0))

        def axis_pdf(self, c):
            """Solid-angle pdf of directions at axis cosine c."""
            if self.shape == "power":
                return dr.select(c > 0.0, (self.n + 1.0) / (2.0 * math.pi) * dr.power(dr.maximum(c, 0.0), self.n), 0.0)
            w = self.k * (c - 1.0) + 1.0
            return dr.select(w > 0.0, self.family_power(dr.maximum(w, 0.0)) / self.z, 0.0)

        def axis_cosine(self, xi):
            """The axis cosine from one uniform number (inverse CDF)."""
            if self.shape == "power":
                return dr.power(xi, 1.0 / (self.n + 1.0))
            mixed = self.w0_power + xi * (1.0 - self.w0_power)
            w = dr.cbrt(mixed) if self.power == 2 else dr.power(mixed, 1.0 / (self.power + 1))
            return 1.0 + (w - 1.0) / self.k

        def cosine(self, wi, wo):
            """The lobe's argument c for the pair (wi, wo), and the half vector (Blinn)."""
            if self.form == "phong":
                return wo.x * -wi.x + wo.y * -wi.y + wo.z * wi.z, None
            h = dr.normalize(wi + wo)
            return h.z, h

        def eval(self, ctx, si, wo, active=True):
            cos_i, cos_o = mi.Frame3f.cos_theta(si.wi), mi.Frame3f.cos_theta(wo)
            c, _ = self.cosine(si.wi, wo)
            value = self.coef * self.lobe(c) * cos_o
            return mi.Color3f(dr.select(active & (cos_i > 0.0) & (cos_o > 0.0), value, 0.0))

        def pdf(self, ctx, si, wo, active=True):
            cos_i, cos_o = mi.Frame3f.cos_theta(si.wi), mi.Frame3f.cos_theta(wo)
            if self.sampler == "cosine":
                p = mi.warp.square_to_cosine_hemisphere_pdf(wo)
            else:
                c, h = self.cosine(si.wi, wo)
                p = self.axis_pdf(c)
                if self.form == "blinn":
                    # Both h and -h reflect wi to wo; where the lobe reaches below the horizon
                    # (k < 1) the sampler draws either, so both densities count.
                    p = (p + self.axis_pdf(-c)) / (4.0 * dr.abs(dr.dot(wo, h)))
            return dr.select(active & (cos_i > 0.0) & (cos_o > 0.0), p, 0.0)

        def eval_pdf(self, ctx, si, wo, active=True):
            return self.eval(ctx, si, wo, active), self.pdf(ctx, si, wo, active)

        def sample(self, ctx, si, sample1, sample2, active=True):
            wi = si.wi
            if self.sampler == "cosine":
                wo = mi.warp.square_to_cosine_hemisphere(sample2)
            else:
                c = self.axis_cosine(sample2.x)
                sin = dr.safe_sqrt(1.0 - c * c)
                s, co = dr.sincos(2.0 * math.pi * sample2.y)
                local = mi.Vector3f(sin * co, sin * s, c)
                if self.form == "phong":
                    wo = mi.Frame3f(mi.Vector3f(-wi.x, -wi.y, wi.z)).to_world(local)
                else:
                    wo = 2.0 * dr.dot(wi, local) * local - wi
            value, p = self.eval_pdf(ctx, si, wo, active)
            bs = mi.BSDFSample3f()
            bs.wo = wo
            bs.pdf = p
            bs.eta = 1.0
            bs.sampled_type = mi.UInt32(+mi.BSDFFlags.GlossyReflection)
            bs.sampled_component = mi.UInt32(0)
            ok = active & (p > 0.0)
            return bs, mi.Color3f(dr.select(ok, value / dr.select(ok, p, 1.0), 0.0))

        def traverse(self, callback):
            pass

        def to_string(self):
            return (f"CosQuadLobe[shape={self.shape}, power={self.power}, form={self.form}, n={self.n}, k={self.k}, "
                    f"coef={self.coef}, sampler={self.sampler}]")

    return CosQuadLobe
