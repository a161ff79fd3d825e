"""Fixtures sized to what a test needs: the paper's full run is computed once, for the tests that
compare with the paper's numbers; every other test that needs a whole derivation uses the light
configuration (`tests/light.toml`: the paper's settings and n range with small renders, few Monte
Carlo samples and a low symbolic complexity), also computed once."""

from pathlib import Path

import pytest

import pipeline
from pipeline.engine import paths
from pipeline.engine.cache import Cache
from pipeline.engine.exponents import n_range
from pipeline.run import run_stages

LIGHT_CONFIG = Path(__file__).parent / "light.toml"


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


@pytest.fixture(scope="session", autouse=True)
def shared_compilation_cache(tmp_path_factory):
    """One folder of compiled XLA programs for the session: the runs in this process and the CLI
    subprocesses (`helpers.cli_env`) compile each program once."""
    folder = tmp_path_factory.getbasetemp() / "xla"
    paths.XLA_CACHE = str(folder)
    return folder


@pytest.fixture(scope="session")
def paper_run(paper_config, paper_cache):
    """Every stage of the paper's configuration, computed once into a fresh cache."""
    results, keys, computed = run_stages(paper_config, Cache(paper_cache), log=lambda s: None)
    return results


@pytest.fixture(scope="session")
def n_all(paper_config):
    return n_range(paper_config)


@pytest.fixture(scope="session")
def light_config():
    return pipeline.load_config(LIGHT_CONFIG)


@pytest.fixture(scope="session")
def light_cache(tmp_path_factory):
    return tmp_path_factory.mktemp("light_cache")


@pytest.fixture(scope="session")
def light_run(light_config, light_cache, paper_run, tmp_path_factory):
    """Every stage of the light configuration and its figures, computed once into a fresh cache (after
    the paper's run, whose compiled programs it mostly shares)."""
    from pipeline.run import run_derivation

    outcome = run_derivation(light_config, cache_dir=light_cache, outputs=tmp_path_factory.mktemp("light_out"),
                             log=lambda s: None)
    return outcome.results


@pytest.fixture()
def refit_cache(paper_run, paper_cache, light_run, light_cache, tmp_path):
    """`tmp_path / "cache"`, holding the paper's and the light run (what a CLI refit of the light config reads)."""
    from .helpers import copy_caches
    return copy_caches(tmp_path / "cache", paper_cache, light_cache)


@pytest.fixture(scope="session")
def paper_outputs(paper_config, paper_run, paper_cache, tmp_path_factory):
    """The paper's run with its outputs written (figures, report, results.json), into a private copy of
    the paper's cache: (outputs folder, run outcome, cache root)."""
    import shutil

    from pipeline.run import run_derivation

    root = tmp_path_factory.mktemp("paper_outputs")
    shutil.copytree(paper_cache, root / "cache")
    outcome = run_derivation(paper_config, cache_dir=root / "cache", outputs=root / "out", log=lambda s: None)
    return root / "out", outcome, root / "cache"
