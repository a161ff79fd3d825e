"""The documentation's generator (`scripts/docs.py`), imported by the docs tests."""

import importlib.util
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def load_docs():
    spec = importlib.util.spec_from_file_location("docs_script", ROOT / "scripts" / "docs.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module          # the dataclasses of the module look themselves up there
    spec.loader.exec_module(module)
    return module


docs = load_docs()
