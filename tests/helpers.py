"""Helpers shared by the tests."""

import os


def cli_env(tmp_path, **extra):
    """Environment for running the CLI in a subprocess with its own cache and outputs; compiled XLA
    programs are shared by the session's subprocesses (the stage cache is what the tests test)."""
    from pipeline.engine import paths

    xla = paths.XLA_CACHE or str(tmp_path.parent / "xla")      # the session's (conftest), where it is set
    return dict(os.environ, PIPELINE_CACHE_DIR=str(tmp_path / "cache"), PIPELINE_OUTPUTS_DIR=str(tmp_path / "out"),
                PIPELINE_XLA_CACHE_DIR=xla, **extra)

