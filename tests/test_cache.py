import shutil

import numpy as np
import pytest

import pipeline
from pipeline import paths
from pipeline.cache import Cache, code_modules
from pipeline.run import run_stages
from pipeline.stages import PAPER_STAGES, STAGES


@pytest.fixture()
def warm_cache(paper_run, paper_cache, tmp_path):
    """A private copy of the cache that already holds the paper's run."""
    target = tmp_path / "cache"
    shutil.copytree(paper_cache, target)
    return Cache(target)


def run(config, cache, stages=STAGES):
    log = []
    results, keys, computed = run_stages(config, cache, log=log.append, stages=stages)
    return results, computed, "\n".join(log)


def test_second_run_computes_nothing(paper_config, warm_cache):
    _, computed, log = run(paper_config, warm_cache)
    assert computed == []
    assert log.count("cached") == len(STAGES)


def test_changing_one_parameter_recomputes_only_what_depends_on_it(warm_cache):
    # The paper's stages only (the stages beyond it read these and would all follow).
    cfg = pipeline.load_config(paths.PAPER_CONFIG, ("regression.threshold_count=81",))
    assert run(cfg, warm_cache, PAPER_STAGES)[1] == ["sparse_regression", "hemispherical"]
    cfg = pipeline.load_config(paths.PAPER_CONFIG, ("energy.quadrature_nodes=48",))
    assert run(cfg, warm_cache, PAPER_STAGES)[1] == ["energy_dataset", "sparse_regression", "hemispherical"]
    cfg = pipeline.load_config(paths.PAPER_CONFIG, ('zone.sensitivity_levels=[0.6]',))
    assert run(cfg, warm_cache)[1] == ["accuracy"]
    cfg = pipeline.load_config(paths.PAPER_CONFIG, ("comparison.albedo_angles=10",))
    assert run(cfg, warm_cache)[1] == ["lobe_comparison"]


def test_a_damaged_entry_is_reported_and_recomputed(paper_config, paper_run, warm_cache):
    entry = next((warm_cache.root / "linear_coefficient").iterdir())
    text = (entry / "values.json").read_text()
    (entry / "values.json").write_text(text.replace("0.448", "0.449", 1))
    results, computed, log = run(paper_config, warm_cache)
    assert "damaged (values.json does not match its checksum); recomputing" in log
    assert computed == ["linear_coefficient"]
    assert results["linear_coefficient"]["lin_slope"] == paper_run["linear_coefficient"]["lin_slope"]


def test_an_unreadable_entry_is_damaged_too(paper_config, warm_cache):
    entry = next((warm_cache.root / "zone").iterdir())
    (entry / "manifest.json").write_text("{not json")
    _, computed, log = run(paper_config, warm_cache)
    assert "zone" in computed and "damaged" in log


def test_an_interrupted_write_leaves_no_entry(tmp_path, monkeypatch):
    cache = Cache(tmp_path)

    def boom(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(np, "savez_compressed", boom)
    with pytest.raises(KeyboardInterrupt):
        cache.store("stage", "abc", dict(x=np.arange(3.0), y=1.0))
    assert cache.load("stage", "abc") is None
    assert list((tmp_path / "stage").iterdir()) == []


def test_entries_round_trip_without_pickle(tmp_path):
    cache = Cache(tmp_path)
    cache.store("s", "k", dict(a=np.linspace(0, 1, 5), b=2.5, c="text", d=[dict(e=1)], f=True))
    out = cache.load("s", "k")
    np.testing.assert_array_equal(out["a"], np.linspace(0, 1, 5))
    assert (out["b"], out["c"], out["d"], out["f"]) == (2.5, "text", [dict(e=1)], True)


def test_code_key_covers_the_helpers_a_stage_imports():
    mods = code_modules("pipeline.stages.q_scan")
    assert {"pipeline.lobes", "pipeline.error_measures", "pipeline.roots", "pipeline.stages.common"} <= set(mods)
    assert "pipeline.stages.sparse_regression" not in mods
    assert "pipeline.stages.energy_dataset" in code_modules("pipeline.stages.sparse_regression")
