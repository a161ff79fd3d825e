"""Every path the pipeline reads or writes, in one place."""

import os
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent.parent
CONFIGS = ROOT / "configs"
PAPER_CONFIG = CONFIGS / "paper.toml"
OUTPUTS = Path(os.environ.get("PIPELINE_OUTPUTS_DIR", ROOT / "outputs"))
# Stage results, content-addressed; `make clean` removes the folder.
CACHE = Path(os.environ.get("PIPELINE_CACHE_DIR", ROOT / ".cache" / "stages"))
# Shaders compiled to GPU machine code, by text, chip, compiler and the code that reads them
# (`pipeline.isa.machine_code`): shared by every run and cache folder of this checkout.
MACHINE_CODE_CACHE = Path(os.environ.get("PIPELINE_MACHINE_CODE_CACHE", ROOT / ".cache" / "machine_code"))
# `pipeline derive`'s searches (the families' fits and the grammar's candidates), by target, budget
# and the code that searches (`pipeline.approximate.engines`).
DERIVE_CACHE = Path(os.environ.get("PIPELINE_DERIVE_CACHE", ROOT / ".cache" / "derive"))
# The `pipeline` modules each source file of the package imports, kept by the sources' digest
# (`engine.cache`: the code keys of stages, memos and figures).
IMPORTS = Path(os.environ.get("PIPELINE_IMPORTS_CACHE", ROOT / ".cache" / "imports"))
# The page library (Vega) `engine.web_page` inlines, kept by its version.
WEB_CACHE = Path(os.environ.get("PIPELINE_WEB_CACHE", ROOT / ".cache" / "web"))
# Compiled XLA programs: in the cache (`<cache>/_xla`) unless set apart (the tests share one).
XLA_CACHE = os.environ.get("PIPELINE_XLA_CACHE_DIR")


def output_dir(name: str, outputs: Path = OUTPUTS) -> Path:
    """The folder that one run (the paper's or a refit) writes: `outputs/<name>/`."""
    return outputs / name
