"""AMD's machine code (`pipeline.isa.radv`) and the rows every back end gives
(`pipeline.isa.machine_code`): the parser on a listing written out here, and, where Mesa's RADV
compiler is installed (the Makefile installs Debian's mesa-vulkan-drivers and libvulkan1 where it
can), the compiled lobes themselves."""

import re

import numpy as np
import pytest

from pipeline.isa import machine_code, radv
from pipeline.optics import registry
from pipeline.optics.spirv import ToolMissing

AMD = [a.name for a in machine_code.ARCHITECTURES.values() if a.vendor == "amd"]

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
    shaders = radv.split_shaders(LISTING)
    assert list(shaders) == ["one"]
    parsed = radv.parse_fragment(shaders["one"])
    assert parsed["transcendental"] == 2 and parsed["vector_alu"] == 3 and parsed["scalar"] == 2
    assert parsed["other"] == 2             # the interpolation and the export
    assert parsed["listing_length"] == 9 and parsed["latency_cycles"] == 70.0 and parsed["cycles_per_wave"] == 16.0


def test_a_listing_without_estimates_is_an_error():
    with pytest.raises(ValueError, match="perfinfo"):
        radv.parse_fragment(LISTING.replace("latency: 70.000000", ""))


@pytest.fixture(scope="module")
def compiled():
    try:
        radv.check_available()
    except (machine_code.CompilerMissing, ToolMissing) as e:
        pytest.skip(f"machine-code cost not measured here: {e}")
    p = registry.Parameters(Q=0.64, slope=0.448, intercept=0.099, coef_scale=0.214, coef_offset=0.807)
    return machine_code.costs(p, (2, 3, 4, 8, 16))["rows"]


def test_pow_compiles_to_log_and_exp_on_every_chip(compiled):
    rows = [r for r in compiled if r["lobe"] == registry.REFERENCE and r["what"] == "lobe"]
    assert {r["architecture"] for r in rows if r["vendor"] == "amd"} == set(AMD)
    for r in (r for r in rows if r["vendor"] == "amd"):
        ops = [line.split()[0] for line in r["listing"]]
        assert any(op.startswith("v_log_f32") for op in ops) and any(op.startswith("v_exp_f32") for op in ops), r["family"]


def test_no_power_of_the_family_holds_a_transcendental_instruction(compiled):
    family = [r for r in compiled if r["what"] == "family lobe" and r["vendor"] == "amd"]
    assert {r["lobe"] for r in family} == {registry.family_name(m) for m in (2, 3, 4, 8, 16)}
    for r in family:
        assert r["transcendental"] == 0, (r["lobe"], r["family"], r["listing"])
    # The squarings are there: f_Q16's four multiplies after the base's multiply-add and clamp.
    rdna3 = {r["lobe"]: r for r in family if r["architecture"] == "rdna3"}
    assert rdna3["f_Q16"]["net_vector_alu"] - rdna3["f_Q2"]["net_vector_alu"] == registry.multiplies(16) - 1


def test_the_check_can_fail_pow_of_16_keeps_its_transcendentals(tmp_path):
    """On this compiler pow(b, 16.0) stays log, multiply, exp: writing the squarings out matters."""
    try:
        icd = radv.check_available()
    except (machine_code.CompilerMissing, ToolMissing) as e:
        pytest.skip(f"machine-code cost not measured here: {e}")
    body = "float b = max(k * t + (1.0 - k), 0.0);\n    return pow(b, 16.0);"
    radv.spirv_binary(radv.VERTEX, tmp_path, "vert.spv", "vert")
    radv.spirv_binary(machine_code.UNIFORM.format(body=body), tmp_path, "pow16.frag.spv")
    parsed = radv.parse_fragment(radv.split_shaders(radv.compile_family("gfx1100", tmp_path, icd))["pow16"])
    assert parsed["transcendental"] == 2


def test_radv_s_running_process_compiles_a_later_folder_as_a_fresh_one_does(tmp_path, monkeypatch):
    """Each family's `vulkan_pipeline.py` is kept running (`compiler_process`): a second folder goes
    to the same process, its listings parse as a fresh process's, and each batch names the device;
    a folder that does not exist ends the process with the driver's words, and the next batch
    starts another."""
    from pipeline.isa import compiler_process

    try:
        icd = radv.check_available()
    except (machine_code.CompilerMissing, ToolMissing) as e:
        pytest.skip(f"machine-code cost not measured here: {e}")
    monkeypatch.setattr(compiler_process, "_RUNNING", {})
    folders = [tmp_path / "a", tmp_path / "b"]
    bodies = ["return k * t;", "float b = max(k * t + (1.0 - k), 0.0);\n    return pow(b, 16.0);"]
    for folder, body in zip(folders, bodies):
        folder.mkdir()
        radv.spirv_binary(radv.VERTEX, folder, "vert.spv", "vert")
        radv.spirv_binary(machine_code.UNIFORM.format(body=body), folder, "one.frag.spv")
    try:
        first = radv.compile_family("vega10", folders[0], icd)
        (running,) = compiler_process._RUNNING.values()
        second = radv.compile_family("vega10", folders[1], icd)
        again = radv.compile_family("vega10", folders[0], icd)
        assert list(compiler_process._RUNNING.values()) == [running] and running.alive()
        assert all("@@@ DEVICE " in text for text in (first, second, again))
        compiler_process.close_all()
        fresh = radv.compile_family("vega10", folders[0], icd)
        parsed = [radv.parse_fragment(radv.split_shaders(text)["one"]) for text in (first, again, fresh)]
        assert parsed[0] == parsed[1] == parsed[2]
        assert radv.parse_fragment(radv.split_shaders(second)["one"])["transcendental"] == 2
        with pytest.raises(machine_code.CompilerMissing, match=r"RADV could not compile for vega10 \(exit 1\): (.|\n)*No such file"):
            radv.compile_family("vega10", tmp_path / "missing", icd)
        assert radv.split_shaders(radv.compile_family("vega10", folders[1], icd)).keys() == {"one"}
    finally:
        compiler_process.close_all()


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


