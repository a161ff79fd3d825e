"""Exhaustive symbolic regression: the complexity measure, the enumeration against a brute-force
oracle, the fit against scipy, recovery of known formulas, the paper's front, and `pipeline regress`."""

from functools import lru_cache

import numpy as np
import pytest
import sympy as sp
from scipy.optimize import minimize_scalar

from pipeline.symbolic import search as symbolic


X50 = np.concatenate([np.arange(2.0, 32.0), np.round(np.linspace(74.0, 1000.0, 20))])


def coef_sample():
    k = 0.448 * X50 + 0.099
    return np.round(6 * k**2 / (np.pi * (4 * k - 1)), 3)


@lru_cache(maxsize=None)
def every_tree(size):
    """Every expression tree of the grammar at this complexity, with no rule at all: the oracle."""
    if size == 1:
        return [symbolic.X, symbolic.C]
    out = []
    for op in "+-*/":
        w = symbolic.COST[op]
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


def test_no_form_s_best_constants_beat_the_front():
    """Complete in constants: every form the search enumerates up to complexity 9 refitted from 24
    random starts of its own (another seed, twice as wide, 40 steps, none of the search's starts)
    finds nothing better at or below any complexity than the search's front. Tolerance: 1e-9
    relative on the RMS, twice what the front's stopping rule allows: its refits stop after 20
    steps that each lower the sum of squares S by less than 1e-9 S, so near an optimum S - S* <=
    1e-9 S (a Gauss-Newton step would lower S by S - S*), 5e-10 on the RMS, while the oracle's 40
    steps may reach S* itself."""
    t = np.linspace(0.5, 6.0, 40)
    y = (3 * t * t + 1) / (t * t + 2 * t + 5) + 0.002 * np.cos(3 * t)
    found = symbolic.search(t, y, 9)
    forms = found["forms"]
    K, width = 24, found["width"]
    program, linear = symbolic.programs(forms, symbolic.MIN_STEPS), symbolic.linear_masks(forms, width)
    starts = np.random.default_rng(12345).uniform(-4.0, 4.0, (K, width))
    rows = np.repeat(np.arange(len(forms)), K)
    _, s, _ = symbolic._fit(program[rows], linear[rows], starts[np.tile(np.arange(K), len(forms))],
                            np.broadcast_to(t, (rows.size, 1, t.size)), np.broadcast_to(y, (rows.size, t.size)),
                            symbolic.POLISH_ROWS, 40, 0)
    best = np.full(len(forms), np.inf)
    np.minimum.at(best, rows, np.where(np.isfinite(s), s, np.inf))
    oracle_rms = np.sqrt(best / t.size)
    for k in range(1, 10):
        at_or_below = found["complexity"] <= k
        assert oracle_rms[at_or_below].min() >= found["rms"][at_or_below].min() * (1 - 1e-9), k


def test_the_front_does_not_depend_on_the_maximum_complexity():
    """Every form's starts are its own (not drawn from one stream over all forms): the front up to
    complexity 9 is the same whether the search stops at 9 or goes on to 10."""
    t = np.linspace(0.5, 6.0, 40)
    y = (3 * t * t + 1) / (t * t + 2 * t + 5) + 0.002 * np.cos(3 * t)
    nine, ten = symbolic.search(t, y, 9), symbolic.search(t, y, 10)
    below = [i for i in ten["front"] if ten["complexity"][i] <= 9]
    assert [nine["forms"][i] for i in nine["front"]] == [ten["forms"][i] for i in below]
    # The same forms fitted by the same program from the same starts in one process: equal to the
    # last bits on any machine (the two searches differ only in what else they fit).
    np.testing.assert_allclose(nine["rms"][nine["front"]], ten["rms"][below], rtol=1e-12)


def test_a_degenerate_optimum_is_kept():
    """Two poles fitted to one: at the optimum one residue is 0 and its pole is free (a singular
    Jacobian). Convergence is judged by the objective, so the exact fit counts as converged."""
    t = np.linspace(0.5, 6.0, 40)
    c, rms, converged = symbolic.fit_forms([symbolic.parse("c/(x + c) + c/(x + c)")], t, 2 / (t + 3))[0]
    assert converged and rms < 1e-12


