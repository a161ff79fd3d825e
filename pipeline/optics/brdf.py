"""The GGX microfacet specular terms that shaders approximate, computed exactly, the approximations
shaders use in their place (the anchors, each with its source), and the largest error of each.

Notation: N the normal, V the view and L the light direction, H = (V + L) / |V + L| the half
vector; NoV = N.V, NoL = N.L, NoH = N.H, VoH = V.H (all cosines, in (0, 1] where they are used).
`alpha` is GGX's width; `roughness` r is the artists' (perceptual) roughness, alpha = r^2.

1. The visibility term V = G2 / (4 NoV NoL) of height-correlated Smith GGX (Heitz 2014), exact, and
   its two anchors: Hammon's (GDC 2017) and Filament's `V_SmithGGXCorrelatedFast`. The two are the
   same function: 2 NoL NoV (1 - alpha) + alpha (NoL + NoV) in both denominators.
2. The split-sum environment BRDF of GGX (Karis 2013): the scale A(NoV, r) and bias B(NoV, r) with
   int f_spec NoL dL = F0 A + B for Schlick's Fresnel, by a deterministic quadrature (`env_brdf`),
   and its two anchors: Karis's `EnvBRDFApprox` (2014) and Lazarov's fit (2013).
3. `largest_error`: the largest |error| of an approximation over a box of 2 or 3 variables, on a
   grid refined at its largest local maxima (as `pipeline.approximate.measures.measure` does in one variable).

Measured (the tests pin each): Hammon's V is at most 28.586 % off (1 - sqrt(0.51), below the exact
V, at alpha = 0.02, NoV = NoL = 1/51), and so is Filament's fast V. Against the quadrature on
NoV in [0.02, 1], roughness in [0.05, 1]: Karis's EnvBRDFApprox A is at most 0.1812 off (low, at
NoV = 1, r = 0.428), B 0.1922 (high, at NoV = 0.02, r = 0.122); Lazarov's (g = 1 - r) A 0.4665
(high, at NoV = 0.02, r = 0.091), B 0.3488 (low, at NoV = 0.0223, r = 0.05).

Numpy float64 throughout. The closed forms take `xp=` (numpy, or `jax.numpy` for a JAX twin that
jit compiles); the quadrature and the measures are numpy and scipy only.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass
from itertools import product

import numpy as np

from . import nelder_mead

HEITZ_2014 = ("Heitz, 'Understanding the Masking-Shadowing Function in Microfacet-Based BRDFs', "
              "JCGT 3(2), 2014 (height-correlated Smith G2); as Filament writes V_SmithGGXCorrelated")
HAMMON_2017 = "Hammon, 'PBR Diffuse Lighting for GGX+Smith Microsurfaces', GDC 2017"
FILAMENT_2018 = ("Guy and Agopian, 'Physically Based Rendering in Filament', Google, 2018: "
                 "V_SmithGGXCorrelatedFast")
KARIS_2013 = "Karis, 'Real Shading in Unreal Engine 4', SIGGRAPH 2013 course (split-sum environment BRDF)"
KARIS_2014 = "Karis, 'Physically Based Shading on Mobile', Unreal Engine blog, 2014: EnvBRDFApprox"
LAZAROV_2013 = ("Lazarov, 'Getting More Physical in Call of Duty: Black Ops II', SIGGRAPH 2013 course "
                "(environment BRDF fit in gloss)")

# The boxes the anchors are measured on: (alpha, NoV, NoL) for the visibility, (NoV, roughness) for
# the environment BRDF.
VISIBILITY_BOX = ((0.02, 0.01, 0.01), (1.0, 1.0, 1.0))
ENV_BRDF_BOX = ((0.02, 0.05), (1.0, 1.0))


# ---- 1. visibility ------------------------------------------------------------------------------

def visibility_smith_ggx_correlated(nov, nol, alpha, xp=np):
    """V = G2 / (4 NoV NoL) of height-correlated Smith GGX (HEITZ_2014), exact:
    0.5 / (NoL sqrt(NoV^2 (1 - alpha^2) + alpha^2) + NoV sqrt(NoL^2 (1 - alpha^2) + alpha^2)).
    Units 1/sr per unit D; NoV, NoL in (0, 1], alpha in (0, 1]."""
    a2 = alpha * alpha
    ggx_v = nol * xp.sqrt(nov * nov * (1.0 - a2) + a2)
    ggx_l = nov * xp.sqrt(nol * nol * (1.0 - a2) + a2)
    return 0.5 / (ggx_v + ggx_l)


def visibility_hammon(nov, nol, alpha, xp=np):
    """Hammon's approximation of V (HAMMON_2017): 0.5 / lerp(2 NoL NoV, NoL + NoV, alpha)."""
    return 0.5 / (2.0 * nol * nov * (1.0 - alpha) + (nol + nov) * alpha)


