"""The error bound on a GPU (`approximate.bounds`, `isa.special_functions`): the documented accuracies as
their sources state them, and their first-order propagation on planted forms whose bound is known
by hand."""

import math

import numpy as np
import pytest
import sympy as sp

from pipeline.approximate import targets
from pipeline.approximate.measures import bounds
from pipeline.isa import special_functions


def test_the_documented_accuracies_are_their_sources():
    vulkan = special_functions.accuracy("exp2", "intel", "fp32")
    assert (vulkan.ulps, vulkan.ulps_per_x, vulkan.source) == (3, 2, special_functions.VULKAN)
    assert special_functions.accuracy("exp2", "nvidia", "fp32").ulps == 2                  # ex2.approx.f32
    assert special_functions.accuracy("exp2", "amd", "fp32").ulps == 1                     # v_exp_f32
    log2 = special_functions.accuracy("log2", "arm", "fp16")
    assert log2.absolute == 2.0 ** -7 and (log2.lo, log2.hi) == (0.5, 2.0) and log2.ulps == 3
    assert special_functions.accuracy("acos", "intel", "fp32").ulps == 4096                # inherited from atan2
    for vendor in ("amd", "qualcomm", "arm"):                                       # Mesa's own lowering
        assert special_functions.accuracy("acos", vendor, "fp32").mesa
    assert not special_functions.accuracy("acos", "nvidia", "fp32").mesa
    assert special_functions.accuracy("pow", "intel", "fp32").text() == "inherited from exp2(y log2 x)"


X = sp.Symbol("x", real=True)


def bound(expression, vendor, precision, lo=0.0, hi=1.0):
    target = targets.from_expression("x", f"x={lo}:{hi}")
    x = bounds.grid(target)
    calls = bounds.sensitivities(expression, X, x)
    return bounds.propagated(calls, vendor, precision, bounds.scale_of(target, target.numpy(), x))


def test_a_single_call_is_bounded_by_its_accuracy_at_its_worst_input():
    """exp2(x) on [0, 1]: 1 ULP at 2 (AMD), (3 + 2) ULP at x = 1 (Vulkan's minimum), in float32's
    ULP of 2, 2^-22; 3 sqrt(x): three times 4.5 ULP of sqrt(1) = 1 (2^-23)."""
    assert bound(sp.Integer(2) ** X, "amd", "fp32") == 2.0 ** -22
    assert bound(sp.Integer(2) ** X, "intel", "fp32") == 5 * 2.0 ** -22
    assert bound(3 * sp.sqrt(X), "intel", "fp32") == pytest.approx(3 * 4.5 * 2.0 ** -23, rel=1e-12)


def test_pow_inherits_from_exp2_of_y_log2_x():
    """x^2.5 on [0.5, 1] in float16 (Vulkan): log2's 2^-7 absolute times 2.5 ln 2 x^2.5, plus exp2's
    (1 + 2 |2.5 log2 x|) ULP of x^2.5, largest at x = 1 (the ULP of 1 in float16 is 2^-10)."""
    x = np.linspace(0.5, 1.0, 20001)
    value = x ** 2.5
    expected = value * math.log(2) * 2.5 * 2.0 ** -7 + (1 + 2 * np.abs(2.5 * np.log2(x))) * \
        np.spacing(value.astype(np.float16)).astype(float)
    got = bound(X ** sp.Float(2.5), "arm", "fp16", 0.5, 1.0)
    assert got == pytest.approx(float(np.max(expected)), rel=2e-3)


def test_mesas_acos_adds_nothing_where_mesa_compiles_it():
    """acos on [0, 1]: executed by lavapipe with Mesa's lowering, as RADV compiles it (0 more), while
    NVIDIA's driver may err 4096 ULP of pi / 2 (Vulkan's minimum, inherited from atan2)."""
    assert bound(sp.acos(X), "amd", "fp32") == 0.0
    assert bound(sp.acos(X), "nvidia", "fp32") == 4096 * float(np.spacing(np.float32(math.pi / 2)))
    assert sorted(bounds.functions_used((1 - X) ** sp.Float(0.5) * sp.acos(X) + sp.exp(X))) == ["acos", "exp2", "sqrt"]
