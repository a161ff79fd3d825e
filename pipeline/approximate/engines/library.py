"""A shader library derived as one batch: the files `--shader` names (files, folders, globs), one task
per function of each (its overloads together), run on Dask (`engine.cluster`: a LocalCluster by
default, or the cluster a scheduler names), each task the single-file derivation of that function
(`shader_file.derive_file`).

Each task keeps its outcome under `paths.DERIVE_CACHE/library/`, keyed by what the function computes
and how it is asked: the file's path, the optimized SPIR-V of each of its overloads' harnesses (so that an edit of its
body, of a helper it calls or of a macro it reads changes the key, and an edit elsewhere in the file
does not), its annotation, the command line's settings and this code. A rerun reads the kept
outcomes and computes only the functions whose key changed; two batches sharing a function compute it
once. `records` lists, per task, "kept" or "computed", appended to `library/records.log` (what a test
counts). A task that fails (a crash, a lost worker twice, a compiler's error) is its function's row,
refused with the reason, and the batch goes on.
"""

from __future__ import annotations

import glob
import hashlib
import json
import pickle
import time
import uuid
from pathlib import Path

SUFFIXES = (".glsl", ".hlsl", ".fx", ".hlsli", ".frag", ".vert", ".comp", ".fsh", ".vsh")


def shader_files(paths) -> list[Path]:
    """The shader files of `paths` (each a file, a folder: every file under it with a shader suffix,
    `SUFFIXES`, or a glob), sorted, each once. Raises ShaderError naming a path that names none."""
    from ...shaders.definitions import ShaderError

    out = []
    for given in paths:
        text = str(given)
        if any(c in text for c in "*?["):
            found = sorted(Path(p) for p in glob.glob(text, recursive=True) if Path(p).is_file())
        elif Path(text).is_dir():
            found = sorted(p for p in Path(text).rglob("*") if p.is_file() and p.suffix.lower() in SUFFIXES)
        elif Path(text).is_file():
            found = [Path(text)]
        else:
            raise ShaderError(f"--shader {text}: no such file or folder")
        if not found:
            raise ShaderError(f"--shader {text}: no shader file ({', '.join(SUFFIXES)}) there")
        out += found
    return list(dict.fromkeys(p.resolve() for p in out))


def tasks(files: list[Path], options_of) -> list[tuple[Path, str]]:
    """(file, function name) of every function the files define, in file order (`options_of(path)`:
    the file's `shaders.harness.Options`); a file that defines none (macros, constants: what others
    include) has no task."""
    from ...shaders import definitions

    out = []
    for path in files:
        _, found = definitions.read(path, options_of(path).language)
        out += [(path, name) for name in dict.fromkeys(d.name for d in found)]
    return out


def key_of(path: Path, name: str, options, command_line: dict | None, settings: dict) -> str:
    """The kept outcome's key (module docstring). A function that does not compile keys on the file's
    text (its task then says why)."""
    from ...shaders import definitions, harness
    from ..search.grammar_search import code_version

    parts = [code_version(), str(Path(path).resolve()), name, json.dumps(command_line or {}, sort_keys=True, default=str),
             json.dumps(settings, sort_keys=True, default=str)]
    try:
        text = harness.preprocessed(path, options)
        for d in (d for d in definitions.read(path, options.language)[1] if d.name == name):
            parts += [d.annotation or "", d.signature]
            try:
                parts.append(harness.disassembly(text, d, options, path))
            except definitions.ShaderError as e:
                parts.append(str(e))
    except definitions.ShaderError as e:
        parts += [Path(path).read_text(errors="replace"), str(e)]
    return hashlib.sha256("\0".join(parts).encode()).hexdigest()[:32]


def derive_function(path: Path, name: str, options, command_line: dict | None, settings: dict, cache: Path,
                    derive) -> tuple[list, str, float]:
    """(the function's outcomes, "kept" or "computed", seconds): one task, run in a worker (or here),
    its outcome kept in `cache` by `key_of`; `derive` derives a target (`api.derive`)."""
    from ...shaders.definitions import ShaderError
    from . import shader_file

    start = time.perf_counter()
    key = key_of(path, name, options, command_line, settings)
    kept = Path(cache) / f"{key}.pickle"
    how = "kept"
    try:
        outcomes = pickle.loads(kept.read_bytes())
    except (OSError, pickle.UnpicklingError, EOFError, AttributeError):
        how = "computed"
        try:
            outcomes, _ = shader_file.derive_file(path, options, derive, [name], command_line, log=lambda s: None,
                                                  **settings)
        except ShaderError as e:            # (the file does not compile: as deterministic as a derivation)
            outcomes = [shader_file.Outcome(name, 0, shader_file.REFUSED, str(e))]
        kept.parent.mkdir(parents=True, exist_ok=True)
        partial = kept.with_suffix(f".{time.time_ns()}.tmp")
        partial.write_bytes(pickle.dumps(outcomes))
        partial.replace(kept)
    outcomes = in_place(outcomes, path, name, options)
    with open(Path(cache) / "records.log", "a") as records:
        records.write(f"{how} {Path(path).name} {name} {key}\n")
    return outcomes, how, time.perf_counter() - start


