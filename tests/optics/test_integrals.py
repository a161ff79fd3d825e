"""Beyond the paper: exact normalization, directional albedo, other cheap lobes.

Each number is compared with an independent computation: scipy quadrature over the sphere, mpmath
at high precision, a closed form, or a dense numpy grid.
"""

import jax.numpy as jnp
import mpmath
import numpy as np
import pytest
import sympy as sp
from scipy import integrate

from pipeline.optics import integrals as exact

from ..oracles import scipy_albedo

# ---- exact normalization ----------------------------------------------------------------------

@pytest.mark.parametrize("k", [0.5, 0.995, 1.0, 3.7, 448.1])
def test_exact_integral_matches_scipy(k):
    Int = float(exact.phong_integral().subs(exact.k, k))
    c0 = max(1.0 - 1.0 / k, 0.0)
    expected = integrate.quad(lambda c: (k * (c - 1) + 1) ** 2 * c, c0, 1.0, epsabs=1e-14, epsrel=1e-14)[0]
    assert Int == pytest.approx(expected, rel=1e-12)
    # The paper's integral up to gran runs below the horizon for k < 1 only.
    gran = float(exact.phong_integral_gran().subs(exact.k, k))
    below = integrate.quad(lambda c: (k * (c - 1) + 1) ** 2 * c, 1.0 - 1.0 / k, 1.0, epsabs=1e-14)[0]
    assert gran == pytest.approx(below, rel=1e-12)
    assert (gran < Int) == (k < 1.0)


@pytest.mark.parametrize("k", [2.0, 2 + np.sqrt(2) + 0.01, 50.0])
def test_exact_blinn_coef_normalizes_the_blinn_form_at_normal_incidence(k):
    coef = float(exact.coef_of_k(exact.blinn_integral()).subs(exact.k, k))
    assert scipy_albedo("blinn", k, 0.0, coef) == pytest.approx(1.0, abs=1e-9)


def test_large_k_expansion_matches_mpmath():
    """The pipeline's exact coef (its sympy integral) at k = 10^6 with 50 digits: coef(k) - (3k/(2 pi)
    + 3/(8 pi)) = 3 / (32 pi k) + O(1/k^2), so k times it is 3/(32 pi) to 1e-6 relative (the next
    term, 3/(128 pi k^2), relative to it: 1/(4k) = 2.5e-7), and the pipeline's expansion has these terms."""
    mpmath.mp.dps = 50
    k = mpmath.mpf(10) ** 6
    coef = mpmath.mpf(str(sp.N(exact.coef_of_k(exact.phong_integral()).subs(exact.k, sp.Integer(10) ** 6), 50)))
    assert coef == pytest.approx(6 * k**2 / (mpmath.pi * (4 * k - 1)), rel=1e-45)      # 50 digits, both
    remainder = (coef - 3 * k / (2 * mpmath.pi) - 3 / (8 * mpmath.pi)) * k
    assert float(remainder) == pytest.approx(3 / (32 * np.pi), rel=1e-6)
    expansion = exact.large_k_expansion("phong")
    assert sp.simplify(expansion - (3 * exact.k / (2 * sp.pi) + 3 / (8 * sp.pi) + 3 / (32 * sp.pi * exact.k))) == 0
    blinn = exact.large_k_expansion("blinn")
    assert sp.simplify(blinn.coeff(exact.k, 1) - 3 / (8 * sp.pi)) == 0          # a quarter of the Phong slope
    constant = blinn - blinn.coeff(exact.k, 1) * exact.k - blinn.coeff(exact.k, -1) / exact.k
    assert sp.simplify(constant - 15 / (32 * sp.pi)) == 0                          # (3/(8 pi)) (k + 5/4)


def test_exact_coef_jax_code_matches_sympy():
    fn, source = exact.exact_coef_code("phong")
    assert "select" in source
    n = jnp.array([2.0, 3.0, 100.0])
    expr = exact.coef_of_n(exact.phong_integral())
    for v, got in zip(np.asarray(n), np.asarray(fn(n, 0.448, 0.099))):
        want = float(expr.subs({exact.n: v, exact.slope: 0.448, exact.intercept: 0.099}))
        assert got == pytest.approx(want, rel=1e-14)


