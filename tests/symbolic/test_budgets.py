"""Searches planned in work, not in seconds (`pipeline.symbolic.ladder.make_plan`,
`pipeline.symbolic.budgets`): the plan of a budget is the same whatever this machine's kept rates
say (only the forecast moves with them); a rung that runs slow does not change the front; a
recorded plan replays to the same front; pyoperon's models depend on its seed and generations
alone; a plan that does not fit its search, or a file without one, is refused naming why."""

import json

import numpy as np
import pytest

from pipeline.symbolic import budgets, ladder, operon, rates, search
from pipeline.symbolic.grammar import TEN
from tests.helpers import PLANTED_SLOW_RATES

X = np.linspace(0.5, 3.0, 60)[None]
Y = 0.3 + 1.0 / (X[0] + 0.5) + 0.1 * np.exp(-X[0])
# 3 s of fits beside the compilation: + - * / to complexity 9, the ten operations to 5, the
# suggested rung's work (0.4 s, which a 2 s slower first rung took under a budget counted in
# seconds), no pyoperon
SECONDS = rates.DEFAULTS["functions/squares"]["compile_s"] + 3.0


def same(a, b) -> bool:
    """Two ladders' candidates equal to the last bit: the same trees, constants and losses in order."""
    return len(a) == len(b) and all(
        ta == tb and np.array_equal(np.asarray(ca), np.asarray(cb)) and la == lb and ea == eb and ra == rb
        for (ta, ca, la, _, ea, ra), (tb, cb, lb, _, eb, rb) in zip(a, b))


def test_a_plan_is_the_reference_rates_and_a_forecast_is_this_machine_s(monkeypatch, tmp_path):
    """The same budget plans the same work with the kept rates of a machine 1000 times slower; the
    forecast of that work follows the kept rates (at least 100 times longer there)."""
    monkeypatch.setattr(rates, "compiled", lambda kind: True)
    monkeypatch.setenv("PIPELINE_RATES", str(tmp_path / "fresh.json"))
    here = ladder.make_plan(1, X.size, 12, TEN, 30.0, "max")
    fast = ladder.forecast(here)
    slow_file = tmp_path / "slow.json"
    slow_file.write_text(json.dumps(PLANTED_SLOW_RATES))
    monkeypatch.setenv("PIPELINE_RATES", str(slow_file))
    assert rates.load() == PLANTED_SLOW_RATES
    assert ladder.make_plan(1, X.size, 12, TEN, 30.0, "max") == here
    assert ladder.forecast(here) > 100 * fast
    names = [r["name"] for r in here["rungs"]]
    assert names[:2] == ["arithmetic", "wide"] and here["rungs"][0]["complexity"] > here["rungs"][1]["complexity"]
    # a larger budget plans at least as much work
    more = ladder.make_plan(1, X.size, 12, TEN, 60.0, "max")
    assert sum(r.get("forms") or 0 for r in more["rungs"]) >= sum(r.get("forms") or 0 for r in here["rungs"])


def test_a_slow_rung_leaves_the_front_as_it_is_and_a_recorded_plan_replays_it(monkeypatch, tmp_path):
    """The ladder once as it runs; again from its plan written as JSON and read back, with this
    machine's kept rates replaced by a 1000 times slower machine's and its first rung made 2 s
    slower (a sleep), which under a budget counted in seconds took the next rungs' time: the same
    candidates, to the last bit, and the same rungs. The slow rung did run slow."""
    import time

    monkeypatch.setenv("PIPELINE_RATES", str(tmp_path / "rates.json"))
    plan = ladder.make_plan(1, X.size, 9, TEN, SECONDS)
    assert [r["name"] for r in plan["rungs"]] == ["arithmetic", "wide", "suggested"]
    first, rungs, _ = ladder.run(X, Y, 9, TEN, SECONDS, log=lambda s: None)
    (tmp_path / "slow.json").write_text(json.dumps(PLANTED_SLOW_RATES))
    monkeypatch.setenv("PIPELINE_RATES", str(tmp_path / "slow.json"))
    (tmp_path / "plan.json").write_text(json.dumps(dict(plan=dict(seconds=SECONDS, searches=dict(regress=plan)))))
    replayed = budgets.recorded(tmp_path / "plan.json").plan("regress", 1, X.size, 9, TEN, "rms")
    assert replayed == plan
    original, slowed = search.search, []

    def slow(*a, **k):
        if not slowed:
            slowed.append(1)
            time.sleep(2.0)
        return original(*a, **k)

    monkeypatch.setattr(search, "search", slow)
    again, slow_rungs, _ = ladder.run(X, Y, 9, TEN, None, plan=replayed, log=lambda s: None)
    assert slow_rungs[0].seconds >= 2.0
    assert [(r.name, r.complexity, r.forms) for r in slow_rungs] == [(r.name, r.complexity, r.forms) for r in rungs]
    assert [r.name for r in rungs][2:] in (["suggested"], ["wide, deeper"])     # (the work the sleep took before)
    assert same(first, again)


