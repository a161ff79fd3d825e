"""Images for a person: display (Reinhard tone map, sRGB), luminance, the error statistics of a
candidate image against a reference, and NVIDIA's FLIP error map; shared by the JAX renders and the
Mitsuba renders.
"""

from __future__ import annotations

from .numerics import jax
import flip_evaluator
import jax.numpy as jnp
import numpy as np

LUMINANCE = np.array([0.2126, 0.7152, 0.0722])


@jax.jit
def display_and_luminance(radiance):
    """(8-bit sRGB display values, linear luminance as float32) of a radiance image."""
    return jnp.round(255.0 * to_display(radiance)).astype(jnp.uint8), luminance(radiance).astype(jnp.float32)


def to_display(radiance):
    """Reinhard tone map, then the sRGB transfer function; values in [0, 1]."""
    x = radiance / (1.0 + radiance)
    return jnp.where(x <= 0.0031308, 12.92 * x, 1.055 * jnp.power(jnp.maximum(x, 0.0031308), 1.0 / 2.4) - 0.055)


def luminance(rgb):
    return rgb @ jnp.array([0.2126, 0.7152, 0.0722])


@jax.jit
def _statistics(candidate, reference, highlight):
    diff = jnp.abs(candidate - reference)
    rel = jnp.abs(luminance(candidate) - luminance(reference)) / jnp.maximum(luminance(reference), 1e-12)
    count = jnp.maximum(jnp.sum(highlight), 1)
    mse = jnp.mean((to_display(candidate) - to_display(reference)) ** 2)
    return dict(max_abs=jnp.max(diff), mean_abs=jnp.mean(diff), max_rel=jnp.max(jnp.where(highlight, rel, 0.0)),
                mean_rel=jnp.sum(jnp.where(highlight, rel, 0.0)) / count,
                psnr=jnp.where(mse > 0, 10.0 * jnp.log10(1.0 / jnp.maximum(mse, 1e-300)), jnp.inf))


def image_statistics(candidate, reference, highlight):
    """Error of a candidate image against the reference.

    max_abs, mean_abs: |linear radiance difference| (all channels, all pixels); max_rel, mean_rel:
    |luminance difference| / reference luminance over the highlight mask; psnr: of the displayed
    (tone-mapped sRGB) images, peak 1.
    """
    return {k: float(v) for k, v in _statistics(candidate, reference, highlight).items()}


# FLIP's filters at its default 67 pixels per degree reach this many pixels along each axis: its
# spatial filter ceil(3 sqrt(0.04 / (2 pi^2)) 67.02) = 10, its feature filter ceil(3 (0.5 0.082) 67.02) = 9
# (FLIP.h: calculateSpatialFilterRadius, the feature filter's radius).
FLIP_REACH = 10


def flip_map(reference8, test8) -> np.ndarray:
    """FLIP error map (values in [0, 1]) of two 8-bit sRGB images, passed as floats (uint8 input would
    be silently misread).

    FLIP's filters are separable, reach `FLIP_REACH` pixels and clamp at the image's edges; every
    other step is per pixel. So a pixel farther than that from every pixel where the images differ
    has error exactly 0, and the pixels within it see only the box around the differing pixels
    widened twice: FLIP runs on that box alone (the same operations in the same order, so the same
    values, bit for bit; a highlight's difference is often a small part of the image)."""
    differs = np.any(reference8 != test8, axis=-1)
    out = np.zeros(differs.shape, dtype=np.float32)
    if not differs.any():
        return out
    rows, columns = np.flatnonzero(differs.any(axis=1)), np.flatnonzero(differs.any(axis=0))
    height, width = differs.shape

    def span(first, last, size, reach):
        return slice(max(first - reach, 0), min(last + reach + 1, size))

    box = (span(rows[0], rows[-1], height, 2 * FLIP_REACH), span(columns[0], columns[-1], width, 2 * FLIP_REACH))
    inner = (span(rows[0], rows[-1], height, FLIP_REACH), span(columns[0], columns[-1], width, FLIP_REACH))
    err, _, _ = flip_evaluator.evaluate(reference8[box].astype(np.float32) / 255.0,
                                        test8[box].astype(np.float32) / 255.0, "LDR", applyMagma=False,
                                        computeMeanError=False)
    within = tuple(slice(i.start - b.start, i.stop - b.start) for i, b in zip(inner, box))
    out[inner] = np.asarray(err)[..., 0][within]
    return out


def visible(image8, base8) -> np.ndarray:
    """Pixels where an image is at least one 8-bit level brighter than the image without specular."""
    return (image8.astype(np.float64) - base8.astype(np.float64)) @ LUMINANCE >= 1.0
