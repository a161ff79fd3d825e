"""Forms executed by Mesa's lavapipe (`isa.execution`), against numpy's per-operation emulation in
the same format (numpy's float32 and float16 + - * / and sqrt are correctly rounded per operation):
bit for bit on planted forms; a cancelling form's executed error, which its float64 mathematics
does not have; the driver's own acos measured; float16 literals rounded to the nearest; a form that
does not compile, one line. Skipped with the reason where lavapipe is not installed; the emulation
that stands in for it there (`execution.emulate`) is checked against the same numpy operations
everywhere, and against lavapipe where it runs."""

import math

import numpy as np
import pytest

from pipeline.isa import execution
from tests.helpers import spirv_tools_missing

needs_lavapipe = pytest.mark.skipif(execution.available() is not None, reason=f"{execution.available()}")



# (GLSL body, its per-operation emulation with the format's constants c(...))
FORMS = {
    "horner": ("(0.5*x + 0.25)*x + 0.125", lambda x, c: (c(0.5) * x + c(0.25)) * x + c(0.125)),
    "lagarde_acos": ("(1.5707963 - 0.15658276*x)*sqrt(1.0 - x)",
                     lambda x, c: (c(1.5707963) - c(0.15658276) * x) * np.sqrt(c(1.0) - x)),
    "rational": ("x/(0.75*x + 0.3) - 0.1", lambda x, c: x / (c(0.75) * x + c(0.3)) - c(0.1)),
}


def inputs(precision: str) -> np.ndarray:
    """fp16: every float16 in [0, 1]; fp32: 2^18 float32 spread over [0, 1], and the 512 below 1."""
    if precision == "fp16":
        return np.arange(0, 0x3C01, dtype=np.uint16).view(np.float16)
    spread = np.linspace(0.0, 1.0, 1 << 18, dtype=np.float32)
    near_one = (np.float32(1.0).view(np.uint32) - np.arange(512, dtype=np.uint32)).view(np.float32)
    return np.concatenate([spread, near_one])


@needs_lavapipe
@pytest.mark.parametrize("precision", ["fp32", "fp16"])
@pytest.mark.parametrize("name", list(FORMS))
def test_lavapipe_rounds_each_operation_as_numpy_does(precision, name):
    body, emulation = FORMS[name]
    dtype = np.float32 if precision == "fp32" else np.float16
    x = inputs(precision)
    with np.errstate(all="ignore"):
        expected = np.asarray(emulation(x, dtype), dtype=dtype)
    got = execution.execute(body, x, precision, name=name)
    assert got.dtype == dtype and got.shape == x.shape
    bits = np.uint32 if precision == "fp32" else np.uint16
    assert np.array_equal(got.view(bits), expected.view(bits))
    assert np.array_equal(execution.emulate(body, x, precision).view(bits), got.view(bits))


@pytest.mark.parametrize("precision", ["fp32", "fp16"])
@pytest.mark.parametrize("name", list(FORMS))
def test_the_emulation_rounds_each_operation_in_the_format(precision, name):
    if spirv_tools_missing():
        pytest.skip(spirv_tools_missing())
    body, emulation = FORMS[name]
    dtype = np.float32 if precision == "fp32" else np.float16
    x = inputs(precision)
    with np.errstate(all="ignore"):
        expected = np.asarray(emulation(x, dtype), dtype=dtype)
    bits = np.uint32 if precision == "fp32" else np.uint16
    assert np.array_equal(execution.emulate(body, x, precision).view(bits), expected.view(bits))


@needs_lavapipe
def test_a_cancelling_form_errs_as_executed_where_its_mathematics_does_not():
    """sqrt(1 + x) - 1 on [1e-6, 1e-3]: exact in real numbers (its float64 error about 1e-13
    relative), in float32 it loses its digits to the cancellation (per operation, as numpy does)."""
    x = np.linspace(1e-6, 1e-3, 1 << 18, dtype=np.float32)
    truth = np.expm1(0.5 * np.log1p(x.astype(np.float64)))
    got = execution.execute("sqrt(1.0 + x) - 1.0", x, "fp32", name="cancelling")
    assert np.array_equal(got, np.sqrt(np.float32(1) + x) - np.float32(1))
    mathematics = np.sqrt(1.0 + x.astype(np.float64)) - 1.0
    assert np.max(np.abs(mathematics / truth - 1)) < 1e-9
    assert np.max(np.abs(got / truth - 1)) > 0.05


