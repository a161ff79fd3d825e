"""Rendered comparison (for shader authors): the reference Blinn-Phong lobe cos^n(N.H) with
Giesen's exact normalization, against f_2 and f_Q2, on the scenes of `pipeline.optics.raytrace`, at the
exponents of `render.exponents`. render.normalization = "reference" gives every lobe Giesen's
factor (equal peaks: the images differ by shape alone); "exact" gives each its own exact
Blinn-form normalization (`pipeline.optics.integrals`; equal energy at normal view). Either way f_Q2 is
also rendered as an adopter ships it, with its own exact Blinn-form coef (`shipped_*`).

Per scene, exponent and candidate lobe, against the reference:
- the relative error of luminance in the epicenter zone, where the reference lobe cos^n(N.H) >= L
  (as d is defined: with equal normalizations it cannot exceed the lobe's d at that n);
- NVIDIA's FLIP (flip-evaluator, LDR, on the displayed 8-bit images as floats in [0, 1]) over the
  frame and over the visible highlight, and its error map;
- the area of each lobe's visible highlight: pixels its specular term brightens by at least one
  8-bit display level, and how the FLIP error splits between the epicenter, the rest of the
  visible highlight (the blooming zone) and elsewhere;
- absolute error of linear radiance and the PSNR of the displayed images, as before.
"""

import functools

from ..optics.numerics import jax  # noqa: F401  (float64 before any array)
import numpy as np

from ..optics import integrals, registry
from ..optics.images import display_and_luminance, flip_map, image_statistics, visible
from ..optics.normalizations import giesen
from ..optics.raytrace import SCENES, epicenter_mask, shade

# The rendered lobes (registry keys), the reference first.
LOBES = (registry.REFERENCE, "f_2", "f_Q2")


@functools.lru_cache(maxsize=4)
def _base_display(scene_index: int, resolution: int) -> np.ndarray:
    """The scene's 8-bit display without a specular term (coef 0): what a highlight brightens."""
    return np.asarray(display_and_luminance(shade(SCENES[scene_index], resolution, "power", 1.0, 0.0))[0])


@functools.lru_cache(maxsize=4)
def _reference_image(scene_index: int, resolution: int, n: float, coef: float):
    """(radiance, 8-bit display, luminance) of the reference cos^n at exponent n: shared by every
    candidate at that n and by `reference`, computed once per stage run."""
    radiance = shade(SCENES[scene_index], resolution, "power", n, coef)
    display, lum = (np.asarray(v) for v in display_and_luminance(radiance))
    return radiance, display, lum


def candidate(scene_index: int, resolution: int, n: float, shape: str, p: float, coef: float, reference_coef: float,
              level: float, power: int = 2) -> dict:
    """One candidate lobe's image at exponent n against the reference cos^n (both with their coef):
    its display and luminance, FLIP map, visible-highlight mask of both, and its statistics. A
    memoized call: a candidate that does not depend on a setting (f_2 under a Q refit) is reused."""
    scene = SCENES[scene_index]
    base8 = _base_display(scene_index, resolution)
    ref, ref8, _ = _reference_image(scene_index, resolution, n, reference_coef)
    image = shade(scene, resolution, shape, p, coef, int(power))
    image8, lum = (np.asarray(v) for v in display_and_luminance(image))
    epicenter = np.asarray(epicenter_mask(scene, resolution, n, level))
    fmap = flip_map(ref8, image8)
    seen_ref, seen = visible(ref8, base8), visible(image8, base8)
    region = seen_ref | seen
    total = float(fmap.sum())
    stats = dict(epicenter_pixels=int(epicenter.sum()), flip_frame=float(fmap.mean()),
                 flip_highlight=float(fmap[region].mean()),
                 # Where the FLIP error lies: epicenter, rest of the visible highlight, elsewhere.
                 flip_share_epicenter=float(fmap[epicenter].sum()) / total,
                 flip_share_blooming=float(fmap[region & ~epicenter].sum()) / total,
                 flip_share_elsewhere=float(fmap[~region & ~epicenter].sum()) / total,
                 highlight_pixels=int(region.sum()), visible_pixels=int(seen.sum()),
                 reference_visible_pixels=int(seen_ref.sum()),
                 **image_statistics(image, ref, epicenter))
    return dict(display=image8, luminance=lum.astype(np.float32), flip=fmap.astype(np.float16), stats=stats)


def reference(scene_index: int, resolution: int, n: float, coef: float) -> dict:
    """The reference cos^n image: display and luminance."""
    _, image8, lum = _reference_image(scene_index, resolution, n, coef)
    return dict(display=image8, luminance=lum.astype(np.float32))


