"""Exhaustive symbolic regression: the complexity measure, the enumeration against a brute-force
oracle, the fit against scipy, recovery of known formulas, the paper's front, and `pipeline regress`."""

import csv
import subprocess
import sys
from functools import lru_cache

import numpy as np
import pytest
import sympy as sp
from scipy.optimize import least_squares

from pipeline.symbolic import search as symbolic
from pipeline.symbolic.regress import RegressError, parse_operations, read_columns, regress
from pipeline.stages.symbolic_regression import exact_constants, partial_fractions

from .conftest import cli_env

X50 = np.concatenate([np.arange(2.0, 32.0), np.round(np.linspace(74.0, 1000.0, 20))])


def coef_sample():
    k = 0.448 * X50 + 0.099
    return np.round(6 * k**2 / (np.pi * (4 * k - 1)), 3)


@pytest.mark.parametrize("text, size", [("c", 1), ("c*n", 3), ("c*(c + n)", 5), ("c*n + c + c/n", 10),
                                        ("c*(c + c/(n - c) + n)", 12), ("n/c", 4)])
def test_the_paper_rows_have_their_printed_sizes_under_turingbot_complexity(text, size):
    assert symbolic.complexity(symbolic.parse(text, "n")) == size


def test_parse_errors_name_the_problem():
    with pytest.raises(ValueError, match="unknown symbol 'q'"):
        symbolic.parse("c*q", "n")
    with pytest.raises(ValueError, match="ends early"):
        symbolic.parse("c*(n + c", "n")


@lru_cache(maxsize=None)
def every_tree(size):
    """Every expression tree of the grammar at this complexity, with no rule at all: the oracle."""
    if size == 1:
        return [symbolic.X, symbolic.C]
    out = []
    for op, w in symbolic.COST.items():
        for left in range(1, size - w):
            out += [(op, a, b) for a in every_tree(left) for b in every_tree(size - w - left)]
    return out


def test_no_expression_of_the_unreduced_grammar_beats_the_front():
    """The reduction rules lose nothing: the same search run on every tree up to complexity 7
    (2,434 trees, none dropped, with twice the starts and three times the steps) finds nothing
    better at or below any complexity than the search over the reduced forms. Tolerance: 1e-6
    relative, the fits' convergence tolerance with a wide margin."""
    y = (2 * X50 + 1) / (X50 + 3) + 0.01 * np.sin(X50)     # rational, with structure at every size
    found = symbolic.search(X50, y, 7)
    trees = [t for k in range(1, 8) for t in every_tree(k)]
    assert len(trees) == 2434 and len(found["forms"]) < len(trees) / 10
    oracle = symbolic.search(X50, y, 7, starts=4, iterations=30, forms=trees)
    for k in range(1, 8):
        best_search = found["rms"][found["complexity"] <= k].min()
        best_oracle = oracle["rms"][oracle["complexity"] <= k].min()
        assert best_oracle >= best_search * (1 - 1e-6) - 1e-12, (k, best_oracle, best_search)


def test_the_fit_agrees_with_scipy():
    """optimistix's Levenberg-Marquardt (via fit_forms) against scipy's MINPACK on the paper's forms."""
    y = coef_sample()
    for text in ("c*(c + n)", "c*n + c + c/n", "c*(c + c/(n - c) + n)"):
        e = symbolic.parse(text, "n")
        c, rms, converged = symbolic.fit_forms([e], X50, y)[0]
        ref = least_squares(lambda p: symbolic.evaluate_numpy(e, p, X50) - y, c * 1.01, method="lm",
                            xtol=1e-15, ftol=1e-15)
        assert converged
        # the RMS and the fitted values are well determined; the pole of the size-12 form is not
        # (moving it by 6e-6 relative changes the RMS by < 1e-9 relative), hence 1e-4 on constants
        assert rms == pytest.approx(np.sqrt(np.mean(ref.fun**2)), rel=1e-9)
        np.testing.assert_allclose(symbolic.evaluate_numpy(e, c, X50), ref.fun + y, rtol=0, atol=1e-8)
        np.testing.assert_allclose(c, ref.x, rtol=1e-4)


def test_a_known_formula_comes_back_exactly():
    """y = 3.5 - 6/(n + 2) (complexity 8): the front reaches it, with its constants, and stops."""
    y = 3.5 - 6.0 / (X50 + 2.0)
    found = symbolic.search(X50, y, 10)
    last = found["front"][-1]
    assert found["complexity"][last] == 8 and found["rms"][last] < 1e-12
    n = sp.Symbol("n")
    expression = symbolic.to_sympy(found["forms"][last], found["constants"][last][:found["constant_count"][last]], n)
    target = 3.5 - 6 / (n + 2)
    for v in (2.0, 10.0, 500.0):
        assert float(expression.subs(n, v)) == pytest.approx(float(target.subs(n, v)), rel=1e-10)


def test_partial_fractions_of_the_exact_coef():
    a, b = 0.448, 0.099
    n = sp.Symbol("n", positive=True)
    k = a * n + b
    found = partial_fractions(6 * k**2 / (sp.pi.evalf() * (4 * k - 1)))
    for name, value in exact_constants(a, b).items():
        assert found[name] == pytest.approx(value, rel=1e-12)
    assert partial_fractions(0.2 * n + 1) is None


