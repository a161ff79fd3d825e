"""The GGX specular terms of `pipeline.optics.brdf`, each against an independent computation: Heitz's
Lambda form of the Smith visibility, scipy's adaptive quadrature over L for the environment BRDF, the
mirror limit of small roughness, a white furnace, closed forms and dense grids for the largest errors.
"""

import math

import numpy as np
import pytest
from scipy import integrate

from pipeline.optics import brdf
from pipeline.optics.numerics import jax

jnp = jax.numpy
RNG = np.random.default_rng(20140604)


# ---- oracles (plain numpy / scipy, none of the module's code) -----------------------------------

def lambda_ggx(cos, alpha):
    """Smith's Lambda of GGX (Heitz 2014, eq. 72): (-1 + sqrt(1 + alpha^2 tan^2 theta)) / 2."""
    tan2 = (1.0 - cos * cos) / (cos * cos)
    return (-1.0 + np.sqrt(1.0 + alpha * alpha * tan2)) / 2.0


def scipy_env_brdf(nov, roughness, tolerance=1e-10):
    """(A, B) by scipy's dblquad over L in spherical coordinates (theta, phi) around N, V in the x-z
    plane at phi = 0: int D G (1 - Fc or Fc) / (4 NoV NoL) NoL sin(theta) dtheta dphi, phi over [0, pi]
    doubled (V's plane is a plane of symmetry), theta split at the mirror direction theta_v."""
    a = roughness ** 2
    a2, k = a * a, a / 2
    cv, sv = nov, math.sqrt(1 - nov * nov)
    g1_v = cv / (cv * (1 - k) + k)

    def integrand(phi, theta, bias):
        st, ct = math.sin(theta), math.cos(theta)
        hx, hy, hz = st * math.cos(phi) + sv, st * math.sin(phi), ct + cv
        norm = math.sqrt(hx * hx + hy * hy + hz * hz)
        noh, voh = hz / norm, (sv * hx + cv * hz) / norm
        d = a2 / (math.pi * (noh * noh * (a2 - 1) + 1) ** 2)
        g = ct / (ct * (1 - k) + k) * g1_v
        fc = (1 - voh) ** 5
        # f NoL sin(theta): the BRDF's 1 / NoL cancels the cosine
        return d * g * (fc if bias else 1 - fc) / (4 * cv) * st

    theta_v = math.acos(cv)
    pieces = [(0, theta_v), (theta_v, math.pi / 2)] if theta_v > 0 else [(0, math.pi / 2)]
    return tuple(2 * sum(integrate.dblquad(integrand, lo, hi, 0, math.pi, args=(bias,), epsabs=tolerance,
                                           epsrel=tolerance)[0] for lo, hi in pieces)
                 for bias in (False, True))


# ---- 1. visibility ------------------------------------------------------------------------------

def test_visibility_is_heitz_g2_over_4_nov_nol():
    alpha = RNG.uniform(0.005, 1.0, 2000)
    nov, nol = RNG.uniform(1e-3, 1.0, (2, 2000))
    g2 = 1.0 / (1.0 + lambda_ggx(nov, alpha) + lambda_ggx(nol, alpha))
    # Both forms are a few roundings deep; 1e-12 is ~5000 ulp, room for the cancellation in Lambda's
    # -1 + sqrt(...) (absolute ~1e-16, against the 1 it is added to).
    np.testing.assert_allclose(brdf.visibility_smith_ggx_correlated(nov, nol, alpha), g2 / (4 * nov * nol),
                               rtol=1e-12, atol=0)
    # alpha = 1: both square roots are 1, V = 0.5 / (NoL + NoV)
    np.testing.assert_allclose(brdf.visibility_smith_ggx_correlated(nov, nol, 1.0), 0.5 / (nov + nol),
                               rtol=1e-15)


def test_hammon_and_filament_fast_are_one_function():
    alpha = RNG.uniform(0.0, 1.0, 2000)
    nov, nol = RNG.uniform(1e-3, 1.0, (2, 2000))
    # Same polynomial, summed in another order: a few ulp apart.
    np.testing.assert_allclose(brdf.visibility_filament_fast(nov, nol, alpha),
                               brdf.visibility_hammon(nov, nol, alpha), rtol=1e-15)