def test_every_row_has_the_fields_every_vendor_gives(compiled):
    """architecture, vendor, n_per, instructions, cycles, cost_model on every row; for AMD the
    common fields are the vendor's own (ACO's net cycles; vector ALU and transcendental, net)."""
    for r in compiled:
        assert {"architecture", "vendor", "family", "n_per", "instructions", "special", "cycles", "cost_model"} <= set(r)
        assert r["architecture"] in machine_code.ARCHITECTURES and r["n_per"] in ("material", "pixel")
        if r["vendor"] == "amd":
            assert r["cycles"] == r["net_cycles_per_wave"] and r["cost_model"] == "aco-perfinfo"
            assert r["instructions"] == r["net_vector_alu"] + r["net_transcendental"]
    pixel = [r for r in compiled if r["what"] == "lobe and coef, n per pixel"]
    assert pixel and all(r["n_per"] == "pixel" for r in pixel)


def test_every_input_of_a_form_is_interpolated_none_folded():
    """A form of three inputs (the most a derived form reads: two variables and the parameter) costs
    what its arithmetic costs on every architecture: 1 / (0.7 z (x + y)) holds a reciprocal, a multiply
    and an add. RADV links each fragment shader to `radv.VERTEX`, which writes four outputs: an input
    it did not write would be a constant, the form folded to nothing (as rcp(0))."""
    from pipeline.approximate import engines

    available = [a for a in ("rdna3", "gcn5", "sm_89", "xe_hpg", "g610", "a740") if a in engines.available_architectures()]
    if not available:
        pytest.skip("no GPU compiler runs here")
    names = ["x", "y", "z"]
    cycles, missing, _ = machine_code.form_cycles({"three": ("return 1.0 / (0.7 * z * (x + y));", names)},
                                                  names, available)
    assert not missing
    for a in available:
        assert cycles[a]["three"] >= 3, (a, cycles[a])            # (at least its three operations' issue)
    assert radv.VERTEX.count("layout(location") >= 3


def test_a_form_a_back_end_cannot_lower_is_left_out_and_the_rest_compiled_in_halves(monkeypatch):
    """A constant form (`return 0.5;`: the NVIDIA and Intel back ends read no operation that writes the
    output) among 15 others: it alone is left out with its reason, every other form costs what it
    costs in a batch without it, and the batches are halves of halves (at most 1 + 2 log2(16) = 9
    compilations), not the 17 of one batch and then each form alone."""
    from pipeline.approximate import engines

    available = [a for a in ("sm_89", "xe_hpg") if a in engines.available_architectures()]
    if not available:
        pytest.skip("neither NVIDIA's nor Intel's compiler runs here")
    bodies = {f"f{i}": (f"return x * (x + {i + 1}.0);", ["x"]) for i in range(15)}
    clean, missing, _ = machine_code.form_cycles(bodies, ["x"], available)
    assert not missing
    bodies = dict(list(bodies.items())[:6]) | {"constant": ("return 0.5;", ["x"])} | dict(list(bodies.items())[6:])
    batches = []
    compile_shaders = machine_code.compile_shaders
    monkeypatch.setattr(machine_code, "compile_shaders",
                        lambda sources, *args: batches.append(len(sources)) or compile_shaders(sources, *args))
    cycles, missing, _ = machine_code.form_cycles(bodies, ["x"], available)
    assert missing == {"constant": "the shader writes no output"}
    assert cycles == clean
    assert len(batches) <= 9, batches


def test_an_unknown_architecture_is_named():
    with pytest.raises(ValueError, match="unknown GPU architecture 'gfx1100'; the architectures are rdna3, rdna2"):
        machine_code.compile_shaders({"w": machine_code.WRAPPER_UNIFORM}, {}, ("gfx1100",))


class _Counting:
    """A back end that records what it is asked to compile."""

    TOOL = "shader_tools"
    calls: list = []

    @staticmethod
    def check():
        pass

    @staticmethod
    def compile_shaders(sources, chips):
        _Counting.calls.append((sorted(sources), list(chips)))
        return ({chip: {name: {"length": len(text), "listing": [text]} for name, text in sources.items()} for chip in chips},
                {chip: f"counting {chip}" for chip in chips})