# The paper's forms as a linear model in a basis of functions of n (given the size-12 form's pole p),
# and the map from the basis coefficients a back to the form's constants, in the parse's order.
PAPER_FORMS = {
    "c*(c + n)": (lambda n, p: [n, np.ones_like(n)], lambda a, p: [a[0], a[1] / a[0]]),
    "c*n + c + c/n": (lambda n, p: [n, np.ones_like(n), 1 / n], lambda a, p: list(a)),
    "c*(c + c/(n - c) + n)": (lambda n, p: [n, np.ones_like(n), 1 / (n - p)],
                              lambda a, p: [a[0], a[1] / a[0], a[2] / a[0], p]),
}


def independent_optimum(text, x, y, pole_guess):
    """(constants, fitted values, sum of squares) at the least-squares optimum of one of the paper's
    forms, computed without the pipeline: the constants that enter linearly by numpy's lstsq, and the
    size-12 form's pole (its one nonlinear constant) by scipy's Brent minimization of the projected
    sum of squares, to 1e-15 relative in the pole (the optimum's sum of squares to ~1e-16 relative)."""
    basis, constants_of = PAPER_FORMS[text]

    def projected(p):
        A = np.stack(basis(x, p), axis=1)
        a = np.linalg.lstsq(A, y, rcond=None)[0]
        return a, A @ a, float(np.sum((A @ a - y) ** 2))

    p = None
    if "(n - c)" in text:
        p = minimize_scalar(lambda q: projected(q)[2], bracket=(pole_guess * 0.9, pole_guess, pole_guess * 1.1),
                            tol=1e-15).x
    a, fitted, S = projected(p)
    return np.array(constants_of(a, p)), fitted, S


def test_the_fit_reaches_the_optimum_its_stopping_rule_promises():
    """The variable-projection Levenberg-Marquardt (via fit_forms) on the paper's forms against the
    optimum computed independently (numpy's lstsq and scipy's Brent: `independent_optimum`).

    What the fit guarantees is its stopping rule: it stops after 20 steps in a row that each lower
    the sum of squares S by less than 1e-9 S. Near the optimum a Gauss-Newton step lowers S by
    S - S* = |f - f*|^2 (the optimum's residual is orthogonal to the model's tangent space), so a
    fit that stopped there has S - S* <= 1e-9 S and fitted values f within sqrt(1e-9 S) of the
    optimum's f* (2-norm over the points): those are the tolerances here, on any machine. The
    constants follow through the pseudo-inverse of the Jacobian J at the optimum, |c - c*|_i <=
    |row i of J+| |f - f*|: wide for the size-12 form's pole (J's smallest singular value is
    0.008), which the data barely determine. (Comparing with scipy's MINPACK at 1e-8 on the fitted
    values failed on AVX2 machines: MINPACK stopped by its own ftol 4.8e-8 short of the optimum in
    the pole's flat valley, from a start that moved with the last bits of this fit's result.)"""
    y = coef_sample()
    for text in PAPER_FORMS:
        e = symbolic.parse(text, "n")
        c, rms, converged = symbolic.fit_forms([e], X50, y)[0]
        assert converged
        c_star, f_star, S_star = independent_optimum(text, X50, y, c[-1])
        f = symbolic.evaluate_numpy(e, c, X50)
        S = float(np.sum((f - y) ** 2))
        assert rms == pytest.approx(np.sqrt(S / X50.size), rel=1e-12)      # the same S, summed apart
        # Rounding: each residual is a difference of values up to max|y| = 214, each good to a few
        # ulps (4 eps |y|), so S is known to 2 |r| |dr| with |dr| <= sqrt(N) 4 eps max|y|; within
        # that neither sum can tell the two optima apart.
        rounding = 2 * np.sqrt(S_star) * np.sqrt(X50.size) * 4 * np.finfo(float).eps * np.max(np.abs(y))
        assert S_star - rounding <= S <= S_star * (1 + 1e-9) + rounding, (text, S, S_star)
        distance = np.linalg.norm(f - f_star)
        assert distance <= np.sqrt(1e-9 * S_star + rounding), (text, distance)
        h = 1e-6 * np.maximum(np.abs(c_star), 1.0)         # central differences: error ~h^2, relative 1e-12
        J = np.stack([(symbolic.evaluate_numpy(e, c_star + h[i] * np.eye(len(c))[i], X50)
                       - symbolic.evaluate_numpy(e, c_star - h[i] * np.eye(len(c))[i], X50)) / (2 * h[i])
                      for i in range(len(c))], axis=1)
        reach = np.linalg.norm(np.linalg.pinv(J), axis=1) * np.sqrt(1e-9 * S_star)
        assert np.all(np.abs(c - c_star) <= reach), (text, c - c_star, reach)


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
        # an exact fit (RMS < 1e-12): its constants are exact to the fit's conditioning times that
        assert float(expression.subs(n, v)) == pytest.approx(float(target.subs(n, v)), rel=1e-10)