def visibility_filament_fast(nov, nol, alpha, xp=np):
    """Filament's V_SmithGGXCorrelatedFast (FILAMENT_2018):
    0.5 / (NoV (NoL (1 - alpha) + alpha) + NoL (NoV (1 - alpha) + alpha)). Algebraically Hammon's;
    only the rounding differs."""
    return 0.5 / (nov * (nol * (1.0 - alpha) + alpha) + nol * (nov * (1.0 - alpha) + alpha))


def hammon_largest_relative_error(alpha_min: float) -> tuple[float, float]:
    """(max |V_Hammon / V - 1| over alpha in [alpha_min, 1] and NoV, NoL in (0, 1], the NoV = NoL
    where it is attained), in closed form.

    On the diagonal NoV = NoL = x the ratio is sqrt(x^2 (1 - a^2) + a^2) / (x (1 - a) + a); it is
    smallest at x = a / (1 + a), where it is sqrt((1 + a) / 2), and that is smallest at the least a.
    That the diagonal holds the box's maximum is what `largest_error` finds (the tests check it)."""
    return 1.0 - float(np.sqrt((1.0 + alpha_min) / 2.0)), alpha_min / (1.0 + alpha_min)


# ---- 2. the split-sum environment BRDF ----------------------------------------------------------

@functools.cache
def _nodes(step: float, phi_nodes: int, t_max: float = 3.2):
    """The quadrature's rules on (0, 1): tanh-sinh nodes x for u, with 1 - x computed without
    cancellation, and weights (the last kept weighs 7e-18 at step 1/16); Gauss-Legendre nodes and
    weights for phi."""
    t = np.arange(-np.ceil(t_max / step), np.ceil(t_max / step) + 1) * step
    s = 0.5 * np.pi * np.sinh(t)
    x, one_minus_x = 1.0 / (1.0 + np.exp(-2.0 * s)), 1.0 / (1.0 + np.exp(2.0 * s))
    w = step * 0.5 * np.pi * np.cosh(t) / (2.0 * np.cosh(s) ** 2)
    y, wy = np.polynomial.legendre.leggauss(phi_nodes)
    rules = (x, one_minus_x, w), ((y + 1.0) / 2.0, wy / 2.0)
    for array in (*rules[0], *rules[1]):
        array.flags.writeable = False
    return rules


def _u_of_theta_h(cos2, a2):
    """The GGX CDF u of the half vector's polar angle (u uniform gives H distributed by D(H) NoH), and
    1 - u, from cos^2 theta_h."""
    d = 1.0 + (a2 - 1.0) * cos2
    return (1.0 - cos2) / d, a2 * cos2 / d


def _check_env_inputs(nov, roughness):
    if not np.all((nov > 0.0) & (nov <= 1.0)):
        bad = nov[~((nov > 0.0) & (nov <= 1.0))].flat[0]
        raise ValueError(f"env_brdf: nov must lie in (0, 1], got {bad}")
    if not np.all((roughness > 0.0) & (roughness <= 1.0)):
        bad = roughness[~((roughness > 0.0) & (roughness <= 1.0))].flat[0]
        raise ValueError(f"env_brdf: roughness must lie in (0, 1], got {bad}")


