"""The lobes in Mitsuba 3: Mitsuba's own chi-square test of every sampler, a white furnace against
the pipeline's quadrature albedo, and reciprocity (`pipeline.mitsuba.bsdf`)."""

import math

import numpy as np
import pytest

from pipeline.mitsuba import bsdf as mitsuba_bsdf
from pipeline.optics.albedo import albedo_table

from ..helpers import require_fast_variant
from ..oracles import scipy_normal_albedo

import drjit as dr  # noqa: E402
import mitsuba as mi  # noqa: E402
from mitsuba.chi2 import BSDFAdapter, ChiSquareTest  # noqa: E402

A, B = 0.448, 0.099          # the paper's line: f_Q2's k = A n + B
EXPONENTS = (2.0, 10.0, 100.0, 1000.0)
ANGLES = (0.0, 45.0, 80.0)
# (shape, k(n), power m). f_Q3 and f_Q4: the large-n asymptotes of k_Q(n) at Q = 0.65 (the best Q
# of the power-4 run), (1 - Q^(1/m)) (n / (-ln Q) + 1/2).
LOBES = {"f_b": ("power", lambda n: n, 2), "f_2": ("linear_power", lambda n: n / 2.0, 2),
         "f_Q2": ("linear_power", lambda n: A * n + B, 2),
         "f_Q3": ("linear_power", lambda n: 0.3105065 * n + 0.0668804, 3),
         "f_Q4": ("linear_power", lambda n: 0.2370086 * n + 0.0510496, 4)}
PAPER_LOBES = ("f_b", "f_2", "f_Q2")
CASES = ([(lobe, form, n, angle) for lobe in PAPER_LOBES for form in ("phong", "blinn") for n in EXPONENTS
          for angle in ANGLES]
         + [(lobe, form, n, angle) for lobe in ("f_Q3", "f_Q4") for form in ("phong", "blinn")
            for n in (2.0, 100.0, 1000.0) for angle in (0.0, 80.0)])


@pytest.fixture(scope="module")
def variant():
    """The fast variant; the tests need a vectorized one (Mitsuba's chi2 harness works on arrays).
    Where no LLVM >= 15 loads (the Makefile installs Debian's libllvm19 where it can), the pipeline
    falls back to scalar_rgb and these tests are skipped, with this reason in pytest's summary."""
    variant = mitsuba_bsdf.register()
    require_fast_variant(variant, f"Mitsuba's {mitsuba_bsdf.FAST_VARIANT} is not in use (no LLVM >= 15 loaded, or "
                         "PIPELINE_MITSUBA_VARIANT chose another); "
                         f"the fallback {variant} cannot run the vectorized chi2 harness")
    return variant


def plugin_dict(lobe, form, n, name=mitsuba_bsdf.NAME, sampler="lobe"):
    shape, k, power = LOBES[lobe]
    p = k(n)
    return {"type": name, "shape": shape, "form": form, "exponent": n, "k": p, "coef": 1.0 / normal_albedo(lobe, form, n),
            "sampler": sampler, "power": power}


def normal_albedo(lobe, form, n):
    """The lobe's albedo per unit coef at normal incidence, by the pipeline's quadrature."""
    return quadrature_albedo(lobe, form, n, [0.0])[0]


def test_the_default_normalization_is_the_exact_one(variant):
    """Without a coef the plugin takes the exact normalization: the closed forms (n + 2)/(2 pi) for
    cos^n (Phong) and 6k^2/(pi (4k - 1)) for the quadratic lobe with k >= 1 (Phong)."""
    cos_n = mi.load_dict({"type": mitsuba_bsdf.NAME, "shape": "power", "form": "phong", "exponent": 50.0})
    quadratic = mi.load_dict({"type": mitsuba_bsdf.NAME, "shape": "linear_power", "form": "phong", "exponent": 50.0,
                              "k": 22.499})
    k = 22.499
    assert cos_n.coef == pytest.approx(52.0 / (2 * math.pi), rel=1e-9)
    assert quadratic.coef == pytest.approx(6 * k * k / (math.pi * (4 * k - 1)), rel=1e-9)


def quadrature_albedo(lobe, form, n, angles_deg):
    shape, k, power = LOBES[lobe]
    if shape == "power":
        return albedo_table(form, "power", n, n, 1.0, np.radians(angles_deg), 96)[0]
    p = k(n)
    return albedo_table(form, "linear_power", n, p, min(1.0 / p, 2.0), np.radians(angles_deg), 96, power)[0]


