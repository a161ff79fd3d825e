"""The lobe as the D of a Cook-Torrance BSDF in Mitsuba 3 (`pipeline.mitsuba.microfacet`): its sampler
by Mitsuba's chi-square test, the white furnace bound (albedo <= 1 with F = 1), and against
Mitsuba's own roughconductor: cos^n as an NDF at large n is Beckmann, so their albedos agree."""

import math

import pytest

from pipeline.mitsuba import bsdf as mitsuba_bsdf, microfacet
from pipeline.optics import distributions as ndf

import drjit as dr  # noqa: E402
from mitsuba.chi2 import BSDFAdapter, ChiSquareTest  # noqa: E402

from ..helpers import require_fast_variant
from .test_bsdf import LOBES, LobeDomain, weight_albedo

CASES = [(lobe, n, angle) for lobe in ("f_b", "f_Q2", "f_Q4") for n in (10.0, 100.0, 1000.0) for angle in (0.0, 60.0)]


@pytest.fixture(scope="module")
def variant():
    variant = microfacet.register()
    require_fast_variant(variant, f"Mitsuba's {mitsuba_bsdf.FAST_VARIANT} is not in use: the chi2 harness needs "
                         "a vectorized variant")
    return variant


def props(lobe, n, **extra):
    shape, k, power = LOBES[lobe]
    return {"type": microfacet.NAME, "shape": shape, "form": "blinn", "exponent": n, "k": k(n), "power": power,
            "alpha": float(ndf.alpha_of_n(n))} | extra


@pytest.mark.parametrize("lobe, n, angle", CASES)
def test_the_microfacet_sampler_passes_mitsubas_chi2_test(variant, lobe, n, angle):
    theta = math.radians(angle)
    wi = [math.sin(theta), 0.0, math.cos(theta)]
    domain = LobeDomain(lobe, "blinn", n, wi)
    sample, pdf = BSDFAdapter(microfacet.NAME, props(lobe, n), wi=wi)

    def density(wo):
        p = pdf(wo)
        return dr.select(p > 0.0, p * domain.jacobian(wo), 0.0)
    test = ChiSquareTest(domain=domain, sample_func=sample, pdf_func=density, sample_dim=3,
                         sample_count=1_000_000, res=64, ires=16)
    test._dump_tables = lambda: None
    assert test.run(significance_level=0.01, test_count=len(CASES), quiet=True), test.messages


def albedo(bsdf_props, angle, samples=1 << 20):
    """(mean, standard error) of the sample weight at incidence `angle`: the directional albedo."""
    return weight_albedo(bsdf_props, angle, samples, seed=11)


@pytest.mark.parametrize("lobe", ("f_b", "f_Q2", "f_Q4"))
def test_white_furnace_bound(variant, lobe):
    """With F = 1 and G <= 1 the albedo is at most 1 at every angle (4 standard errors + 1e-5), and
    close to 1 at normal incidence for a narrow lobe (G ~ 1 there)."""
    for n in (10.0, 100.0, 1000.0):
        for angle in (0.0, 45.0, 80.0):
            mean, error = albedo(props(lobe, n), angle)
            assert mean <= 1.0 + 4 * error + 1e-5, (lobe, n, angle, mean, error)
        mean, error = albedo(props(lobe, 1000.0), 0.0)
        assert mean > 0.99, (lobe, mean)


@pytest.mark.parametrize("angle", (0.0, 45.0, 70.0))
def test_cos_n_as_ndf_at_large_n_reflects_as_mitsubas_beckmann(variant, angle):
    """At n = 1000 cos^n as an NDF is within 0.08 % of Beckmann's D (the ndf stage), and both use
    Beckmann's Smith G and F = 1: the albedos agree within 0.3 % (plus 4 standard errors)."""
    n = 1000.0
    ours, e1 = albedo(props("f_b", n), angle)
    theirs, e2 = albedo({"type": "roughconductor", "distribution": "beckmann", "alpha": float(ndf.alpha_of_n(n)),
                         "material": "none"}, angle)
    assert abs(ours - theirs) <= 0.003 * theirs + 4 * math.hypot(e1, e2), (ours, theirs)
