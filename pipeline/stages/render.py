"""Rendered comparison (for shader authors): the reference Blinn-Phong lobe cos^n(N.H) with
Giesen's exact normalization, against f_2 and f_Q2, on the scenes of `pipeline.render`, at the
exponents of `render.exponents`. render.normalization = "reference" gives every lobe Giesen's
factor (equal peaks: the images differ by shape alone); "exact" gives each its own exact
Blinn-form normalization (`pipeline.exact`; equal energy at normal view).

Stored: the displayed images (sRGB, 8 bit), the linear luminance of each (for the heatmaps), and
the image-space error statistics of each candidate against the reference.
"""

from ..numerics import jax  # noqa: F401  (float64 before any array)
import numpy as np

from .. import exact
from ..cheap_lobes import giesen
from ..render import SCENES, display_and_luminance, highlight_mask, image_statistics, shade

LOBES = ("cos^n", "f_2", "f_Q2")


def run(config, inputs, memo):
    a, b = inputs["linear_coefficient.slope_used"], inputs["linear_coefficient.intercept_used"]
    level = inputs["zone.level"]
    blinn_coef, _ = exact.exact_coef_code("blinn")
    res = config["render.resolution"]
    exponents = [float(v) for v in config["render.exponents"]]
    own = config["render.normalization"] == "exact"

    def lobes(n):
        """(shape, parameter, coef) of each lobe at exponent n."""
        return {"cos^n": ("power", n, giesen(n)),
                "f_2": ("quadratic", n / 2.0, float(blinn_coef(n, 0.5, 0.0)) if own else giesen(n)),
                "f_Q2": ("quadratic", a * n + b, float(blinn_coef(n, a, b)) if own else giesen(n))}

    display = np.zeros((len(SCENES), len(exponents), len(LOBES), res, res, 3), dtype=np.uint8)
    lum = np.zeros((len(SCENES), len(exponents), len(LOBES), res, res), dtype=np.float32)
    stats = []
    for i, scene in enumerate(SCENES):
        base = shade(scene, res, "power", 1.0, 0.0)
        for j, n in enumerate(exponents):
            images = {name: shade(scene, res, shape, p, coef) for name, (shape, p, coef) in lobes(n).items()}
            ref = images["cos^n"]
            highlight = highlight_mask(ref, base, level)
            for l, name in enumerate(LOBES):
                display[i, j, l], lum[i, j, l] = (np.asarray(v) for v in display_and_luminance(images[name]))
                if name != "cos^n":
                    stats.append(dict(scene=scene.name, n=n, lobe=name, coef=float(lobes(n)[name][2]),
                                      highlight_pixels=int(np.sum(np.asarray(highlight))),
                                      **image_statistics(images[name], ref, highlight)))
    return dict(lobes=list(LOBES), scenes=[s.name for s in SCENES], display=display, luminance=lum,
                statistics=stats, psnr_f_Q2_min=min(s["psnr"] for s in stats if s["lobe"] == "f_Q2"),
                psnr_f_2_min=min(s["psnr"] for s in stats if s["lobe"] == "f_2"))
