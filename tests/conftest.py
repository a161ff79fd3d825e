"""Fixtures sized to what a test needs: the paper's full run is computed once, for the tests that
compare with the paper's numbers; every other test that needs a whole derivation uses the light
configuration (`tests/light.toml`: the paper's settings with a low symbolic complexity, two rendered
exponents and small Mitsuba renders), also computed once.

`make test` runs the tests in two worker processes (pytest-xdist, whole files per worker). The runs
are computed once for the session, not once per worker: the first worker to need one computes it
into a stage cache shared by the workers, under a file lock, and the other finds every stage there.
Compiled XLA programs are shared the same way, by every test and the CLI subprocesses too."""

import contextlib
import fcntl
import os
from pathlib import Path

import pytest

from pipeline.engine.cluster import WORKER_ENV

if os.environ.get("PYTEST_XDIST_WORKER"):
    # `make test` runs two worker processes on two cores, as a sweep runs its Dask workers: XLA's
    # operations run on one thread in each (set before the first computation initializes XLA; the
    # CLI subprocesses inherit it). Its own pool of one thread per core in each worker measured 15 %
    # more CPU time for the suite. An instruction-set flag (`make test-isa`) is kept.
    os.environ["XLA_FLAGS"] = " ".join(filter(None, (os.environ.get("XLA_FLAGS"), WORKER_ENV["XLA_FLAGS"])))
    os.environ["OMP_NUM_THREADS"] = WORKER_ENV["OMP_NUM_THREADS"]

# The search rates the tests measure (two workers on two cores) are kept apart from the rates a
# user's searches keep in the checkout (`pipeline.symbolic.rates`).
os.environ.setdefault("PIPELINE_RATES", os.path.join(os.environ.get("TMPDIR", "/tmp"),
                                                      f"pipeline-test-rates-{os.getppid()}.json"))

import pipeline  # noqa: E402
from pipeline.engine import paths
from pipeline.engine.cache import Cache
from pipeline.engine.exponents import n_range
from pipeline.runner import run_derivation, run_stages

from .helpers import copy_cache

LIGHT_CONFIG = Path(__file__).parent / "light.toml"


# The fixtures that hold a whole derivation (the first test that needs one computes it).
RUN_FIXTURES = {"paper_run", "light_run", "refit_cache", "paper_outputs", "light_cache", "paper_cache"}


def pytest_configure(config):
    # xdist sends whole files in the order `pytest_collection_modifyitems` gives them, not sorted by
    # their number of tests.
    if hasattr(config.option, "loadscopereorder"):
        config.option.loadscopereorder = False


def pytest_collection_modifyitems(session, config, items):
    """Files in the order that keeps both workers busy: first the file with the most slow tests among
    those that need a whole derivation (its worker computes the paper's and the light run, a minute
    and more), then every file that needs none (the other worker runs them meanwhile instead of
    waiting for the runs), then the other files that need one, those with more slow tests first."""
    files: dict[str, list] = {}
    for item in items:
        files.setdefault(item.nodeid.split("::")[0], []).append(item)

    def needs_run(name):
        return any(RUN_FIXTURES & set(getattr(item, "fixturenames", ())) for item in files[name])

    def slow(name):
        return sum(item.get_closest_marker("slow") is not None for item in files[name])

    dependent = sorted((f for f in files if needs_run(f)), key=slow, reverse=True)
    independent = [f for f in files if not needs_run(f)]
    order = dependent[:1] + independent + dependent[1:]
    items[:] = [item for name in order for item in files[name]]


def pytest_sessionstart(session):
    # float64 must be on for every test; an array made before the switch would silently be float32.
    from pipeline.optics.numerics import jax
    assert jax.config.jax_enable_x64 and jax.numpy.zeros(1).dtype == jax.numpy.float64
    if os.environ.get("PYTEST_XDIST_WORKER"):
        # one thread per worker for numpy's and scipy's BLAS too (OMP_NUM_THREADS, read as each loads)
        import scipy.linalg  # noqa: F401
        import threadpoolctl
        pools = {p["filepath"]: p["num_threads"] for p in threadpoolctl.threadpool_info()}
        assert pools and set(pools.values()) == {1}, pools


