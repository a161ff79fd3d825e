"""Mali machine code of the lobes by Mesa's panfrost compiler (Bifrost on G72, Valhall on G610):
the compiler's statistics and final listing read from what Mesa prints, pow compiled to FLOGD,
FEXP and conversions, the clamped square without the transcendental unit, no pow-free registry
lobe with a logarithm, and the cycles as the compiler's arithmetic estimate net of the wrapper's, per
64 threads."""

import pytest

from pipeline.isa import gles, machine_code, mali
from pipeline.optics import registry

MALI = [a.name for a in machine_code.ARCHITECTURES.values() if a.vendor == "arm"]
BODIES = {
    "pow": "return pow(t, n);",
    "square": "float b = max(k * t + (1.0 - k), 0.0);\n    return b * b;",
    "exp2": "return exp2(rate * t - rate);",
    "log": "return log(t);",
}
VALHALL = """block0 {
   r0 = FMA.f32 r1, u0, u1
}
   LD_VAR_BUF_IMM.f32.slot0.src_f32.center.store.wait0 @r1, ^r61, index:0x0
   FREXPE.f32.log.discard r0, r1
   S32_TO_F32 r0, ^r0
   FLOGD.f32 r3, r1
   FMA.f32 r0, ^r3, ^r2, ^r0
   FEXP.f32.wait0126 r0, ^r2, ^r0
   ATEST.wait0 @r60, ^r60, 0x0, atest_datum.w0
   MOV.i32 r2, 0x0
   BLEND.slot2.v4.f32.end @r0:r1:r2:r3, blend_descriptor_0.w0, r60, target:0x0

SHADER-DB: MESA_SHADER_FRAGMENT shader: 18 inst, 1.000000 cycles, 0.046875 fma, 0.140625 cvt, 0.125000 sfu, 0.125000 v, \
0.000000 t, 1.000000 ls, 16 quadwords, 2 threads, 0 loops, 0:0 spills:fills""".splitlines()
BIFROST = """slot 0 reads: r0
clause_0:
ds(0) nbb vary td ncph next_attr dwb(0)
{
    *NOP t0
    +LD_VAR_IMM.store.f32.center t1, #0.y, index:0, @r1
}
clause_1:
{
    *FMA.f32 t0, t1, t0, r0
    +FEXP.f32 r0:t1, t1, t0
}
SHADER-DB: MESA_SHADER_FRAGMENT shader: 12 inst, 10 tuples, 5 clauses, 2.000000 cycles, 0.208333 arith, 0.000000 \
texture, 0.125000 vary, 2.000000 ldst, 17 quadwords, 1 threads, 0 loops, 0:0 spills:fills""".splitlines()


def test_the_statistics_and_the_final_listing_are_read():
    v = mali.parse(VALHALL)
    assert [mali.opcode(line) for line in v["listing"]][:3] == ["LD_VAR_BUF_IMM", "FREXPE", "S32_TO_F32"]
    assert (v["arith"], v["sfu"], v["cvt"], v["inst"]) == (1, 2, 2, 18)
    assert (v["fma_cycles"], v["cvt_cycles"], v["sfu_cycles"]) == (0.046875, 0.140625, 0.125)
    b = mali.parse(BIFROST)
    assert (b["arith"], b["sfu"], b["cvt"], b["arith_cycles"]) == (1, 1, 0, 0.208333)
    assert (b["fma_slot"], b["add_slot"]) == (1, 1)         # the varying's load is the harness's


def test_the_cost_is_the_busiest_unit_net_of_the_wrapper_s_on_valhall_and_the_busier_slot_on_bifrost():
    v = mali.parse(VALHALL)
    wrapper = dict(v, fma_cycles=0.0, cvt_cycles=0.078125, sfu_cycles=0.0, arith=0, sfu=0, cvt=0, inst=8)
    row = mali.net(v, wrapper, "0xa867")
    assert row["cycles"] == 8.0 and (row["instructions"], row["special"]) == (5, 2)     # 64 x the SFU's 2 / 16
    b = mali.parse(BIFROST)
    wrapper = dict(b, fma_slot=0, add_slot=0, arith_cycles=0.208333)       # the same tuple count: no net tuple
    assert mali.net(b, wrapper, "0x6221")["cycles"] == pytest.approx(64 / 24, abs=1e-3)
    assert mali.net(dict(b, fma_slot=3), wrapper, "0x6221")["cycles"] == pytest.approx(3 * 64 / 24, abs=1e-3)


