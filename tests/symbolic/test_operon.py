"""pyoperon as the oracle of the exhaustive search, and as `pipeline regress`'s second engine; the
search on two variables."""

import csv

import numpy as np
import pytest

from pipeline.symbolic import grammar, operon, search
from pipeline.symbolic.regress import regress

RNG = np.random.default_rng(7)
T2, Q2 = RNG.uniform(0.5, 6.0, 60), RNG.uniform(0.2, 1.0, 60)
CASES = {
    "rational in one variable": (np.linspace(0.5, 8.0, 50)[None], lambda x: (2 * x[0] + 1) / (x[0] + 3), 10, "+-*/"),
    "noisy rational in one variable": (np.linspace(0.5, 8.0, 50)[None], lambda x: 3 * x[0] / (x[0] + 2)
                                       + np.random.default_rng(1).normal(0, 0.01, 50), 10, "+-*/"),
    "rational in two variables": (np.stack([T2, Q2]), lambda x: (2 * x[0] + x[1]) / (x[0] + 3), 8, "+-*/"),
    "noisy Gaussian bump with functions and powers": (
        np.linspace(0.0, 3.0, 50)[None], lambda x: 0.2 + np.exp(-2.0 * (x[0] - 1.1) ** 2)
        + np.random.default_rng(2).normal(0, 0.01, 50), 8, "+,-,*,/,exp,log,sqrt,square,pow"),
    "noisy sine with a kink, with sin, cos and abs": (
        np.linspace(0.0, 3.0, 50)[None], lambda x: 0.5 + 1.3 * np.sin(2.1 * x[0] + 0.4) + 0.3 * np.abs(x[0] - 1.5)
        + np.random.default_rng(4).normal(0, 0.01, 50), 9, "+,*,sin,cos,abs"),
}


@pytest.mark.parametrize("case", CASES)
def test_no_pyoperon_member_beats_the_front_at_equal_complexity(case):
    """pyoperon's front (its models' constants polished in float64, complexity recomputed TuringBot's
    way) against the exhaustive front: at every complexity the search reaches, no pyoperon member
    fits better than the front's best at or below it. Tolerance: 1e-6 relative, the refits'
    convergence with margin."""
    x, f, depth, ops = CASES[case]
    y = f(x)
    found = search.search(x, y, depth, ops)
    models = operon.polished(operon.operon_models(x, y, depth, ops, generations=60, population=500), x, y)
    assert models, "pyoperon returned no model within the complexity"
    if set(grammar.operations(ops)) - {"+", "-", "*", "/"}:     # its models were read back with the functions
        assert any(grammar.operations_of(tree) - {"+", "-", "*", "/"} for tree, *_ in models)
    for tree, c, rms, ok in models:
        k = grammar.complexity(tree)
        best = found["rms"][found["complexity"] <= k].min()
        assert rms >= best * (1 - 1e-6) - 1e-12, (case, k, grammar.show(tree, constants=c), rms, best)


def test_a_known_form_in_two_variables_comes_back_with_its_constants():
    """(2 t + q) / (t + 3), complexity 10 in (t, q): the front's member there has RMS at rounding
    level and its values equal the truth to 1e-9 relative over the data (its constants are those
    up to the common factor of numerator and denominator)."""
    x = np.stack([T2, Q2])
    y = (2 * x[0] + x[1]) / (x[0] + 3)
    found = search.search(x, y, 10)
    last = found["front"][-1]
    assert found["complexity"][last] == 10 and found["rms"][last] < 1e-12
    c = found["constants"][last][:found["constant_count"][last]]
    grid = np.stack(np.meshgrid(np.linspace(0.5, 6, 7), np.linspace(0.2, 1, 5))).reshape(2, -1)
    # An exact fit: RMS < 1e-12 on values of order 1 over 60 points, so the constants (and so the values
    # off the data) are exact to the conditioning of the fit times that: 1e-9 with margin.
    np.testing.assert_allclose(grammar.evaluate_numpy(found["forms"][last], c, grid),
                               (2 * grid[0] + grid[1]) / (grid[0] + 3), rtol=1e-9)


def noisy_two_column_data(tmp_path):
    x = np.stack([T2, Q2])
    v = (2 * x[0] + x[1]) / (x[0] + 3) + np.random.default_rng(3).normal(0, 0.002, T2.size)
    data = tmp_path / "two.csv"
    data.write_text("t,q,v\n" + "".join(f"{float(a)!r},{float(b)!r},{float(c)!r}\n" for a, b, c in zip(*x, v)))
    return data, x, v


