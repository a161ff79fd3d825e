"""The lobe as a microfacet NDF in Mitsuba 3 (beyond the paper): the three spheres of
`mitsuba.exponents` rendered with a Cook-Torrance BSDF whose D is each normalized lobe (cos^n, f_2,
f_Q2: `pipeline.mitsuba.microfacet`), beside Mitsuba's own `roughconductor` with Beckmann and GGX at
the matched roughness alpha = sqrt(2 / (n + 2)); F = 1 and Smith's G of Beckmann everywhere, so
that the images differ by D alone (GGX's own G for GGX, as an engine ships it). Same scene, sampler
and seeds as `mitsuba_render`.

Each NDF is rendered twice (seeds `mitsuba.seed`, `mitsuba.seed + 1`); FLIP over each sphere's
sun highlight (pixels where the sun's direct term D G E / (4 n.v) of Beckmann or of the candidate
brightens the image without the sun by one display level) against the Beckmann image, beside the
FLIP between Beckmann's two seeds (what noise alone gives): a candidate is distinguishable from
Beckmann there if its FLIP is more than twice that.
"""

import time

import numpy as np

from ..mitsuba import bsdf, microfacet, scene
from ..optics import distributions as ndf, registry
from ..optics.images import display_and_luminance, flip_map, visible
from .common import mitsuba_settings

LOBES = (registry.REFERENCE, "f_2", "f_Q2")
CANDIDATES = ("ggx",) + LOBES
NOISE_FACTOR = 2.0


def _display8(radiance) -> np.ndarray:
    return np.asarray(display_and_luminance(radiance)[0])


def run(config, inputs, memo):
    with bsdf.MITSUBA:        # one stage at a time uses Mitsuba (`pipeline.mitsuba.bsdf.MITSUBA`)
        return _run(config, inputs, memo)


def _run(config, inputs, memo):
    a, b = inputs["linear_coefficient.slope_used"], inputs["linear_coefficient.intercept_used"]
    s = mitsuba_settings(config, microfacet.register, memo.log)
    exponents, width, height, seed, variant, spp, nodes = (s[k] for k in ("exponents", "width", "height", "seed",
                                                                          "variant", "spp", "nodes"))
    params = registry.Parameters(slope=a, intercept=b, power=config["lobe.power"])
    alphas = [float(ndf.alpha_of_n(n)) for n in exponents]

    def spheres(name):
        """The BSDF dicts of the three spheres with NDF `name` (a registry key, "beckmann" or "ggx")."""
        out = []
        for n, alpha in zip(exponents, alphas):
            if name in ("beckmann", "ggx"):
                out.append({"type": "roughconductor", "distribution": name, "alpha": alpha, "material": "none"})
                continue
            lobe = registry.LOBES[name]
            p, power = float(lobe.parameter(np, n, params)), lobe.power_of(params)
            coef = bsdf.normalization(lobe.shape, "phong", n, p, nodes, power)     # the NDF normalization
            out.append({"type": microfacet.NAME, "shape": lobe.shape, "form": "blinn", "exponent": n, "k": p,
                        "power": power, "alpha": alpha, "coef": coef})
        return out

    def D(name, i, t):
        """The NDF of sphere i at t = n.h (numpy), as the renders use it."""
        if name == "beckmann":
            return ndf.beckmann(t, alphas[i])
        if name == "ggx":
            return ndf.ggx(t, alphas[i])
        props = spheres(name)[i]
        base = 1.0 - props["k"] * (1.0 - t) if props["shape"] == "linear_power" else t
        value = np.maximum(base, 0.0) ** (props["power"] if props["shape"] == "linear_power" else props["exponent"])
        return props["coef"] * value

    start = time.perf_counter()
    runs = {}
    for name in ("beckmann",) + CANDIDATES:
        pair = memo("microfacet_pair", scene.render_pair, lobes=spheres(name), width=width, height=height, spp=spp,
                    seed=seed, variant=variant)
        runs[name] = (pair["first"], pair["second"])
    no_sun = memo("microfacet_no_sun", scene.render_no_sun, lobes=spheres("beckmann"), width=width, height=height,
                  spp=spp, seed=seed, variant=variant)["image"]
    seconds = time.perf_counter() - start

    geometry = scene.pixel_geometry(width, height, spheres("beckmann"))
    t, cos_l, cos_v, sphere = (geometry[k] for k in ("t", "cos_light", "cos_view", "sphere"))
    display = {name: _display8(0.5 * (p[0] + p[1])) for name, p in runs.items()}
    base8 = _display8(no_sun)
    noise_map = flip_map(_display8(runs["beckmann"][0]), _display8(runs["beckmann"][1]))

    def highlight(name):
        """Pixels whose sun term with NDF `name` is visible over the image without the sun."""
        direct = np.zeros(no_sun.shape)
        for i, alpha in enumerate(alphas):
            here = (sphere == i) & (cos_l > 0.0) & (cos_v > 0.0)
            G = ndf.smith_g1_beckmann(cos_l, alpha) * ndf.smith_g1_beckmann(cos_v, alpha)
            value = D(name, i, t) * G / (4.0 * np.maximum(cos_v, 1e-12))
            direct[here] = (scene.SUN_IRRADIANCE * value[..., None])[here]
        return visible(_display8(no_sun + direct), base8)

    reference_seen = highlight("beckmann")
    statistics, maps = [], []
    for name in CANDIDATES:
        fmap = flip_map(display["beckmann"], display[name])
        maps.append(fmap.astype(np.float16))
        seen = reference_seen | highlight(name)
        for i, n in enumerate(exponents):
            region = seen & (sphere == i)
            flip = float(fmap[region].mean())
            noise = float(noise_map[region].mean())
            statistics.append(dict(ndf=name, n=n, alpha=alphas[i], highlight_pixels=int(region.sum()),
                                   flip_highlight=flip, flip_noise=noise,
                                   distinguishable=bool(flip > NOISE_FACTOR * noise)))
    by = {(s["ndf"], s["n"]): s for s in statistics}
    return dict(variant=variant, spp=int(spp), render_seconds=seconds, exponents=exponents, alphas=alphas,
                ndfs=["beckmann"] + list(CANDIDATES),
                display=np.stack([display[k] for k in ("beckmann",) + CANDIDATES]), flip_maps=np.stack(maps),
                statistics=statistics,
                flip_f_Q2_vs_beckmann_max=max(by[("f_Q2", n)]["flip_highlight"] for n in exponents),
                flip_ggx_vs_beckmann_max=max(by[("ggx", n)]["flip_highlight"] for n in exponents),
                f_Q2_distinguishable_count=int(sum(by[("f_Q2", n)]["distinguishable"] for n in exponents)))