def run(config, inputs, memo):
    a, b = inputs["linear_coefficient.slope_used"], inputs["linear_coefficient.intercept_used"]
    level = inputs["zone.level"]
    power = config["lobe.power"]
    blinn_fns = {m: integrals.exact_coef_code("blinn", m)[0] for m in {2, power}}
    res = config["render.resolution"]
    exponents = [float(v) for v in config["render.exponents"]]
    own = config["render.normalization"] == "exact"

    params = registry.Parameters(slope=a, intercept=b, power=power)
    d_curves = {"f_2": inputs["f2_errors.d_f_2_curve"], "f_Q2": inputs["accuracy.d_f_Q2_curve"]}

    def d_bound(name, n):
        """The lobe's d at exponent n (the bound of its epicenter error; NaN outside the n range)."""
        i = int(round(n)) - config["derivation.n_min"]
        return float(d_curves[name][i]) if n == round(n) and 0 <= i < len(d_curves[name]) else float("nan")

    def lobes(n):
        """(shape, parameter, coef, power) of each lobe at exponent n: the reference with Giesen's
        factor, each candidate with Giesen's or its own exact Blinn-form coef (of k: k = 1 k + 0)."""
        out = {}
        for key in LOBES:
            lobe = registry.LOBES[key]
            p = float(lobe.parameter(np, n, params))
            m = lobe.power_of(params)
            own_coef = float(blinn_fns[m](p, 1.0, 0.0)) if own and key != registry.REFERENCE else giesen(n)
            out[key] = (lobe.shape, p, own_coef, m)
        return out

    shape = (len(SCENES), len(exponents))
    display = np.zeros(shape + (len(LOBES), res, res, 3), dtype=np.uint8)
    lum = np.zeros(shape + (len(LOBES), res, res), dtype=np.float32)
    flip_maps = np.zeros(shape + (len(LOBES) - 1, res, res), dtype=np.float16)
    stats, areas, shipped = [], [], []
    shipped_display = np.zeros(shape + (res, res, 3), dtype=np.uint8)
    for i, scene in enumerate(SCENES):
        for j, n in enumerate(exponents):
            spec = lobes(n)
            ref_coef = float(spec[registry.REFERENCE][2])
            r = memo("render_reference", reference, scene_index=i, resolution=res, n=n, coef=ref_coef)
            display[i, j, 0], lum[i, j, 0] = r["display"], r["luminance"]
            area = dict(scene=scene.name, n=n)
            for l, name in enumerate(LOBES[1:], 1):
                shape_, p, coef, m = spec[name]
                c = memo("render_candidate", candidate, scene_index=i, resolution=res, n=n, shape=shape_,
                         p=float(p), coef=float(coef), reference_coef=ref_coef, level=level, power=m)
                display[i, j, l], lum[i, j, l], flip_maps[i, j, l - 1] = c["display"], c["luminance"], c["flip"]
                st = dict(c["stats"])
                area[registry.REFERENCE], area[name] = st.pop("reference_visible_pixels"), st.pop("visible_pixels")
                stats.append(dict(scene=scene.name, n=n, lobe=name, coef=float(coef), d_bound=d_bound(name, n), **st))
            areas.append(area)
            # f_Q2 as an adopter ships it: with its own exact Blinn-form coef (the same call as above
            # where render.normalization is "exact").
            shape_, p, _, m = spec["f_Q2"]
            own_coef = float(blinn_fns[m](p, 1.0, 0.0))
            c = memo("render_candidate", candidate, scene_index=i, resolution=res, n=n, shape=shape_,
                     p=float(p), coef=own_coef, reference_coef=ref_coef, level=level, power=m)
            shipped_display[i, j] = c["display"]
            shipped.append(dict(scene=scene.name, n=n, coef=own_coef, coef_over_reference=own_coef / ref_coef,
                                flip_highlight=c["stats"]["flip_highlight"],
                                equal_peak_flip_highlight=next(x["flip_highlight"] for x in stats if x["scene"] == scene.name
                                                               and x["n"] == n and x["lobe"] == "f_Q2")))
    _base_display.cache_clear()
    _reference_image.cache_clear()
    # The first scene at the largest exponent: f_Q2's visible highlight against the reference's.
    last = next(a for a in areas if a["scene"] == SCENES[0].name and a["n"] == max(exponents))
    return dict(lobes=list(LOBES), scenes=[s.name for s in SCENES], display=display, luminance=lum,
                flip_maps=flip_maps, statistics=stats, visible_areas=areas,
                shipped_display=shipped_display, shipped_statistics=shipped,
                visible_area_ratio_n=float(last["n"]), visible_area_scene=last["scene"],
                visible_area_ratio_f_Q2=last["f_Q2"] / max(last[registry.REFERENCE], 1),
                flip_f_Q2_max=max(s["flip_highlight"] for s in stats if s["lobe"] == "f_Q2"),
                flip_f_2_max=max(s["flip_highlight"] for s in stats if s["lobe"] == "f_2"),
                psnr_f_Q2_min=min(s["psnr"] for s in stats if s["lobe"] == "f_Q2"),
                psnr_f_2_min=min(s["psnr"] for s in stats if s["lobe"] == "f_2"))
