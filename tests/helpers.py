"""Helpers shared by the tests."""

import os
import shutil


def cli_env(tmp_path, **extra):
    """Environment for running the CLI in a subprocess with its own cache and outputs; compiled XLA
    programs are shared by the session's subprocesses (the stage cache is what the tests test)."""
    from pipeline.engine import paths

    xla = paths.XLA_CACHE or str(tmp_path.parent / "xla")      # the session's (conftest), where it is set
    return dict(os.environ, PIPELINE_CACHE_DIR=str(tmp_path / "cache"), PIPELINE_OUTPUTS_DIR=str(tmp_path / "out"),
                PIPELINE_XLA_CACHE_DIR=xla, **extra)


def copy_caches(target, *caches):
    """One stage cache holding the entries of all `caches` (a refit of the light config also computes the
    paper's run, for its comparison, so its CLI tests need both)."""
    for cache in caches:
        shutil.copytree(cache, target, dirs_exist_ok=True)
    return target
