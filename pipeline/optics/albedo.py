"""Directional albedo of a normalized lobe at any incidence angle, by quadrature over the hemisphere.

A lobe is a function `lobe(u, n)` of u = 1 - cos x (x the lobe's angle) that is 0 for u >= u_end.
Two BRDFs are built from it, each times its normalization coef(n):

- Phong form:  f(L, V) = coef lobe(1 - R.V), R the mirror direction of L;
- Blinn form:  f(L, V) = coef lobe(1 - N.H), H = (L + V) / |L + V|.

The directional albedo a(theta_i) = int_{upper hemisphere} f(L, V) cos(theta_o) dw_o is the energy
that leaves for each unit that arrives from incidence angle theta_i; a lobe is energy conserving
where a <= 1. Both integrals are written in polar coordinates around the lobe's axis (R for the
Phong form, N for the half vector of the Blinn form). The azimuthal integral of the clamped cosine
(and, for the Blinn form, of the Jacobian dw_o = 4 (L.H) dw_h) is done in closed form, which leaves
a smooth one-dimensional integral over u, split where the horizon first and last cuts the circle
of constant u (and, for the Phong form, at R.V = 0). Each piece is integrated by Gauss-Legendre in s = log(1 + n u), which puts the nodes
where a lobe of width ~1/n lives.
"""

from __future__ import annotations

import functools

from .numerics import jax
import jax.numpy as jnp
import numpy as np

from .lobes import SHAPE_NAMES, SHAPES, lobe_of_shape

TWO_PI = 2.0 * np.pi


def _clamped_cosine_azimuth(A, B):
    """int_0^{2 pi} max(A + B cos(phi), 0) dphi for B >= 0."""
    safe_B = jnp.where(B > 0.0, B, 1.0)
    phi0 = jnp.arccos(jnp.clip(-A / safe_B, -1.0, 1.0))
    cut = 2.0 * (A * phi0 + B * jnp.sin(phi0))
    return jnp.where(B > 0.0, cut, TWO_PI * jnp.maximum(A, 0.0))


def _phong_azimuth(u, theta_i):
    """Azimuthal integral of cos(theta_o)^+ on the circle at angle x = arccos(1 - u) around R."""
    cos_x = 1.0 - u
    sin_x = jnp.sqrt(jnp.clip(u * (2.0 - u), 0.0, None))
    return _clamped_cosine_azimuth(cos_x * jnp.cos(theta_i), sin_x * jnp.sin(theta_i))


def _blinn_azimuth(u, theta_i):
    """Azimuthal integral of 4 (L.H) cos(theta_o)^+ over H on the circle at angle theta_h from N.

    With p = L.H = A + B cos(phi) and cos(theta_o) = 2 p cos(theta_h) - cos(theta_i), the integrand
    8 cos(theta_h) p^2 - 4 cos(theta_i) p is kept where p > T = cos(theta_i) / (2 cos(theta_h)).
    """
    cos_h = 1.0 - u
    sin_h = jnp.sqrt(jnp.clip(u * (2.0 - u), 0.0, None))
    cos_i, sin_i = jnp.cos(theta_i), jnp.sin(theta_i)
    A, B = cos_h * cos_i, sin_h * sin_i
    T = cos_i / (2.0 * jnp.maximum(cos_h, 1e-300))
    safe_B = jnp.where(B > 0.0, B, 1.0)
    phi0 = jnp.arccos(jnp.clip((T - A) / safe_B, -1.0, 1.0))
    s, c = jnp.sin(phi0), jnp.cos(phi0)
    int_p = 2.0 * (A * phi0 + B * s)
    int_p2 = 2.0 * (A * A * phi0 + 2.0 * A * B * s + 0.5 * B * B * (phi0 + s * c))
    cut = 8.0 * cos_h * int_p2 - 4.0 * cos_i * int_p
    flat = jnp.where(A > T, TWO_PI * (8.0 * cos_h * A * A - 4.0 * cos_i * A), 0.0)
    return jnp.where((B > 0.0) & (cos_h > 0.0), cut, jnp.where(cos_h > 0.0, flat, 0.0))


def _split_points(form: str, theta_i):
    """u where the horizon first and last cuts the azimuthal circle (the integrand's kinks)."""
    if form == "phong":   # x = pi/2 -/+ theta_i
        return 1.0 - jnp.sin(theta_i), 1.0 + jnp.sin(theta_i)
    # Blinn: theta_h = (pi/2 -/+ theta_i) / 2; past the second, V is below the horizon.
    return 1.0 - jnp.cos(0.5 * (0.5 * np.pi - theta_i)), 1.0 - jnp.cos(0.5 * (0.5 * np.pi + theta_i))


