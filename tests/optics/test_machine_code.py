"""The machine-code cost (`pipeline.optics.machine_code`): the parser on a listing written out here,
and, where Mesa's RADV compiler is installed (the Makefile installs Debian's mesa-vulkan-drivers
and libvulkan1 where it can), the compiled lobes themselves."""

import pytest

from pipeline.optics import machine_code, registry

LISTING = """
@@@ SHADER one
ACO shader stage: fragment_fs
BB0
	 v1: %5:v[0] = v_log_f32 %4:v[0]
After RA:
ACO shader stage: fragment_fs
BB0
	(  9 clk)   v0 = v_log_f32 v0
num_waves: 16
latency: 70.000000
wave64_per_cycle: 0.062500

Pixel Shader
disasm:
BB0:
	s_mov_b32 m0, s3                                            ; befd0003
	v_interp_p2_f32 v0, v2, v1, v0 wait_exp:7                   ; cd010700 04020302
	v_log_f32_e32 v0, v0                                        ; 7e004f00
	v_mul_f32_e32 v0, v0, v0                                    ; 10000002
	(then repeated 2 times)
	v_exp_f32_e32 v0, v0                                        ; 7e004b00
	exp mrt0 v0, v0, v0, v0 done                                ; f800080f 00000000
	s_endpgm                                                    ; bfb00000

@@@ END
"""


def test_the_parser_counts_by_kind_and_unfolds_repeats():
    shaders = machine_code.split_shaders(LISTING)
    assert list(shaders) == ["one"]
    parsed = machine_code.parse_fragment(shaders["one"])
    assert parsed["transcendental"] == 2 and parsed["vector_alu"] == 3 and parsed["scalar"] == 2
    assert parsed["other"] == 2             # the interpolation and the export
    assert parsed["instructions"] == 9 and parsed["latency_cycles"] == 70.0 and parsed["cycles_per_wave"] == 16.0


def test_a_listing_without_estimates_is_an_error():
    with pytest.raises(ValueError, match="perfinfo"):
        machine_code.parse_fragment(LISTING.replace("latency: 70.000000", ""))


@pytest.fixture(scope="module")
def compiled():
    try:
        machine_code.check_available()
    except (machine_code.CompilerMissing, machine_code.spirv.ToolMissing) as e:
        pytest.skip(f"machine-code cost not measured here: {e}")
    p = registry.Parameters(Q=0.64, slope=0.448, intercept=0.099, coef_scale=0.214, coef_offset=0.807)
    return machine_code.costs(p, (2, 3, 4, 8, 16))["rows"]


def test_pow_compiles_to_log_and_exp_on_every_chip(compiled):
    rows = [r for r in compiled if r["lobe"] == registry.REFERENCE and r["what"] == "lobe"]
    assert {r["family"] for r in rows} == set(machine_code.FAMILIES)
    for r in rows:
        ops = [line.split()[0] for line in r["listing"]]
        assert any(op.startswith("v_log_f32") for op in ops) and any(op.startswith("v_exp_f32") for op in ops), r["family"]


def test_no_power_of_the_family_holds_a_transcendental_instruction(compiled):
    family = [r for r in compiled if r["what"] == "family lobe"]
    assert {r["lobe"] for r in family} == {registry.family_name(m) for m in (2, 3, 4, 8, 16)}
    for r in family:
        assert r["transcendental"] == 0, (r["lobe"], r["family"], r["listing"])
    # The squarings are there: f_Q16's four multiplies after the base's multiply-add and clamp.
    rdna3 = {r["lobe"]: r for r in family if r["family"] == "gfx1100"}
    assert rdna3["f_Q16"]["net_vector_alu"] - rdna3["f_Q2"]["net_vector_alu"] == registry.multiplies(16) - 1


def test_the_check_can_fail_pow_of_16_keeps_its_transcendentals(tmp_path):
    """On this compiler pow(b, 16.0) stays log, multiply, exp: writing the squarings out matters."""
    try:
        icd = machine_code.check_available()
    except (machine_code.CompilerMissing, machine_code.spirv.ToolMissing) as e:
        pytest.skip(f"machine-code cost not measured here: {e}")
    body = "float b = max(k * t + (1.0 - k), 0.0);\n    return pow(b, 16.0);"
    machine_code.spirv_binary(machine_code.VERTEX, tmp_path, "vert.spv", "vert")
    machine_code.spirv_binary(machine_code.UNIFORM.format(body=body), tmp_path, "pow16.frag.spv")
    parsed = machine_code.parse_fragment(machine_code.split_shaders(
        machine_code.compile_family("gfx1100", tmp_path, icd))["pow16"])
    assert parsed["transcendental"] == 2


def test_the_stage_s_parts_compiled_apart_give_the_rows_of_one_compilation(compiled, tmp_path):
    """`gpu_isa` memoizes the registry's shaders and the family at each power apart: a first run
    compiles the registry and f_Q3 at once and stores them apart, a second run with f_Q16 added
    reads both and compiles f_Q16 alone. Merged, its rows equal those of one compilation of them
    all, in the same order."""
    from pipeline.engine.cache import Cache, Memo
    from pipeline.stages import gpu_isa

    cache = Cache(tmp_path)
    gpu_isa.run({"lobe.power": 3, "front.powers": [3]}, {}, Memo(cache))
    memo = Memo(cache)
    out = gpu_isa.run({"lobe.power": 16, "front.powers": [3]}, {}, memo)
    assert memo.reused == ["machine_code_registry", "machine_code_family"]
    assert memo.computed == ["machine_code_family"]
    others = {registry.family_name(m) for m in (2, 4, 8)}
    assert out["rows"] == [r for r in compiled if not (r["lobe"] in others and r["what"] in ("family lobe", "NDF"))]
