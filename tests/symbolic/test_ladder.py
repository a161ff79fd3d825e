"""The ladder of grammars (`pipeline.symbolic.ladder`) and the rates behind its estimates
(`pipeline.symbolic.rates`): a planted law that a narrower grammar finds is never lost to a wider
default, in one variable and in two; what pyoperon alone finds, the ladder keeps; the kept rates
move with what a search measures and survive a corrupt file."""

import json

import numpy as np
import pytest

from pipeline.symbolic import grammar, ladder, operon, rates, search
from pipeline.symbolic.grammar import TEN


@pytest.fixture
def pinned_rates(monkeypatch, tmp_path):
    """The kept rates not learned during the test, and a compiled search assumed: the forecasts the
    same on every machine (the plans are made at the reference rates whatever the machine)."""
    monkeypatch.setenv("PIPELINE_RATES", str(tmp_path / "rates.json"))
    monkeypatch.setattr(rates, "learn", lambda timing: None)
    monkeypatch.setattr(rates, "compiled", lambda kind: True)


def best_at(candidates, k):
    """The least loss among candidates of complexity at most k."""
    return min((c[2] for c in candidates if grammar.complexity(c[0]) <= k), default=np.inf)


def test_a_form_an_earlier_rung_fitted_is_not_fitted_again():
    """The wide grammar's forms to complexity 6 less those + - * / reached to 6: exactly the forms
    that use one of the other operations."""
    searched = [(grammar.ARITHMETIC, 6)]
    for k in range(1, 7):
        new = ladder.new_forms(TEN, 1, k, 100, searched)
        assert all(grammar.operations_of(e) - set(grammar.ARITHMETIC) for e in new)
        assert len(new) == sum(1 for e in grammar.forms_of(k, TEN, 1)
                               if grammar.operations_of(e) - set(grammar.ARITHMETIC))
    # forms with as many constants as the data have points cannot be fitted: left out
    assert all(grammar.constants(e) < 2 for e in ladder.new_forms(TEN, 1, 7, 2))


@pytest.mark.parametrize("variables, law, complexity", [
    (1, lambda x: 0.3 + 1.0 / (x[0] + 0.5), 8),
    (2, lambda x: x[0] * x[1] / (x[0] + x[1]), 8),
])
def test_a_law_the_arithmetic_grammar_finds_is_not_lost_to_the_ten_operations(pinned_rates, variables, law,
                                                                               complexity):
    """A rational law within reach of + - * / but not of the ten operations in the same budget (the
    budget chosen so, and checked: the ten operations' reach falls short of the law's complexity):
    the ladder's front holds it exactly (RMS < 1e-10), and at every complexity fits at least as well
    as the arithmetic grammar's own front to the depth the ladder gave it."""
    rng = np.random.default_rng(5)
    x = rng.uniform(0.5, 3.0, (variables, 60))
    y = law(x)
    # 6 s of fits, beside the compilation a plan counts
    seconds = 6.0 + rates.DEFAULTS["functions/squares"]["compile_s"]
    wide, _, _ = ladder.reach(TEN, variables, y.size, 12, ladder.EXHAUSTIVE_SHARE * 6.0, "functions/squares")
    assert wide < complexity
    candidates, rungs, _ = ladder.run(x, y, 12, TEN, seconds, operon="never", log=lambda s: None)
    arithmetic = next(r for r in rungs if r.name == "arithmetic")
    assert arithmetic.complexity >= complexity and arithmetic.operations == grammar.ARITHMETIC
    assert best_at(candidates, complexity) < 1e-10
    # (compiled for the ten operations' opcodes, as the ladder's rungs are: one compilation)
    alone = search.search(x, y, arithmetic.complexity, "+-*/", codes=grammar.operation_codes(TEN))
    for k in range(1, arithmetic.complexity + 1):
        own = min((alone["loss"][i] for i in alone["front"] if alone["complexity"][i] <= k), default=np.inf)
        assert best_at(candidates, k) <= own * (1 + 1e-6) + 1e-14, k


def test_what_pyoperon_alone_finds_the_ladder_keeps(pinned_rates, monkeypatch):
    """With pyoperon's run fixed by its generations (not its time), the ladder's pyoperon rung is
    pyoperon alone: the ladder's front is at least as good at every complexity as pyoperon's
    polished front alone (same seed), on a law beyond the exhaustive reach of a small budget."""
    monkeypatch.setattr(operon, "MAX_GENERATIONS", 40)
    monkeypatch.setattr(operon, "POPULATION", 300)
    x = np.linspace(0.0, 3.0, 60)[None]
    y = 0.5 + 2.0 * x[0] * np.exp(-1.5 * x[0])
    candidates, rungs, _ = ladder.run(x, y, 12, TEN, 12.0, operon="always", log=lambda s: None)
    assert rungs[-1].engine == "operon"
    models = operon.operon_models(x, y, 12, TEN, 0, generations=40, population=300)
    alone = operon.polished(models, x, y, 0)
    assert alone
    for tree, _, value, _ in alone:
        assert best_at(candidates, grammar.complexity(tree)) <= value * (1 + 1e-6) + 1e-14