def _env_brdf_points(nov, roughness, u_nodes, phi_nodes):
    """(A, B) at 1-D arrays of points (the quadrature of `env_brdf`)."""
    x, one_minus_x, wx = (v[None, :, None] for v in u_nodes)
    y, wy = (v[None, None, :] for v in phi_nodes)
    cv = nov[:, None, None]
    a2 = roughness[:, None, None] ** 4
    k = roughness[:, None, None] ** 2 / 2.0
    sv = np.sqrt(1.0 - cv * cv)
    theta_v = np.arccos(cv)
    # For theta_h below (pi/2 - theta_v) / 2 the whole circle of H at theta_h reflects V above the
    # horizon; above (pi/2 + theta_v) / 2 none of it does; between, the arc |phi| < phi0.
    u1, v1 = _u_of_theta_h(np.cos((np.pi / 2 - theta_v) / 2) ** 2, a2)
    u2, v2 = _u_of_theta_h(np.cos((np.pi / 2 + theta_v) / 2) ** 2, a2)
    g1_v = cv / (cv * (1.0 - k) + k)
    A = B = 0.0
    for lo, hi, one_minus_hi, arc in ((0.0, u1, v1, False), (u1, u2, v2, True)):
        length = hi - lo
        u = lo + length * x
        one_minus_u = one_minus_hi + length * one_minus_x
        cos2 = one_minus_u / (a2 * u + one_minus_u)
        ch, sh = np.sqrt(cos2), np.sqrt(a2 * u / (a2 * u + one_minus_u))
        if arc:
            # cos phi0 where N.L = 2 VoH NoH - NoV = 0; the guard only matters at NoV = 1, where this
            # piece has length 0
            cos_phi0 = -cv * (2.0 * cos2 - 1.0) / np.maximum(2.0 * sv * ch * sh, 1e-300)
            phi0 = np.arccos(np.clip(cos_phi0, -1.0, 1.0))
            # phi = phi0 (1 - (1 - t)^2) crowds the nodes at the horizon, where G1(N.L) has its pole
            # at N.L = -k / (1 - k)
            phi = phi0 * (1.0 - (1.0 - y) ** 2)
            w_phi = phi0 * 2.0 * (1.0 - y) * wy
        else:
            phi, w_phi = np.pi * y, np.pi * wy
        voh = sv * sh * np.cos(phi) + cv * ch
        nol = np.maximum(2.0 * voh * ch - cv, 0.0)
        g_vis = nol / (nol * (1.0 - k) + k) * g1_v * voh / (ch * cv)
        fc = (1.0 - voh) ** 5
        weight = length * wx * w_phi / np.pi
        A = A + np.sum(weight * (1.0 - fc) * g_vis, axis=(1, 2))
        B = B + np.sum(weight * fc * g_vis, axis=(1, 2))
    return A, B