def test_statistics_missing_is_an_error():
    with pytest.raises(ValueError, match="no statistics"):
        mali.parse(VALHALL[:-1])


@pytest.fixture(scope="module")
def compiled():
    try:
        gles.tools()
    except gles.CompilerMissing as e:
        pytest.skip(f"Mali machine code not measured here: {e}")
    sources = {name: machine_code.UNIFORM.format(body=body) for name, body in BODIES.items()}
    sources["wrapper"] = machine_code.WRAPPER_UNIFORM
    for lobe in registry.LOBES.values():
        sources[f"lobe_{lobe.key}"] = machine_code.UNIFORM.format(body=lobe.glsl_of(registry.Parameters(power=2)))
    return machine_code.compile_shaders(sources, dict.fromkeys(sources, "wrapper"), MALI)["rows"]


def ops(row):
    return [mali.opcode(line) for line in row["listing"]]


def test_every_architecture_compiles(compiled):
    assert list(compiled) == MALI == ["g610", "g72"]


def test_pow_is_a_log_an_exp_and_conversions_and_the_square_has_no_transcendental(compiled):
    for arch, rows in compiled.items():
        assert {"FLOGD", "FEXP"} <= set(ops(rows["pow"])) and rows["pow"]["net_cvt"] >= 2, (arch, rows["pow"]["listing"])
        assert rows["square"]["special"] == 0 and rows["square"]["instructions"] >= 2, (arch, rows["square"]["listing"])
        assert "FEXP" in ops(rows["exp2"]) and "FLOGD" not in ops(rows["exp2"]) and rows["exp2"]["special"] == 1


def test_no_pow_free_registry_lobe_holds_a_logarithm(compiled):
    for arch, rows in compiled.items():
        for lobe in registry.LOBES.values():
            has_pow = "pow(" in lobe.glsl_of(registry.Parameters(power=2))
            assert ("FLOGD" in ops(rows[f"lobe_{lobe.key}"])) == has_pow, (arch, lobe.key)


def test_the_counts_follow_the_operations(compiled):
    """More operations of a kind cost more: pow over exp2, the cube over the square (on Bifrost too,
    where the compiler's own tuple count can say otherwise)."""
    cube = machine_code.UNIFORM.format(body="float b = max(k * t + (1.0 - k), 0.0);\n    return b * b * b;")
    cubes = machine_code.compile_shaders({"cube": cube, "wrapper": machine_code.WRAPPER_UNIFORM},
                                         {"cube": "wrapper"}, MALI)["rows"]
    for arch, rows in compiled.items():
        assert rows["pow"]["special"] > rows["exp2"]["special"] > rows["square"]["special"] == 0
        assert rows["exp2"]["cycles"] < rows["pow"]["cycles"], arch
        assert cubes[arch]["cube"]["cycles"] > rows["square"]["cycles"], (arch, cubes[arch]["cube"]["listing"])


def test_on_bifrost_a_natural_log_needs_the_tuples_of_pow(compiled):
    """ln t is FLOGD's log2 and a multiply by ln 2 on the FMA unit; pow's multiply folds into the
    exp's FMA_RSCALE: four FMA-slot operations each, so the two cost alike on G72."""
    rows = compiled["g72"]
    assert "FLOGD" in ops(rows["log"]) and "FEXP" not in ops(rows["log"])
    assert rows["log"]["net_fma_slot"] == rows["pow"]["net_fma_slot"] == 4
    assert rows["log"]["cycles"] == rows["pow"]["cycles"]