@needs_lavapipe
def test_the_drivers_own_acos_is_an_approximation():
    """GLSL acos as Mesa lowers it (a polynomial times a square root, shared by RADV, ANV, turnip and
    panfrost): in float32 about 1.6e-4 off, a thousand times float32's rounding; in float16 more
    than float16's rounding (2^-11 near pi/2) allows."""
    x = inputs("fp32")
    error32 = np.max(np.abs(execution.execute("acos(x)", x, "fp32").astype(np.float64) - np.arccos(x.astype(np.float64))))
    assert 1e-5 < error32 < 1e-3
    h = inputs("fp16")
    error16 = np.max(np.abs(execution.execute("acos(x)", h, "fp16").astype(np.float64) - np.arccos(h.astype(np.float64))))
    assert 2.0 ** -11 < error16 < 1e-2


@needs_lavapipe
def test_float16_literals_are_the_nearest_float16_and_a_bad_form_is_one_line():
    h = inputs("fp16")
    assert np.array_equal(execution.execute("x*0.3", h, "fp16"), h * np.float16(0.3))   # (glslang alone: 0.2998)
    assert "float16_t(0.2998046875)" not in execution.shader_source("x*0.3", "fp16")
    with pytest.raises(execution.ExecutionError) as failed:
        execution.execute("foo(x)", h[:4], "fp16", name="planted")
    assert str(failed.value).startswith("planted: the shader does not compile") and len(str(failed.value).splitlines()) == 1


def test_without_lavapipe_one_line_says_what_is_missing_and_the_emulation_runs(monkeypatch):
    from pipeline.engine import toolchains

    absent = toolchains.find_lavapipe(folders=("/nonexistent",))
    assert not absent.found and "lvp_icd" in absent.missing and "emulation stands in" in absent.missing
    monkeypatch.setattr(toolchains, "locate", lambda tool: absent)
    assert execution.available() == absent.missing
    with pytest.raises(execution.ExecutionError, match="^planted: not executed: Mesa's lavapipe is not installed"):
        execution.execute("x*0.5", np.ones(4, np.float32), name="planted")
    if spirv_tools_missing():
        pytest.skip(spirv_tools_missing())
    assert np.array_equal(execution.emulate("x*0.5 + 1.0", np.ones(4, np.float32)), np.full(4, 1.5, np.float32))


def test_errors_on_planted_values():
    """The largest absolute and relative error and where: the first largest; 0 where value and truth
    are both 0; inf at the first input whose value is not finite (NaN or inf); the floor bounds the
    relative error's denominator; a denominator passed in gives the same answer."""
    x = np.array([0.0, 0.25, 0.5, 0.75, 1.0], dtype=np.float32)
    truth = np.array([0.0, 1.0, 2.0, -4.0, 1.0])
    values = np.array([0.0, 1.5, 2.0, -3.0, 2.0], dtype=np.float32)
    got = execution.errors(values, x, truth)
    assert got == dict(max_abs_error=1.0, x_abs=0.75, max_rel_error=1.0, x_rel=1.0)
    assert execution.errors(values, x, truth, 2.0) == dict(max_abs_error=1.0, x_abs=0.75, max_rel_error=0.5,
                                                           x_rel=1.0)
    denominator = np.maximum(np.abs(truth), 2.0)
    assert execution.errors(values, x, truth, 2.0, denominator) == execution.errors(values, x, truth, 2.0)
    for bad in (np.nan, np.inf):
        planted = values.copy()
        planted[[2, 4]] = [bad, np.nan]
        assert execution.errors(planted, x, truth) == dict(max_abs_error=math.inf, x_abs=0.5, max_rel_error=math.inf,
                                                           x_rel=0.5)
    off = values.copy()
    off[0] = 0.5                                    # truth 0: relative error inf there, absolute 0.5
    assert execution.errors(off, x, truth)["max_rel_error"] == math.inf