def in_place(outcomes: list, path: Path, name: str, options) -> list:
    """The outcomes with each overload's definition (its byte spans, which the patch replaces) and
    line those of the file as it is now: a kept outcome was computed where an edit elsewhere in the
    file (which keeps its key) may have moved the function. Overloads are matched by signature (part
    of the key)."""
    import dataclasses

    from ...shaders import definitions

    try:
        now = {d.signature: d for d in definitions.read(path, options.language)[1] if d.name == name}
    except definitions.ShaderError:
        return outcomes
    return [dataclasses.replace(o, definition=now[o.definition.signature], line=now[o.definition.signature].line)
            if o.definition is not None and o.definition.signature in now else o for o in outcomes]


def failed(path: Path, name: str, why: str) -> list:
    """A task that did not finish, as its function's refused row."""
    from . import shader_file

    return [shader_file.Outcome(name, 0, shader_file.REFUSED, f"its task failed: {why}")]


def running(client, batch: str, left: int) -> int:
    """How many of the batch's tasks the workers are running now: those the scheduler has given them
    (`Client.processing`), at most one per worker thread, at most those left."""
    processing = sum(str(key).endswith(batch) for keys in client.processing().values() for key in keys)
    threads = sum(w["nthreads"] for w in client.scheduler_info()["workers"].values())
    return min(processing, threads, left)


def calibrated(architecture: str) -> str:
    """One architecture's cost table compiled and kept (`gpu_costs.operation_costs`: its CALIBRATION
    forms' machine code in the machine-code cache), in a worker: the batch's tasks then read it
    instead of each compiling it at once."""
    from ...symbolic import gpu_costs
    from .one_variable import CALIBRATION

    gpu_costs.operation_costs(CALIBRATION, [architecture])
    return architecture


def calibrate(client, architectures, log=print) -> None:
    """Every architecture's cost table compiled once, one task per architecture spread over the
    workers, before the batch (`calibrated`); an architecture whose compiler fails here is left to the
    tasks, which say why."""
    from distributed import wait

    start = time.perf_counter()
    futures = client.map(calibrated, list(architectures), key=[f"calibrate-{a}-{uuid.uuid4().hex[:8]}"
                                                               for a in architectures], pure=False)
    wait(futures)
    done = [f.result() for f in futures if f.status == "finished"]
    log(f"cost tables of {len(done)} architecture{'s' * (len(done) != 1)} ready ({time.perf_counter() - start:.0f} s)")


def derive_library(work: list[tuple[Path, str]], options_of, command_line: dict | None, settings: dict, cache: Path,
                   client, derive, log=print) -> dict[tuple[Path, str], list]:
    """{(file, function): its outcomes} of every task of `work`, on the Dask `client` (each task's
    reruns: one, where its worker died), a failed task's row `failed`; progress after each task:
    done, running, left, the time left at the pace so far."""
    from distributed import as_completed

    start = time.perf_counter()
    batch = uuid.uuid4().hex[:8]           # (a key of this batch's: a rerun's tasks are not an earlier one's results)
    futures = {client.submit(derive_function, path, name, options_of(path), command_line, settings, cache, derive,
                             key=f"derive-{Path(path).name}-{name}-{batch}", pure=False, retries=1): (path, name)
               for path, name in work}
    out = {}
    log(f"{len(work)} functions of {len({p for p, _ in work})} files on {len(client.scheduler_info()['workers'])} "
        "Dask workers")
    for done, future in enumerate(as_completed(futures), 1):
        path, name = futures[future]
        try:
            outcomes, how, seconds = future.result()
        except Exception as e:          # (the worker died twice, or the task raised)
            outcomes, how, seconds = failed(path, name, f"{type(e).__name__}: {e}"), "failed", 0.0
        out[(path, name)] = outcomes
        left = len(work) - done
        pace = (time.perf_counter() - start) / done
        log(f"[{done}/{len(work)}] {Path(path).name}:{name} {how} ({seconds:.0f} s); "
            f"{running(client, batch, left)} running, {left} left, about {pace * left:.0f} s left")
    return {(p, n): out[(p, n)] for p, n in work}
