"""The Mitsuba stage: the path-traced comparison of the paper's run."""

import numpy as np
import pytest

from pipeline.mitsuba import bsdf as mitsuba_bsdf


def test_the_mitsuba_renders(paper_run):
    """The path-traced comparison: it ran the fast variant; noise is well below the differences it
    is set beside; the lobe's sampler beats cosine-weighted sampling where the lobe is narrow; the
    highlights contain their epicenters; FLIP over the highlights ranks as the report says."""
    s = paper_run["mitsuba_render"]
    if s["variant"] != mitsuba_bsdf.FAST_VARIANT:
        pytest.skip(f"the renders ran the fallback {s['variant']} at {s['spp']} spp: too noisy for these checks")
    assert s["noise_to_difference_max"] < 0.3
    ratios = {x["n"]: x["variance_ratio"] for x in s["sampling"]}
    assert ratios[100.0] > 5 and ratios[1000.0] > 2
    assert np.all(s["highlight"][s["epicenter"]] >= 0)
    for x in s["statistics"]:
        fmap = s["flip_maps"][("f_2", "f_Q2").index(x["lobe"])].astype(np.float64)
        region = s["highlight"] == s["exponents"].index(x["n"])
        assert x["flip_highlight"] == pytest.approx(fmap[region].mean(), rel=1e-3)
        assert 0 < x["flip_share_epicenter"] < 1
    by = {(x["lobe"], x["n"]): x["flip_highlight"] for x in s["statistics"]}
    assert s["f_Q2_closer_count"] == sum(by[("f_Q2", n)] < by[("f_2", n)] for n in s["exponents"])


@pytest.mark.slow
def test_two_cold_runs_write_identical_results(light_config, light_run, light_cache, tmp_path):
    """The Mitsuba stage computed twice from nothing (its entry and its memoized renders removed):
    results.json is the same bytes but for its "timings" (the render time), which it keeps apart."""
    import json
    import shutil

    from pipeline.engine import checks
    from pipeline.engine.cache import MEMO, Cache
    from pipeline.publish import results as results_mod
    from pipeline.runner import run_stages

    from ..helpers import copy_cache
    copy_cache(light_cache, tmp_path / "cache")
    written = []
    for i in range(2):
        for kind in ("mitsuba_render", f"{MEMO}/mitsuba_pair", f"{MEMO}/mitsuba_no_sun"):
            shutil.rmtree(tmp_path / "cache" / kind, ignore_errors=True)
        results, keys, computed = run_stages(light_config, Cache(tmp_path / "cache"), log=lambda s: None)
        assert computed == ["mitsuba_render"]
        doc = results_mod.write(tmp_path / f"results{i}.json", light_config, keys, results,
                                checks.evaluate(light_config, results))
        assert "render_seconds" not in doc["stages"]["mitsuba_render"]
        written.append(json.dumps({k: v for k, v in doc.items() if k != "timings"}, sort_keys=True))
    assert written[0] == written[1]
