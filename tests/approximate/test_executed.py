"""Errors as the shader executes (`approximate.executed`): where a one-variable target is executed
(every float16 of the domain; at least 2^22 float32 and the 512 nearest around each extremum), the
truth's precision checked against mpmath, the exhaustive float16 maximum equal to numpy's
per-operation one on planted forms, a gap's cause named by its rule, and numbers printed as exactly
the format's values."""

import math

import numpy as np
import pytest
import sympy as sp

from pipeline.approximate import forms, targets
from pipeline.approximate.measures import executed
from pipeline.isa import execution
from tests.helpers import spirv_tools_missing



@pytest.mark.parametrize("precision", ["fp32", "fp16"])
def test_places_count_the_representable_values(precision):
    dtype = executed.DTYPES[precision]
    values = np.array([-2.5, -1.0, -1e-3, -0.0, 0.0, 1e-3, 0.5, 1.0, 3.0], dtype=dtype)
    places = executed.ordinals(values, precision)
    assert np.all(np.diff(places[values != 0]) > 0) and places[3] == places[4] == 0
    assert np.array_equal(executed.from_ordinals(places, precision)[values != 0], values[values != 0])
    one = int(executed.ordinals(dtype(1.0), precision))
    assert float(executed.from_ordinals(one + 1, precision)) == float(np.nextafter(dtype(1.0), dtype(2.0)))


def test_float16_inputs_are_every_value_of_the_domain():
    x = executed.inputs(0.0, 1.0, "fp16")
    every = np.arange(0, 1 << 16, dtype=np.uint16).view(np.float16)
    inside = np.sort(every[np.isfinite(every) & (every >= 0) & (every <= 1) & ~np.signbit(every)])
    assert x.dtype == np.float16 and np.array_equal(x, inside) and x.size == 15361
    assert executed.inputs(-1.0, 1.0, "fp16").size == 2 * 15361 - 1         # (-0 and 0 are one input)


