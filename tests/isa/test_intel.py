"""Intel's machine code of the lobes: each operation is printed as the OpenCL C function a driver
uses and compiled to the EU instructions its expression needs on every architecture (pow: one
math.pow on Gen9, a log, a multiply and an exp on Xe; the clamped square: no extended math), a
changed operation changes the count, and Mesa's occupancy model gives the cycles its rule says."""

import pytest

from pipeline.isa import intel, lowering, machine_code
from pipeline.optics import registry, spirv

INTEL = [a.name for a in machine_code.ARCHITECTURES.values() if a.vendor == "intel"]
BODIES = {
    "pow": "return pow(t, n);",
    "square": "float b = max(k * t + (1.0 - k), 0.0);\n    return b * b;",
    "exp2": "return exp2(rate * t - rate);",
    "schlick": "return t / (n - n * t + t);",
    "roots": "return sqrt(t) * inversesqrt(t + rate);",
}


def test_the_opencl_text_names_the_driver_s_functions():
    ops, result = lowering.operations(spirv.optimized_disassembly(machine_code.UNIFORM.format(
        body="return pow(t, n) + exp(t) + clamp(t, 0.0, rate) / sqrt(t);")))
    text = intel.kernel("k", ops, result)
    for name in ("native_powr(", "native_exp(", "fmin(fmax(", "native_divide(", "native_sqrt(",
                 "intel_reqd_sub_group_size(16)"):
        assert name in text, name


def test_mesa_s_occupancy_model_on_a_planted_listing():
    """SIMD16 float instructions are 2 GRFs: a mad occupies the FPU 4 cycles, a math.exp the math
    unit 8 and the front end 6, a math.pow the math unit 16; a scalar (1|M0) add 2; the harness's
    integer address arithmetic and sends count nothing."""
    listing = ["(W)     add (1|M0)   r3.0<1>:f   -r5.4<0;1,0>:f   1.0:f",
               "add (16|M0)   r7.0<1>:d   r7.0<8;8,1>:d   r4.0<0;1,0>:d",
               "send (16|M0)   r121:w   r9   0xC   0x04205E00",
               "mad (16|M0)   r119.0<1>:f   r3.0<0;0>:f   r121.0<2;1>:f   r5.4<0>:f",
               "math.exp (16|M0)   r17.0<1>:f   r15.0<8;8,1>:f",
               "math.pow (16|M0)   r13.0<1>:f   r11.0<8;8,1>:f   r5.4<0;1,0>:f"]
    c = intel.count(listing)
    assert (c["fpu"], c["math"], c["pow"], c["other"]) == (2, 1, 1, 0)
    assert (c["busy_fpu"], c["busy_math"], c["busy_front"]) == (2 + 4, 8 + 16, 2 + 4 + 6 + 6)
    assert intel.cycles(c) == 24.0


@pytest.fixture(scope="module")
def compiled():
    try:
        intel.tools()
    except intel.CompilerMissing as e:
        pytest.skip(f"Intel machine code not measured here: {e}")
    sources = {name: machine_code.UNIFORM.format(body=body) for name, body in BODIES.items()}
    sources["wrapper"] = machine_code.WRAPPER_UNIFORM
    for lobe in registry.LOBES.values():
        sources[f"lobe_{lobe.key}"] = machine_code.UNIFORM.format(body=lobe.glsl_of(registry.Parameters(power=2)))
    return machine_code.compile_shaders(sources, dict.fromkeys(sources, "wrapper"), INTEL)["rows"]


def ops(row):
    return [intel._instruction(line)[0] for line in row["listing"]]


def test_every_architecture_compiles(compiled):
    assert list(compiled) == INTEL == ["xe_hpg", "xe_lp", "gen9"]


def test_pow_is_math_pow_on_gen9_and_log_multiply_exp_on_xe_and_the_square_has_no_extended_math(compiled):
    assert ops(compiled["gen9"]["pow"]).count("math.pow") == 1
    for arch in ("xe_hpg", "xe_lp"):
        assert {"math.log", "math.exp"} <= set(ops(compiled[arch]["pow"])) and "math.pow" not in ops(compiled[arch]["pow"])
    for arch, rows in compiled.items():
        assert rows["square"]["special"] == 0 and rows["square"]["net_fpu"] >= 3, (arch, rows["square"]["listing"])
        assert "math.exp" in ops(rows["exp2"]) and rows["exp2"]["special"] == 1, arch
        assert rows["schlick"]["special"] == 1, (arch, rows["schlick"]["listing"])      # the division


def test_no_pow_free_registry_lobe_holds_a_logarithm(compiled):
    for arch, rows in compiled.items():
        for lobe in registry.LOBES.values():
            has_pow = "pow(" in lobe.glsl_of(registry.Parameters(power=2))
            listing = ops(rows[f"lobe_{lobe.key}"])
            assert ("math.log" in listing or "math.pow" in listing) == has_pow, (arch, lobe.key)


def test_the_counts_follow_the_operations(compiled):
    """pow against the square it stands in for: extended math where the square has none; by
    Mesa's model the exp2 form (one mad, one math.exp) is cheapest, the square next and pow last."""
    for arch, rows in compiled.items():
        assert rows["pow"]["special"] > rows["square"]["special"] == 0
        assert rows["exp2"]["cycles"] < rows["square"]["cycles"] < rows["pow"]["cycles"], arch
