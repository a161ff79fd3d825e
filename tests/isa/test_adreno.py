"""Adreno machine code of the lobes by Mesa's freedreno compiler (ir3): ir3's statistics and
listing read from what Mesa prints, pow compiled to log2, a multiply and exp2 on a630 and a740, the
clamped square without the special-function unit, no pow-free registry lobe with a logarithm, a
changed operation changing the count, and the cycles as ir3's issue slots and stalls."""

import pytest

from pipeline.isa import adreno, gles, machine_code
from pipeline.optics import registry

ADRENO = [a.name for a in machine_code.ARCHITECTURES.values() if a.vendor == "qualcomm"]
BODIES = {
    "pow": "return pow(t, n);",
    "square": "float b = max(k * t + (1.0 - k), 0.0);\n    return b * b;",
    "exp2": "return exp2(rate * t - rate);",
    "schlick": "return t / (n - n * t + t);",
}
PRINTED = """MESA: info: Native code for unnamed FRAG shader GLSL3 with sha1 f46af7cc:
MESA: info: SIMD0
MESA: info: ; num_ubos:           0
MESA: info: @in(r0.x)\tin0 (wrmask=0x3)
MESA: info: bary.f (ei)r0.w, 0, r0.x
MESA: info: (rpt3)nop
MESA: info: log2 r1.z, r0.w
MESA: info: (ss)(nop3) mul.f r1.z, r1.z, c0.x
MESA: info: (rpt2)nop
MESA: info: exp2 r0.z, r1.z
MESA: info: (ss)end
MESA: info: nop
MESA: info: ; FRAG: outputs: r0.z (FRAG_RESULT_DATA0)
MESA: info: ; FRAG prog 6/1: 17 instr, 10 nops, 7 non-nops, 2 mov, 0 cov, 32 dwords
MESA: info: ; FRAG prog 6/1: 0 last-baryf, 0 last-helper, 0 half, 2 full, 0 constlen
MESA: info: ; FRAG prog 6/1: 11 cat0, 2 cat1, 2 cat2, 0 cat3, 2 cat4, 0 cat5, 0 cat6, 0 cat7
MESA: info: ; FRAG prog 6/1: 10 sstall, 2 (ss), 3 systall, 0 (sy), 0 loops
MESA: info: ; pos (ij_pixel): r0.x
MESA: info: Native code for unnamed VERT shader TTN2 with sha1 fc642ddb:
MESA: info: ; VERT prog 2/1: 1 instr, 0 nops, 1 non-nops, 0 mov, 0 cov, 32 dwords
""".splitlines()


def test_ir3_s_statistics_and_listing_are_read_and_costed():
    parsed = adreno.parse(PRINTED)
    assert (parsed["issue"], parsed["nop"], parsed["mov"], parsed["alu"], parsed["mad"], parsed["sfu"]) == (17, 10, 2, 2, 0, 2)
    assert (parsed["sstall"], parsed["systall"]) == (10, 3)
    assert [adreno.opcode(line) for line in parsed["listing"]] == ["bary.f", "nop", "log2", "mul.f", "nop", "exp2",
                                                                    "end", "nop"]
    wrapper = dict(parsed, issue=6, nop=1, alu=1, sfu=0, sstall=0, systall=0, mov=3)
    row = adreno.net(parsed, wrapper, "630")
    assert (row["instructions"], row["special"], row["cycles"]) == (1 + 2, 2, 11 + 10 + 3)


def test_a_listing_without_statistics_is_an_error():
    with pytest.raises(ValueError, match="no statistics"):
        adreno.parse([line for line in PRINTED if "cat0" not in line and "instr" not in line])
    with pytest.raises(ValueError, match="no fragment shader listing"):
        adreno.parse(PRINTED[-2:])


@pytest.fixture(scope="module")
def compiled():
    try:
        gles.tools()
    except gles.CompilerMissing as e:
        pytest.skip(f"Adreno machine code not measured here: {e}")
    sources = {name: machine_code.UNIFORM.format(body=body) for name, body in BODIES.items()}
    sources["wrapper"] = machine_code.WRAPPER_UNIFORM
    for lobe in registry.LOBES.values():
        sources[f"lobe_{lobe.key}"] = machine_code.UNIFORM.format(body=lobe.glsl_of(registry.Parameters(power=2)))
    return sources, machine_code.compile_shaders(sources, dict.fromkeys(sources, "wrapper"), ADRENO)["rows"]


def ops(row):
    return [adreno.opcode(line) for line in row["listing"]]


def test_every_architecture_compiles(compiled):
    assert list(compiled[1]) == ADRENO == ["a740", "a630"]


def test_pow_is_log2_multiply_exp2_and_the_square_has_no_special_function(compiled):
    for arch, rows in compiled[1].items():
        assert {"log2", "mul.f", "exp2"} <= set(ops(rows["pow"])) and rows["pow"]["special"] == 2, arch
        assert rows["square"]["special"] == 0 and rows["square"]["instructions"] >= 3, (arch, rows["square"]["listing"])
        assert "exp2" in ops(rows["exp2"]) and "log2" not in ops(rows["exp2"]) and rows["exp2"]["special"] == 1
        assert "rcp" in ops(rows["schlick"]), (arch, rows["schlick"]["listing"])           # the division


def test_no_pow_free_registry_lobe_holds_a_logarithm(compiled):
    for arch, rows in compiled[1].items():
        for lobe in registry.LOBES.values():
            has_pow = "pow(" in lobe.glsl_of(registry.Parameters(power=2))
            assert ("log2" in ops(rows[f"lobe_{lobe.key}"])) == has_pow, (arch, lobe.key)


def test_the_counts_follow_the_operations(compiled):
    """pow waits on two SFU results where exp2 waits on one and the square on none."""
    for arch, rows in compiled[1].items():
        assert rows["pow"]["special"] > rows["exp2"]["special"] > rows["square"]["special"] == 0
        assert max(rows["exp2"]["cycles"], rows["square"]["cycles"]) < rows["pow"]["cycles"], arch


def test_a_compiled_shader_is_not_compiled_again(compiled, monkeypatch):
    def refuse(*args, **kwargs):
        raise AssertionError("the compiler ran again")

    monkeypatch.setattr(gles.toolchains, "qemu", refuse)
    sources, rows = compiled
    again = machine_code.compile_shaders(sources, dict.fromkeys(sources, "wrapper"), ADRENO)["rows"]
    assert again == rows
