"""Renders in Mitsuba 3 (beyond the paper): the lobes as BSDF plugins (`pipeline.mitsuba.bsdf`, Blinn
form, each with its exact normalization at normal view) on three spheres of exponents
`mitsuba.exponents` under a sky and a sun, path traced with indirect light
(`pipeline.mitsuba.scene`); reference cos^n against f_2 and f_Q2, judged by FLIP.

- Every lobe is rendered twice, with seeds `mitsuba.seed` and `mitsuba.seed + 1`, at `mitsuba.spp`
  samples per pixel; the image is their mean, and (a - b)^2 / 4 estimates its noise variance per
  pixel, so the noise can be set beside the differences between lobes.
- The sun's visible highlight in each sphere: its pixels where the sun's direct specular term of
  any lobe (in closed form from an AOV pass, E coef lobe(N.H) N.L) brightens the image without the
  sun by at least one 8-bit display level, as in the direct-lighting renders; its epicenter, where
  cos^n(N.H) >= the zone level L.
- FLIP (flip-evaluator, LDR) on the displayed 8-bit images (Reinhard tone map and sRGB, as the
  direct-lighting renders), as floats: mean over the frame and over each highlight, and the share
  of each highlight's FLIP error in its epicenter.
- Importance sampling: f_Q2 rendered also with cosine-weighted sampling at the same samples per
  pixel; the per-pixel variance of each over the highlights.
- The sphere of the largest n zoomed: the frame rendered at an integer scale (up to 8x) in a
  window around its highlight only, so that its FLIP statistics rest on at least `ZOOM_PIXELS`
  highlight pixels (about a hundred at the frame's own resolution for n = 1000).

Without a vectorized Mitsuba variant (no LLVM >= 15: `pipeline.mitsuba.bsdf.choose_variant`) the
scalar variant runs the Python plugins one sample at a time, so the stage renders at
`mitsuba.fallback_spp` samples per pixel and says so.
"""

import time

import numpy as np

from ..mitsuba import bsdf, scene
from ..optics import registry
from ..optics.images import display_and_luminance, flip_map, luminance, visible
from ..optics.lobes import SHAPES
from .common import mitsuba_settings

# The rendered lobes (registry keys), the reference first.
REFERENCE = registry.REFERENCE
LOBES = (REFERENCE, "f_2", "f_Q2")


def _display8(radiance) -> np.ndarray:
    return np.asarray(display_and_luminance(radiance)[0])


# The zoomed render of the sphere of the largest n: at least this many highlight pixels.
ZOOM_PIXELS, ZOOM_SCALE_MAX = 1500, 8


def zoom_window(highlight, index: int, width: int, height: int) -> tuple[int, tuple[int, int, int, int]]:
    """(scale, crop) of a render zoomed on sphere `index`'s highlight: the frame scaled so that the
    highlight covers at least `ZOOM_PIXELS` pixels (at most `ZOOM_SCALE_MAX`), and the window around
    it (half again its extent, at least 8 pixels of the unscaled frame each side)."""
    ys, xs = np.nonzero(highlight == index)
    scale = int(min(ZOOM_SCALE_MAX, max(1, np.ceil(np.sqrt(ZOOM_PIXELS / max(len(ys), 1))))))
    cy, cx = int(ys.mean()), int(xs.mean())
    half = max(8, int(0.75 * max(ys.max() - ys.min(), xs.max() - xs.min())) + 2)
    x0, x1 = max(cx - half, 0), min(cx + half, width)
    y0, y1 = max(cy - half, 0), min(cy + half, height)
    return scale, (x0 * scale, y0 * scale, (x1 - x0) * scale, (y1 - y0) * scale)


def run(config, inputs, memo):
    with bsdf.MITSUBA:        # one stage at a time uses Mitsuba (`pipeline.mitsuba.bsdf.MITSUBA`)
        return _run(config, inputs, memo)


