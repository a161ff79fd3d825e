"""The bracketed root find (`pipeline.optics.roots`) against closed-form roots, and its compiled
program reused by eager calls with other numbers."""

import math

import pytest

from pipeline.optics.numerics import CompileCounter
from pipeline.optics.roots import SolverSettings, bracketed_root

SETTINGS = SolverSettings(1e-12, 1e-12, 256)


def cube_minus(y, a):
    return y ** 3 - a


@pytest.mark.parametrize("a", [0.5, 2.0, 7.0])
def test_the_root_is_the_closed_form_to_the_bracket_s_width(a):
    root, has_root, ok = bracketed_root(cube_minus, 0.0, 2.0, a, SETTINGS)
    # Bisection stops at a bracket narrower than atol + rtol |y|: 1e-12 absolute and relative.
    assert bool(has_root) and bool(ok)
    assert float(root) == pytest.approx(a ** (1 / 3), abs=3e-12)


def test_no_sign_change_is_no_root_and_no_failure():
    root, has_root, ok = bracketed_root(cube_minus, 0.0, 2.0, 9.0, SETTINGS)     # 9 > 2^3
    # The root of y - lower, to the bracket's width (the docstring's "root is lower").
    assert not bool(has_root) and bool(ok) and float(root) == pytest.approx(0.0, abs=1e-12)


def test_an_eager_call_with_other_numbers_compiles_nothing_new():
    # Python numbers among the args and the bracket are made arrays: optimistix would compile its
    # root find again for each value it sees as static.
    bracketed_root(cube_minus, 0.0, 2.0, 3.0, SETTINGS)
    counter = CompileCounter()
    root, _, _ = bracketed_root(cube_minus, 0.5, 3.0, 11.0, SETTINGS)
    assert counter.count == 0
    assert float(root) == pytest.approx(math.cbrt(11.0), abs=3e-12)
