"""The Mitsuba scene of the rendered comparison: three spheres of exponents n (left to right) with
the lobe alone as their BSDF (Blinn form), on a grey Lambertian floor, under a constant sky and a
sun (a directional light), rendered by Mitsuba's path tracer (indirect light included).

Also an AOV pass (position and shading normal at each pixel centre), from which the sphere seen at
each pixel, N.H for the sun there (H the half vector of the sun and the view direction) and N.L
(L towards the sun) are computed: the sun's direct specular radiance of any lobe follows in closed
form, E coef lobe(N.H) N.L.
"""

from __future__ import annotations

import numpy as np

from . import bsdf

CAMERA, TARGET = (0.0, 2.2, 6.5), (0.0, 0.55, 0.0)
SUN = np.array([0.4, -1.0, -0.6]) / np.linalg.norm([0.4, -1.0, -0.6])     # direction light travels
SUN_IRRADIANCE = np.array([4.0, 3.8, 3.5])
SPHERE_X, RADIUS = (-1.25, 0.0, 1.25), 0.55
SAMPLER = "multijitter"     # stratified pixel positions: far less noise across a narrow highlight than independent


def scene_dict(lobes, width: int, height: int, spp: int, integrator: dict | None = None, sun: bool = True,
               sampler: dict | None = None, crop=None) -> dict:
    """The scene with one BSDF dict per sphere (`lobes`, three); without the sun if `sun` is False;
    `crop` = (x, y, width, height) renders only that window of the width x height frame."""
    import mitsuba as mi

    film = {"type": "hdrfilm", "width": width, "height": height, "rfilter": {"type": "box"}}
    if crop is not None:
        x, y, w, h = (int(v) for v in crop)
        film |= {"crop_offset_x": x, "crop_offset_y": y, "crop_width": w, "crop_height": h}
    scene = {
        "type": "scene",
        "integrator": integrator or {"type": "path", "max_depth": 4},
        "sensor": {"type": "perspective", "fov": 35,
                   "to_world": mi.ScalarTransform4f().look_at(origin=list(CAMERA), target=list(TARGET), up=[0, 1, 0]),
                   "film": film,
                   "sampler": sampler or {"type": SAMPLER, "sample_count": spp}},
        "sky": {"type": "constant", "radiance": {"type": "rgb", "value": [0.25, 0.3, 0.4]}},
        "sun": {"type": "directional", "direction": SUN.tolist(), "irradiance": {"type": "rgb", "value": SUN_IRRADIANCE.tolist()}},
        "floor": {"type": "rectangle", "to_world": mi.ScalarTransform4f().rotate([1, 0, 0], -90).scale(6),
                  "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": [0.4, 0.4, 0.4]}}},
    }
    if not sun:
        del scene["sun"]
    for i, (x, props) in enumerate(zip(SPHERE_X, lobes)):
        scene[f"sphere{i}"] = {"type": "sphere", "center": [x, RADIUS, 0.0], "radius": RADIUS, "bsdf": props}
    return scene


def lobe_dict(shape: str, n: float, k: float, coef: float, sampler: str = "lobe", power: int = 2) -> dict:
    return {"type": bsdf.NAME, "shape": shape, "form": "blinn", "exponent": float(n), "k": float(k),
            "coef": float(coef), "sampler": sampler, "power": int(power)}


def render(lobes, width: int, height: int, spp: int, seed: int, sun: bool = True, crop=None) -> np.ndarray:
    """Linear RGB radiance (height, width, 3), float64 (of the crop window where one is given)."""
    import mitsuba as mi

    scene = mi.load_dict(scene_dict(lobes, width, height, spp, sun=sun, crop=crop))
    return np.asarray(mi.render(scene, spp=spp, seed=seed), dtype=np.float64)


def render_pair(lobes, width, height, spp, seed, variant, crop=None) -> dict:
    """The scene with these sphere BSDFs, rendered with seeds `seed` and `seed + 1` (of the window
    `crop` of the frame where given), with the pipeline's plugins registered for `variant`."""
    from . import microfacet

    microfacet.register(variant)
    return dict(first=render(lobes, width, height, spp, seed, crop=crop),
                second=render(lobes, width, height, spp, seed + 1, crop=crop))


def render_no_sun(lobes, width, height, spp, seed, variant, crop=None) -> dict:
    """The same scene without the sun: the background against which a highlight is visible."""
    from . import microfacet

    microfacet.register(variant)
    return dict(image=render(lobes, width, height, spp, seed, sun=False, crop=crop))


def sun_geometry(width: int, height: int, lobes) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(N.H and N.L of the sun at each pixel centre, index of the sphere seen there or -1)."""
    g = pixel_geometry(width, height, lobes)
    return g["t"], g["cos_light"], g["sphere"]


def pixel_geometry(width: int, height: int, lobes, crop=None) -> dict:
    """At each pixel centre (of the crop window where one is given): t = N.H of the sun, N.L, N.V
    (V towards the camera), and the index of the sphere seen there or -1 (0 where no sphere is seen)."""
    import mitsuba as mi

    aov = {"type": "aov", "aovs": "pp:position,nn:sh_normal"}
    centres = {"type": "stratified", "sample_count": 1, "jitter": False}     # one ray through each pixel centre
    scene = mi.load_dict(scene_dict(lobes, width, height, 1, integrator=aov, sampler=centres, crop=crop))
    image = np.asarray(mi.render(scene, spp=1, seed=0), dtype=np.float64)
    position, normal = image[..., -6:-3], image[..., -3:]
    sphere = np.full(image.shape[:2], -1)
    hit = np.linalg.norm(normal, axis=-1) > 0.5          # the sky leaves position and normal 0
    for i, x in enumerate(SPHERE_X):
        distance = np.linalg.norm(position - np.array([x, RADIUS, 0.0]), axis=-1)
        sphere[hit & (np.abs(distance - RADIUS) < 1e-3 * RADIUS)] = i
    view = np.array(CAMERA) - position
    view /= np.maximum(np.linalg.norm(view, axis=-1, keepdims=True), 1e-12)
    half = view - SUN
    half /= np.maximum(np.linalg.norm(half, axis=-1, keepdims=True), 1e-12)
    t = np.sum(half * normal, axis=-1)
    cos_light = np.sum(-SUN * normal, axis=-1)
    cos_view = np.sum(view * normal, axis=-1)
    on = sphere >= 0
    return dict(t=np.where(on, t, 0.0), cos_light=np.where(on, cos_light, 0.0), cos_view=np.where(on, cos_view, 0.0),
                sphere=sphere)
