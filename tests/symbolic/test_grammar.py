"""Exhaustive symbolic regression: the complexity measure, the enumeration against a brute-force
oracle, the fit against scipy, recovery of known formulas, the paper's front, and `pipeline regress`."""


import pytest

from pipeline.symbolic import search as symbolic


@pytest.mark.parametrize("text, size", [("c", 1), ("c*n", 3), ("c*(c + n)", 5), ("c*n + c + c/n", 10),
                                        ("c*(c + c/(n - c) + n)", 12), ("n/c", 4)])
def test_the_paper_rows_have_their_printed_sizes_under_turingbot_complexity(text, size):
    assert symbolic.complexity(symbolic.parse(text, "n")) == size


def test_parse_errors_name_the_problem():
    with pytest.raises(ValueError, match="unknown symbol 'q'"):
        symbolic.parse("c*q", "n")
    with pytest.raises(ValueError, match="ends early"):
        symbolic.parse("c*(n + c", "n")




@pytest.mark.parametrize("text, linear", [("c*(c + c/(x - c) + x)", (False, True, True, False)),
                                          ("c*x + c + c/x", (True, True, True)), ("c/(x + c)", (True, False)),
                                          ("(c*x + c)/(x + c)", (True, True, False)), ("c*x*x1 + c", (True, True))])
def test_the_constants_that_enter_linearly(text, linear):
    """Jointly affine: none in a denominator, no two multiplied together (c (c + ...): the outer
    one or the inner ones, the larger set)."""
    assert symbolic.linear_constants(symbolic.parse(text, ["x", "x1"])) == linear
