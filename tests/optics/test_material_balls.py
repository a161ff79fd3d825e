"""The material balls' scene: its shading against an independent float64 evaluation at a few pixels,
its environment's prefilter against its irradiance, the tone map's fixed points."""

import math

import numpy as np
import pytest

from pipeline.optics import material_balls as balls


def _independent_radiance(scene, y, x):
    """One pixel's radiance from the lights alone, in float64, written out from the scene's definition
    (module docstring of `material_balls`), sharing no code with it."""
    s = scene.size
    i, j = y // s, x // s
    cu = ((x % s) + 0.5) / s * 2.0 - 1.0
    cv = ((y % s) + 0.5) / s * 2.0 - 1.0
    u, v = cu / balls.RADIUS, -cv / balls.RADIUS
    n = np.array([u, v, math.sqrt(1.0 - u * u - v * v)])
    roughness = scene.roughness[j]
    alpha = roughness * roughness
    material = (balls.DIELECTRIC, balls.METAL)[i]
    F0, base = np.array(material["F0"]), np.array(material["base"])
    view = np.array([0.0, 0.0, 1.0])
    lights = [(np.array(balls.KEY["direction"]) / np.linalg.norm(balls.KEY["direction"]), np.array(balls.KEY["irradiance"])),
              (np.array(balls.RIM["direction"]) / np.linalg.norm(balls.RIM["direction"]), np.array(balls.RIM["irradiance"]))]
    to_light = np.array(balls.POINT["offset"]) - n
    d2 = to_light @ to_light
    lights.append((to_light / math.sqrt(d2), np.array(balls.POINT["intensity"]) / d2))
    total = np.zeros(3)
    for L, E in lights:
        nol = n @ L
        if nol <= 0:
            continue
        h = (L + view) / np.linalg.norm(L + view)
        noh, voh, nov = n @ h, view @ h, n @ view
        D = alpha ** 2 / (math.pi * (noh ** 2 * (alpha ** 2 - 1) + 1) ** 2)
        lam_v = nov * math.sqrt(nol ** 2 * (1 - alpha ** 2) + alpha ** 2)
        lam_l = nol * math.sqrt(nov ** 2 * (1 - alpha ** 2) + alpha ** 2)
        V = 0.5 / (lam_v + lam_l)
        F = F0 + (1 - F0) * (1 - voh) ** 5
        total += (D * V * F + base / math.pi) * nol * E
    return total


def test_shading_against_an_independent_evaluation_at_a_few_pixels():
    """The lights' shading (no environment) at pixels of every sphere: float32 factors composed in
    float32 against float64 written out independently, within 1e-5 relative (a few float32 roundings
    of ten factors: about 1e-6)."""
    scene = balls.Scene((0.1, 0.5, 1.0), size=16, environment=False)
    terms = balls.exact_terms(scene, lambda nov, r: (np.zeros_like(nov), np.zeros_like(nov)))
    image = balls.shade(scene, terms)
    rng = np.random.default_rng(3)
    inside = np.argwhere(balls.mask(scene))
    checked = 0
    for y, x in inside[rng.choice(len(inside), 12, replace=False)]:
        expected = _independent_radiance(scene, y, x)
        assert image[y, x] == pytest.approx(expected, rel=1e-5, abs=1e-7), (y, x)
        checked += expected.max() > 0.01
    assert checked >= 6                 # (most pixels lit: the comparison is not of zeros)
    assert np.all(image[~balls.mask(scene)] == np.float32(balls.BACKGROUND))


def test_the_prefilter_at_roughness_one_is_the_cosine_weighted_mean():
    """At alpha = 1 GGX's D is 1/pi everywhere, so the split sum's prefiltered radiance is the
    environment's irradiance over the sum of the cosine (about pi: the quadrature's own error)."""
    d, radiance, solid = balls.environment_texels()
    normals = balls._unit(np.array([[0.0, 1.0, 0.0], [0.3, -0.2, 0.9], [0.0, 0.0, 1.0]]))
    prefiltered = balls.prefiltered(normals, np.ones(3))
    cosine = (np.maximum(normals @ d.T, 0.0) * solid).sum(axis=1)
    assert cosine == pytest.approx(math.pi, rel=2e-3)
    assert prefiltered == pytest.approx(balls.irradiance(normals) / cosine[:, None], rel=1e-12)


def test_the_tone_map_leaves_dark_colours_nearly_alone_and_compresses_bright_ones():
    """Khronos PBR Neutral: below its start (0.76) only the small offset (a grey 0.5 comes out 0.46);
    above, the peak is compressed towards 1 and never reaches it."""
    grey = balls.pbr_neutral(np.array([0.5, 0.5, 0.5]))
    assert grey == pytest.approx(0.46, abs=1e-12)
    bright = balls.pbr_neutral(np.array([10.0, 10.0, 10.0]))
    assert 0.97 < bright.max() < 1.0
    assert balls.display(np.zeros((1, 1, 3))).max() == 0