def test_the_paper_front(paper_run):
    """Four of the paper's five rows are the exhaustive front's members at their sizes; at size 10
    the search finds a better expression than TuringBot's; the size-12 member is the exact form."""
    sr = paper_run["symbolic_regression"]
    assert [r["on_front"] for r in sr["paper_rows"]] == [True, True, True, False, True]
    assert sr["front_complexities"][:3] == [1, 3, 5] and 12 in sr["front_complexities"]
    ten = next(m for m in sr["front"] if m["complexity"] == 10)
    assert ten["rms"] < sr["size10_rms"]
    # within the rounding step of the exact coef from size 10 on, and not below
    assert sr["sr_exact_complexity"] == 10
    assert all(not m["equivalent_to_exact"] for m in sr["front"] if m["complexity"] < 10)
    # the size-12 member's well-determined constants against the exact ones (residue and pole show
    # only at the few smallest n, where rounding y moves them: test_the_exact_form_is_found_for_another_line)
    assert sr["size12_scale"] == pytest.approx(sr["exact_scale"], abs=1e-6)
    assert sr["size12_offset"] == pytest.approx(sr["exact_offset"], abs=1e-3)
    # RMS of the exact-form member: at the floor of rounding y to 3 decimals
    assert sr["size12_rms"] == pytest.approx(0.001 / np.sqrt(12), rel=0.05)
    # Another seed of the random starts finds the same front (10 seeds do, measured).
    other = symbolic.search(X50, coef_sample(), 12, seed=1)
    np.testing.assert_allclose(other["rms"][other["front"]], [m["rms"] for m in sr["front"]], rtol=1e-8)


@pytest.mark.parametrize("a, b", [(0.40, 0.15)])
def test_the_exact_form_is_found_for_another_line(a, b):
    """On unrounded y = exact coef for the line k = a n + b, the front's size-12 member is the exact
    form, with its constants to 1e-6: pole (1 - 4b)/(4a), residue 1/(16 a^2)."""
    k = a * X50 + b
    y = 6 * k**2 / (np.pi * (4 * k - 1))
    found = symbolic.search(X50, y, 12)
    twelve = next(i for i in found["front"] if found["complexity"][i] == 12)
    assert found["rms"][twelve] < 1e-9
    n = sp.Symbol("n", positive=True)
    member = symbolic.to_sympy(found["forms"][twelve], found["constants"][twelve][:found["constant_count"][twelve]], n)
    constants = partial_fractions(member)
    for name, value in exact_constants(a, b).items():
        assert constants[name] == pytest.approx(value, rel=1e-6), name


def test_regress_reads_and_rejects_csv_files(tmp_path):
    good = tmp_path / "good.csv"
    good.write_text("n,val\n1,2\n2,3.5\n")
    x, y = read_columns(good, "n", "val")
    np.testing.assert_array_equal(x, [1, 2])
    cases = {
        "missing.csv": (None, "no such file"),
        "nocol.csv": ("a,b\n1,2\n", "no column 'n'"),
        "text.csv": ("n,val\n1,2\n2,abc\n", "line 3, column 'val': 'abc' is not a number"),
        "nan.csv": ("n,val\n1,nan\n", "not a finite number"),
        "empty.csv": ("", "the file is empty"),
    }
    for name, (text, message) in cases.items():
        if text is not None:
            (tmp_path / name).write_text(text)
        with pytest.raises(RegressError, match=message):
            read_columns(tmp_path / name, "n", "val")
    assert parse_operations("+, -, *, /") == "+-*/" and parse_operations("*/") == "*/"
    with pytest.raises(RegressError, match="--ops"):
        parse_operations("+,^")


def test_regress_writes_the_front(tmp_path):
    """2t/(t + 4) is of complexity 8: found exactly, written as a front file and a figure."""
    data = tmp_path / "data.csv"
    t = np.arange(1.0, 51.0)
    data.write_text("t,v\n" + "".join(f"{a},{float(b)!r}\n" for a, b in zip(t, 2.0 * t / (t + 4.0))))
    out = tmp_path / "front"
    front = regress(data, "t", "v", out, max_complexity=8, log=lambda s: None)
    assert front[-1]["complexity"] == 8 and front[-1]["rms"] < 1e-12
    with open(out / "front.csv") as f:
        rows = list(csv.DictReader(f))
    assert [int(r["complexity"]) for r in rows] == [m["complexity"] for m in front]
    assert "t" in rows[-1]["canonical"] and float(rows[-1]["rms"]) < 1e-12
    assert (out / "front.png").stat().st_size > 10_000


def test_regress_command_rejects_too_few_points(tmp_path):
    """Fewer points than the constants of the search: exit 2, a message, nothing written."""
    few = tmp_path / "few.csv"
    few.write_text("t,v\n1,2\n2,3\n3,5\n")
    out = tmp_path / "bad"
    run = subprocess.run([sys.executable, "-m", "pipeline", "regress", str(few), "--x", "t", "--y", "v",
                          "--out", str(out)], capture_output=True, text=True, env=cli_env(tmp_path))
    assert run.returncode == 2 and "3 data points" in run.stderr and not out.exists()
    run = subprocess.run([sys.executable, "-m", "pipeline", "regress", str(few), "--x", "t", "--y", "w"],
                         capture_output=True, text=True, env=cli_env(tmp_path))
    assert run.returncode == 2 and "no column 'w' (--y)" in run.stderr
