"""Importance sampling of the quadratic lobe: the sampled cosines follow the pdf (chi-square), the pdf
integrates to 1, and estimates of the directional albedo with it match the quadrature of
`pipeline.optics.albedo`; deliberately wrong samplers fail the same tests."""

import numpy as np
import pytest
from scipy import integrate, stats

from pipeline.optics import sampling
from pipeline.optics.albedo import albedo_table
from pipeline.optics.numerics import jax

# The sampler's functions compiled once each (as the pipeline's importance_albedo compiles them),
# rather than run one operation at a time.
SAMPLE = {"phong": jax.jit(sampling.sample_phong), "blinn": jax.jit(sampling.sample_blinn)}
PDF = {"phong": jax.jit(sampling.pdf_phong), "blinn": jax.jit(sampling.pdf_blinn)}

K = {2.0: 0.448 * 2 + 0.099, 10.0: 0.448 * 10 + 0.099, 100.0: 0.448 * 100 + 0.099, 1000.0: 0.448 * 1000 + 0.099}


@pytest.mark.parametrize("k", [0.3, 0.995, 5.0, 448.099])
def test_pdf_integrates_to_one(k):
    c0 = max(1 - 1 / k, -1.0)
    total = integrate.quad(lambda c: 2 * np.pi * float(sampling.lobe_pdf(c, k)), c0, 1, epsabs=1e-13)[0]
    assert total == pytest.approx(1.0, abs=1e-10)


def _chi2_pvalue(c, k, bins=40):
    """p-value of the sampled cosines c against the lobe's CDF in w = k (c - 1) + 1 (equal-probability bins)."""
    w0 = max(1 - 2 * k, 0.0) ** 3
    w = k * (np.asarray(c) - 1) + 1
    u = (w**3 - w0) / (1 - w0)           # uniform on [0, 1) if c follows the pdf
    counts, _ = np.histogram(u, bins=bins, range=(0, 1))
    return stats.chisquare(counts).pvalue


@pytest.mark.parametrize("n", [2.0, 10.0, 100.0, 1000.0])
def test_sampled_cosines_follow_the_pdf_and_a_wrong_sampler_fails(n):
    k = K[n]
    xi = np.asarray(jax.random.uniform(jax.random.PRNGKey(int(n)), (200_000,)))
    assert _chi2_pvalue(sampling.lobe_cosine(xi, k), k) > 1e-3
    # The square root instead of the cube root: the same test rejects it.
    w0 = max(1 - 2 * k, 0.0) ** 3
    wrong = 1 + (np.sqrt(w0 + xi * (1 - w0)) - 1) / k
    assert _chi2_pvalue(wrong, k) < 1e-9


def _albedo_estimate(form, k, theta, pdf_scale=1.0, samples=100_000, seed=0):
    """(mean, standard error) of int f cos(theta_o) dw_o with the lobe's own sampler (coef = 1)."""
    xi = jax.random.uniform(jax.random.PRNGKey(seed), (samples, 2))
    wi = np.broadcast_to([np.sin(theta), 0.0, np.cos(theta)], (samples, 3))
    wo, pdf = (np.asarray(v) for v in SAMPLE[form](xi, wi, k))
    if form == "phong":
        t = np.sum(np.asarray(sampling.reflect(wi, sampling.NORMAL)) * wo, axis=-1)
    else:
        h = (wi + wo) / np.linalg.norm(wi + wo, axis=-1, keepdims=True)
        t = h[:, 2]
    lobe = np.where(k * (t - 1) + 1 > 0, (k * (t - 1) + 1) ** 2, 0.0)
    values = np.where((wo[:, 2] > 0) & (pdf > 0), lobe * wo[:, 2] / (pdf_scale * np.where(pdf > 0, pdf, 1.0)), 0.0)
    return values.mean(), values.std() / np.sqrt(samples)


@pytest.mark.parametrize("form", ["phong", "blinn"])
@pytest.mark.parametrize("n", [2.0, 10.0, 100.0, 1000.0])
def test_importance_sampled_albedo_matches_the_quadrature(form, n):
    k = K[n]
    for deg in (0.0, 45.0, 80.0):
        theta = np.radians(deg)
        quad = float(albedo_table(form, "linear_power", [n], [k], [1 / k], [theta], 96)[0, 0])
        mean, se = _albedo_estimate(form, k, theta)
        assert abs(mean - quad) < 4 * se + 1e-7 * quad, (form, n, deg, mean, quad, se)
        # A pdf 10 % too large biases the estimate by 10 %: far outside the same bound.
        wrong, _ = _albedo_estimate(form, k, theta, pdf_scale=1.1)
        assert abs(wrong - quad) > 10 * se


def test_sampled_pdf_is_the_pdf_function():
    xi = jax.random.uniform(jax.random.PRNGKey(3), (1000, 2))
    theta = np.radians(60.0)
    wi = np.broadcast_to([np.sin(theta), 0.0, np.cos(theta)], (1000, 3))
    for k in (0.7, K[10.0]):
        for form in ("phong", "blinn"):
            wo, pdf = SAMPLE[form](xi, wi, k)
            np.testing.assert_allclose(pdf, PDF[form](wi, wo, k), rtol=1e-9)
            np.testing.assert_allclose(np.linalg.norm(np.asarray(wo), axis=-1), 1.0, rtol=1e-12)
