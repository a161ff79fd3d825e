"""The lobe search's forms: one function written two ways, and its minimax fit against independent
optima (a brute-force grid, the closed-form measure of the paper's family, Chebyshev alternation)."""

import numpy as np
import pytest
from scipy.optimize import minimize_scalar
from scipy.signal import argrelextrema

from pipeline.optics import lobe_families as lf
from pipeline.optics.error_measures import relative_parts
from pipeline.stages.lobe_search import fit_family

LEVEL = 0.6


def fit_minimax(name, n, level):
    """(q, the largest relative error on the zone's points) of the family at one n: the search's fit."""
    fit = fit_family(name, [n], level, lf.ZONE_POINTS)
    return fit["grid_q"][0], fit["grid_zone_error"][0]


@pytest.mark.parametrize("name", lf.NAMES)
@pytest.mark.parametrize("n", [2.0, 37.0, 1000.0])
def test_the_scaled_form_and_the_shader_form_are_one_function(name, n):
    """value_w(q) at w equals the shader's form at t = 1 - w/n with shader_parameters(q). Tolerance
    1e-9 relative: A t + B cancels terms of size n (1e3) to a value of order 1, losing 3 of 16 digits."""
    rng = np.random.default_rng(int(n))
    q = np.asarray(lf.FAMILIES[name].start) * rng.uniform(0.8, 1.2, len(lf.FAMILIES[name].start)) + 0.01
    w = np.linspace(0.0, min(n, 3.0), 200)
    P = lf.shader_parameters(name, np.asarray([n]), q[None])[0]
    np.testing.assert_allclose(lf.value_t(np, lf.NAMES.index(name), 1.0 - w / n, P), lf.value_w(name, w, n, q),
                               rtol=1e-9, atol=1e-15)


@pytest.mark.parametrize("n", [3.0, 50.0, 800.0])
def test_the_fit_is_no_worse_than_a_brute_force_grid(n):
    """exp2(A t + B) at n: no point of a 301 x 301 grid of (q0, q1) around the fit (+-2 %) has a smaller
    error on the same zone points than the fit, beyond 1e-6 relative (the fit stops where its linear
    program gains less than 1e-9 relative)."""
    q, error = fit_minimax("exp2_linear", n, LEVEL)
    u = lf.zone_points(n, LEVEL)
    reference = (1.0 - u) ** n
    q0 = q[0] + np.linspace(-0.02, 0.02, 301) * max(abs(q[0]), 1e-3)
    q1 = q[1] * (1.0 + np.linspace(-0.02, 0.02, 301))
    g = np.exp(q0[:, None, None] - q1[None, :, None] * (n * u)[None, None, :])
    grid = np.abs(g / reference - 1.0).max(axis=-1)
    assert error <= grid.min() * (1.0 + 1e-6)
    # ... and the grid does reach the fit's neighbourhood (the comparison is not vacuous).
    assert grid.min() <= error * 1.01


@pytest.mark.parametrize("n", [2.9, 20.0, 400.0])
def test_the_best_k_of_the_paper_s_family_matches_the_closed_form_optimum(n):
    """square_peak1 is (k (t - 1) + 1)^2 with one k per n: its fitted k against the k that minimizes
    the closed-form max d of `error_measures` (exact stationary point, no sampling) found by a scalar
    minimizer. The fit sees 256 zone points, so its d (measured exactly) may exceed the optimum by
    what the points miss: at most 1e-4 relative here (the error's peaks are at the zone's end,
    a point, and at one interior stationary point, among Chebyshev points that crowd the ends)."""
    q, _ = fit_minimax("square_peak1", n, LEVEL)

    def d(k):
        over, under, _, _ = relative_parts(np.float64(n), np.float64(k), LEVEL, 2)
        return float(max(over, under))

    best = minimize_scalar(d, bounds=(0.3 * n, 0.6 * n + 1.0), method="bounded", options=dict(xatol=1e-12))
    assert d(q[0] * n) == pytest.approx(best.fun, rel=1e-4)
    assert d(q[0] * n) >= best.fun * (1.0 - 1e-9)


def test_the_minimax_error_equioscillates():
    """Chebyshev's alternation: the best two-parameter fit exp(q0 - q1 w) has its error at three
    extremes of alternating sign and equal size. On 4001 points of the zone, the interior extremum
    and the two ends are within 1e-4 of one size (the 256 points the fit ran on), signs alternating."""
    n = 120.0
    q, error = fit_minimax("exp2_linear", n, LEVEL)
    w = np.linspace(0.0, lf.zone_w(n, LEVEL), 4001)
    r = lf.value_w("exp2_linear", w, n, q) / (1.0 - w / n) ** n - 1.0
    inner = argrelextrema(np.abs(r), np.greater)[0]
    extremes = np.concatenate([[0], inner, [w.size - 1]])
    assert extremes.size == 3
    values = r[extremes]
    assert np.all(np.sign(values[1:]) == -np.sign(values[:-1]))
    np.testing.assert_allclose(np.abs(values), error, rtol=1e-4)


def test_a_family_left_out_of_the_config_is_a_config_error():
    import pipeline
    from pipeline.engine import paths
    from pipeline.engine.config import ConfigError
    with pytest.raises(ConfigError, match="lobe_search.families"):
        pipeline.load_config(paths.PAPER_CONFIG, ('lobe_search.families=["square", "sine"]',))
    with pytest.raises(ConfigError, match="lobe_search.n_ranges"):
        pipeline.load_config(paths.PAPER_CONFIG, ("lobe_search.n_ranges=[[10, 2]]",))