def test_five_thousand_points_in_bounded_memory(tmp_path):
    """5,000 points: screened on a spanning subsample, refitted on every point. The exact form comes
    back (RMS at rounding level) and the search's peak memory stays under 1 GB (it was 5.1 GB when
    every form was screened on every point; 0.66 GB here). Measured in its own process as VmHWM, the
    high-water mark of its own memory: getrusage's ru_maxrss would carry over the forking pytest
    worker's, which Linux keeps across exec."""
    import subprocess
    import sys

    script = tmp_path / "big.py"
    script.write_text(
        "import numpy as np\n"
        "from pipeline.symbolic import search\n"
        "t = np.linspace(1.0, 50.0, 5000)\n"
        "found = search.search(t, 2 * t / (t + 4), 8)\n"
        "i = found['front'][-1]\n"
        "peak = next(line.split()[1] for line in open('/proc/self/status') if line.startswith('VmHWM'))\n"
        "print(found['complexity'][i], found['rms'][i], peak)\n")
    done = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    size, rms, peak_kb = done.stdout.split()
    assert int(size) == 8 and float(rms) < 1e-12
    assert int(peak_kb) < 1_000_000, f"peak resident memory {int(peak_kb) / 1e6:.2f} GB"


def test_the_screening_subsample_spans_x():
    from pipeline.symbolic.search import spanning_subsample
    x = np.random.default_rng(0).uniform(0, 10, 1000)
    sub = spanning_subsample(x, 256)
    assert sub.size == 256 and x[sub].min() == x.min() and x[sub].max() == x.max()
    gaps = np.diff(np.sort(x[sub]))
    assert gaps.max() < 0.2


def test_padded_points_add_nothing_to_what_is_measured():
    """The compiled programs see the points padded to a few sizes (copies of the first point at
    weight 0): at most 1.5x the points, never fewer, and the sums of squares and residuals of 37
    points (padded to 48) are numpy's on the 37 alone (1e-12 relative: sums of 37 terms in another
    order), even where the first point's residual is large."""
    sizes = [symbolic.padded_points(p) for p in range(1, 3000)]
    assert all(p <= s <= max(8, 1.5 * p) for p, s in zip(range(1, 3000), sizes))
    assert len(set(sizes)) == 18      # 8, 12, 16, 24, ..., 2048, 3072
    x = np.linspace(0.5, 3.0, 37)
    y = np.exp(x) + np.where(np.arange(37) == 0, 100.0, 0.0)     # the first point far off
    forms = [symbolic.parse(t) for t in ("c * x + c", "c / (x + c)", "x * x")]
    c = np.array([[1.3, -0.4, 0, 0, 0], [2.0, 0.7, 0, 0, 0], [1, 1, 1, 1, 1]], dtype=float)
    program = symbolic.programs(forms, symbolic.MIN_STEPS)
    values = np.stack([1.3 * x - 0.4, 2.0 / (x + 0.7), x * x])
    w = np.linspace(1.0, 2.0, 37)
    np.testing.assert_allclose(symbolic.sums_of_squares(program, c, x[None], y, w),
                               np.sum(((values - y) * w) ** 2, axis=1), rtol=1e-12)
    residuals = symbolic.weighted_residuals(program, c, x[None], y, w)
    assert residuals.shape == (3, 37)
    np.testing.assert_allclose(residuals, (values - y) * w, rtol=1e-12, atol=1e-12)


