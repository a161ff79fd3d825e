"""A small per-pixel renderer in JAX: a unit sphere, and a sphere resting on a plane, under one
directional light, shaded with a normalized specular lobe of the Blinn form (t = N.H) plus a
Lambertian base, with a shadow ray against the sphere.

Radiance (linear, per RGB channel) = E max(N.L, 0) (albedo / pi + k_s coef(n) lobe(1 - N.H, n)).
Display: exposure 1, Reinhard tone map x / (1 + x) (keeps highlights from clipping), then the
sRGB transfer function (correct gamma).
"""

from __future__ import annotations

import dataclasses
import functools

from .numerics import jax
import jax.numpy as jnp
import numpy as np

from .lobes import SHAPES

IRRADIANCE = np.pi      # a white Lambertian surface facing the light has radiance 1
SPECULAR = 0.25
BACKGROUND = np.array([0.02, 0.02, 0.025])


@dataclasses.dataclass(frozen=True)
class Scene:
    name: str
    camera: tuple
    target: tuple
    fov_deg: float
    light: tuple
    plane: bool


SCENES = (
    Scene("sphere", (0.0, 0.0, 3.2), (0.0, 0.0, 0.0), 42.0, (-0.45, 0.55, 0.70), False),
    Scene("sphere_on_plane", (0.0, 1.4, 4.2), (0.0, -0.4, 0.0), 48.0, (-0.55, 0.45, -0.70), True),
)
SPHERE_ALBEDO = np.array([0.20, 0.33, 0.60])
PLANE_ALBEDO = np.array([0.45, 0.45, 0.42])


def _normalize(v):
    return v / jnp.linalg.norm(v, axis=-1, keepdims=True)


def _hit_sphere(origin, direction):
    """Distance along unit rays to the unit sphere at the origin (inf where missed)."""
    b = jnp.sum(origin * direction, axis=-1)
    c = jnp.sum(origin * origin, axis=-1) - 1.0
    disc = b * b - c
    t = -b - jnp.sqrt(jnp.maximum(disc, 0.0))
    return jnp.where((disc > 0.0) & (t > 1e-9), t, jnp.inf)


def geometry(scene: Scene, resolution: int):
    """Per pixel: (hit mask, position, normal, view direction V, albedo) of the first surface hit."""
    cam, target = jnp.array(scene.camera), jnp.array(scene.target)
    forward = _normalize(target - cam)
    right = _normalize(jnp.cross(forward, jnp.array([0.0, 1.0, 0.0])))
    up = jnp.cross(right, forward)
    half = np.tan(np.radians(scene.fov_deg) / 2.0)
    s = (jnp.arange(resolution) + 0.5) / resolution * 2.0 - 1.0
    x, y = jnp.meshgrid(s * half, -s * half)
    direction = _normalize(forward + x[..., None] * right + y[..., None] * up)
    origin = jnp.broadcast_to(cam, direction.shape)
    t_sphere = _hit_sphere(origin, direction)
    if scene.plane:
        t_plane = jnp.where(direction[..., 1] < 0.0, (-1.0 - cam[1]) / jnp.minimum(direction[..., 1], -1e-12),
                            jnp.inf)
    else:
        t_plane = jnp.full(t_sphere.shape, jnp.inf)
    on_sphere = t_sphere <= t_plane
    t = jnp.minimum(t_sphere, t_plane)
    hit = jnp.isfinite(t)
    position = origin + jnp.where(hit, t, 0.0)[..., None] * direction
    normal = jnp.where(on_sphere[..., None], _normalize(position), jnp.array([0.0, 1.0, 0.0]))
    albedo = jnp.where(on_sphere[..., None], jnp.array(SPHERE_ALBEDO), jnp.array(PLANE_ALBEDO))
    return hit, position, normal, -direction, albedo, on_sphere


def _surface(scene: Scene, resolution: int):
    """Per pixel: (hit, albedo, irradiance E max(N.L, 0) with the shadow, t = N.H clamped to [0, 1])."""
    hit, position, normal, V, albedo, on_sphere = geometry(scene, resolution)
    L = _normalize(jnp.array(scene.light))
    n_dot_l = jnp.maximum(normal @ L, 0.0)
    # Shadow: a ray from a plane point toward the light that meets the sphere.
    shadowed = (~on_sphere) & jnp.isfinite(_hit_sphere(position + 1e-6 * normal, jnp.broadcast_to(L, position.shape)))
    H = _normalize(V + L)
    t = jnp.clip(jnp.sum(normal * H, axis=-1), 0.0, 1.0)
    lit = IRRADIANCE * n_dot_l * jnp.where(shadowed, 0.0, 1.0)
    return hit, albedo, lit, t


@functools.partial(jax.jit, static_argnames=("scene", "resolution", "shape"))
def _shade(scene: Scene, resolution: int, shape: str, p, coef, power):
    return _radiance(scene, resolution, shape, p, coef, power)


def shade(scene: Scene, resolution: int, shape: str, p, coef, power=2):
    """Linear RGB radiance [res, res, 3] with the Blinn-form lobe `SHAPES[shape](u, p, power)`
    normalized by coef; one compiled program per scene, resolution and shape, for every power."""
    return _shade(scene, resolution, shape, p, coef, np.float64(power))


def _radiance(scene: Scene, resolution: int, shape: str, p, coef, power):
    hit, albedo, lit, t = _surface(scene, resolution)
    specular = SPECULAR * coef * SHAPES[shape](1.0 - t, p, power)
    radiance = lit[..., None] * (albedo / np.pi + specular[..., None])
    return jnp.where(hit[..., None], radiance, jnp.array(BACKGROUND))


@functools.partial(jax.jit, static_argnames=("scene", "resolution"))
def epicenter_mask(scene: Scene, resolution: int, n, level):
    """The epicenter zone on the image: lit pixels where the reference lobe cos^n(N.H) >= level, as d
    is defined (so the relative error there is bounded by the lobe's d at this n)."""
    hit, albedo, lit, t = _surface(scene, resolution)
    return hit & (lit > 0.0) & (t ** n >= level)