@pytest.mark.parametrize("name", ["hammon", "filament_fast"])
def test_visibility_anchor_is_28_6_percent_off_at_most(name):
    found = brdf.visibility_anchor_error(name)
    closed, x = brdf.hammon_largest_relative_error(alpha_min=brdf.VISIBILITY_BOX[0][0])
    # The number: 28.6 %.
    assert round(100 * found["max_rel_error"], 1) == 28.6
    # The search over the whole (alpha, NoV, NoL) box finds the closed form's maximum 1 - sqrt(0.51)
    # on the diagonal: its stopping rule allows 1e-12 of the value; 1e-11 leaves room for rounding.
    assert closed == pytest.approx(1 - math.sqrt(0.51), rel=1e-15)
    assert found["max_rel_error"] == pytest.approx(closed, abs=1e-11)
    # Where: alpha at its least, NoV = NoL = 1/51. At a smooth maximum a value within 1e-12 pins the
    # point only to ~sqrt(1e-12) = 1e-6.
    np.testing.assert_allclose(found["where"], (0.02, x, x), atol=1e-5)


# ---- 2. the environment BRDF --------------------------------------------------------------------

@pytest.mark.parametrize("nov, roughness", [(0.5, 0.5), (0.1, 0.3), (0.02, 1.0), (0.3, 0.15), (0.9, 0.8),
                                            (1.0, 0.43), (0.02, 0.12), (0.05, 0.1)])
def test_env_brdf_matches_scipy_over_the_hemisphere_of_l(nov, roughness):
    A, B = brdf.env_brdf(nov, roughness)
    ref_A, ref_B = scipy_env_brdf(nov, roughness)
    # Measured |difference| <= 1e-11 at these points; scipy's own target is 1e-10, hence 1e-9.
    assert float(A) == pytest.approx(ref_A, abs=1e-9)
    assert float(B) == pytest.approx(ref_B, abs=1e-9)


@pytest.mark.parametrize("nov, roughness", [(0.02, 0.05), (0.02, 0.13), (0.03, 0.15), (0.2, 0.07), (1.0, 0.2)])
def test_env_brdf_has_converged_where_it_is_hardest(nov, roughness):
    """Grazing view and small roughness (the lobe straddles the horizon; scipy's dblquad cannot reach
    1e-10 at (0.02, 0.05)): the defaults against 4x the tanh-sinh density and 5x the phi nodes. On a
    32 x 32 grid of the box (uniform and Chebyshev) the largest difference measured 1.2e-11 (A) and
    1.0e-12 (B)."""
    coarse = brdf.env_brdf(nov, roughness)
    fine = brdf.env_brdf(nov, roughness, step=1 / 64, phi_nodes=128)
    np.testing.assert_allclose(coarse, fine, rtol=0, atol=5e-11)


def test_env_brdf_tends_to_the_mirror_as_roughness_vanishes():
    """As alpha -> 0, D tends to a delta at H = N: L is V's mirror, NoL = NoV, VoH = NoV, and
    A + B -> G1(NoV)^2, B -> Fc(NoV) G1(NoV)^2 (-> 1 and (1 - NoV)^5 as k = alpha / 2 -> 0 too). The
    first correction is O(alpha^2): measured -(1.0 to 1.4) alpha^2 for A + B and up to 4.5 alpha^2
    for B (NoV >= 0.5; B converges slower, Fc varies fast); bounds 2 alpha^2 and 10 alpha^2. At
    grazing view the lobe reaches the horizon and the limit is slower (not tested)."""
    nov = np.linspace(0.2, 1.0, 17)
    for roughness in (0.01, 0.02):
        alpha = roughness ** 2
        k = alpha / 2
        g1 = nov / (nov * (1 - k) + k)
        A, B = brdf.env_brdf(nov, roughness)
        assert np.max(np.abs(A + B - g1 ** 2)) <= 2 * alpha ** 2
        upper = nov >= 0.5
        assert np.max(np.abs(B - (1 - nov) ** 5 * g1 ** 2)[upper]) <= 10 * alpha ** 2
        # the brief's form: A + B -> 1 (here within 2k (1 - NoV) / NoV + 2 alpha^2 <= 4e-4 at r = 0.01)
        assert np.min(A + B) >= 1 - 2 * k * (1 - nov[0]) / nov[0] - 2 * alpha ** 2


