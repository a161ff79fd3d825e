"""The Mitsuba scene: renders repeat bit for bit, and the largest allowed seed runs."""

import hashlib

import numpy as np
import pytest

from pipeline.engine.config import KEYS, MITSUBA_SEED_MAX
from pipeline.mitsuba import bsdf, scene
from pipeline.optics import registry

from ..helpers import require_fast_variant


@pytest.fixture(scope="module")
def spheres():
    """The three f_Q2 spheres of the paper's renders (exact Blinn-form coef)."""
    require_fast_variant(bsdf.register(), "no vectorized Mitsuba variant here (no LLVM >= 15)")
    lobe, p = registry.LOBES["f_Q2"], registry.Parameters(slope=0.448, intercept=0.099)
    out = []
    for n in (10.0, 100.0, 1000.0):
        k = float(lobe.parameter(np, n, p))
        out.append(scene.lobe_dict(lobe.shape, n, k, bsdf.normalization(lobe.shape, "blinn", n, k, 96), "lobe"))
    return out


def test_a_render_repeats_bit_for_bit(spheres):
    """At the paper's size and default samples per pixel, three renders with one seed are the same
    bytes. (With 128 spp, which the multijitter sampler rounds up to 132, Dr.Jit's threads summed
    samples of one pixel in varying order, and renders differed in the last bits.)"""
    spp = KEYS["mitsuba.spp"].default
    digests = {hashlib.sha256(scene.render(spheres, 320, 160, spp, 0).tobytes()).hexdigest() for _ in range(3)}
    assert len(digests) == 1


def test_the_largest_allowed_seed_renders(spheres):
    """mitsuba.seed at its maximum: the stage's second render uses seed + 1, still a 32-bit seed."""
    image = scene.render(spheres, 16, 16, 1, MITSUBA_SEED_MAX + 1)
    assert image.shape == (16, 16, 3) and np.all(np.isfinite(image))