def test_a_shader_compiled_once_is_kept_and_a_damaged_entry_is_compiled_again(monkeypatch, tmp_path):
    monkeypatch.setattr(machine_code.paths, "MACHINE_CODE_CACHE", tmp_path)
    monkeypatch.setitem(machine_code.BACKENDS, "counting", _Counting)
    _Counting.calls.clear()
    first = machine_code._compile_kept("counting", {"a": "x", "b": "yy"}, ["c1", "c2"])
    assert _Counting.calls == [(["a", "b"], ["c1", "c2"])]
    assert first[0]["c2"]["b"] == {"length": 2, "listing": ["yy"]} and first[1] == {"c1": "counting c1", "c2": "counting c2"}
    assert machine_code._compile_kept("counting", {"a": "x", "b": "yy"}, ["c1", "c2"]) == first
    assert len(_Counting.calls) == 1                                       # nothing compiled again
    machine_code._compile_kept("counting", {"a": "x", "b": "yy", "new": "zzz"}, ["c1", "c2"])
    assert _Counting.calls[-1] == (["new"], ["c1", "c2"])                  # only what is new
    machine_code._kept_file("counting", "c1", "x").write_text('{"parsed": ')   # cut short
    again = machine_code._compile_kept("counting", {"a": "x", "b": "yy"}, ["c1", "c2"])
    assert _Counting.calls[-1] == (["a"], ["c1"]) and again == first


def test_the_kept_entries_are_keyed_by_every_module_that_compiles_and_reads_a_shader():
    """The key's modules (`COMPILING`) hold every module of the wing that machine_code imports, and the
    scripts its back ends run in their own processes; a module it neither imports nor runs (lavapipe's
    execution) changes no key."""
    import subprocess
    import sys
    from pathlib import Path

    loaded = subprocess.run([sys.executable, "-c", "import sys, pipeline.isa.machine_code; print(' '.join(m for m in "
                             "sys.modules if m.startswith('pipeline.isa.')))"], capture_output=True, text=True,
                            check=True).stdout.split()
    wing = Path(machine_code.__file__).parent
    run = {name for name in ("vulkan_pipeline", "gles_driver")
           if any(name in (wing / f"{b}.py").read_text() for b in ("radv", "gles"))}
    assert {m.rsplit(".", 1)[1] for m in loaded} | run <= set(machine_code.COMPILING)
    assert run == {"vulkan_pipeline", "gles_driver"}
    assert all((wing / f"{name}.py").exists() for name in machine_code.COMPILING)
    assert "execution" not in machine_code.COMPILING and "pipeline.isa.execution" not in loaded


HALF_MARKERS = {"rdna3": r"_f16\b", "sm_89": r"^(HFMA2|HADD2|HMUL2)\b", "xe_hpg": r":hf\b", "a740": r"\.f16\b|\bhr\d",
                "g610": r"\.v2f16\b|\.f16\b"}


def test_a_float16_form_is_read_as_16_bit_operations():
    """fp16's shader (explicit 16-bit types): its operations after the input's conversion are of width
    16, and computed by `lowering.evaluate` as numpy's float16 operations compute them, bit for bit."""
    from pipeline.isa import lowering, shaders
    from pipeline.optics import spirv

    source = shaders.form_shader(["t"], ["t"], "return (0.3 * t + 0.7) * t - sqrt(t);", "", precision="fp16")
    ops, result = lowering.operations(spirv.optimized_disassembly(source))
    kinds = {(op.kind, op.width) for op in ops}
    assert ("convert", 16) in kinds and ("convert", 32) in kinds and ("arithmetic", 32) not in kinds
    t = np.arange(0, 0x3C01, dtype=np.uint16).view(np.float16)
    got = lowering.evaluate(ops, result, {"t": t.astype(np.float32)}, {})
    h = np.float16
    with np.errstate(all="ignore"):
        expected = ((h(0.3) * t + h(0.7)) * t - np.sqrt(t)).astype(np.float32)
    assert got.dtype == np.float32 and np.array_equal(got, expected)


def test_a_float16_form_computes_in_16_bits_on_every_vendor():
    """The same form costed in fp16 (`form_cycles(..., "fp16")`) on one architecture per vendor whose
    compiler runs here: its machine code holds the vendor's 16-bit instructions (v_*_f16, HFMA2,
    :hf, ir3's half registers, Bifrost's v2f16), and its float32 twin's does not."""
    from pipeline.approximate.engines.options import available_architectures

    here = [a for a in HALF_MARKERS if a in available_architectures()]
    if not here:
        pytest.skip("no GPU compiler runs here")
    bodies = {"f": ("return t * (0.5 + t * 0.25) + exp2(t);", ["t"])}
    for precision, wanted in (("fp16", True), ("fp32", False)):
        sources, wrappers, _ = machine_code.form_sources(bodies, ["t"], precision)
        rows = machine_code.compile_shaders(sources, wrappers, here)["rows"]
        for a in here:
            listing = rows[a]["form_000"]["listing"]
            assert any(re.search(HALF_MARKERS[a], line) for line in listing) == wanted, (a, precision, listing)