def env_brdf(nov, roughness, step: float = 1 / 16, phi_nodes: int = 24, block: int = 256):
    """(A, B), the split-sum environment BRDF of GGX (KARIS_2013): int f_spec NoL dL = F0 A + B, for
    f_spec = D G F / (4 NoV NoL), GGX's D with alpha = roughness^2, Schlick's Fresnel
    F = F0 + (1 - F0) (1 - VoH)^5 and G the Schlick-Smith product G1(NoV) G1(NoL),
    G1(x) = x / (x (1 - k) + k), k = alpha / 2 (as UE4's table). V = (sqrt(1 - NoV^2), 0, NoV).

    With H distributed by D(H) NoH (GGX's sampling) and Fc = (1 - VoH)^5,
    A = E[(1 - Fc) G_vis], B = E[Fc G_vis], G_vis = G VoH / (NoH NoV), 0 where N.L <= 0.
    Both are dimensionless and broadcast over nov, roughness (nov in (0, 1], roughness in (0, 1]).
    A + B <= 1 (the white furnace: measured up to 0.9999935, at NoV = 1, r = 0.05).

    Quadrature: H's polar angle through the GGX CDF u (cos^2 theta_h = (1 - u) / (1 + (alpha^2 - 1) u)),
    its azimuth phi in [0, pi] (V's plane is a plane of symmetry). The u range is split where the
    horizon N.L = 0 starts and stops cutting the circle of H: below, phi runs over [0, pi]; between,
    over [0, phi0(u)], so no kink is inside a piece. Each piece of u by a tanh-sinh rule of `step`
    (105 nodes at 1/16), phi by `phi_nodes`-point Gauss-Legendre crowded at phi0. Why tanh-sinh: at
    both ends of the pieces the u-integrand has near-singularities (G1's pole at N.L = -k / (1 - k)
    just past the horizon; the pole of cos^2 theta_h(u) at u = 1 / (1 - alpha^2) just past u = 1),
    where Gauss-Legendre in u converged only to 4e-6 with 128 nodes per piece. Measured on a 32 x 32
    grid of NoV in [0.02, 1], roughness in [0.05, 1] against step 1/64 and 128 phi nodes: |error|
    <= 1.2e-11 in A, 1.0e-12 in B; against scipy's dblquad over L (to 1e-10) at 8 points, <= 1e-11.
    A 32 x 32 table takes 0.4 s on one core (0.7 s while another process shares it)."""
    nov, roughness = np.broadcast_arrays(np.asarray(nov, dtype=np.float64),
                                         np.asarray(roughness, dtype=np.float64))
    _check_env_inputs(nov, roughness)
    u_nodes, phi_nodes_01 = _nodes(float(step), int(phi_nodes))
    flat_v, flat_r = nov.ravel(), roughness.ravel()
    A, B = np.empty(flat_v.size), np.empty(flat_v.size)
    # blocks of points keep the temporaries in cache (the whole grid at once is 3x slower)
    for start in range(0, flat_v.size, block):
        part = slice(start, start + block)
        A[part], B[part] = _env_brdf_points(flat_v[part], flat_r[part], u_nodes, phi_nodes_01)
    return A.reshape(nov.shape), B.reshape(nov.shape)


def env_brdf_table(nov_grid, roughness_grid, **quadrature):
    """(A, B), each of shape (len(nov_grid), len(roughness_grid)): `env_brdf` on the grid's product
    (rows NoV, columns roughness)."""
    nov_grid = np.asarray(nov_grid, dtype=np.float64)
    roughness_grid = np.asarray(roughness_grid, dtype=np.float64)
    return env_brdf(nov_grid[:, None], roughness_grid[None, :], **quadrature)


def env_brdf_karis_mobile(nov, roughness, xp=np):
    """(A, B) of Karis's EnvBRDFApprox (KARIS_2014), fitted by hand to UE4's table:
    r = roughness c0 + c1, c0 = (-1, -0.0275, -0.572, 0.022), c1 = (1, 0.0425, 1.04, -0.04);
    a004 = min(r.x^2, 2^(-9.28 NoV)) r.x + r.y; (A, B) = (-1.04, 1.04) a004 + (r.z, r.w)."""
    rx, ry = 1.0 - roughness, 0.0425 - 0.0275 * roughness
    rz, rw = 1.04 - 0.572 * roughness, -0.04 + 0.022 * roughness
    a004 = xp.minimum(rx * rx, xp.exp2(-9.28 * nov)) * rx + ry
    return -1.04 * a004 + rz, 1.04 * a004 + rw


def env_brdf_lazarov(nov, roughness, xp=np):
    """(A, B) of Lazarov's environment BRDF fit (LAZAROV_2013), as Karis's 2014 post prints it, in
    gloss g: t = (1/0.96, 0.475, (0.0275 - 0.25 0.04)/0.96, 0.25) g + (0, 0, (0.015 - 0.75 0.04)/0.96, 0.75),
    a0 = t.x min(t.y, 2^(-9.28 NoV)) + t.z, a1 = t.w; F0 A + B = a0 + F0 (a1 - a0), so A = a1 - a0,
    B = a0 (unclamped: the shader saturates F0 A + B).

    Assumption: g = 1 - roughness. Lazarov fitted a normalized Blinn-Phong lobe whose power comes from
    the gloss, not GGX with alpha = roughness^2, so no mapping of g to roughness is exact; this one is
    the simplest, and the errors measured against GGX include the mismatch of the two models."""
    g = 1.0 - roughness
    tx, ty = g / 0.96, 0.475 * g
    tz = (0.0275 - 0.25 * 0.04) / 0.96 * g + (0.015 - 0.75 * 0.04) / 0.96
    tw = 0.25 * g + 0.75
    a0 = tx * xp.minimum(ty, xp.exp2(-9.28 * nov)) + tz
    return tw - a0, a0


