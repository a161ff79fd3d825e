"""Rendered comparison (for shader authors): the reference Blinn-Phong lobe cos^n(N.H) with
Giesen's exact normalization, against f_2 and f_Q2, on the scenes of `pipeline.render`, at the
exponents of `render.exponents`. render.normalization = "reference" gives every lobe Giesen's
factor (equal peaks: the images differ by shape alone, as d and D measure it); "exact" gives each
its own exact Blinn-form normalization (`pipeline.exact`; equal energy at normal view).

Stored: the displayed images (sRGB, 8 bit), the linear luminance of each (for the heatmaps), and
the image-space error statistics of each candidate against the reference.
"""

import jax.numpy as jnp
import numpy as np

from .. import exact
from ..cheap_lobes import giesen
from ..lobes import f_b_u, quadratic_u
from ..render import SCENES, image_statistics, luminance, shade, to_display

READS = ("render.*",)
UPSTREAM = ("zone", "linear_coefficient")


def run(config, upstream):
    lin = upstream["linear_coefficient"]
    a, b = lin["slope_used"], lin["intercept_used"]
    blinn_coef, _ = exact.exact_coef_code("blinn")
    res = config["render.resolution"]
    exponents = [float(v) for v in config["render.exponents"]]
    own = config["render.normalization"] == "exact"
    lobes = {
        "cos^n": (lambda u, n: f_b_u(u, n), giesen),
        "f_2": (lambda u, n: quadratic_u(u, n / 2.0), (lambda n: float(blinn_coef(n, 0.5, 0.0))) if own else giesen),
        "f_Q2": (lambda u, n: quadratic_u(u, a * n + b), (lambda n: float(blinn_coef(n, a, b))) if own else giesen),
    }
    level = upstream["zone"]["level"]
    names = list(lobes)
    display = np.zeros((len(SCENES), len(exponents), len(names), res, res, 3), dtype=np.uint8)
    lum = np.zeros((len(SCENES), len(exponents), len(names), res, res), dtype=np.float32)
    stats = []
    for i, scene in enumerate(SCENES):
        base = shade(scene, res, lambda u, n: jnp.zeros_like(u), 1.0, 0.0)
        for j, n in enumerate(exponents):
            images = {name: shade(scene, res, fn, n, coef(n)) for name, (fn, coef) in lobes.items()}
            ref = images["cos^n"]
            spec = luminance(ref - base)
            # The highlight's epicenter: where the reference lobe is at least the zone level of its peak.
            highlight = spec >= level * jnp.max(spec)
            for l, name in enumerate(names):
                display[i, j, l] = np.asarray(jnp.round(255.0 * to_display(images[name]))).astype(np.uint8)
                lum[i, j, l] = np.asarray(luminance(images[name]), dtype=np.float32)
                if name != "cos^n":
                    stats.append(dict(scene=scene.name, n=n, lobe=name, coef=lobes[name][1](n),
                                      highlight_pixels=int(jnp.sum(highlight)),
                                      **image_statistics(images[name], ref, highlight)))
    return dict(normalization=config["render.normalization"], zone_level=level, display=display, luminance=lum, scenes=[s.name for s in SCENES], exponents=exponents,
                lobes=names, statistics=stats, resolution=res, slope_used=a, intercept_used=b,
                psnr_f_Q2_min=min(s["psnr"] for s in stats if s["lobe"] == "f_Q2"),
                psnr_f_2_min=min(s["psnr"] for s in stats if s["lobe"] == "f_2"))

