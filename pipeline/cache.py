"""Content-addressed cache of stage results: no pickle, atomic writes, verified reads.

A stage's key hashes (1) the config keys it reads, (2) the keys of the stages it reads, and (3) the
source of its module and of every `pipeline` module that module imports, transitively: editing a
stage or a helper it uses changes the key.

An entry is a folder `<cache>/<stage>/<key>/` holding `values.json` (numbers, strings, lists),
`arrays.npz` (numpy arrays, loaded with allow_pickle=False) and `manifest.json` (the key and the
SHA-256 of both files). It is written into a temporary folder and renamed into place, so a run
killed mid-write leaves no entry. A read re-hashes both files; a mismatch, a missing file or a
parse error makes the entry "damaged": it is reported, removed and recomputed, never used.
"""

from __future__ import annotations

import ast
import hashlib
import json
import os
import shutil
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

PACKAGE_ROOT = Path(__file__).resolve().parent
FORMAT = 1


class DamagedEntry(Exception):
    """A cache entry that failed verification; the message says why."""


def _module_file(name: str) -> Path | None:
    """The source file of a `pipeline.*` module name, or None for anything outside the package."""
    parts = name.split(".")
    if parts[0] != "pipeline":
        return None
    base = PACKAGE_ROOT.joinpath(*parts[1:])
    for candidate in (base.with_suffix(".py"), base / "__init__.py"):
        if candidate.is_file():
            return candidate
    return None


def _imports(path: Path, module: str) -> set[str]:
    """Names of the `pipeline` modules that the file at `path` (module `module`) imports."""
    package = module if path.name == "__init__.py" else module.rsplit(".", 1)[0]
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            found.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - (node.level - 1)]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            found.add(target)
            # `from . import x` imports submodule x.
            found.update(f"{target}.{a.name}" for a in node.names)
    return {m for m in found if _module_file(m) is not None}


def code_modules(module: str) -> dict[str, Path]:
    """`module` and every `pipeline` module it imports, transitively: name -> source file."""
    seen, todo = {}, [module]
    while todo:
        name = todo.pop()
        path = _module_file(name)
        if name in seen or path is None:
            continue
        seen[name] = path
        # A package's __init__ re-exports everything; following it would tie every stage to
        # every module, so only the package's own modules that are named are followed.
        if path.name != "__init__.py":
            todo.extend(_imports(path, name))
    return seen


def code_hash(module: str) -> str:
    """SHA-256 over the sources of `module` and every `pipeline` module it imports, transitively."""
    seen = code_modules(module)
    digest = hashlib.sha256()
    for name in sorted(seen):
        digest.update(name.encode())
        digest.update(seen[name].read_bytes())
    return digest.hexdigest()


def stage_key(stage: str, config_subset: dict[str, Any], upstream_keys: dict[str, str], code: str) -> str:
    """The cache key of one stage run."""
    blob = json.dumps(dict(format=FORMAT, stage=stage, config=config_subset, upstream=upstream_keys,
                           code=code), sort_keys=True, default=str)
    return hashlib.sha256(blob.encode()).hexdigest()[:32]


def _sha(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _split(result: dict[str, Any]) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    values, arrays = {}, {}
    for k, v in result.items():
        if isinstance(v, np.ndarray):
            if v.dtype == object:
                raise TypeError(f"result '{k}' is an object array; store it as a list")
            arrays[k] = v
        elif isinstance(v, np.generic):
            values[k] = v.item()
        else:
            values[k] = v
    return values, arrays


class Cache:
    """Stage results under `root/<stage>/<key>/`."""

    def __init__(self, root: Path):
        self.root = Path(root)

    def entry(self, stage: str, key: str) -> Path:
        return self.root / stage / key

    def load(self, stage: str, key: str) -> dict[str, Any] | None:
        """The stored result, or None if absent. Raises `DamagedEntry` if it fails verification."""
        folder = self.entry(stage, key)
        if not folder.exists():
            return None
        try:
            manifest = json.loads((folder / "manifest.json").read_text())
            if manifest.get("key") != key or manifest.get("stage") != stage:
                raise DamagedEntry("its manifest names another entry")
            for name in ("values.json", "arrays.npz"):
                if _sha(folder / name) != manifest["sha256"][name]:
                    raise DamagedEntry(f"{name} does not match its checksum")
            values = json.loads((folder / "values.json").read_text())
            with np.load(folder / "arrays.npz", allow_pickle=False) as data:
                arrays = {k: data[k] for k in data.files}
        except DamagedEntry:
            raise
        except (OSError, ValueError, KeyError, TypeError) as e:
            raise DamagedEntry(f"{type(e).__name__}: {e}") from None
        return values | arrays

    def discard(self, stage: str, key: str) -> None:
        shutil.rmtree(self.entry(stage, key), ignore_errors=True)

    def store(self, stage: str, key: str, result: dict[str, Any]) -> None:
        """Writes the entry atomically: a temporary folder renamed into place."""
        values, arrays = _split(result)
        parent = self.root / stage
        parent.mkdir(parents=True, exist_ok=True)
        tmp = Path(tempfile.mkdtemp(prefix=f".{key}.", dir=parent))
        try:
            (tmp / "values.json").write_text(json.dumps(values, sort_keys=True))
            with open(tmp / "arrays.npz", "wb") as f:
                np.savez_compressed(f, **arrays)
            manifest = dict(stage=stage, key=key, format=FORMAT,
                            sha256={name: _sha(tmp / name) for name in ("values.json", "arrays.npz")})
            (tmp / "manifest.json").write_text(json.dumps(manifest, sort_keys=True))
            final = self.entry(stage, key)
            if final.exists():
                shutil.rmtree(final)
            os.replace(tmp, final)
        finally:
            shutil.rmtree(tmp, ignore_errors=True)