# ---- the anchors ---------------------------------------------------------------------------------

@dataclass(frozen=True)
class Anchor:
    """An approximation that shaders use: its numpy/JAX function (arguments as the exact term's), and
    where it comes from."""
    name: str
    function: Callable
    source: str


VISIBILITY_ANCHORS = {a.name: a for a in (
    Anchor("hammon", visibility_hammon, HAMMON_2017),
    Anchor("filament_fast", visibility_filament_fast, FILAMENT_2018),
)}
ENV_BRDF_ANCHORS = {a.name: a for a in (
    Anchor("karis_mobile", env_brdf_karis_mobile, KARIS_2014),
    Anchor("lazarov", env_brdf_lazarov, LAZAROV_2013),
)}


def visibility_anchor_error(name: str, box=VISIBILITY_BOX) -> dict:
    """{max_rel_error, where=(alpha, NoV, NoL)} of a visibility anchor against the exact V over `box`."""
    anchor = VISIBILITY_ANCHORS[name]
    value, where = largest_error(lambda a, v, l: anchor.function(v, l, a),
                                 lambda a, v, l: visibility_smith_ggx_correlated(v, l, a),
                                 *box, relative=True, cells=48, chebyshev=33)
    return {"max_rel_error": value, "where": tuple(where)}


def _remember_last(f):
    """f, remembering its last value: called again with equal arrays, it returns it."""
    last = {}

    def remembered(*x):
        key = tuple((np.shape(c), np.asarray(c, dtype=np.float64).tobytes()) for c in x)
        if key not in last:
            last.clear()
            last[key] = f(*x)
        return last[key]
    return remembered


def env_brdf_anchor_errors(name: str, box=ENV_BRDF_BOX) -> dict:
    """{A: (max |A_anchor - A|, (NoV, roughness)), B: (...)} of an environment BRDF anchor against
    `env_brdf` over `box`."""
    anchor = ENV_BRDF_ANCHORS[name]
    exact = _remember_last(env_brdf)     # the grid's quadrature serves A and B
    out = {}
    for part, index in (("A", 0), ("B", 1)):
        value, where = largest_error(lambda v, r, index=index: anchor.function(v, r)[index],
                                     lambda v, r, index=index: exact(v, r)[index], *box, cells=24, chebyshev=9)
        out[part] = (value, tuple(where))
    return out


# ---- 3. the largest error over a box -------------------------------------------------------------

GRID = 32
CHEBYSHEV = 17
PEAKS = 4


def axis_grid(lo: float, hi: float, cells: int = GRID, chebyshev: int = CHEBYSHEV) -> np.ndarray:
    """One axis of the measuring grid: `cells` uniform cells of [lo, hi] and `chebyshev`
    Chebyshev-Lobatto points (they crowd the ends, where these errors peak), sorted, no repeats."""
    k = np.arange(chebyshev)
    nodes = lo + (hi - lo) * (1 - np.cos(np.pi * k / max(chebyshev - 1, 1))) / 2
    return np.unique(np.concatenate([np.linspace(lo, hi, cells + 1), nodes]))


def error_function(f_approx, f_exact, relative: bool = False):
    """e(*x) = f_approx(*x) - f_exact(*x), divided by |f_exact(*x)| if `relative` (0 where equal)."""
    def e(*x):
        x = [np.asarray(c, dtype=np.float64) for c in x]
        with np.errstate(all="ignore"):
            exact = f_exact(*x)
            diff = f_approx(*x) - exact
            if not relative:
                return diff
            return np.where(diff == 0, 0.0, diff / np.abs(exact))
    return e


