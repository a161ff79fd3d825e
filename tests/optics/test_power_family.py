"""The family (k (cos x - 1) + 1)^m at powers m = 3 and 4, against independent computations: the
level-matched k_Q and its large-n line, d and D on dense grids, the relative RMS error by scipy,
the exact normalization in closed form against the hemisphere quadrature at every n, and the
closed-form sampler by its own pdf."""

import jax
import numpy as np
import pytest
import sympy as sp
from scipy.integrate import quad

from pipeline.optics import integrals
from pipeline.optics.albedo import albedo_table
from pipeline.optics.error_measures import absolute_parts, relative_parts, rms_relative
from pipeline.optics.lobes import k_Q, linear_power_u
from pipeline.optics.registry import multiplies, power_steps
from pipeline.optics.roots import SolverSettings
from pipeline.optics.sampling import importance_albedo, lobe_cosine, lobe_pdf
from pipeline.stages.family import asymptote

from ..oracles import dense_max_errors, quadratic_np

SETTINGS = SolverSettings(1e-12, 1e-12, 256)
POWERS = (3, 4)


def k_Q_np(n, Q, m):
    """(Q^(1/m) - 1) / (Q^(1/n) - 1), the lobe equal to cos^n where cos^n = Q, in plain numpy."""
    return (Q ** (1.0 / m) - 1.0) / (Q ** (1.0 / n) - 1.0)


@pytest.mark.parametrize("m", POWERS)
def test_k_Q_matches_cos_n_at_level_Q(m):
    for n in (2.0, 7.0, 100.0, 1000.0):
        k = float(k_Q(n, 0.65, m))
        assert k == pytest.approx(k_Q_np(n, 0.65, m), rel=1e-12)
        u = 1.0 - 0.65 ** (1.0 / n)             # where cos^n = Q
        assert (1.0 - k * u) ** m == pytest.approx(0.65, rel=1e-12)


def test_k_Q_at_power_2_is_the_papers_formula():
    n = np.array([2.0, 30.0, 1000.0])
    assert np.allclose(np.asarray(k_Q(n, 0.64, 2)), (np.sqrt(0.64) - 1) / (0.64 ** (1 / n) - 1), rtol=1e-13)


@pytest.mark.parametrize("m", POWERS)
def test_the_line_is_the_large_n_asymptote_of_k_Q(m):
    """k_Q(n) - (slope n + intercept) = O(1/n): it falls 100x from n = 1e4 to n = 1e6."""
    slope, intercept = asymptote(0.65, m)
    gaps = [float(k_Q(n, 0.65, m)) - (slope * n + intercept) for n in (1e4, 1e6)]
    assert abs(gaps[0]) < 1e-3 and abs(gaps[1]) < abs(gaps[0]) / 50


@pytest.mark.parametrize("m", POWERS)
@pytest.mark.parametrize("n", (2.0, 3.0, 10.0, 57.0, 400.0, 1000.0))
def test_d_and_D_agree_with_a_dense_grid(m, n):
    level = 0.5936
    slope, intercept = asymptote(0.65, m)
    for k in (slope * n + intercept, float(k_Q_np(n, 0.3, m)), n / m):
        over, under, *_ = relative_parts(n, k, level, m)
        D_over, D_under, _, _, ok = absolute_parts(n, k, SETTINGS, m)
        d_grid, D_grid = dense_max_errors(n, k, level, power=m)
        assert bool(ok)
        assert max(float(over), float(under)) == pytest.approx(d_grid, abs=2e-8)
        assert max(float(over), float(under)) >= d_grid - 1e-12
        assert max(float(D_over), float(D_under)) == pytest.approx(D_grid, abs=2e-8)
        assert max(float(D_over), float(D_under)) >= D_grid - 1e-14


@pytest.mark.parametrize("m", POWERS)
@pytest.mark.parametrize("n,k", [(2.0, 0.6), (20.0, 5.0), (1000.0, 237.1)])
def test_rms_against_scipy(m, n, k):
    num = quad(lambda u: (float(quadratic_np(u, k, m)) - (1 - u) ** n) ** 2, 0, 1, points=[min(1 / k, 1)],
               epsabs=1e-16, epsrel=1e-12, limit=200)[0]
    den = quad(lambda u: (1 - u) ** (2 * n), 0, 1, epsabs=1e-16, epsrel=1e-12)[0]
    # Gauss-Legendre against quad (epsrel 1e-12 on each integral; the numerator cancels near u = 0)
    assert float(rms_relative(n, k, m)) == pytest.approx(np.sqrt(num / den), rel=1e-7)