def test_env_brdf_table_passes_the_white_furnace():
    nov, roughness = np.linspace(0.02, 1, 32), np.linspace(0.05, 1, 32)
    A, B = brdf.env_brdf_table(nov, roughness)
    # With F = 1 the BRDF's albedo A + B is at most 1 (it reaches 0.9999935 at NoV = 1, r = 0.05, the
    # table's corner: G1(1)^2 - O(alpha^2)); A and B are integrals of positive terms.
    assert np.max(A + B) <= 1.0
    assert np.max(A + B) == pytest.approx(float(sum(brdf.env_brdf(1.0, 0.05))), abs=0)
    assert np.min(A) > 0 and np.min(B) > 0
    # rows NoV, columns roughness
    assert (A[7, 3], B[7, 3]) == tuple(float(t) for t in brdf.env_brdf(nov[7], roughness[3]))


def test_env_brdf_names_the_bad_input():
    with pytest.raises(ValueError, match=r"env_brdf: nov must lie in \(0, 1\], got 0.0"):
        brdf.env_brdf([0.5, 0.0], 0.5)
    with pytest.raises(ValueError, match=r"env_brdf: roughness must lie in \(0, 1\], got 1.5"):
        brdf.env_brdf(0.5, 1.5)


def dense_edge_maximum(anchor, part, nov=None, roughness=None, points=401):
    """max |anchor - env_brdf| along one edge of the box (nov or roughness fixed), on `points` points."""
    (v_lo, r_lo), (v_hi, r_hi) = brdf.ENV_BRDF_BOX
    if nov is not None:
        v, r = np.full(points, nov), np.linspace(r_lo, r_hi, points)
    else:
        v, r = np.linspace(v_lo, v_hi, points), np.full(points, roughness)
    index = "AB".index(part)
    return float(np.max(np.abs(brdf.ENV_BRDF_ANCHORS[anchor].function(v, r)[index] - brdf.env_brdf(v, r)[index])))


# Each maximum lies on an edge of the box (NoV = 0.02 or 1, roughness = 0.05): (value, NoV, roughness).
# Values to 1e-9: the quadrature is good to 2e-11 and the search stops within 1e-12 of the value.
# A 200 x 200 grid of the box (uniform and Chebyshev) found each maximum 2e-6 or less below these,
# at the same place.
ENV_ANCHOR_MAXIMA = {
    ("karis_mobile", "A"): (0.18119457920, 1.0, 0.428246),
    ("karis_mobile", "B"): (0.19220219933, 0.02, 0.122200),
    ("lazarov", "A"): (0.46645323892, 0.02, 0.091287),
    ("lazarov", "B"): (0.34880653892, 0.022305, 0.05),
}


@pytest.mark.parametrize("anchor", ["karis_mobile", "lazarov"])
def test_env_brdf_anchor_errors(anchor):
    found = brdf.env_brdf_anchor_errors(anchor)
    for part in "AB":
        value, nov, roughness = ENV_ANCHOR_MAXIMA[anchor, part]
        assert found[part][0] == pytest.approx(value, abs=1e-9)
        # the point only to ~sqrt(1e-12) where the maximum is smooth (roughness of Karis's A)
        np.testing.assert_allclose(found[part][1], (nov, roughness), atol=1e-5)
        # No point of a dense scan of the edge holding the maximum beats it.
        edge = {"roughness": roughness} if roughness == 0.05 else {"nov": nov}
        assert dense_edge_maximum(anchor, part, **edge) <= value + 1e-12
    if anchor == "karis_mobile":
        # The numbers: 0.18 off the exact scale, 0.19 off the bias.
        assert (round(found["A"][0], 2), round(found["B"][0], 2)) == (0.18, 0.19)


