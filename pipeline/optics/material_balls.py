"""Material balls as a real-time engine shades them: the scene in which a shading term's
approximations are rendered and compared by FLIP (`approximate.measures.rendered`).

The scene: spheres in a grid, one column per roughness (perceptual; alpha = roughness^2) and two
rows of F0, a dielectric's 0.04 over a red base colour (Lambert diffuse) and gold's
(1.0, 0.782, 0.344) (no diffuse), seen by an orthographic camera along -z (V = (0, 0, 1)). Lights:
- a key light (directional, from the upper left front) and a rim light (directional, from behind,
  so that its half vector grazes: VoH about 0.31), each with its irradiance;
- a point light beside each sphere (inverse-square falloff), whose direction varies over the sphere,
  and with it NoL, NoH and VoH;
- an environment the project makes (`environment`: a sky, a ground and a bright window, in a 64 x 32
  latitude-longitude map), prefiltered for the split sum (N = V = R, the GGX lobe of the sphere's
  roughness) and convolved with the cosine for the diffuse light.

Each light's specular is D V F NoL E (GGX's D, the height-correlated Smith-GGX visibility, Schlick's
Fresnel F0 + (1 - F0)(1 - VoH)^5); the environment's is the prefiltered radiance times F0 A + B, A
and B the split-sum environment BRDF of GGX (`approximate.targets.env_brdf_table`'s quadrature). A shading
term's role (`ROLES`) names which factor a form replaces; the other factors stay exact. Every factor
is rounded to float32 and the shading composed in float32 (`shade`), as an engine's fragment shader
computes it; the radiance is tone-mapped by the Khronos PBR Neutral operator, encoded in sRGB and
quantized to 8 bits (the display). Pixels outside the spheres are a constant background, the same in
every image.
"""

from __future__ import annotations

import dataclasses
import functools
import math

import numpy as np

from .numerics import jax
import jax.numpy as jnp

from .roles import ROLES, Role  # noqa: F401


DIELECTRIC = dict(F0=(0.04, 0.04, 0.04), base=(0.75, 0.18, 0.12))
METAL = dict(F0=(1.0, 0.782, 0.344), base=(0.0, 0.0, 0.0))      # gold (Filament's table of metals)
KEY = dict(direction=(-0.45, 0.55, 0.70), irradiance=(2.2, 2.1, 2.0))
RIM = dict(direction=(0.55, 0.25, -0.80), irradiance=(2.4, 2.6, 3.0))
POINT = dict(offset=(1.2, -0.9, 1.4), intensity=(5.0, 4.6, 4.0))   # offset from the centre, in radii
LIGHTS = 3                      # key, rim, point
RADIUS = 0.92                   # of a sphere, in half cells
BACKGROUND = (0.05, 0.05, 0.05)  # radiance outside the spheres
ENVIRONMENT_SIZE = (64, 32)     # the latitude-longitude map's texels (longitude, latitude)
SIZE = 64                       # pixels per sphere's cell
ROUGHNESS_COLUMNS = 5           # spheres per row: the roughness from the range's low end to its high end


@dataclasses.dataclass(frozen=True)
class Scene:
    """The grid of spheres: a roughness per column, the rows DIELECTRIC and METAL, SIZE pixels a cell."""

    roughness: tuple[float, ...]
    size: int = SIZE
    environment: bool = True        # False: the three lights alone

    @property
    def shape(self) -> tuple[int, int]:
        return 2 * self.size, len(self.roughness) * self.size


def roughness_grid(lo: float, hi: float, count: int = ROUGHNESS_COLUMNS) -> tuple[float, ...]:
    """`count` roughness values evenly from lo (included) to hi."""
    return tuple(float(v) for v in np.linspace(lo, hi, count))