@pytest.mark.parametrize("lo, hi", [(-2.0, -1.0), (-3.0, 5.0)])     # (one binade; both signs and many binades)
def test_float32_inputs_spread_over_the_domain_and_crowd_its_extrema(lo, hi):
    extremum = lo + 0.37 * (hi - lo)
    x = executed.inputs(lo, hi, "fp32", [extremum])
    assert x.dtype == np.float32 and x.size >= executed.SPREAD
    assert np.all(np.diff(x.astype(np.float64)) > 0) and x[0] >= lo and x[-1] <= hi
    near = [np.float32(extremum)]
    for direction in (-np.inf, np.inf):         # the 255 float32 values each side, by nextafter
        v = near[0]
        for _ in range(255):
            v = np.nextafter(v, np.float32(direction))
            near.append(v)
    assert np.isin(np.array(near, dtype=np.float32), x).all()
    # spread in value too: no gap wider than 1/(SPREAD/4 - 1) of the domain, plus float32's rounding
    ulp = float(np.spacing(np.float32(max(abs(lo), abs(hi)))))
    assert np.max(np.diff(x.astype(np.float64))) <= (hi - lo) / (executed.SPREAD // 4 - 1) + 2 * ulp


def test_the_truth_is_checked_against_mpmath():
    """A benign target keeps float64; a cancelling one (float64 loses 1e-10 of sqrt(1 + x) - 1 at
    x = 1e-6) gets a wider truth, which agrees with mpmath to 1e-3 of float32's unit."""
    benign = targets.from_expression("exp(x)", "x=0:1")
    x = executed.inputs(0.0, 1.0, "fp16")
    values, how = executed.truth(benign, x, executed.UNIT["fp16"], log=lambda s: None)
    assert how["computed_by"] == "float64" and how["float64_difference"] < 1e-15
    np.testing.assert_array_equal(values, np.exp(x.astype(np.float64)))
    cancelling = targets.from_expression("sqrt(1 + x) - 1", "x=1e-6:1e-3", "rel")
    x = executed.inputs(1e-6, 1e-3, "fp32")[::64]
    said = []
    values, how = executed.truth(cancelling, x, executed.UNIT["fp32"], log=said.append)
    assert how["computed_by"] != "float64" and how["float64_difference"] > 1e-3 * executed.UNIT["fp32"] and said
    import mpmath
    with mpmath.workdps(40):
        exact = np.array([float(mpmath.sqrt(1 + mpmath.mpf(float(v))) - 1) for v in x[::97]])
    assert np.max(np.abs(values[::97] - exact) / exact) < 1e-3 * executed.UNIT["fp32"]


# planted forms: (GLSL body, per-operation numpy in the format with its constants c(...))
PLANTED = {
    "horner": ("(0.5*x + 0.25)*x + 0.125", lambda x, c: (c(0.5) * x + c(0.25)) * x + c(0.125)),
    "cancelling": ("sqrt(1.0 + x) - 1.0", lambda x, c: np.sqrt(c(1.0) + x) - c(1.0)),
    "rational": ("x/(0.75*x + 0.3) - 0.1", lambda x, c: x / (c(0.75) * x + c(0.3)) - c(0.1)),
}


@pytest.mark.parametrize("name", list(PLANTED))
def test_the_exhaustive_float16_maximum_is_numpys_per_operation_one(name):
    """Every float16 of [0, 1] executed (lavapipe, or the emulation where it is absent): the largest
    error equals the one computed from numpy's float16 operations, input for input."""
    if spirv_tools_missing():
        pytest.skip(spirv_tools_missing())
    body, per_operation = PLANTED[name]
    target = targets.from_expression("sqrt(1 + x)", "x=0:1")
    run = executed.measure({name: body}, target, "fp16", log=lambda s: None)
    x = executed.inputs(0.0, 1.0, "fp16")
    with np.errstate(all="ignore"):
        values = np.asarray(per_operation(x, np.float16), dtype=np.float16)
    expected = execution.errors(values, x, np.sqrt(1 + x.astype(np.float64)))
    assert run["inputs"] == x.size and run["errors"][name]["max_abs_error"] == expected["max_abs_error"]
    assert run["errors"][name]["x_abs"] == expected["x_abs"]
    assert ("lavapipe" in run["how"]) == (execution.available() is None)


def test_a_gaps_cause_is_named_by_its_rule():
    """constants: a cubic whose coefficients float16 moves (1.0003 to 1, 0.3 to 0.30005: 4.39e-4 off its
    target at x = 1, which an executed error of 5e-4 is less than twice); arithmetic: sqrt(1 + x) - 1
    in float32 (no constants, no special function); function: acos (the driver's own)."""
    if spirv_tools_missing():
        pytest.skip(spirv_tools_missing())
    x = sp.Symbol("x", real=True)
    cubic = targets.from_expression("1.00048828125*x**3 + 0.3*x", "x=0:1")
    form = 1.0003 * x ** 3 + 0.3 * x                 # (its constants round to 1.0 and 0.2998 in float16)
    gap = executed.gap_cause(form, forms.glsl(form, "x", "fp16"), cubic, "fp16", 5e-4, "max_abs_error")
    assert gap["cause"] == "constants" and gap["constants_error"] == pytest.approx(0.000439453125, rel=1e-9)
    gap = executed.gap_cause(form, forms.glsl(form, "x", "fp16"), cubic, "fp16", 1e-3, "max_abs_error")
    assert gap["cause"] == "arithmetic"         # (twice the constants' error is less than executed)
    cancelling = targets.from_expression("sqrt(1 + x) - 1", "x=1e-6:1e-3", "rel")
    written = cancelling.sympy()
    gap = executed.gap_cause(written, forms.glsl(written, "x", "fp32"), cancelling, "fp32", 0.158, "max_rel_error")
    assert gap["cause"] == "arithmetic" and gap["constants_error"] == 0.0
    acos = targets.registry()["acos"]
    gap = executed.gap_cause(acos.sympy(), "acos(x)", acos, "fp32", 1.56e-4, "max_abs_error")
    assert gap["cause"] == "function" and gap["functions"] == ["acos"]


@pytest.mark.parametrize("precision, dtype", [("fp32", np.float32), ("fp16", np.float16)])
def test_printed_numbers_are_the_formats_values(precision, dtype):
    """Each number as printed reads back as exactly the format's nearest value: float32 in 9
    significant digits (read as a float32, as glslang reads it), float16 as its exact decimal
    (Python's float() of the text)."""
    rng = np.random.default_rng(3)
    largest = float(np.finfo(dtype).max)
    for v in np.concatenate([rng.uniform(-10, 10, 200), rng.lognormal(0, 8, 200), [1 / 3, 0.1, 65504.0, 2.0 ** -24]]):
        if abs(v) > largest:
            continue
        text = forms.number_text(float(v), precision)
        assert (np.float32(text) if precision == "fp32" else float(text)) == dtype(v), (v, text)
        if precision == "fp32":
            assert len(text.split("e")[0].replace("-", "").replace(".", "").strip("0")) <= 9, text
    if precision == "fp16":        # beyond its range: inf, as a shader reads the literal
        x = sp.Symbol("x", real=True)
        assert forms.glsl(sp.Float(1e5) * x, "x", "fp16") == "(1.0 / 0.0)*x"
        assert forms.python(sp.Float(-1e5) * x, "x", "fp16") == "-math.inf*x"
    x = sp.Symbol("x", real=True)
    printed = forms.glsl(sp.exp(-0.3 * x) + sp.Rational(1, 3), "x", precision)
    numbers = [float(t) for t in __import__("re").findall(r"\d+\.\d+(?:e-?\d+)?", printed)]
    assert numbers and all(float(dtype(n)) == n for n in numbers) if precision == "fp16" else \
        all(len(f"{n!r}".rstrip("0")) <= 11 for n in numbers)


def test_a_bad_precision_is_one_line():
    with pytest.raises(executed.ExecutedError, match="--precision 'fp64': give one of fp32, fp16"):
        executed.check_precision("fp64")
    with pytest.raises(targets.DeriveError, match="precision 'bf16'"):
        targets.check(targets.Target("t", "x", precision="bf16"))
    assert math.isclose(executed.UNIT["fp16"], 2.0 ** -10)
