"""The rendered comparison against a direct numpy computation, and the exported shader against the
pipeline's own lobe (through its Python twin) and, where glslangValidator is installed, a compiler.
"""


import numpy as np
import pytest

from pipeline.optics.raytrace import SCENES

from ..oracles import quadratic_np


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
            # the stage's jitted max and mean over the same image: a sum's order changes its rounding
            # by ~N eps (N ~1e4 pixels): 1e-12 relative; 1e-9 with margin
            assert stats["max_abs"] == pytest.approx(diff.max(), rel=1e-9)
            assert stats["mean_abs"] == pytest.approx(diff.mean(), rel=1e-9)
            assert stats["max_rel"] == pytest.approx(rel.max(), rel=1e-6)
            assert stats["epicenter_pixels"] == int(zone.sum())
    # What the tables say, seen in the image: f_Q2's epicenter is several times closer than f_2's.
    for s2 in (s for s in r["statistics"] if s["lobe"] == "f_2" and s["scene"] == "sphere"):
        sq2 = next(s for s in r["statistics"] if s["lobe"] == "f_Q2" and s["scene"] == "sphere" and s["n"] == s2["n"])
        assert sq2["max_rel"] < s2["max_rel"] and sq2["psnr"] > s2["psnr"]


def test_epicenter_error_in_the_images_is_within_the_analytic_bound(paper_run, paper_config):
    # With equal normalizations, the luminance error relative to the reference, on pixels where the
    # reference lobe is >= L, cannot exceed the lobe's own d at that n (the diffuse term only shrinks it).
    curves = {"f_2": paper_run["f2_errors"]["d_f_2_curve"], "f_Q2": paper_run["accuracy"]["d_f_Q2_curve"]}
    n_min = paper_config["derivation.n_min"]
    for s in paper_run["render"]["statistics"]:
        bound = curves[s["lobe"]][int(s["n"]) - n_min]
        assert s["epicenter_pixels"] > 0
        assert s["max_rel"] <= bound * (1 + 1e-9), (s["scene"], s["n"], s["lobe"], s["max_rel"], bound)
        assert s["d_bound"] == bound          # the bound the report prints is that d


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




def test_f_Q2_as_shipped_has_its_exact_blinn_coef_and_differs_from_equal_peak(paper_run, n_all):
    """The shipped renders use f_Q2's exact Blinn-form coef: its ratio to Giesen's is the exact_normalization
    stage's coef over Giesen's closed form (n + 2)(n + 4) / (8 pi (2^(-n/2) + n)), and the images differ
    from the equal-peak ones wherever that ratio is not 1."""
    s, e = paper_run["render"], paper_run["exact_normalization"]
    for j, n in enumerate(sorted({x["n"] for x in s["shipped_statistics"]})):
        giesen = (n + 2) * (n + 4) / (8 * np.pi * (2.0 ** (-n / 2) + n))
        exact = e["coef_blinn"][int(n) - int(n_all[0])]
        for row in (x for x in s["shipped_statistics"] if x["n"] == n):
            assert row["coef_over_reference"] == pytest.approx(exact / giesen, rel=1e-9)
        f_Q2 = s["lobes"].index("f_Q2")
        assert not np.array_equal(s["shipped_display"][0, j], s["display"][0, j, f_Q2])