def axis_cdf(lobe, n, c):
    """The axis cosine's CDF F (the uniform number the exact sampler would need), written out
    independently of the plugin: cos^n: c^(n+1) on [0, 1]; the family at power m:
    (w^(m+1) - w0^(m+1))/(1 - w0^(m+1)), w = k (c - 1) + 1, w0 = max(1 - 2k, 0)."""
    shape, k, power = LOBES[lobe]
    if shape == "power":
        return dr.power(dr.clip(c, 0.0, 1.0), n + 1.0)
    p = k(n)
    w0 = max(1.0 - 2.0 * p, 0.0) ** (power + 1)
    w = dr.clip(p * (c - 1.0) + 1.0, 0.0, 1.0)
    return (dr.power(w, power + 1.0) - w0) / (1.0 - w0)


def axis_cosine(lobe, n, u):
    shape, k, power = LOBES[lobe]
    if shape == "power":
        return dr.power(u, 1.0 / (n + 1.0))
    p = k(n)
    w0 = max(1.0 - 2.0 * p, 0.0) ** (power + 1)
    return 1.0 + (dr.power(w0 + u * (1.0 - w0), 1.0 / (power + 1.0)) - 1.0) / p


def axis_density(lobe, n, c):
    """dF/dc."""
    shape, k, power = LOBES[lobe]
    if shape == "power":
        return (n + 1.0) * dr.power(dr.maximum(c, 0.0), n)
    p = k(n)
    w0 = max(1.0 - 2.0 * p, 0.0) ** (power + 1)
    w = dr.maximum(p * (c - 1.0) + 1.0, 0.0)
    return (power + 1.0) * p * dr.power(w, float(power)) / (1.0 - w0)


def folded_cdf(lobe, n, c):
    """The Blinn form's half-vector cosine folded onto [0, 1]: h and -h reflect wi to the same wo,
    so the sampler's draws at c and -c land together; F(c) - F(-c) for c >= 0 (= F(c) where the
    lobe stays above the horizon, k >= 1)."""
    return axis_cdf(lobe, n, c) - axis_cdf(lobe, n, -c)


def folded_cosine(lobe, n, u, steps=40):
    """Inverse of `folded_cdf` on [0, 1], by bisection (it is increasing)."""
    lo, hi = dr.zeros(mi.Float, dr.width(u)), dr.ones(mi.Float, dr.width(u))
    for _ in range(steps):
        mid = 0.5 * (lo + hi)
        below = folded_cdf(lobe, n, mid) < u
        lo, hi = dr.select(below, mid, lo), dr.select(below, hi, mid)
    return 0.5 * (lo + hi)


class LobeDomain:
    """Directions parameterized around the lobe: (phi, F(c)) over [-pi, pi] x [0, 1], c the cosine to
    the lobe's axis (Phong: to the mirror direction; Blinn: of the half vector to the normal, with
    F folded onto the upper hemisphere, `folded_cdf`). The
    exact sampler fills it uniformly, so every one of Mitsuba's histogram cells carries samples at
    any n (its default spherical grid puts a narrow lobe in a handful of cells)."""

    def __init__(self, lobe, form, n, wi):
        self.lobe, self.form, self.n, self.wi = lobe, form, n, mi.Vector3f(*wi)
        self.axis = mi.Frame3f(mi.Vector3f(-wi[0], -wi[1], wi[2]) if form == "phong" else mi.Vector3f(0, 0, 1))

    def bounds(self):
        return mi.ScalarBoundingBox2f([-dr.pi, 0.0], [dr.pi, 1.0])

    def aspect(self):
        return 1.0

    def map_forward(self, p):
        c = axis_cosine(self.lobe, self.n, p.y) if self.form == "phong" else folded_cosine(self.lobe, self.n, p.y)
        sin = dr.safe_sqrt(1.0 - c * c)
        s, co = dr.sincos(p.x)
        d = self.axis.to_world(mi.Vector3f(sin * co, sin * s, c))
        return d if self.form == "phong" else 2.0 * dr.dot(self.wi, d) * d - self.wi

    def local(self, wo):
        d = wo if self.form == "phong" else dr.normalize(self.wi + wo)
        return self.axis.to_local(d), d

    def map_backward(self, wo):
        v, _ = self.local(wo)
        c = dr.clip(v.z, -1.0, 1.0)
        return mi.Vector2f(dr.atan2(v.y, v.x), axis_cdf(self.lobe, self.n, c) if self.form == "phong"
                           else folded_cdf(self.lobe, self.n, dr.maximum(c, 0.0)))

    def jacobian(self, wo):
        """Solid angle of wo per unit parameter area: dw/dphi dF = 1 / F'(c), times 4 |wo.h| for
        the Blinn form (dw_o = 4 |wo.h| dw_h)."""
        v, d = self.local(wo)
        if self.form == "phong":
            return 1.0 / axis_density(self.lobe, self.n, v.z)
        folded = axis_density(self.lobe, self.n, v.z) + axis_density(self.lobe, self.n, -v.z)
        return 4.0 * dr.abs(dr.dot(wo, d)) / folded


