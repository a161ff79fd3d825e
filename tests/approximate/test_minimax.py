"""Remez's exchange and the whole-interval measure of `pipeline derive`, against closed forms."""

import math

import numpy as np
import pytest

from pipeline.approximate.measures import measure
from pipeline.approximate.search import minimax


def _powers(degree):
    return [lambda s, k=k: np.asarray(s, dtype=np.float64) ** k for k in range(degree + 1)]


def _one(s):
    return np.ones_like(np.asarray(s, dtype=np.float64))


def _equioscillates(fit, basis_count, f, approx, lo, hi):
    """The m + 1 reference points alternate in sign at one level (1e-6 relative), and that level is
    the largest error over the interval (measured independently, by `measure.largest`)."""
    assert fit["converged"] and not fit["exact"]
    assert len(fit["reference"]) == basis_count + 1
    assert np.all(fit["signs"][1:] == -fit["signs"][:-1])
    e = lambda s: approx(s) - f(s)
    levels = np.abs(e(np.asarray(fit["reference"])))
    assert np.ptp(levels) <= 1e-6 * levels.max()
    whole, _ = measure.largest(e, lo, hi)
    assert whole == pytest.approx(levels.max(), rel=1e-6)


@pytest.mark.parametrize("degree", range(1, 8))
def test_the_exchange_equioscillates_for_every_degree(degree):
    """exp on [-1, 2] by polynomials of degree 1 to 7: d + 2 alternating extrema at one level, the
    largest error over the interval (Chebyshev's theorem: the minimax polynomial)."""
    fit = minimax.remez(_powers(degree), np.exp, _one, -1.0, 2.0)
    _equioscillates(fit, degree + 1, np.exp, lambda s: np.polyval(fit["coefficients"][::-1], s), -1.0, 2.0)


def test_the_exchange_finds_the_closed_forms():
    """Two minimax errors known in closed form: the best line for exp on [0, 1], (2 - e + (e - 1)
    ln(e - 1)) / 2 (chord slope, tangent at ln(e - 1)); x^5 by degree 4 on [-1, 1], 2^-4 (the
    monic Chebyshev polynomial)."""
    line = minimax.remez(_powers(1), np.exp, _one, 0.0, 1.0)
    e = math.e
    assert line["error"] == pytest.approx((2 - e + (e - 1) * math.log(e - 1)) / 2, rel=1e-10)
    assert line["coefficients"][1] == pytest.approx(e - 1, rel=1e-10)
    quartic = minimax.remez(_powers(4), lambda s: np.asarray(s) ** 5, _one, -1.0, 1.0)
    assert quartic["error"] == pytest.approx(2.0 ** -4, rel=1e-10)


def test_the_exchange_on_a_weighted_basis_with_a_singular_end():
    """acos on [0, 1] by p(x) sqrt(1 - x), degree 2: equioscillates, although every basis function
    vanishes at 1 (no reference point there); beats Eberly's degree-2 fit, which minimizes the error
    of acos / sqrt(1 - x) instead of acos's."""
    basis = [lambda s, k=k: np.asarray(s) ** k * np.sqrt(1 - np.asarray(s)) for k in range(3)]
    fit = minimax.remez(basis, np.arccos, _one, 0.0, 1.0)
    approx = lambda s: np.polyval(fit["coefficients"][::-1], s) * np.sqrt(1 - s)
    _equioscillates(fit, 3, np.arccos, approx, 0.0, 1.0)
    eberly = lambda s: (1.5707963267948966 + (-0.20347053865798365 + 0.046887774236182234 * s) * s) * np.sqrt(1 - s)
    assert fit["error"] < measure.largest(lambda s: eberly(s) - np.arccos(s), 0.0, 1.0)[0]


def test_an_exact_basis_stops_without_equioscillation():
    """(1 - x)^5 by degree 5 is exact: the exchange says so instead of failing."""
    fit = minimax.remez(_powers(5), lambda s: (1 - np.asarray(s)) ** 5, _one, 0.0, 1.0)
    assert fit["exact"] and fit["error"] < 1e-13


@pytest.mark.parametrize("name, approx, f, lo, hi", [
    ("Karis", lambda s: np.exp2((-5.55473 * s - 6.98316) * s), lambda s: (1 - s) ** 5, 0.0, 1.0),
    ("Lagarde", lambda s: (-0.156583 * s + np.pi / 2) * np.sqrt(1 - s), np.arccos, 0.0, 1.0),
    ("narrow peak", lambda s: np.exp(-((s - 0.3141) / 1e-3) ** 2), lambda s: 0 * s, 0.0, 1.0),
])
def test_the_measure_finds_the_true_maximum(name, approx, f, lo, hi):
    """The grid and refinement against a 20x denser grid (100,000 cells) refined by the same
    bisection: not below it, and within 1e-9 relative (a narrow peak between grid cells included)."""
    e = lambda s: approx(s) - f(s)
    found, where = measure.largest(e, lo, hi)
    dense = np.linspace(lo, hi, 100_001)
    assert found >= np.max(np.abs(e(dense))) * (1 - 1e-12)
    assert found == pytest.approx(np.max(np.abs(e(dense))), rel=1e-6)
    assert lo <= where <= hi


def test_the_measure_of_a_form_that_is_not_finite_is_inf():
    with np.errstate(invalid="ignore"):
        value, where = measure.largest(lambda s: np.sqrt(0.5 - s), 0.0, 1.0)
    assert value == math.inf and where > 0.5


def test_a_constant_beside_the_sqrt_basis_is_still_a_haar_system():
    """asin on [0, 1] by c + p(x) sqrt(1 - x), degree 2 (1 and odd powers of s = sqrt(1 - x)):
    equioscillates at 5 points, and beats p(x) sqrt(1 - x) of the same degree on acos."""
    basis = [lambda s: np.ones_like(np.asarray(s, dtype=np.float64))]
    basis += [lambda s, k=k: np.asarray(s) ** k * np.sqrt(1 - np.asarray(s)) for k in range(3)]
    fit = minimax.remez(basis, np.arcsin, _one, 0.0, 1.0)
    a = fit["coefficients"]
    approx = lambda s: a[0] + np.polyval(a[1:][::-1], s) * np.sqrt(1 - s)      # noqa: E731
    _equioscillates(fit, 4, np.arcsin, approx, 0.0, 1.0)
    plain = minimax.remez(basis[1:], np.arccos, _one, 0.0, 1.0)
    assert fit["error"] < plain["error"]