def test_anchors_name_their_sources():
    sources = {a.name: a.source for a in (*brdf.VISIBILITY_ANCHORS.values(), *brdf.ENV_BRDF_ANCHORS.values())}
    assert sources == {"hammon": brdf.HAMMON_2017, "filament_fast": brdf.FILAMENT_2018,
                       "karis_mobile": brdf.KARIS_2014, "lazarov": brdf.LAZAROV_2013}
    assert all(any(str(year) in s for year in range(2013, 2019)) for s in sources.values())


def test_jax_twins_agree_with_numpy():
    alpha = RNG.uniform(0.02, 1.0, 500)
    nov, nol = RNG.uniform(0.01, 1.0, (2, 500))
    for f in (brdf.visibility_smith_ggx_correlated, brdf.visibility_hammon, brdf.visibility_filament_fast):
        twin = jax.jit(lambda v, l, a, f=f: f(v, l, a, xp=jnp))
        np.testing.assert_allclose(np.asarray(twin(nov, nol, alpha)), f(nov, nol, alpha), rtol=1e-15)
    for f in (brdf.env_brdf_karis_mobile, brdf.env_brdf_lazarov):
        twin = jax.jit(lambda v, r, f=f: f(v, r, xp=jnp))
        # exp2 may differ by an ulp between XLA and numpy; A and B are O(1) sums
        np.testing.assert_allclose(np.asarray(twin(nov, alpha)), f(nov, alpha), rtol=0, atol=1e-15)


# ---- 3. the largest error over a box ------------------------------------------------------------

X0, Y0, A0, WIDTH = 0.3711, 0.6123, 0.5123, 0.01


def _grid_maximum(f, dims):
    axes = [brdf.axis_grid(0.0, 1.0)] * dims
    return float(np.max(np.abs(f(*np.meshgrid(*axes, indexing="ij")))))


@pytest.mark.parametrize("shape", ["gaussian", "cone", "slanted ridge", "gaussian 3-d"])
def test_largest_finds_a_narrow_peak_between_grid_points(shape):
    """A peak of height 1 and width 0.01 (a third of a grid cell) at a point off the grid: the grid
    alone sees less than 0.8 of it; the refinement must find 1 and its place."""
    f = {
        "gaussian": lambda x, y: np.exp(-((x - X0) ** 2 + (y - Y0) ** 2) / (2 * WIDTH ** 2)),
        "cone": lambda x, y: 1 / (1 + (np.abs(x - X0) + np.abs(y - Y0)) / WIDTH),
        # a kink along a line that no axis follows (as min() in the anchors makes)
        "slanted ridge": lambda x, y: 1 / (1 + np.abs((x - X0) - 0.8 * (y - Y0)) / WIDTH
                                           + 0.1 * ((x - X0) ** 2 + (y - Y0) ** 2) / WIDTH ** 2),
        "gaussian 3-d": lambda a, x, y: np.exp(-((a - A0) ** 2 + (x - X0) ** 2 + (y - Y0) ** 2) / (2 * WIDTH ** 2)),
    }[shape]
    dims = 3 if shape.endswith("3-d") else 2
    assert _grid_maximum(f, dims) < 0.8
    value, where = brdf.largest(f, (0.0,) * dims, (1.0,) * dims)
    # Stopping within 1e-12 of the value: the maximum to 1e-11 everywhere; the place to 1e-7 where
    # the peak is a kink (|f - 1| ~ distance / width), to ~width sqrt(1e-12) = 1e-8 where smooth.
    assert value == pytest.approx(1.0, abs=1e-11)
    np.testing.assert_allclose(where, (A0, X0, Y0)[3 - dims:], atol=1e-7)


def test_largest_error_is_relative_on_request_and_inf_where_not_finite():
    exact = lambda x, y: 2.0 + x * y
    approx = lambda x, y: exact(x, y) + 0.5 * x * y
    # max 0.5 x y = 0.5 at (1, 1); relative 0.5 / 3
    assert brdf.largest_error(approx, exact, (0, 0), (1, 1))[0] == pytest.approx(0.5, abs=1e-15)
    assert brdf.largest_error(approx, exact, (0, 0), (1, 1), relative=True)[0] == pytest.approx(0.5 / 3, rel=1e-14)
    value, where = brdf.largest_error(lambda x, y: 1 / (x - 0.5), exact, (0, 0), (1, 1))
    assert value == float("inf") and where[0] == 0.5
