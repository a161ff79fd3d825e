"""Errors taken over every input of a one-variable domain (`measures.exhaustive`, `derive --certify`):
against an independent plain loop over the same inputs, bit for bit; the same maxima however the
inputs are split into tasks and processes; a driver's own function on lavapipe, or not certified
with the reason; the fronts read off the certified errors (`one_variable.certified`)."""

import math

import numpy as np
import pytest

from pipeline.approximate.measures import exhaustive
from pipeline.approximate.targets import reading
from pipeline.isa import execution

FORM = "(1.0 - x) / (1.0 + 0.5 * x) + sqrt(x)"


def plain_loop(lo: float, hi: float, dtype, truth) -> dict:
    """The largest absolute and relative error of FORM over every value of `dtype` in [lo, hi], one
    input at a time with numpy scalars of the format (each operation rounded to it), from the first
    value upward by nextafter."""
    one, half = dtype(1.0), dtype(0.5)
    x = dtype(lo)
    if float(x) < lo:
        x = np.nextafter(x, dtype(np.inf))
    best = dict(max_abs_error=-1.0, x_abs=None, max_rel_error=-1.0, x_rel=None)
    count = 0
    while float(x) <= hi:
        value = dtype(dtype(one - x) / dtype(one + dtype(half * x))) + dtype(np.sqrt(x))
        f = truth(float(x))
        error = abs(float(dtype(value)) - f)
        relative = error / abs(f)
        if error > best["max_abs_error"]:
            best["max_abs_error"], best["x_abs"] = error, float(x)
        if relative > best["max_rel_error"]:
            best["max_rel_error"], best["x_rel"] = relative, float(x)
        count += 1
        x = np.nextafter(x, dtype(np.inf))
    return best | dict(inputs=count)


def _truth(x: float) -> float:
    return (1.0 - x) / (1.0 + 0.5 * x) + math.sqrt(x)


@pytest.mark.parametrize("precision, dtype, lo, hi", [("fp32", np.float32, 0.7, 0.7005),
                                                     ("fp16", np.float16, 0.0, 1.0)])
def test_the_exhaustive_maximum_is_a_plain_loop_s_bit_for_bit(precision, dtype, lo, hi):
    """The target is FORM's own mathematics in float64: its error as executed is the format's rounding
    alone, and the maximum and where it lies are the loop's to the last bit."""
    target = reading.from_expression("(1 - x)/(1 + 0.5*x) + sqrt(x)", f"x={lo}:{hi}", metric="rel")
    found = exhaustive.certify({"form": FORM}, target, precision, log=lambda s: None, processes=1)
    expected = plain_loop(lo, hi, dtype, _truth)
    assert found["inputs"] == expected["inputs"] == exhaustive.count(lo, hi, precision)
    assert found["how"] == {"form": "emulation"} and found["not_certified"] == {}
    e = found["errors"]["form"]
    assert (e["max_abs_error"], e["x_abs"], e["max_rel_error"], e["x_rel"]) == \
        (expected["max_abs_error"], expected["x_abs"], expected["max_rel_error"], expected["x_rel"])
    assert 0 < e["max_abs_error"] < 8 * 2.0 ** (-24 if precision == "fp32" else -11)


def test_tasks_and_processes_split_the_inputs_without_changing_the_maxima(monkeypatch):
    """Tasks of 3,000 inputs in pieces of 700 on 2 processes: the same maxima, at the same inputs, as
    one task in one piece (the merge keeps the earlier input on a tie)."""
    target = reading.from_expression("acos(x)", "x=0.25:0.2505")
    bodies = {"poly": "(-0.156583 * x + 1.5707964) * sqrt(1.0 - x)", "line": "1.5707964 - x"}
    whole = exhaustive.certify(bodies, target, "fp32", log=lambda s: None, processes=1)
    monkeypatch.setattr(exhaustive, "TASK", 3000)
    monkeypatch.setattr(exhaustive, "PIECE", 700)
    said = []
    split = exhaustive.certify(bodies, target, "fp32", log=said.append, processes=2)
    assert whole["inputs"] == split["inputs"] > 3 * 3000
    assert split["errors"] == whole["errors"]
    assert "on 2 processes" in said[0] and any("certified" in s and "tasks" in s for s in said[1:])