def chi2(lobe, form, n, angle, name=mitsuba_bsdf.NAME):
    theta = math.radians(angle)
    wi = [math.sin(theta), 0.0, math.cos(theta)]
    domain = LobeDomain(lobe, form, n, wi)
    sample, pdf = BSDFAdapter(name, plugin_dict(lobe, form, n, name), wi=wi)
    # Where the horizon cuts the lobe the density jumps inside cells: integrate them finely.
    def density(wo):     # per unit parameter area; 0 where the plugin's pdf is (below the surface)
        p = pdf(wo)
        return dr.select(p > 0.0, p * domain.jacobian(wo), 0.0)

    test = ChiSquareTest(domain=domain, sample_func=sample, pdf_func=density,
                         sample_dim=3, sample_count=1_000_000, res=64, ires=16)
    test._dump_tables = lambda: None    # it would write chi2_data.py into the working folder
    return test.run(significance_level=0.01, test_count=len(CASES), quiet=True), test


@pytest.mark.parametrize("lobe, form, n, angle", CASES)
def test_every_sampler_passes_mitsubas_chi2_test(variant, lobe, form, n, angle):
    passed, test = chi2(lobe, form, n, angle)
    assert passed, test.messages


@pytest.fixture(scope="module")
def wrong_plugins(variant):
    """Two deliberately wrong versions of the plugin: the quadratic sampler with a square root
    where the cube root belongs (for cos^n, the sampler of cos^(n/2), the Phong/Blinn exponent
    mix-up), and the right sampler with a pdf 10 % too large."""
    base = mitsuba_bsdf.plugin_class()

    class WrongRoot(base):
        def axis_cosine(self, xi):
            if self.shape == "power":
                return dr.power(xi, 1.0 / (self.n / 2.0 + 1.0))
            # The root of degree m where m + 1 belongs (the square root at m = 2).
            return 1.0 + (dr.power(self.w0_power + xi * (1.0 - self.w0_power), 1.0 / self.power) - 1.0) / self.k

    class PdfTooLarge(base):
        def pdf(self, ctx, si, wo, active=True):
            return 1.1 * base.pdf(self, ctx, si, wo, active)

    mi.register_bsdf("cosquad_wrong_root", lambda props: WrongRoot(props))
    mi.register_bsdf("cosquad_wrong_pdf", lambda props: PdfTooLarge(props))
    return ("cosquad_wrong_root", "cosquad_wrong_pdf")


@pytest.mark.parametrize("lobe, form, n", [(lobe, form, n) for lobe in PAPER_LOBES for form in ("phong", "blinn")
                                           for n in (10.0, 100.0)] + [("f_Q4", "phong", 100.0)])
def test_wrong_samplers_fail_the_same_test(wrong_plugins, lobe, form, n):
    for name in wrong_plugins:
        passed, test = chi2(lobe, form, n, 45.0, name)
        assert not passed, (name, test.messages)


def weight_albedo(bsdf_props, angle, samples=1 << 20, seed=7):
    """(mean, standard error) of the sample weight of the BSDF `bsdf_props` at incidence `angle`:
    the directional albedo Mitsuba integrates."""
    plugin = mi.load_dict(bsdf_props)
    theta = math.radians(angle)
    si = dr.zeros(mi.SurfaceInteraction3f, samples)
    si.wi = mi.Vector3f(math.sin(theta), 0.0, math.cos(theta))
    sampler = mi.load_dict({"type": "independent"})
    sampler.seed(seed, samples)
    _, weight = plugin.sample(mi.BSDFContext(), si, sampler.next_1d(), sampler.next_2d())
    w = np.asarray(weight.x, dtype=np.float64)
    return w.mean(), w.std() / math.sqrt(samples)