def _unit(v) -> np.ndarray:
    v = np.asarray(v, dtype=np.float64)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def environment(directions) -> np.ndarray:
    """The environment's radiance (RGB) in unit directions (..., 3), y up: a sky brighter towards the
    zenith, a dark ground, a soft horizon and a bright window."""
    d = np.asarray(directions, dtype=np.float64)
    y = d[..., 1:2]
    sky = np.array([0.35, 0.50, 0.80]) * (0.45 + 0.55 * np.clip(y, 0.0, 1.0))
    ground = np.array([0.12, 0.10, 0.08]) * np.ones_like(y)
    blend = np.clip(0.5 + y / 0.1, 0.0, 1.0)
    window_axis = _unit([0.55, 0.45, 0.70])
    window = np.where((d @ window_axis)[..., None] > math.cos(math.radians(14.0)), 6.0, 0.0) * np.array([1.0, 0.95, 0.9])
    return blend * sky + (1.0 - blend) * ground + window


def environment_texels() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(directions (T, 3), radiance (T, 3), solid angles (T,)) of the latitude-longitude map's texel
    centres."""
    width, height = ENVIRONMENT_SIZE
    phi = (np.arange(width) + 0.5) / width * 2.0 * np.pi
    theta = (np.arange(height) + 0.5) / height * np.pi           # from the zenith (+y)
    theta, phi = np.meshgrid(theta, phi, indexing="ij")
    d = np.stack([np.sin(theta) * np.cos(phi), np.cos(theta), np.sin(theta) * np.sin(phi)], axis=-1).reshape(-1, 3)
    solid = (np.sin(theta) * (np.pi / height) * (2.0 * np.pi / width)).reshape(-1)
    return d, environment(d), solid


def ggx(noh, alpha):
    """GGX's (Trowbridge-Reitz's) D."""
    a2 = alpha * alpha
    return a2 / (np.pi * (noh * noh * (a2 - 1.0) + 1.0) ** 2)


def visibility(nov, nol, alpha):
    """The height-correlated Smith-GGX visibility G2 / (4 NoV NoL) (Heitz 2014)."""
    a2 = alpha * alpha
    return 0.5 / (nol * np.sqrt(nov * nov * (1.0 - a2) + a2) + nov * np.sqrt(nol * nol * (1.0 - a2) + a2))


def schlick(voh):
    """Schlick's Fresnel weight (1 - VoH)^5."""
    return (1.0 - voh) ** 5


def prefiltered(reflected, alpha) -> np.ndarray:
    """The environment prefiltered for the split sum at reflection directions (P, 3), each with its
    GGX alpha (P,): sum over the texels of L D(h) NoL dw / sum of D(h) NoL dw, N = V = R (Karis 2013),
    h the half vector of R and the texel's direction: NoH = sqrt((1 + NoL) / 2)."""
    d, radiance, solid = environment_texels()
    out = np.empty((len(reflected), 3))
    for start in range(0, len(reflected), 2048):
        r, a = reflected[start:start + 2048], alpha[start:start + 2048, None]
        nol = r @ d.T
        noh = np.sqrt(np.maximum(0.5 * (1.0 + nol), 0.0))
        w = np.where(nol > 0, ggx(noh, a) * nol, 0.0) * solid
        out[start:start + 2048] = (w @ radiance) / w.sum(axis=1, keepdims=True)
    return out


def irradiance(normals) -> np.ndarray:
    """The environment's irradiance at normals (P, 3): sum of L max(N.w, 0) dw over the texels."""
    d, radiance, solid = environment_texels()
    return (np.maximum(normals @ d.T, 0.0) * solid) @ radiance


