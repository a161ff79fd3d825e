import jax
import jax.numpy as jnp
import pytest

import pipeline
from pipeline import paths
from pipeline.cache import Cache
from pipeline.run import run_stages


def pytest_sessionstart(session):
    # float64 must be on for every test; an array made before the switch would silently be float32.
    assert jax.config.jax_enable_x64 and jnp.zeros(1).dtype == jnp.float64


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