def pytest_sessionfinish(session):
    # The search rates the session measured go with it (the controller's end; its workers share the file).
    if not hasattr(session.config, "workerinput") and os.environ["PIPELINE_RATES"].endswith(
            f"pipeline-test-rates-{os.getppid()}.json"):
        Path(os.environ["PIPELINE_RATES"]).unlink(missing_ok=True)


@pytest.fixture(scope="session")
def shared_root(tmp_path_factory) -> Path:
    """A folder shared by the session's worker processes (each worker's own base folder otherwise)."""
    base = tmp_path_factory.getbasetemp()
    root = base.parent / "shared" if os.environ.get("PYTEST_XDIST_WORKER") else base / "shared"
    root.mkdir(parents=True, exist_ok=True)
    return root


@contextlib.contextmanager
def locked(root: Path, name: str):
    """An exclusive lock on `root/<name>.lock`, held across worker processes."""
    with open(root / f"{name}.lock", "a") as handle:
        fcntl.flock(handle, fcntl.LOCK_EX)
        yield


@pytest.fixture(scope="session", autouse=True)
def shared_compilation_cache(shared_root):
    """One folder of compiled XLA programs for the session: the runs in the workers and the CLI
    subprocesses (`helpers.cli_env`) compile each program once. `PIPELINE_XLA_CACHE_DIR` keeps them
    between sessions (`make test` sets it to the pipeline's own folder, so a later session compiles
    only what changed: JAX keys each program on its HLO, the XLA flags and the jaxlib version);
    unset or empty, the session starts from an empty folder of its own (`make test-isa`)."""
    paths.XLA_CACHE = paths.XLA_CACHE or str(shared_root / "xla")
    # The tests that call the library directly compile into it too, from the first test on.
    from pipeline.optics.numerics import use_compilation_cache
    use_compilation_cache(paths.XLA_CACHE)
    return Path(paths.XLA_CACHE)


@pytest.fixture(scope="session")
def paper_config():
    return pipeline.load_config(paths.PAPER_CONFIG)


@pytest.fixture(scope="session")
def paper_cache(shared_root):
    """The session's stage cache: it holds the paper's run and the light run. Tests that change it
    work on a copy."""
    return shared_root / "cache"


@pytest.fixture(scope="session")
def paper_run(paper_config, paper_cache, shared_root):
    """Every stage of the paper's configuration, computed once into the session's cache."""
    with locked(shared_root, "paper_run"):
        results, keys, computed = run_stages(paper_config, Cache(paper_cache), log=lambda s: None)
    return results


@pytest.fixture(scope="session")
def n_all(paper_config):
    return n_range(paper_config)


@pytest.fixture(scope="session")
def light_config():
    return pipeline.load_config(LIGHT_CONFIG)


@pytest.fixture(scope="session")
def light_cache(paper_cache):
    """The light run's stage cache: the paper's, so that the light run reuses the work the two share
    (the zone, the shader costs, the Q-independent memoized lobes and renders). It holds both runs."""
    return paper_cache


@pytest.fixture(scope="session")
def light_run(light_config, light_cache, paper_run, shared_root):
    """Every stage of the light configuration and its figures, computed once into the session's cache
    (after the paper's run, whose compiled programs and work it mostly shares)."""
    with locked(shared_root, "light_run"):
        outcome = run_derivation(light_config, cache_dir=light_cache, outputs=shared_root / "light_out",
                                 log=lambda s: None)
    return outcome.results


@pytest.fixture()
def refit_cache(paper_run, light_run, light_cache, tmp_path):
    """`tmp_path / "cache"`, a copy of the cache holding the paper's and the light run (what a CLI refit of
    the light config reads: it computes the paper's run too, for its comparison)."""
    copy_cache(light_cache, tmp_path / "cache")
    return tmp_path / "cache"


@pytest.fixture(scope="module")
def paper_outputs(paper_config, paper_run, paper_cache, tmp_path_factory):
    """The paper's run with its outputs written (figures, report, results.json), into a private copy of
    the session's cache, once per test module: (outputs folder, run outcome, cache root)."""
    root = tmp_path_factory.mktemp("paper_outputs")
    copy_cache(paper_cache, root / "cache")
    outcome = run_derivation(paper_config, cache_dir=root / "cache", outputs=root / "out", log=lambda s: None)
    return root / "out", outcome, root / "cache"