def test_pyoperon_s_models_depend_on_its_seed_and_generations_alone():
    """Two runs of one seed give the same models, constants to the last bit, on one thread and on
    two; another seed gives others."""
    def models(seed, threads):
        return operon.operon_models(X, Y, 10, TEN, seed, threads=threads, generations=15, population=200)

    one = models(3, 2)
    assert one
    for again in (models(3, 2), models(3, 1)):
        assert [repr(t) for t, _ in again] == [repr(t) for t, _ in one]
        assert all(np.array_equal(a, b) for (_, a), (_, b) in zip(again, one))
    other = models(4, 2)
    assert [repr(t) for t, _ in other] != [repr(t) for t, _ in one] or not all(
        np.array_equal(a, b) for (_, a), (_, b) in zip(other, one))


def test_a_plan_for_another_search_or_a_file_without_one_is_refused(tmp_path):
    """Other points, complexity, operations or loss than the plan was made for; a rung this version
    enumerates otherwise; a malformed plan; a missing file, one that is not JSON, one without a
    plan, a plan without the search asked for: PlanError naming what is wrong."""
    plan = ladder.make_plan(1, X.size, 9, TEN, SECONDS)
    for args, message in [((1, X.size + 1, 9, TEN, "rms"), "points 60; this search has 61"),
                          ((1, X.size, 8, TEN, "rms"), "max_complexity 9; this search has 8"),
                          ((1, X.size, 9, "+-*/", "rms"), "operations"),
                          ((1, X.size, 9, TEN, "max"), "loss 'rms'; this search has 'max'")]:
        with pytest.raises(ladder.PlanError, match=message):
            ladder.check(plan, *args)
    miscounted = json.loads(json.dumps(plan))
    miscounted["rungs"][0]["forms"] += 1
    with pytest.raises(ladder.PlanError, match="lists .* forms .* this version enumerates"):
        ladder.run(X, Y, 9, TEN, None, plan=miscounted, log=lambda s: None)
    broken = json.loads(json.dumps(plan))
    del broken["rungs"][0]["complexity"]
    with pytest.raises(ladder.PlanError, match="incomplete or malformed"):
        ladder.check(broken, 1, X.size, 9, TEN, "rms")
    with pytest.raises(ladder.PlanError, match="no such file"):
        budgets.recorded(tmp_path / "none.json")
    (tmp_path / "bad.json").write_text("{ not json")
    with pytest.raises(ladder.PlanError, match="not a JSON file"):
        budgets.recorded(tmp_path / "bad.json")
    (tmp_path / "empty.json").write_text(json.dumps(dict(rows=[])))
    with pytest.raises(ladder.PlanError, match="no plan in it"):
        budgets.recorded(tmp_path / "empty.json")
    (tmp_path / "other.json").write_text(json.dumps(dict(plan=dict(seconds=10.0, searches=dict(grammar=plan)))))
    with pytest.raises(ladder.PlanError, match="no plan for the search 'regress' .*'grammar'"):
        budgets.recorded(tmp_path / "other.json").plan("regress", 1, X.size, 9, TEN, "rms")


def test_an_exhaustive_search_s_plan_has_no_budget_and_replays(tmp_path):
    """`regress --engine exhaustive`'s plan: one rung of every form to the complexity, its budget null
    in plan.json, read back as it was written."""
    plan = ladder.make_plan(1, X.size, 6, TEN, None)
    assert [(r["name"], r["complexity"]) for r in plan["rungs"]] == [("exhaustive", 6)]
    assert plan["rungs"][0]["forms"] == sum(len(ladder.new_forms(TEN, 1, k, X.size)) for k in range(1, 7))
    path = tmp_path / "plan.json"
    path.write_text(json.dumps(dict(plan=dict(seconds=None, searches=dict(regress=plan)))))
    budget = budgets.recorded(path)
    assert budget.seconds is None and budget.plan("regress", 1, X.size, 6, TEN, "rms") == plan


def test_a_run_s_plans_are_found_in_its_coverage_by_their_names():
    """Each search's recorded plan under its name, a pair's parts' prefixed by the part."""
    budget = budgets.Budget(30.0)
    a, b = {"version": 1, "a": 1}, {"version": 1, "b": 2}
    coverage = dict(scale=dict(grammar=dict(pixel_search=dict(rungs=[], **budget.within("scale").record("pixel search", a)))),
                    bias=dict(pixel_search=budget.within("bias").record("pixel search", b)), pairs=3)
    assert budgets.plans_of(coverage) == {"bias/pixel search": b, "scale/pixel search": a}
    assert budgets.plans_of(dict(rungs=[], **budget.record("grammar", a))) == {"grammar": a}
