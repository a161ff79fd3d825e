import jax.numpy as jnp
import numpy as np
import pytest

from pipeline.optics.lobes import f_2, f_b, f_Q, f_Q2, gran, k_2, k_Q, linear_power

X = jnp.linspace(0.0, jnp.pi / 2, 2001)


@pytest.mark.parametrize("n", [2.0, 7.0, 20.0, 150.0, 1000.0])
def test_lobes_are_non_negative_and_one_at_the_peak(n):
    for f in (f_b(X, n), f_2(X, n), f_Q(X, n, 0.64), f_Q(X, n, 0.1), f_Q2(X, n, 0.448, 0.099)):
        assert float(jnp.min(f)) >= 0.0
    for f in (f_2(0.0, n), f_Q(0.0, n, 0.64)):
        assert float(f) == 1.0


@pytest.mark.parametrize("Q", [0.1, 0.5, 0.64, 0.9])
@pytest.mark.parametrize("n", [3.0, 20.0, 1000.0])
def test_f_Q_equals_cos_n_at_level_Q(n, Q):
    x_Q = np.arccos(Q ** (1.0 / n))          # where cos^n x = Q
    assert float(f_Q(x_Q, n, Q)) == pytest.approx(Q, rel=1e-12)
    assert float(f_b(x_Q, n)) == pytest.approx(Q, rel=1e-12)


@pytest.mark.parametrize("n", [3.0, 20.0, 500.0])
def test_f_Q_tends_to_f_2_as_Q_tends_to_1(n):
    gaps = [float(jnp.max(jnp.abs(f_Q(X, n, Q) - f_2(X, n)))) for Q in (0.9, 0.99, 0.999, 0.9999)]
    assert all(b < a for a, b in zip(gaps, gaps[1:]))
    assert gaps[-1] < 1e-4
    assert float(k_Q(n, 1.0 - 1e-9)) == pytest.approx(float(k_2(n)), rel=1e-6)


def test_f_2_matches_the_curvature_of_cos_n_at_zero():
    n, x = 40.0, 1e-3
    # Both are 1 - n x^2 / 2 + O(x^4).
    assert float(f_2(x, n)) == pytest.approx(float(f_b(x, n)), abs=1e-9)


def test_clamping_past_the_zero_crossing():
    k = 10.0
    x0 = float(gran(k))
    assert np.cos(x0) == pytest.approx(1 - 1 / k)
    assert float(linear_power(x0 + 1e-6, k)) == 0.0
    assert float(linear_power(x0 - 1e-3, k)) > 0.0
    # With k < 1 the zero crossing lies past the horizon; with k <= 1/2 there is none (the lobe,
    # (1 - 2 k)^m at the antipode, is positive everywhere) and the integral runs over the whole sphere.
    assert float(gran(0.995)) > np.pi / 2
    assert float(gran(0.5)) == pytest.approx(np.pi) and float(gran(0.3)) == pytest.approx(np.pi)
    assert float(linear_power(np.pi, 0.3)) == pytest.approx((1 - 2 * 0.3) ** 2)


def test_f_Q2_is_the_papers_formula():
    n, x = 20.0, 0.1
    expected = ((0.448 * n + 0.099) * (np.cos(x) - 1) + 1) ** 2
    assert float(f_Q2(x, n, 0.448, 0.099)) == pytest.approx(expected, rel=1e-14)