def test_rms_quadrature_agrees_with_the_closed_form_at_power_2():
    from pipeline.optics import error_measures
    for n, k in ((2.0, 0.995), (20.0, 9.06), (1000.0, 448.1)):
        c = min(1 / k, 1.0)
        closed = float(error_measures._power_moment(1 - k, k, n, 1 - c))
        assert float(error_measures._cross_quadrature(n, k, c, 2)) == pytest.approx(closed, rel=1e-11)


@pytest.mark.parametrize("m", POWERS)
def test_the_exact_normalization_closed_form(m):
    """sympy's integral for k >= 1 is ((m + 2) k - 1) / ((m + 1)(m + 2) k^2), and its coef has the
    partial fractions ((m + 1) / (2 pi)) (k + c + c^2 / (k - c)), c = 1 / (m + 2)."""
    k = integrals.k
    Int = integrals.phong_integral(m).args[0][0]
    assert sp.simplify(Int - ((m + 2) * k - 1) / ((m + 1) * (m + 2) * k ** 2)) == 0
    c = sp.Rational(1, m + 2)
    coef = integrals.coef_of_k(integrals.phong_integral(m)).args[0][0]
    assert sp.simplify(coef - (m + 1) / (2 * sp.pi) * (k + c + c ** 2 / (k - c))) == 0


@pytest.mark.parametrize("m", POWERS)
def test_the_exact_coef_against_the_hemisphere_quadrature_at_every_n(m):
    """coef(n) times the albedo per unit coef at normal incidence (an independent route: the
    azimuthal closed forms and Gauss-Legendre of `pipeline.optics.albedo`) is 1 at every n, both
    forms, including the small n where the lobe reaches past the horizon (k < 1)."""
    slope, intercept = asymptote(0.65, m)
    n = np.arange(2.0, 1001.0)
    k = slope * n + intercept
    assert k[0] < 1.0
    for form in ("phong", "blinn"):
        coef_fn, _ = integrals.exact_coef_code(form, m)
        coef = np.asarray(coef_fn(n, slope, intercept))
        albedo = albedo_table(form, "linear_power", n, k, 1.0 / k, np.zeros(1), 96, m)[:, 0]
        assert np.max(np.abs(coef * albedo - 1.0)) < 1e-9, form


@pytest.mark.parametrize("m", POWERS)
def test_the_sampler_draws_its_own_pdf(m):
    """The inverse CDF of `lobe_cosine` against the integral of `lobe_pdf`: the fraction of draws
    below each cosine equals 2 pi times the pdf integrated up to it (k > 1/2 and k < 1/2)."""
    xi = (np.arange(200_000) + 0.5) / 200_000
    for k in (0.3, 3.0, 200.0):
        c = np.asarray(lobe_cosine(xi, k, m))
        lo = max(1.0 - 1.0 / k, -1.0)
        for q in (0.1, 0.5, 0.9):
            edge = lo + q * (1.0 - lo)
            mass = 2 * np.pi * quad(lambda t: float(lobe_pdf(t, k, m)), lo, edge, epsabs=1e-13)[0]
            assert np.mean(c <= edge) == pytest.approx(mass, abs=2e-5)
        total = 2 * np.pi * quad(lambda t: float(lobe_pdf(t, k, m)), lo, 1.0, epsabs=1e-13)[0]
        assert total == pytest.approx(1.0, abs=1e-10)


@pytest.mark.parametrize("m", POWERS)
def test_importance_sampling_estimates_the_quadrature_albedo(m):
    """The sampler's estimate of the albedo (weights f cos / pdf) lies within 4 standard errors of
    the quadrature at oblique incidence, both forms."""
    n, k = 50.0, asymptote(0.65, m)[0] * 50.0
    key = jax.random.PRNGKey(3)
    for form in ("phong", "blinn"):
        theta = np.radians(60.0)
        expected = float(albedo_table(form, "linear_power", n, k, 1.0 / k, [theta], 96, m)[0, 0])
        mean, se = importance_albedo(form, k, 1.0, theta, key, 200_000, m)
        assert abs(float(mean) - expected) <= 4 * float(se), (form, float(mean), expected, float(se))


@pytest.mark.parametrize("m", range(2, 17))
def test_power_steps_compute_the_power_with_few_multiplies(m):
    steps, result = power_steps("b", m)
    values = {"b": 1.7}
    for name, expression in steps:
        left, right = (values[v.strip()] for v in expression.split("*"))
        values[name] = left * right
    assert values[result] == pytest.approx(1.7 ** m, rel=1e-14)
    assert multiplies(m) == int(m).bit_length() - 1 + bin(m).count("1") - 1


def test_linear_power_u_uses_the_power():
    assert float(linear_power_u(0.1, 2.0, 4)) == pytest.approx(0.8 ** 4, rel=1e-15)
    assert float(linear_power_u(0.6, 2.0, 3)) == 0.0