def test_a_block_of_short_programs_runs_only_their_steps():
    """Programs are padded at the front with no-ops to a common length; a block starts at the first
    step any of its programs uses (`first_step`: rows of no-ops alone, the padding of a last block,
    do not count). Its fits are those run from step 0, bit for bit (no step reads a skipped
    register), and starting one step too late changes them."""
    forms = [symbolic.parse(t) for t in ("c * x + c", "c / (x + c)", "x * x")]     # 5, 5 and 3 steps
    program = symbolic.programs(forms, symbolic.MIN_STEPS)
    steps = symbolic.MIN_STEPS
    assert [symbolic.first_step(program[i:i + 1]) for i in range(3)] == [steps - 5, steps - 5, steps - 3]
    assert symbolic.first_step(program) == steps - 5
    assert symbolic.first_step(np.concatenate([program[2:], np.zeros_like(program[:2])])) == steps - 3
    assert symbolic.first_step(np.zeros_like(program)) == steps
    x = np.linspace(0.5, 3.0, 16)
    c = np.array([[1.3, -0.4, 0, 0, 0], [2.0, 0.7, 0, 0, 0], [1, 1, 1, 1, 1]], dtype=float)
    fit = lambda first: [np.asarray(v) for v in symbolic.fit_block(
        program, symbolic.linear_masks(forms, 5), c, x[None], np.exp(x), np.ones(16), 20, 0, True, first=first)]
    whole, skipped, late = fit(0), fit(steps - 5), fit(steps - 4)
    for a, b in zip(whole, skipped):
        np.testing.assert_array_equal(a, b)
    assert not np.array_equal(whole[1], late[1])


def test_a_narrow_screening_program_only_where_its_forms_repay_its_compilation(monkeypatch):
    """Forms with at most SMALL_CONSTANTS constants are screened in narrower blocks only where they
    fill NARROW_ROW_STEPS rows x steps; else in the full width's blocks. Either way the front has
    the same complexities and RMS (1e-9 relative: the same fits, rounded in blocks of another width;
    every refit runs at the full width; its forms may differ between equivalent ones, (c - x) c
    against (c + x) c)."""
    widths = []
    fit_block = symbolic.fit_block

    def recording(block, linear, *args, **kwargs):
        widths.append(linear.shape[1])
        return fit_block(block, linear, *args, **kwargs)

    monkeypatch.setattr(symbolic, "fit_block", recording)
    default = symbolic.NARROW_ROW_STEPS
    y = coef_sample()
    fronts = {}
    for threshold in (0, 10**12):       # every screening narrow where it may be, or none
        monkeypatch.setattr(symbolic, "NARROW_ROW_STEPS", threshold)
        widths.clear()
        found = symbolic.search(X50, y, 7)
        fronts[threshold] = np.array([(found["complexity"][i], found["rms"][i]) for i in found["front"]])
        assert set(widths) == ({symbolic.SMALL_CONSTANTS, found["width"]} if threshold == 0 else {found["width"]})
    assert len(fronts[0]) >= 3
    np.testing.assert_allclose(fronts[0], fronts[10**12], rtol=1e-9)
    # The default: this search's small forms are too few for a program of their own.
    monkeypatch.setattr(symbolic, "NARROW_ROW_STEPS", default)
    widths.clear()
    symbolic.search(X50, y, 7)
    assert set(widths) == {found["width"]}