def _local_maxima(v: np.ndarray) -> np.ndarray:
    """Flat indices of the grid points where v >= every neighbour (diagonals too; the box's faces count)."""
    padded = np.pad(v, 1, constant_values=-np.inf)
    inner = tuple(slice(1, -1) for _ in v.shape)
    keep = np.ones(v.shape, dtype=bool)
    for offset in product((-1, 0, 1), repeat=v.ndim):
        if any(offset):
            keep &= v >= padded[tuple(slice(1 + o, n + 1 + o) for o, n in zip(offset, v.shape))]
    return np.flatnonzero(keep & np.isfinite(padded[inner]))


def largest(e, lo, hi, cells: int = GRID, chebyshev: int = CHEBYSHEV, peaks: int = PEAKS):
    """(max |e(*x)| over the box [lo, hi] (sequences of 2 or 3 bounds), the x where attained as an
    array), (inf, x) where e is not finite somewhere on the grid.

    The grid is the product of `axis_grid`s. The `peaks` largest local maxima of |e| on it are each
    refined by Nelder-Mead (scipy's, derivative-free: these errors have kinks, from min() in the
    anchors; the peaks' runs evaluated together, `nelder_mead`) bounded to the grid cells around the
    peak, restarted once from where it stopped with a fresh simplex (Nelder-Mead can stall on a
    ridge). Assumption: the true maximum lies in the cells around
    one of the grid's largest local maxima; the tests check it against denser grids."""
    lo, hi = np.asarray(lo, dtype=np.float64), np.asarray(hi, dtype=np.float64)
    axes = [axis_grid(a, b, cells, chebyshev) for a, b in zip(lo, hi)]
    mesh = np.meshgrid(*axes, indexing="ij")
    v = np.abs(e(*mesh))
    if not np.all(np.isfinite(v)):
        first = np.unravel_index(np.flatnonzero(~np.isfinite(v))[0], v.shape)
        return float("inf"), np.array([ax[i] for ax, i in zip(axes, first)])
    candidates = _local_maxima(v)
    candidates = candidates[np.argsort(v.flat[candidates])[::-1][:peaks]]
    best = int(np.argmax(v))
    value, where = float(v.flat[best]), np.array([m.flat[best] for m in mesh])

    def refine(flat):
        """The peak at `flat` refined (a run of `nelder_mead.minimize_all`)."""
        index = np.unravel_index(flat, v.shape)
        x0 = np.array([ax[i] for ax, i in zip(axes, index)])
        lower = np.array([ax[max(i - 1, 0)] for ax, i in zip(axes, index)])
        upper = np.array([ax[min(i + 1, ax.size - 1)] for ax, i in zip(axes, index)])
        scale = upper - lower
        for size in (0.25, 0.01):
            # the simplex's other corners step inward from x0 along each axis
            steps = np.where(x0 + size * scale <= upper, 1.0, -1.0) * size * scale
            simplex = np.vstack([x0, x0 + np.diag(steps)])
            # stops when the simplex spans 1e-8 of the box's size and its values 1e-12 of the peak's
            x, _ = yield from nelder_mead.run(simplex, lower, upper, xatol=1e-8 * float(np.max(hi - lo)),
                                              fatol=1e-12 * float(v.flat[flat]), maxfev=1000)
            x0 = np.clip(x, lower, upper)
        return x0

    with np.errstate(invalid="ignore"):        # (a simplex corner where e is not finite)
        found = nelder_mead.minimize_all(lambda points: -np.abs(e(*points.T)),
                                         [refine(flat) for flat in candidates])
        found_values = np.abs(e(*np.array(found).T)) if found else []
    for x0, found_value in zip(found, found_values):
        found_value = float(found_value)
        if np.isfinite(found_value) and found_value > value:
            value, where = found_value, x0
    return value, where


def largest_error(f_approx, f_exact, lo, hi, relative: bool = False, **grid):
    """(max |f_approx - f_exact| (divided by |f_exact| if `relative`) over the box [lo, hi], the point
    where attained): `largest` of `error_function`. f_approx and f_exact take one array per axis."""
    return largest(error_function(f_approx, f_exact, relative), lo, hi, **grid)
