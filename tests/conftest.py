import os

import pytest

import pipeline
from pipeline.engine import paths
from pipeline.engine.cache import Cache
from pipeline.run import run_stages


def pytest_sessionstart(session):
    # float64 must be on for every test; an array made before the switch would silently be float32.
    from pipeline.optics.numerics import jax
    assert jax.config.jax_enable_x64 and jax.numpy.zeros(1).dtype == jax.numpy.float64


@pytest.fixture(scope="session")
def paper_config():
    return pipeline.load_config(paths.PAPER_CONFIG)


@pytest.fixture(scope="session")
def paper_cache(tmp_path_factory):
    return tmp_path_factory.mktemp("cache")


@pytest.fixture(scope="session")
def paper_run(paper_config, paper_cache):
    """Every stage of the paper's configuration, computed once into a fresh cache."""
    results, keys, computed = run_stages(paper_config, Cache(paper_cache), log=lambda s: None)
    return results


@pytest.fixture(scope="session")
def n_all(paper_config):
    import numpy as np
    return np.arange(paper_config["derivation.n_min"], paper_config["derivation.n_max"] + 1, dtype=np.float64)


def cli_env(tmp_path, **extra):
    """Environment for running the CLI in a subprocess with its own cache and outputs; compiled XLA
    programs are shared by the session's subprocesses (the stage cache is what the tests test)."""
    return dict(os.environ, PIPELINE_CACHE_DIR=str(tmp_path / "cache"), PIPELINE_OUTPUTS_DIR=str(tmp_path / "out"),
                PIPELINE_XLA_CACHE_DIR=str(tmp_path.parent / "xla"), **extra)
