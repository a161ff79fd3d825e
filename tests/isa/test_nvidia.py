"""NVIDIA's machine code of the lobes: the shader's SPIR-V read as scalar operations computes what
its GLSL says (numpy twins), each operation is lowered to the SASS its expression needs on every
architecture (pow: a log, a multiply and an exp; the clamped square: no special function), a
changed operation changes the count, and the throughput model gives the cycles its table says."""

import numpy as np
import pytest

from pipeline.isa import lowering, nvidia
from pipeline.isa import machine_code
from pipeline.optics import registry, spirv

NVIDIA = [a.name for a in machine_code.ARCHITECTURES.values() if a.vendor == "nvidia"]
T = np.linspace(0.01, 1.0, 97, dtype=np.float32)
UNIFORMS = {(0,): 37.0, (1,): 18.6, (2,): 0.35}          # n, k, rate
N, K, RATE = (np.float32(UNIFORMS[(i,)]) for i in range(3))
# GLSL bodies covering every lowered operation, each with an independent numpy twin.
BODIES = {
    "pow": ("return pow(t, n);", lambda t: t ** N),
    "square": ("float b = max(k * t + (1.0 - k), 0.0);\n    return b * b;", lambda t: np.maximum(K * t + 1 - K, 0) ** 2),
    "exp2": ("return exp2(rate * t - rate);", lambda t: np.exp2(RATE * t - RATE)),
    "schlick": ("return t / (n - n * t + t);", lambda t: t / (N - N * t + t)),
    "exp_log": ("return exp(log(t) * rate) + log2(t + 1.0);", lambda t: np.exp(np.log(t) * RATE) + np.log2(t + 1)),
    "roots": ("return sqrt(t) * inversesqrt(t + rate);", lambda t: np.sqrt(t) / np.sqrt(t + RATE)),
    "trig": ("return abs(sin(n * t)) + cos(t);", lambda t: np.abs(np.sin(N * t)) + np.cos(t)),
    "clamp": ("return clamp(fma(k, t, -rate), 0.0, 1.0) - min(t, rate);",
              lambda t: np.clip(K * t - RATE, 0, 1) - np.minimum(t, RATE)),
    "select": ("return t > 0.5 ? sqrt(t) : -t * t;", lambda t: np.where(t > 0.5, np.sqrt(t), -t * t)),
}


def lowered(body):
    return lowering.operations(spirv.optimized_disassembly(machine_code.UNIFORM.format(body=body)))


@pytest.mark.parametrize("name", BODIES)
def test_the_operations_read_from_spirv_compute_the_glsl(name):
    body, twin = BODIES[name]
    ops, result = lowered(body)
    got = lowering.evaluate(ops, result, {"t": T}, UNIFORMS)
    # float32 arithmetic on both sides, in other orders: a few ulps, and exp/pow amplify by |x|.
    np.testing.assert_allclose(got, twin(T), rtol=2e-5, atol=1e-6)


def test_an_operation_without_a_lowering_is_named():
    with pytest.raises(lowering.LoweringError, match="GLSL.std.450 function Tanh"):
        lowered("return tanh(t);")


@pytest.fixture(scope="module")
def compiled():
    try:
        nvidia.tools()
    except nvidia.CompilerMissing as e:
        pytest.skip(f"NVIDIA machine code not measured here: {e}")
    sources = {name: machine_code.UNIFORM.format(body=body) for name, (body, _) in BODIES.items()}
    sources["wrapper"] = machine_code.WRAPPER_UNIFORM
    for lobe in registry.LOBES.values():
        sources[f"lobe_{lobe.key}"] = machine_code.UNIFORM.format(body=lobe.glsl_of(registry.Parameters(power=2)))
    sources["per_pixel"] = machine_code.PER_PIXEL.format(body="return pow(t, n);", parameter="n", coef="n + 2.0")
    sources["wrapper_per_pixel"] = machine_code.WRAPPER_PER_PIXEL
    wrappers = dict.fromkeys(sources, "wrapper") | {"per_pixel": "wrapper_per_pixel"}
    return machine_code.compile_shaders(sources, wrappers, NVIDIA)["rows"]


def ops(row):
    return [line.split()[0] for line in row["listing"]]


def test_every_architecture_compiles(compiled):
    assert list(compiled) == NVIDIA == ["sm_120", "sm_90", "sm_89", "sm_86", "sm_75"]


def test_n_per_pixel_adds_its_arithmetic_and_not_its_load(compiled):
    """pow(t, n) times n + 2 with n a varying: one add and one multiply more than pow with n a
    uniform; loading the varying is the harness's, as the wrapper's is."""
    for arch, rows in compiled.items():
        assert rows["per_pixel"]["net_mufu"] == rows["pow"]["net_mufu"] == 2, arch
        assert rows["per_pixel"]["net_fma"] - rows["pow"]["net_fma"] in (1, 2), (arch, rows["per_pixel"]["listing"])


def test_pow_is_a_log_a_multiply_and_an_exp_and_the_square_has_no_special_function(compiled):
    for arch, rows in compiled.items():
        assert ops(rows["pow"]).count("MUFU.LG2") == 1 and ops(rows["pow"]).count("MUFU.EX2") == 1, arch
        assert rows["pow"]["net_mufu"] == 2 and rows["pow"]["net_fma"] == 1, (arch, rows["pow"]["listing"])
        assert rows["square"]["net_mufu"] == 0 and rows["square"]["net_alu"] == 1, (arch, rows["square"]["listing"])
        assert rows["exp2"]["net_mufu"] == 1 and "MUFU.EX2" in ops(rows["exp2"]), arch
        assert "MUFU.RCP" in ops(rows["schlick"]), arch           # the division, as a reciprocal
        assert {"MUFU.SIN", "MUFU.COS"} <= set(ops(rows["trig"])), arch
        assert {"MUFU.SQRT", "MUFU.RSQ"} <= set(ops(rows["roots"])), arch


def test_no_pow_free_registry_lobe_holds_a_logarithm(compiled):
    for arch, rows in compiled.items():
        for lobe in registry.LOBES.values():
            has_pow = "pow(" in lobe.glsl_of(registry.Parameters(power=2))
            assert ("MUFU.LG2" in ops(rows[f"lobe_{lobe.key}"])) == has_pow, (arch, lobe.key)


def test_the_counts_follow_the_operations(compiled):
    """pow against the square it stands in for: two special-function results more, on every chip;
    the model's cycles rank the square first (the MUFU pipe runs 16 results per clock per SM)."""
    for arch, rows in compiled.items():
        assert rows["pow"]["net_mufu"] - rows["square"]["net_mufu"] == 2
        assert rows["square"]["cycles"] < rows["exp2"]["cycles"] < rows["pow"]["cycles"], arch


def test_the_throughput_model_on_planted_counts():
    # Turing: 64 FP32 results per clock per SM, 16 per sub-partition: 2 cycles a warp instruction.
    assert nvidia.cycles(dict(fma=3, alu=1, mufu=0, other=0), "sm_75") == 6.0
    # Ampere: FP32 twice as wide; the issue slots (4) bind.
    assert nvidia.cycles(dict(fma=3, alu=1, mufu=0, other=0), "sm_86") == 4.0
    # One MUFU result: 32 lanes at 4 per clock per sub-partition.
    assert nvidia.cycles(dict(fma=1, alu=0, mufu=1, other=0), "sm_90") == 8.0