def _run(config, inputs, memo):
    a, b = inputs["linear_coefficient.slope_used"], inputs["linear_coefficient.intercept_used"]
    level = inputs["zone.level"]
    s = mitsuba_settings(config, bsdf.register, memo.log)
    exponents, width, height, seed, variant, spp, nodes = (s[k] for k in ("exponents", "width", "height", "seed",
                                                                          "variant", "spp", "nodes"))

    params = registry.Parameters(slope=a, intercept=b, power=config["lobe.power"])

    def lobes(key, sampler="lobe"):
        """The plugin properties of the three spheres with the registry's lobe `key`."""
        lobe, out = registry.LOBES[key], []
        for n in exponents:
            p = float(lobe.parameter(np, n, params))
            power = lobe.power_of(params)
            coef = bsdf.normalization(lobe.shape, "blinn", n, p, nodes, power)
            out.append(scene.lobe_dict(lobe.shape, n, p, coef, sampler, power))
        return out

    def lobe_value(props, t):
        """The sphere's lobe at N.H = t (`pipeline.optics.lobes`, in u = 1 - t)."""
        return np.asarray(SHAPES[props["shape"]](1.0 - t, props["k"], props["power"]))

    start = time.perf_counter()
    runs = {}
    # Memoized per lobe: a Q refit renders f_Q2 again and reuses f_b and f_2.
    for name, sampler in [(lobe, "lobe") for lobe in LOBES] + [("f_Q2", "cosine")]:
        pair = memo("mitsuba_pair", scene.render_pair, lobes=lobes(name, sampler), width=width, height=height, spp=spp,
                    seed=seed, variant=variant)
        runs[(name, sampler)] = [pair["first"], pair["second"]]
    no_sun = memo("mitsuba_no_sun", scene.render_no_sun, lobes=lobes(REFERENCE), width=width, height=height, spp=spp,
                  seed=seed, variant=variant)["image"]
    seconds = time.perf_counter() - start

    def highlights(no_sun, geometry):
        """(the sphere index of each pixel in some lobe's visible sun highlight, or -1; the
        epicenter pixels, where cos^n(N.H) >= L)."""
        t, cos_light, sphere = geometry["t"], geometry["cos_light"], geometry["sphere"]
        base8 = _display8(no_sun)
        seen = np.zeros(sphere.shape, dtype=bool)
        epicenter = np.zeros(sphere.shape, dtype=bool)
        for name in LOBES:
            direct = np.zeros(no_sun.shape)
            for i, props in enumerate(lobes(name)):
                here = (sphere == i) & (cos_light > 0.0)
                value = props["coef"] * lobe_value(props, t) * np.maximum(cos_light, 0.0)
                direct[here] = (scene.SUN_IRRADIANCE * value[..., None])[here]
                if name == REFERENCE:
                    epicenter |= (sphere == i) & (lobe_value(props, t) >= level)
            seen |= visible(_display8(no_sun + direct), base8)
        return np.where(seen & (sphere >= 0), sphere, -1).astype(np.int8), epicenter

    geometry = scene.pixel_geometry(width, height, lobes(REFERENCE))
    sphere = geometry["sphere"]
    highlight, epicenter = highlights(no_sun, geometry)
    mean = {key: 0.5 * (p[0] + p[1]) for key, p in runs.items()}
    lum = {key: np.asarray(luminance(m)) for key, m in mean.items()}
    noise_var = {key: np.asarray(luminance(p[0]) - luminance(p[1])) ** 2 / 4.0 for key, p in runs.items()}
    display = {key: _display8(m) for key, m in mean.items()}
    reference = (REFERENCE, "lobe")
    statistics, flip_frame, maps = [], {}, []
    for name in LOBES[1:]:
        key = (name, "lobe")
        fmap = flip_map(display[reference], display[key])
        maps.append(fmap.astype(np.float16))
        flip_frame[name] = float(fmap.mean())
        for i, n in enumerate(exponents):
            region = highlight == i
            core = region & epicenter
            difference = lum[key][region] - lum[reference][region]
            noise = np.sqrt(np.mean(noise_var[key][region] + noise_var[reference][region]))
            statistics.append(dict(
                lobe=name, n=n, highlight_pixels=int(region.sum()), epicenter_pixels=int(core.sum()),
                flip_highlight=float(fmap[region].mean()),
                flip_share_epicenter=float(fmap[core].sum() / max(fmap[region].sum(), 1e-30)),
                difference_rms=float(np.sqrt(np.mean(difference ** 2))), noise_rms=float(noise),
                noise_to_difference=float(noise / max(np.sqrt(np.mean(difference ** 2)), 1e-30))))
    sampling = []
    for i, n in enumerate(exponents):
        # Over the whole sphere: in the sun's highlight the light is sampled (the sun is a delta
        # light), so the BSDF's sampler matters for the sky it reflects.
        region = sphere == i
        # Variance of one render at spp: twice that of the two-render mean.
        lobe_var = float(np.mean(2.0 * noise_var[("f_Q2", "lobe")][region]))
        cosine_var = float(np.mean(2.0 * noise_var[("f_Q2", "cosine")][region]))
        sampling.append(dict(n=n, lobe_sampler_variance=lobe_var, cosine_sampler_variance=cosine_var,
                             variance_ratio=cosine_var / max(lobe_var, 1e-300)))
    # The sphere of the largest n zoomed: the frame rendered at `scale` times the resolution, only
    # in a window around its highlight, so that its statistics rest on >= ZOOM_PIXELS pixels.
    index = int(np.argmax(exponents))
    scale, crop = zoom_window(highlight, index, width, height)
    zoom_runs = {name: memo("mitsuba_zoom_pair", scene.render_pair, lobes=lobes(name), width=width * scale,
                            height=height * scale, spp=spp, seed=seed, variant=variant, crop=crop)
                 for name in LOBES}
    zoom_no_sun = memo("mitsuba_zoom_no_sun", scene.render_no_sun, lobes=lobes(REFERENCE), width=width * scale,
                       height=height * scale, spp=spp, seed=seed, variant=variant, crop=crop)["image"]
    zoom_highlight, _ = highlights(zoom_no_sun, scene.pixel_geometry(width * scale, height * scale,
                                                                      lobes(REFERENCE), crop))
    zoom_display = {name: _display8(0.5 * (p["first"] + p["second"])) for name, p in zoom_runs.items()}
    region = zoom_highlight == index
    zoom_stats, zoom_maps = [], []
    for name in LOBES[1:]:
        fmap = flip_map(zoom_display[REFERENCE], zoom_display[name])
        zoom_maps.append(fmap.astype(np.float16))
        zoom_stats.append(dict(lobe=name, n=exponents[index], highlight_pixels=int(region.sum()),
                               flip_highlight=float(fmap[region].mean())))
    zoom = dict(n=exponents[index], scale=scale, crop=list(crop), highlight_pixels=int(region.sum()),
                statistics=zoom_stats)

    by = {(s["lobe"], s["n"]): s["flip_highlight"] for s in statistics}
    return dict(
        zoom=zoom, zoom_display=np.stack([zoom_display[k] for k in LOBES]), zoom_flip_maps=np.stack(zoom_maps),
        zoom_highlight=zoom_highlight,
        variant=variant, spp=int(spp), render_seconds=seconds, exponents=exponents,
        display=np.stack([display[k] for k in (reference, ("f_2", "lobe"), ("f_Q2", "lobe"), ("f_Q2", "cosine"))]),
        flip_maps=np.stack(maps), highlight=highlight, epicenter=epicenter,
        statistics=statistics, flip_frame=flip_frame, sampling=sampling,
        flip_f_Q2_max=max(by[("f_Q2", n)] for n in exponents), flip_f_2_max=max(by[("f_2", n)] for n in exponents),
        f_Q2_closer_count=int(sum(by[("f_Q2", n)] < by[("f_2", n)] for n in exponents)),
        noise_to_difference_max=max(s["noise_to_difference"] for s in statistics),
    )