def _segment(fn, lo, hi, n, nodes, weights):
    """int_lo^hi fn(u) du by Gauss-Legendre in s = log(1 + n u); 0 where hi <= lo."""
    s_lo, s_hi = jnp.log1p(n * lo), jnp.log1p(n * jnp.maximum(hi, lo))
    s = 0.5 * (s_hi - s_lo) * (nodes + 1.0) + s_lo
    u = jnp.expm1(s) / n
    du_ds = jnp.exp(s) / n
    return 0.5 * (s_hi - s_lo) * jnp.sum(weights * fn(u) * du_ds)


def directional_albedo(form: str, lobe, n, u_end, coef, theta_i, nodes, weights):
    """a(theta_i) of the lobe (scalar n, u_end, coef, theta_i); nodes/weights: Gauss-Legendre on [-1, 1].

    form: "phong" (lobe around the mirror direction) or "blinn" (lobe of the half vector).
    """
    azimuth = _phong_azimuth if form == "phong" else _blinn_azimuth
    a, b = _split_points(form, theta_i)
    # Phong form: also split at u = 1 (t = R.V = 0), where a shader's max(t, 0) puts a kink.
    m = jnp.clip(1.0, a, b) if form == "phong" else b
    a, m, b = (jnp.minimum(p, u_end) for p in (a, m, b))

    def integrand(u):
        return lobe(u, n) * azimuth(u, theta_i)
    pieces = (_segment(integrand, lo, hi, n, nodes, weights) for lo, hi in ((0.0, a), (a, m), (m, b)))
    return coef * sum(pieces)


# Tables are computed in blocks of N_BLOCK exponents (SMALL_N_BLOCK for tables of a few exponents)
# x THETA_BLOCK angles, by one compiled program per (form, nodes, block): array sizes, the lobe's
# shape, its parameters and the family's power are all traced or padded.
N_BLOCK, SMALL_N_BLOCK, THETA_BLOCK = 64, 8, 16


@functools.partial(jax.jit, static_argnames=("form", "nodes"))
def _block(form, nodes, shape_index, n, p, u_end, theta_i, power):
    x, w = np.polynomial.legendre.leggauss(nodes)

    def one(n_, p_, e_, t_):
        return directional_albedo(form, lambda u, _: lobe_of_shape(shape_index, u, p_, power), n_, e_, 1.0, t_, x, w)
    return jax.vmap(lambda n_, p_, e_: jax.vmap(lambda t_: one(n_, p_, e_, t_))(theta_i))(n, p, u_end)