def test_the_ladder_searches_the_operations_whole_where_they_reach():
    """Where every form of the operations asked for fits the budget, one rung searches them all
    (it holds every narrower grammar's forms) and pyoperon does not run."""
    x = np.linspace(0.5, 2.0, 30)[None]
    candidates, rungs, _ = ladder.run(x, 1.0 / x[0] + 2.0, 6, TEN, 600.0, log=lambda s: None)
    assert [(r.name, r.complexity) for r in rungs] == [("wide", 6)]
    assert best_at(candidates, 6) < 1e-12


def test_the_data_suggest_the_operations_of_the_members_that_beat_arithmetic():
    """Members of the merged front that fit better than every + - * / member at or below their
    complexity suggest their operations; a member no better suggests nothing."""
    arithmetic = grammar.ARITHMETIC
    plain = (grammar.parse("c * x + c"), None, 0.5)
    better = (grammar.parse("c * exp(c * x)"), None, 0.1)
    worse = (grammar.parse("c + sqrt(x) * c * x"), None, 0.6)
    assert ladder._suggested([plain, better, worse], arithmetic) == ("exp",)
    assert ladder._suggested([plain, worse], arithmetic) == ()


def test_rates_move_halfway_to_a_measurement_and_survive_a_corrupt_file(monkeypatch, tmp_path):
    """A search's measured rate moves the kept rate halfway to it; a phase under a second is too
    coarse to be kept; an unreadable or out-of-range file gives the defaults."""
    path = tmp_path / "rates.json"
    monkeypatch.setenv("PIPELINE_RATES", str(path))
    kind = "functions/squares"
    default = rates.DEFAULTS[kind]["screen_s"]
    rates.record(kind, screen=(1e6, 3 * default * 1e6))
    assert rates.load()[kind]["screen_s"] == pytest.approx(2 * default)
    rates.record(kind, screen=(1e6, 0.5))
    assert rates.load()[kind]["screen_s"] == pytest.approx(2 * default)
    path.write_text("{ not json")
    assert rates.load() == rates.DEFAULTS
    path.write_text(json.dumps({kind: {"screen_s": -1.0, "refit_s": "fast"}}))
    assert rates.load() == rates.DEFAULTS


def test_the_estimate_grows_with_the_work_and_the_reach_with_the_budget(pinned_rates):
    """More forms, points or complexities take longer; a larger budget reaches at least as deep."""
    kind = "arithmetic/squares"
    assert (ladder.estimate_seconds(1000, 8, 50, kind) < ladder.estimate_seconds(2000, 8, 50, kind)
            < ladder.estimate_seconds(2000, 8, 5000, kind))
    depths = [ladder.reach(grammar.ARITHMETIC, 2, 100, 12, s, kind)[0] for s in (1.0, 5.0, 20.0)]
    assert depths == sorted(depths) and depths[0] < depths[-1]


def test_pyoperon_s_weights_scale_and_offset_are_dropped_to_reach_the_complexity_asked():
    """pyoperon writes x / (x + 2) as 0 + 1 * ((1 x) / ((1 x) + 2)), complexity 14: read back within
    complexity 6 it is x / (x + 2) with its constant, the only variant that fits; within 10, the
    variants with fewer drops come first."""
    e = grammar.parse("c + c * ((c * x) / ((c * x) + c))")
    values = [0.0, 1.0, 1.0, 1.0, 2.0]
    assert grammar.complexity(e) == 14
    (tree, c), = operon.variants(e, values, 6)
    assert tree == grammar.parse("x / (x + c)") and list(c) == [2.0]
    within = operon.variants(e, values, 10)
    drops = [grammar.constants(e) - grammar.constants(t) for t, _ in within]
    assert drops == sorted(drops) and all(grammar.complexity(t) <= 10 for t, _ in within)
    x = np.linspace(0.5, 3.0, 7)
    for t, c in within:
        np.testing.assert_allclose(grammar.evaluate_numpy(t, c, x[None]), x / (x + 2), rtol=1e-15)


def test_the_readme_and_the_regress_page_state_the_default_budgets():
    """The default budgets the README and docs/regress.md state are the command's."""
    from pipeline.engine import paths
    from pipeline.symbolic.regress import BUDGET_SECONDS, MAX_COMPLEXITY

    one, two = BUDGET_SECONDS[(1, 12)], BUDGET_SECONDS[(2, 12)]
    readme = (paths.ROOT / "README.md").read_text()
    assert f"within {one:.0f} s for one variable, {two:.0f} s for two or three" in " ".join(readme.split())
    page = " ".join((paths.ROOT / "docs" / "regress.md").read_text().split())
    assert (f"The budget is {one:.0f} s for one variable up to complexity 12 and "
            f"{BUDGET_SECONDS[(1, MAX_COMPLEXITY)]:.0f} s beyond it, {two:.0f} s and "
            f"{BUDGET_SECONDS[(2, MAX_COMPLEXITY)]:.0f} s for two or three variables") in page