@functools.cache
def _cell(size: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One sphere's cell of `size` pixels: (rows, columns, normals) of the pixels inside its disc
    (every sphere has the same)."""
    centre = (np.arange(size) + 0.5) / size * 2.0 - 1.0          # in half cells
    v, u = np.meshgrid(-centre / RADIUS, centre / RADIUS, indexing="ij")     # image rows go down: y = -v
    inside = u * u + v * v < 1.0
    z = np.sqrt(np.maximum(1.0 - u * u - v * v, 0.0))
    rows, columns = np.nonzero(inside)
    return rows, columns, np.stack([u, v, z], axis=-1)[inside]


@functools.cache
def _environment_light(size: int, roughness: float | None) -> np.ndarray:
    """One cell's environment light (P, 3): the diffuse irradiance (roughness None), or the radiance
    prefiltered for GGX at that roughness."""
    normals = _cell(size)[2]
    if roughness is None:
        return irradiance(normals)
    reflected = 2.0 * normals[:, 2:3] * normals - np.array([0.0, 0.0, 1.0])
    return prefiltered(reflected, np.full(len(normals), roughness ** 2))


@functools.cache
def geometry(scene: Scene) -> dict:
    """Per sphere pixel (flattened, P of them): its place in the image, normal, roughness, alpha,
    F0 and base colour (RGB), NoV, and per light (L = LIGHTS) NoL, NoH, VoH and the light's
    irradiance E (RGB, 0 where NoL <= 0); the environment's prefiltered radiance and the diffuse
    irradiance (RGB). All float64."""
    s = scene.size
    cell_rows, cell_columns, cell_normals = _cell(s)
    count = len(cell_rows)
    rows, columns, normals, roughness, F0, base, prefiltered_light = [], [], [], [], [], [], []
    for i, material in enumerate((DIELECTRIC, METAL)):
        for j, r in enumerate(scene.roughness):
            rows.append(cell_rows + i * s)
            columns.append(cell_columns + j * s)
            normals.append(cell_normals)
            roughness.append(np.full(count, r))
            F0.append(np.broadcast_to(material["F0"], (count, 3)))
            base.append(np.broadcast_to(material["base"], (count, 3)))
            if scene.environment:
                prefiltered_light.append(_environment_light(s, float(r)))
    g = dict(rows=np.concatenate(rows), columns=np.concatenate(columns), normal=np.concatenate(normals),
             roughness=np.concatenate(roughness), F0=np.concatenate(F0), base=np.concatenate(base))
    n = g["normal"]
    g["alpha"] = g["roughness"] ** 2
    view = np.array([0.0, 0.0, 1.0])
    g["NoV"] = n[:, 2].copy()
    directions, irradiances = [], []
    for light in (KEY, RIM):
        directions.append(np.broadcast_to(_unit(light["direction"]), n.shape))
        irradiances.append(np.broadcast_to(light["irradiance"], n.shape))
    to_light = np.asarray(POINT["offset"]) - n                    # the point light, from the surface point
    distance2 = np.sum(to_light * to_light, axis=1, keepdims=True)
    directions.append(to_light / np.sqrt(distance2))
    irradiances.append(np.asarray(POINT["intensity"]) / distance2)
    L = np.stack(directions)                                       # (LIGHTS, P, 3)
    H = _unit(L + view)
    g["NoL"] = np.einsum("pk,lpk->lp", n, L)
    g["NoH"] = np.einsum("pk,lpk->lp", n, H)
    g["VoH"] = H @ view
    g["E"] = np.where(g["NoL"][..., None] > 0, np.stack(irradiances), 0.0)
    if scene.environment:
        g["prefiltered"] = np.concatenate(prefiltered_light)
        g["irradiance"] = np.tile(_environment_light(s, None), (2 * len(scene.roughness), 1))
    else:
        g["prefiltered"] = g["irradiance"] = np.zeros_like(n)
    return g


def exact_terms(scene: Scene, env_brdf) -> dict:
    """Every factor a role can replace, exact (float64) at the scene's pixels: F, V, D per light
    (LIGHTS, P) and env = F0 A + B (P, 3), with `env_brdf(NoV, roughness)` -> (A, B) (the table)."""
    g = geometry(scene)
    nol = np.maximum(g["NoL"], 0.0)
    A, B = env_brdf(g["NoV"], g["roughness"])
    return dict(F=schlick(np.clip(g["VoH"], 0.0, 1.0)), V=visibility(g["NoV"], nol, g["alpha"]),
                D=ggx(np.clip(g["NoH"], 0.0, 1.0), g["alpha"]), env=g["F0"] * A[:, None] + B[:, None])


def _composed(xp, F, V, D, env, NoL, E, F0, base, prefiltered_radiance, diffuse_irradiance, dtype):
    """The shading of the module docstring in the array namespace `xp`, every factor rounded to `dtype`
    and each operation in it."""
    c = lambda a: xp.asarray(a).astype(dtype)                      # noqa: E731 (each factor in the format)
    F, V, D, env, NoL, E, F0, base = (c(a) for a in (F, V, D, env, NoL, E, F0, base))
    one, zero, pi = (xp.asarray(v).astype(dtype) for v in (1.0, 0.0, np.pi))
    fresnel = F0[None] + (one - F0[None]) * F[..., None]          # (LIGHTS, P, 3)
    nol = xp.maximum(NoL, zero)[..., None]
    per_light = fresnel * (D * V)[..., None] * nol * E
    specular, received = per_light[0], nol[0] * E[0]
    for light in range(1, LIGHTS):                                  # (summed in order, each sum rounded)
        specular, received = specular + per_light[light], received + nol[light] * E[light]
    diffuse = base / pi * (received + c(diffuse_irradiance))
    ambient = c(prefiltered_radiance) * env
    return (specular + diffuse + ambient).astype(xp.float32)


_shade_jax = jax.jit(functools.partial(_composed, jnp), static_argnames=("dtype",))


def shade(scene: Scene, terms: dict, dtype=np.float32) -> np.ndarray:
    """The scene's radiance image (height, width, 3; float32) with the factors `terms` (`exact_terms`,
    one of them replaced), every factor rounded to `dtype` and the shading composed in it: float32 by
    XLA (jitted), float16 by numpy, whose float16 operations round each result (XLA's CPU float16
    needs the F16C instructions, which the oldest x86 machines lack)."""
    g = geometry(scene)
    arguments = (terms["F"], terms["V"], terms["D"], terms["env"], g["NoL"], g["E"], g["F0"], g["base"],
                 g["prefiltered"], g["irradiance"])
    if np.dtype(dtype) == np.float16:
        with np.errstate(over="ignore"):
            radiance = _composed(np, *arguments, dtype=np.float16)
    else:
        radiance = _shade_jax(*arguments, dtype=np.float32)
    image = np.empty(scene.shape + (3,), dtype=np.float32)
    image[:] = BACKGROUND
    image[g["rows"], g["columns"]] = np.asarray(radiance)
    return image


def mask(scene: Scene) -> np.ndarray:
    """The sphere pixels (height, width)."""
    g = geometry(scene)
    out = np.zeros(scene.shape, dtype=bool)
    out[g["rows"], g["columns"]] = True
    return out


def pbr_neutral(color):
    """The Khronos PBR Neutral tone mapper (Khronos, 2024), linear in, linear display values out."""
    color = np.asarray(color, dtype=np.float64)
    start, desaturation = 0.8 - 0.04, 0.15
    x = color.min(axis=-1, keepdims=True)
    offset = np.where(x < 0.08, x - 6.25 * x * x, 0.04)
    color = color - offset
    peak = color.max(axis=-1, keepdims=True)
    d = 1.0 - start
    new_peak = 1.0 - d * d / (peak + d - start)
    compressed = color * np.where(peak >= start, new_peak / np.maximum(peak, 1e-12), 1.0)
    g = 1.0 - 1.0 / (desaturation * (peak - new_peak) + 1.0)
    return np.where(peak >= start, compressed * (1.0 - g) + new_peak * g, color)


def display(radiance) -> np.ndarray:
    """The displayed 8-bit sRGB image (uint8) of a radiance image: PBR Neutral, then sRGB's transfer
    function, rounded to 8 bits."""
    x = np.clip(pbr_neutral(radiance), 0.0, 1.0)
    encoded = np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(np.maximum(x, 0.0031308), 1.0 / 2.4) - 0.055)
    return np.round(255.0 * encoded).astype(np.uint8)