def test_regress_on_two_columns_with_both_engines(tmp_path, monkeypatch):
    """`regress --x t,q --engine both` on noisy (2 t + q)/(t + 3): one merged front, each member's
    engine named in front.csv; the selected member (noise given) is the true form's family; the
    merge took pyoperon's models in: none of them fits better than the merged front at or below its
    complexity (1e-6 relative: the polish's convergence, as in the oracle test above)."""
    data, x, v = noisy_two_column_data(tmp_path)
    said, models = [], []
    monkeypatch.setattr(operon, "GENERATIONS", 60)
    monkeypatch.setattr(operon, "MAX_GENERATIONS", 60)
    monkeypatch.setattr(operon, "POPULATION", 500)
    polished = operon.polished
    monkeypatch.setattr(operon, "polished", lambda *a, **k: models.extend(polished(*a, **k)) or models)
    front = regress(data, "t,q", "v", tmp_path / "out", max_complexity=10, engine="both", noise=0.002, ops="+-*/",
                    log=said.append)
    assert any("pyoperon" in line for line in said) and models
    for tree, c, rms, ok in models:
        k = grammar.complexity(tree)
        assert rms >= min(m["rms"] for m in front if m["complexity"] <= k) * (1 - 1e-6), (k, rms)
    chosen = [m for m in front if m["selected"]]
    assert len(chosen) == 1 and chosen[0]["complexity"] == 10 and "q" in chosen[0]["canonical"]
    with open(tmp_path / "out" / "front.csv") as f:
        rows = list(csv.DictReader(f))
    assert {r["engine"] for r in rows} <= {"exhaustive", "operon", "both"} and len(rows) == len(front)


def test_pyoperon_s_members_fill_the_front_beyond_the_exhaustive_reach(tmp_path, monkeypatch):
    """With the exhaustive search's reach cut to complexity 3, the merged front's members above 3 can
    only be pyoperon's: there are some, front.csv names their engine "operon", and they fit better
    than the exhaustive front's best. (pyoperon 0.6.2 with + - * / returns one model within 10 on
    these data, the line in t at complexity 7 with a redundant weight: RMS 0.082 against 0.256.)"""
    from pipeline.symbolic import ladder

    data, x, v = noisy_two_column_data(tmp_path)
    monkeypatch.setattr(operon, "GENERATIONS", 60)
    monkeypatch.setattr(operon, "MAX_GENERATIONS", 60)
    monkeypatch.setattr(operon, "POPULATION", 500)
    reach = ladder.reach
    monkeypatch.setattr(ladder, "reach", lambda ops, variables, points, max_complexity, *a: reach(
        ops, variables, points, min(max_complexity, 3), *a))
    front = regress(data, "t,q", "v", tmp_path / "out", max_complexity=10, engine="both", noise=0.002, ops="+-*/",
                    log=lambda s: None)
    above = [m for m in front if m["complexity"] > 3]
    assert above and all(m["engine"] == "operon" for m in above)
    assert min(m["rms"] for m in above) < min(m["rms"] for m in front if m["complexity"] <= 3)
    with open(tmp_path / "out" / "front.csv") as f:
        engines = {int(r["complexity"]): r["engine"] for r in csv.DictReader(f)}
    assert all(engines[m["complexity"]] == "operon" for m in above)


def test_a_pyoperon_model_only_its_own_constants_define_is_kept_with_them():
    """pyoperon writes Schlick's 0.04 + 0.96 (1 - x)^5 as 0.04 - 0.96 (x - 1)^5: a negative base
    under its literal exponent 5, real there only, so the float64 fit (which moves the exponent)
    finds it undefined. The model keeps pyoperon's constants and their float64 RMS (the law's
    rounding, < 1e-15) instead of leaving the front; marked not converged (not the fit's)."""
    x = np.linspace(0.0, 1.0, 50)[None]
    y = 0.04 + 0.96 * (1 - x[0]) ** 5
    values = [0.04, -0.96, -1.0, 1.0, 5.0]
    tree = grammar.parse("c + c * ((c + c * x) ^ c)")
    (kept, c, rms, ok), = operon.polished([(tree, np.array(values))], x, y)
    assert kept == tree and list(c) == values and rms < 1e-15 and not ok
    (_, _, largest, _), = operon.polished([(tree, np.array(values))], x, y, loss="max")
    assert largest < 1e-15