def _padded(values, block):
    """values (1-D numpy) padded to a multiple of block by repeating its last value."""
    size = -(-len(values) // block) * block
    return np.concatenate([values, np.full(size - len(values), values[-1])])


def albedo_table(form: str, shape: str, n, p, u_end, theta_i, nodes: int, power: int = 2) -> np.ndarray:
    """a / coef over the grid n x theta_i (both 1-D) of the lobe `SHAPES[shape](u, p, power)`, with
    p and u_end given per n (or as scalars); returns a numpy array [len(n), len(theta_i)].

    The albedo is linear in the normalization: multiply row i by coef(n_i).
    """
    n = np.atleast_1d(np.asarray(n, dtype=np.float64))
    p, u_end = (np.broadcast_to(np.asarray(v, dtype=np.float64), n.shape) for v in (p, u_end))
    theta_i = np.atleast_1d(np.asarray(theta_i, dtype=np.float64))
    rows = SMALL_N_BLOCK if len(n) <= SMALL_N_BLOCK else N_BLOCK
    per_n = [_padded(v, rows) for v in (n, p, u_end)]
    angles = _padded(theta_i, THETA_BLOCK)
    index = SHAPE_NAMES.index(shape)
    # Every block is dispatched before any is read back, so that computation overlaps dispatch.
    blocks = {(i, j): _block(form, nodes, index, *(v[i:i + rows] for v in per_n), angles[j:j + THETA_BLOCK],
                             np.float64(power))
              for i in range(0, len(per_n[0]), rows) for j in range(0, len(angles), THETA_BLOCK)}
    out = np.empty((len(per_n[0]), len(angles)))
    for (i, j), block in blocks.items():
        out[i:i + rows, j:j + THETA_BLOCK] = np.asarray(block)
    return out[: len(n), : len(theta_i)]


def monte_carlo_albedo(form: str, shape: str, p, u_end, coef, theta_i, key, samples: int, power=2):
    """`_monte_carlo_albedo` with the power traced: one compiled program for every power."""
    return _monte_carlo_albedo(form, shape, p, u_end, coef, theta_i, key, samples, np.float64(power))


@functools.partial(jax.jit, static_argnames=("form", "shape", "samples"))
def _monte_carlo_albedo(form: str, shape: str, p, u_end, coef, theta_i, key, samples: int, power):
    """(estimate, standard error) of a(theta_i) by uniform sampling of the lobe's cap u in [0, u_end].

    The direction (V for Phong, H for Blinn) is drawn uniformly in solid angle on the cap of the
    lobe's support around its axis, so nothing of the lobe is missed; everything else (the horizon,
    the Jacobian of the half vector) is evaluated on the sampled 3-D vectors directly.
    """
    k1, k2 = jax.random.split(key)
    cap = jnp.minimum(u_end, 2.0 if form == "phong" else 1.0)
    u = jax.random.uniform(k1, (samples,), maxval=cap)
    phi = jax.random.uniform(k2, (samples,), maxval=TWO_PI)
    cos_a, sin_a = 1.0 - u, jnp.sqrt(jnp.clip(u * (2.0 - u), 0.0, None))
    L = jnp.array([jnp.sin(theta_i), 0.0, jnp.cos(theta_i)])
    N = jnp.array([0.0, 0.0, 1.0])
    if form == "phong":
        R = 2.0 * L[2] * N - L
        # An orthonormal frame (e1, e2, R) around the mirror direction.
        e1 = jnp.array([jnp.cos(theta_i), 0.0, -jnp.sin(theta_i)])
        e2 = jnp.array([0.0, 1.0, 0.0])
        V = (cos_a[:, None] * R + sin_a[:, None] * (jnp.cos(phi)[:, None] * e1 + jnp.sin(phi)[:, None] * e2))
        weight = jnp.maximum(V[:, 2], 0.0)
    else:
        H = jnp.stack([sin_a * jnp.cos(phi), sin_a * jnp.sin(phi), cos_a], axis=1)
        LH = H @ L
        V = 2.0 * LH[:, None] * H - L
        weight = jnp.where((LH > 0.0) & (V[:, 2] > 0.0), 4.0 * LH * V[:, 2], 0.0)
    values = coef * SHAPES[shape](u, p, power) * weight * TWO_PI * cap
    return jnp.mean(values), jnp.std(values) / np.sqrt(samples)


@functools.partial(jax.jit, static_argnames="count")
def random_directions(key, count: int):
    """`count` unit vectors uniform over the upper hemisphere (z >= 0)."""
    v = jax.random.normal(key, (count, 3))
    v = v / jnp.linalg.norm(v, axis=1, keepdims=True)
    return v.at[:, 2].set(jnp.abs(v[:, 2]))


def reciprocity_error(form: str, shape: str, p, coef, L, V, power=2):
    """max |f(L, V) - f(V, L)| / f(L, V) over the direction pairs (rows of L, V) where f(L, V) > 0."""
    return _reciprocity_error(form, shape, p, coef, L, V, np.float64(power))


@functools.partial(jax.jit, static_argnames=("form", "shape"))
def _reciprocity_error(form: str, shape: str, p, coef, L, V, power):
    def lobe(u, _):
        return SHAPES[shape](u, p, power)
    f_lv = brdf(form, lobe, 0.0, coef, L, V)
    f_vl = brdf(form, lobe, 0.0, coef, V, L)
    return jnp.max(jnp.abs(f_lv - f_vl) / jnp.maximum(jnp.abs(f_lv), 1e-300) * (f_lv > 0))


def brdf(form: str, lobe, n, coef, L, V):
    """f(L, V) for unit vectors L, V (last axis 3) above the surface N = (0, 0, 1)."""
    N = jnp.array([0.0, 0.0, 1.0])
    if form == "phong":
        R = 2.0 * (L @ N)[..., None] * N - L
        t = jnp.sum(R * V, axis=-1)
    else:
        H = L + V
        t = (H @ N) / jnp.linalg.norm(H, axis=-1)
    return coef * lobe(1.0 - t, n)
