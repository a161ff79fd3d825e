"""Importance sampling of the family's lobe (k (c - 1) + 1)^m, in closed form (m = 2 in the paper).

Phong form: with c the cosine to the mirror direction R of the incident direction, the lobe
(k (c - 1) + 1)^m lives on c in [1 - 1/k, 1] (k >= 1/2; for k < 1/2 it reaches c = -1). With
w = k (c - 1) + 1, the density proportional to w^m over solid angle has the CDF
(w^(m+1) - w0^(m+1)) / (1 - w0^(m+1)) in w, w0 = max(1 - 2k, 0) its value at c = -1, so

    w = (w0^(m+1) + xi (1 - w0^(m+1)))^(1/(m+1)),   c = 1 + (w - 1) / k,   phi = 2 pi xi_2,

(at m = 2, for w0 = 0, the cube root of one uniform number: the largest of three). Its pdf over
solid angle is pdf(c) = w^m / Z with Z = 2 pi (1 - w0^(m+1)) / ((m + 1) k), on the whole sphere: a
direction below the surface is returned with its pdf and the caller gives it zero weight, so the
pdf of what is returned always equals `pdf_phong`.

Blinn form: the half vector h is drawn the same way around the normal (c = N.h), the outgoing
direction is the reflection of the incident one about h, and its pdf is pdf_h / (4 |wo.h|).

All functions take unit vectors as arrays with a last axis of 3, the surface normal N = (0, 0, 1).
"""

from __future__ import annotations

import functools

from .numerics import jax
import jax.numpy as jnp
import numpy as np

from .lobes import linear_power_u

TWO_PI = 2.0 * np.pi


def _w0(k):
    return jnp.maximum(1.0 - 2.0 * k, 0.0)


def lobe_cosine(xi, k, power=2):
    """The cosine c to the lobe's axis, from one uniform number xi in [0, 1) (the power an int or
    traced: the cube root at m = 2 either way)."""
    w0 = _w0(k) ** (power + 1)
    mixed = w0 + xi * (1.0 - w0)
    if isinstance(power, int):
        w = jnp.cbrt(mixed) if power == 2 else mixed ** (1.0 / (power + 1))
    else:
        w = jnp.where(power == 2, jnp.cbrt(mixed), mixed ** (1.0 / (power + 1)))
    return 1.0 + (w - 1.0) / k


def lobe_pdf(c, k, power: int = 2):
    """Solid-angle pdf of the axis cosine c: (k (c - 1) + 1)^m / Z on the lobe's support, else 0."""
    w = k * (c - 1.0) + 1.0
    z = TWO_PI * (1.0 - _w0(k) ** (power + 1)) / ((power + 1) * k)
    return jnp.where(w > 0.0, jnp.where(w > 0.0, w, 0.0) ** power / z, 0.0)


def _frame(axis):
    """Two unit vectors completing `axis` to an orthonormal frame (Duff et al. 2017)."""
    x, y, z = axis[..., 0], axis[..., 1], axis[..., 2]
    sign = jnp.where(z >= 0.0, 1.0, -1.0)
    a = -1.0 / (sign + z)
    b = x * y * a
    t = jnp.stack([1.0 + sign * x * x * a, sign * b, -sign * x], axis=-1)
    s = jnp.stack([b, sign + y * y * a, -y], axis=-1)
    return t, s


def around(axis, c, phi):
    """The direction at cosine c and azimuth phi around the unit vector `axis`."""
    t, s = _frame(axis)
    sin = jnp.sqrt(jnp.clip(1.0 - c * c, 0.0, None))
    return (c[..., None] * axis + (sin * jnp.cos(phi))[..., None] * t + (sin * jnp.sin(phi))[..., None] * s)


def reflect(wi, h):
    """wi reflected about the unit vector h."""
    return 2.0 * jnp.sum(wi * h, axis=-1, keepdims=True) * h - wi


NORMAL = jnp.array([0.0, 0.0, 1.0])


def sample_phong(xi, wi, k, power: int = 2):
    """(wo, pdf) for uniform numbers xi[..., 2], incident directions wi and coefficients k."""
    R = reflect(wi, NORMAL)
    c = lobe_cosine(xi[..., 0], k, power)
    wo = around(R, c, TWO_PI * xi[..., 1])
    return wo, lobe_pdf(c, k, power)


def pdf_phong(wi, wo, k, power: int = 2):
    """Solid-angle pdf with which `sample_phong` returns wo."""
    return lobe_pdf(jnp.sum(reflect(wi, NORMAL) * wo, axis=-1), k, power)


def sample_blinn(xi, wi, k, power: int = 2):
    """(wo, pdf): the half vector drawn around the normal, wi reflected about it."""
    c = lobe_cosine(xi[..., 0], k, power)
    h = around(jnp.broadcast_to(NORMAL, wi.shape), c, TWO_PI * xi[..., 1])
    wo = reflect(wi, h)
    return wo, pdf_blinn(wi, wo, k, power)


def pdf_blinn(wi, wo, k, power: int = 2):
    """Solid-angle pdf with which `sample_blinn` returns wo. Both h and -h reflect wi to wo; where the
    lobe reaches below the horizon (k < 1) both can be drawn, so both densities count."""
    h = wi + wo
    h = h / jnp.linalg.norm(h, axis=-1, keepdims=True)
    c = h[..., 2]
    return (lobe_pdf(c, k, power) + lobe_pdf(-c, k, power)) / (4.0 * jnp.abs(jnp.sum(wo * h, axis=-1)))


def importance_albedo(form: str, k, coef, theta_i, key, samples: int, power=2):
    """`_importance_albedo` with the power traced: one compiled program for every power."""
    return _importance_albedo(form, k, coef, theta_i, key, samples, np.float64(power))


@functools.partial(jax.jit, static_argnames=("form", "samples"))
def _importance_albedo(form: str, k, coef, theta_i, key, samples: int, power):
    """(estimate, standard error) of the directional albedo a(theta_i) of coef times the family's lobe,
    by its own sampler: the mean of f cos(theta_o) / pdf over `samples` directions drawn by
    `sample_phong` or `sample_blinn`; a direction below the surface has weight 0."""
    xi = jax.random.uniform(key, (samples, 2))
    wi = jnp.broadcast_to(jnp.array([jnp.sin(theta_i), 0.0, jnp.cos(theta_i)]), (samples, 3))
    if form == "phong":
        wo, pdf = sample_phong(xi, wi, k, power)
        c = jnp.sum(reflect(wi, NORMAL) * wo, axis=-1)
    else:
        wo, pdf = sample_blinn(xi, wi, k, power)
        h = wi + wo
        c = h[..., 2] / jnp.linalg.norm(h, axis=-1)
    ok = (wo[..., 2] > 0.0) & (pdf > 0.0)
    values = jnp.where(ok, coef * linear_power_u(1.0 - c, k, power) * wo[..., 2] / jnp.where(ok, pdf, 1.0), 0.0)
    return jnp.mean(values), jnp.std(values) / jnp.sqrt(samples)
