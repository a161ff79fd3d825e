"""The lobe as a microfacet NDF (`pipeline.optics.distributions`, the `ndf` stage) against scipy: every
normalized D has projected area 1, the matched roughness gives Beckmann cos^n's peak, and the
errors against Beckmann agree with a direct evaluation."""

import numpy as np
import pytest
from scipy.integrate import quad

from pipeline.optics import distributions as ndf, integrals

from ..oracles import quadratic_np


def projected_area(D, top=np.pi / 2):
    """2 pi int_0^top D(cos theta) cos theta sin theta d theta, by scipy's adaptive quadrature."""
    return 2 * np.pi * quad(lambda th: float(D(np.cos(th))) * np.cos(th) * np.sin(th), 0, top,
                            epsabs=1e-13, epsrel=1e-11, limit=400)[0]


@pytest.mark.parametrize("n", (2.0, 10.0, 100.0, 1000.0))
def test_every_normalized_ndf_has_projected_area_one(n):
    alpha = float(ndf.alpha_of_n(n))
    assert projected_area(lambda t: ndf.beckmann(t, alpha)) == pytest.approx(1.0, abs=1e-9)
    assert projected_area(lambda t: ndf.ggx(t, alpha)) == pytest.approx(1.0, abs=1e-9)
    assert projected_area(lambda t: (n + 2) / (2 * np.pi) * t ** n) == pytest.approx(1.0, abs=1e-9)
    for power, (a, b) in ((2, (0.448, 0.099)), (3, (0.3105065, 0.0668804))):
        coef_fn, _ = integrals.exact_coef_code("phong", power)
        k = a * n + b
        coef = float(coef_fn(n, a, b))
        edge = np.arccos(max(1 - 1 / k, 0.0))
        area = projected_area(lambda t: coef * quadratic_np(1 - t, k, power), top=min(edge, np.pi / 2))
        assert area == pytest.approx(1.0, abs=1e-9), (power, n)


def test_the_matched_roughness_gives_equal_peaks():
    n = np.array([2.0, 10.0, 1000.0])
    alpha = ndf.alpha_of_n(n)
    assert np.allclose(ndf.beckmann(1.0, alpha), (n + 2) / (2 * np.pi), rtol=1e-14)
    assert np.allclose(ndf.ggx(1.0, alpha), 1 / (np.pi * alpha ** 2), rtol=1e-14)


def test_errors_against_beckmann_match_a_direct_evaluation():
    n = np.array([50.0])
    alpha = ndf.alpha_of_n(n)
    d, D = ndf.errors_against_beckmann(lambda t: (n[0] + 2) / (2 * np.pi) * np.maximum(t, 0) ** n[0], n, alpha, 0.6)
    theta = np.linspace(0, 12 * alpha[0], 200001)
    t = np.cos(theta)
    ref, cand = ndf.beckmann(t, alpha[0]), (n[0] + 2) / (2 * np.pi) * t ** n[0]
    peak = 1 / (np.pi * alpha[0] ** 2)
    zone = ref >= 0.6 * peak
    assert d[0] == pytest.approx(np.max(np.abs(cand[zone] / ref[zone] - 1)), rel=1e-4)
    assert D[0] == pytest.approx(np.max(np.abs(cand - ref)) / peak, rel=1e-4)


def test_smith_g1_against_its_erf_closed_form():
    """Walter et al.'s rational approximation against Smith's G1 of Beckmann in closed form,
    2 / (1 + erf(a) + exp(-a^2) / (a sqrt(pi))), a = 1 / (alpha tan): within 0.35 % everywhere
    (the approximation's own stated accuracy; 0.31 % at its worst, a = 1.34), exactly 1 from
    a = 1.6 on (where the closed form is within 0.35 % of 1), and 0.4470 at grazing incidence."""
    from scipy.special import erf

    for alpha in (0.05, 0.3, 1.0):
        cos_v = np.linspace(0.001, 1.0 - 1e-9, 20001)
        a = cos_v / (alpha * np.sqrt(1 - cos_v**2))
        closed = 2 / (1 + erf(a) + np.exp(-a * a) / (a * np.sqrt(np.pi)))
        approx = ndf.smith_g1_beckmann(cos_v, alpha)
        np.testing.assert_allclose(approx, closed, rtol=3.5e-3)
        assert np.all(approx[a >= 1.6] == 1.0)
    assert float(ndf.smith_g1_beckmann(1.0, 0.3)) == 1.0
    a = 0.05 / (0.3 * np.sqrt(1 - 0.05**2))
    assert float(ndf.smith_g1_beckmann(0.05, 0.3)) == pytest.approx(2 / (1 + erf(a) + np.exp(-a * a) / (a * np.sqrt(np.pi))),
                                                                    rel=3.5e-3)