def mitsuba_albedo(lobe, form, n, angle, samples=1 << 20, sampler="lobe"):
    """`weight_albedo` of one of the test's lobes."""
    return weight_albedo(plugin_dict(lobe, form, n, sampler=sampler), angle, samples)


@pytest.mark.parametrize("lobe, form", [(lobe, form) for lobe in LOBES for form in ("phong", "blinn")])
def test_white_furnace(variant, lobe, form):
    """With each lobe's exact normalization, the albedo Mitsuba integrates by the lobe's sampler
    matches the pipeline's quadrature within 4 standard errors (plus 1e-5: float32 sums) at every
    tested n and angle, and is <= 1 within the same margin."""
    for n in EXPONENTS:
        reference = quadrature_albedo(lobe, form, n, ANGLES) / normal_albedo(lobe, form, n)
        for angle, expected in zip(ANGLES, reference):
            mean, error = mitsuba_albedo(lobe, form, n, angle)
            assert abs(mean - expected) <= 4 * error + 1e-5, (n, angle, mean, expected, error)
            assert mean <= 1.0 + 4 * error + 1e-5
        assert np.all(reference <= 1.0 + 1e-9)


@pytest.mark.parametrize("lobe, form", [(lobe, form) for lobe in LOBES for form in ("phong", "blinn")])
def test_the_quadrature_normal_albedo_against_scipy(lobe, form):
    """The white furnace normalizes each lobe by the pipeline's quadrature albedo at normal incidence
    (`normal_albedo`): that value against scipy's adaptive quadrature of the lobe written out here
    (`oracles.scipy_normal_albedo`). Tolerance 1e-8 relative: the pipeline's Gauss-Legendre rule on
    log(1 + n u) converges far below it (the Monte Carlo comparison above is at ~1e-3)."""
    shape, k, power = LOBES[lobe]
    for n in EXPONENTS:
        p = k(n)
        written = ((lambda t: t ** n) if shape == "power"
                   else (lambda t: np.maximum(p * (t - 1.0) + 1.0, 0.0) ** power))
        expected = scipy_normal_albedo(written, form, n)
        assert normal_albedo(lobe, form, n) == pytest.approx(expected, rel=1e-8), (n, expected)


def test_cosine_weighted_sampling_estimates_the_same_albedo_with_more_variance(variant):
    """The lobe's sampler against cosine-weighted sampling (f_Q2, Phong form, n = 100, 45 deg):
    same mean, and the lobe's sampler has the smaller variance."""
    lobe_mean, lobe_error = mitsuba_albedo("f_Q2", "phong", 100.0, 45.0)
    cosine_mean, cosine_error = mitsuba_albedo("f_Q2", "phong", 100.0, 45.0, sampler="cosine")
    assert abs(cosine_mean - lobe_mean) <= 4 * math.hypot(cosine_error, lobe_error)
    assert lobe_error * 10 < cosine_error


@pytest.mark.parametrize("lobe, form", [(lobe, form) for lobe in LOBES for form in ("phong", "blinn")])
def test_eval_is_reciprocal(variant, lobe, form):
    """f(wi, wo) = eval / cos(theta_o) is symmetric in wi and wo (float32: 1e-5 relative)."""
    rng = np.random.default_rng(3)
    count = 4096
    a, b = (mi.warp.square_to_uniform_hemisphere(mi.Point2f(*rng.random((2, count)))) for _ in range(2))
    for n in EXPONENTS:
        bsdf = mi.load_dict(plugin_dict(lobe, form, n))
        values = []
        for wi, wo in ((a, b), (b, a)):
            si = dr.zeros(mi.SurfaceInteraction3f, count)
            si.wi = wi
            values.append(np.asarray(bsdf.eval(mi.BSDFContext(), si, wo).x) / np.asarray(wo.z))
        np.testing.assert_allclose(values[0], values[1], rtol=1e-5, atol=1e-30)
        assert np.max(values[0]) > 0