def test_a_driver_s_own_function_is_certified_on_lavapipe_or_not_at_all(monkeypatch):
    """acos(x) as the driver computes it: every input on lavapipe, equal to lavapipe's errors over the
    same inputs computed in one run; without lavapipe it is not certified, and the reason says why."""
    target = reading.from_expression("acos(x)", "x=0.5:0.5002")
    if execution.available() is None:
        found = exhaustive.certify({"exact": "acos(x)"}, target, "fp32", log=lambda s: None, processes=1)
        first, last = exhaustive.executed._inside(0.5, 0.5002, "fp32")
        x = exhaustive.executed.from_ordinals(np.arange(first, last + 1), "fp32")
        alone = execution.errors(execution.execute("acos(x)", x), x, np.arccos(x.astype(np.float64)))
        assert found["how"] == {"exact": "lavapipe"} and found["errors"]["exact"] == alone
    monkeypatch.setattr(execution, "available", lambda: "lavapipe is not installed")
    found = exhaustive.certify({"exact": "acos(x)", "poly": "1.5707964 - x"}, target, "fp32", log=lambda s: None,
                               processes=1)
    assert list(found["errors"]) == ["poly"]
    assert list(found["not_certified"]) == ["exact"] and "Acos" in found["not_certified"]["exact"] and \
        found["not_certified"]["exact"].endswith("and lavapipe is not available: lavapipe is not installed")
    found = exhaustive.certify({"fused": "inversesqrt(x)"}, target, "fp32", log=lambda s: None, processes=1)
    assert found["not_certified"] == {"fused": "uses InverseSqrt, which only a driver computes, and lavapipe is not "
                                               "available: lavapipe is not installed"}


def test_the_fronts_are_read_off_certified_errors_until_every_member_is_certified(monkeypatch):
    """A planted sample that missed `cheap`'s largest error: certified, it leaves the front, `dear`
    (dominated by the sampled `cheap`) joins it and is certified in a second pass; a form never on a
    front is never certified."""
    from pipeline.approximate.engines import one_variable
    from pipeline.approximate.forms import Form
    from pipeline.approximate.measures.fronts import front
    from pipeline.approximate.targets import parse

    true_errors = {"cheap": 1e-2, "dear": 1e-3, "worse": 5e-2}
    sampled = {"cheap": 1e-4, "dear": 1e-3, "worse": 5e-2}
    cycles = {"cheap": 5.0, "dear": 6.0, "worse": 7.0}
    passes = []

    def planted(bodies, target, precision, log):
        passes.append(sorted(bodies))
        return dict(errors={n: dict(max_abs_error=true_errors[n], max_rel_error=1.0, x_abs=0.5, x_rel=0.5)
                            for n in bodies}, not_certified={}, how={n: "emulation" for n in bodies},
                    inputs=10, truth=dict(computed_by="float64"), seconds=0.0)

    monkeypatch.setattr(exhaustive, "certify", planted)
    errors = {n: dict(max_abs_error=e, max_rel_error=1.0, x_abs=0.5, x_rel=0.5) for n, e in sampled.items()}
    forms = {n: Form(n, "found", "grammar", parse("x", "x"), "") for n in sampled}
    target = reading.from_expression("x", "x=0:1")

    def needed(current):
        rows = [dict(name=n, cycles=cycles[n], **current[n]) for n in current]
        return {r["name"] for r in front(rows, "max_abs_error", 0.0)}

    done = one_variable.certified(needed, forms, target, "fp32", errors, "max_abs_error", lambda s: None)
    assert passes == [["cheap"], ["dear"]] and done["passes"] == 2
    assert sorted(done["certified"]) == ["cheap", "dear"]
    assert errors["cheap"]["max_abs_error"] == 1e-2 and sorted(needed(errors)) == ["cheap", "dear"]


def test_certify_is_refused_for_a_pair_and_read_from_a_target_file(tmp_path):
    from pipeline.approximate import engines
    from pipeline.approximate.targets import DeriveError

    file = tmp_path / "t.toml"
    file.write_text('[target]\nexpression = "x*x"\ncertify = true\n')
    assert reading.from_file(file).certify is True
    file.write_text('[target]\nexpression = "x*x"\ncertify = "yes"\n')
    with pytest.raises(DeriveError, match="certify = 'yes': give true or false"):
        reading.from_file(file)
    with pytest.raises(DeriveError, match="a pair of outputs is not certified"):
        engines.derive(reading.named("env_brdf"), ["rdna3"], None, None, 4, certify=True)


@pytest.mark.parametrize("precision", ["fp32", "fp16"])
def test_the_format_s_values_by_place_are_the_ordinals_values(precision):
    """The fast view of non-negative places equals `executed.from_ordinals`, bit for bit, and a range
    crossing 0 takes the general path."""
    from pipeline.approximate.measures import executed

    unsigned = np.uint32 if precision == "fp32" else np.uint16
    for start, stop in ((0, 3000), (10_000, 15_361), (-40, 40)):
        assert np.array_equal(exhaustive._values(start, stop, precision).view(unsigned),
                              executed.from_ordinals(np.arange(start, stop), precision).view(unsigned))
