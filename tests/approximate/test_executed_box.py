"""Errors of a target of several variables as executed (`approximate.executed_box`, at the points of
`several_variables.execution_points`): at the box's
measuring grid and the float64 error's peaks, each form's GLSL run in float32 equals numpy's
per-operation float32 at the same points (planted forms, a material member's constants from its
formulas, rounded as push constants), and a form that cancels errs as executed where its
mathematics does not."""

import numpy as np
import pytest
import sympy as sp

from pipeline.approximate.engines import several_variables
from pipeline.approximate.measures import executed_box
from pipeline.approximate.targets import Axis, Target
from pipeline.isa import execution
from tests.helpers import spirv_tools_missing

TARGET = Target("planted", "x*y + a", (Axis("x", 0.0, 1.0), Axis("y", 0.0, 1.0)), Axis("a", 1.0, 2.0), "abs")




def test_the_grid_and_the_peaks_are_executed():
    """`several_variables.execution_points`: the measuring grid of every axis, then the peaks as given."""
    grid = several_variables.execution_points(TARGET)
    peak = np.array([0.123456, 0.654321, 1.5])
    both = several_variables.execution_points(TARGET, [peak])
    from pipeline.optics import brdf
    sizes = [brdf.axis_grid(a.lo, a.hi, cells=24, chebyshev=13).size for a in TARGET.axes]
    assert len(grid) == 3 and grid[0].size == np.prod(sizes) and both[0].size == grid[0].size + 1
    assert [c[-1] for c in both] == list(peak)


def test_executed_errors_are_numpys_per_operation_float32():
    """A pixel form (0.3 + x) * y + 0.7 a and a material one c0 * x * y + c1 a, its constants from
    formulas in a (the twin's text: 1 + 0.1 a and 0.9), against the same arithmetic in numpy float32 on
    the inputs rounded to float32, and the truth in float64 at those inputs."""
    if spirv_tools_missing():
        pytest.skip(spirv_tools_missing())
    x, y, a, c0, c1 = sp.symbols("x y a c0 c1", real=True)
    forms = {"pixel": ((sp.Float(0.3) + x) * y + sp.Float(0.7) * a, None),
             "material": (c0 * x * y + c1 * a, ["1 + 0.1*a", "0.9"])}
    bodies = {name: (several_variables.glsl_text(e), constants) for name, (e, constants) in forms.items()}
    columns = several_variables.execution_points(TARGET)
    run = executed_box.measure(bodies, TARGET.names, columns, TARGET.numpy())
    X, Y, A = (np.asarray(c, dtype=np.float32) for c in columns)
    truth = X.astype(np.float64) * Y + A
    f = np.float32
    constants = (f(1) + f(0.1) * A.astype(np.float64)).astype(np.float32), np.full_like(A, f(0.9))
    expected = {"pixel": (f(0.3) + X) * Y + f(0.7) * A,
                "material": ((1 + 0.1 * A.astype(np.float64)).astype(np.float32) * X) * Y + constants[1] * A}
    for name, values in expected.items():
        want = execution.errors(values, X, truth)
        assert run["errors"][name]["max_abs_error"] == want["max_abs_error"], name
    assert ("lavapipe" in run["how"]) == (execution.available() is None)


def test_a_cancelling_form_errs_as_executed_where_its_mathematics_does_not():
    """sqrt(a^2 + x) - a equals x / (sqrt(a^2 + x) + a) in real numbers; in float32 the first loses
    x's digits next to a in [1, 2] (about float32's unit of a, against values below 5e-4)."""
    if spirv_tools_missing():
        pytest.skip(spirv_tools_missing())
    x, y, a = sp.symbols("x y a", real=True)
    target = Target("stable", "x/(sqrt(a**2 + x) + a) + 0*y", (Axis("x", 0.0, 1e-3), Axis("y", 0.0, 1.0)),
                              Axis("a", 1.0, 2.0), "abs")
    bodies = {"cancelling": (several_variables.glsl_text(sp.sqrt(a ** 2 + x) - a), None),
              "stable": (several_variables.glsl_text(x / (sp.sqrt(a ** 2 + x) + a)), None)}
    run = executed_box.measure(bodies, target.names, several_variables.execution_points(target), target.numpy())
    assert run["errors"]["stable"]["max_abs_error"] < 1e-10
    assert run["errors"]["cancelling"]["max_abs_error"] > 3e-8


def test_float16_forms_of_several_variables_are_executed_and_costed_in_16_bits():
    """fp16: the numbers printed as float16's nearest values, the executed errors equal the
    per-operation float16 emulation's (and at least float16's rounding), a material form reads its
    push constants through float16_t(), and the 16-bit shader compiles where RADV runs."""
    if spirv_tools_missing():
        pytest.skip(spirv_tools_missing())
    x, y, a, c0 = sp.symbols("x y a c0", real=True)
    columns = several_variables.execution_points(TARGET)
    body = several_variables.glsl_text((sp.Float(0.3) + x) * y + sp.Float(0.7) * a, "fp16")
    assert body == "0.7001953125*a + y*(x + 0.300048828125)"
    run = executed_box.measure({"pixel": (body, None)}, TARGET.names, columns, TARGET.numpy(), 0.0, "fp16")
    X, Y, A = (np.asarray(c, dtype=np.float16) for c in columns)
    emulated = execution.emulate(body, dict(x=X, y=Y, a=A), "fp16")
    want = execution.errors(emulated, X, X.astype(np.float64) * Y + A)
    assert run["errors"]["pixel"]["max_abs_error"] == want["max_abs_error"] >= 2.0 ** -12
    assert several_variables.glsl_text(c0 * x, "fp16") == "float16_t(c0)*x"
    from pipeline.approximate.engines.options import available_architectures
    if "rdna3" in available_architectures():
        cycles, missing = several_variables.compile_forms({"m": (c0 * x * y + sp.Float(0.5) * y, "material")}, TARGET,
                                                   ["rdna3"], "fp16")
        assert "m" in cycles["rdna3"] and not missing
