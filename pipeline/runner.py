"""Runs the derivation: each stage from cache or computed, then checks, results, figures, report.

A stage is passed exactly the config keys and upstream fields it declares (`pipeline.engine.graph`) and
must return exactly its declared outputs. Its cache key covers the values it reads, so a change
whose upstream values come out identical stops there.

Outputs are written into a temporary folder beside `outputs/<name>/` and swapped in at the end,
under a lock per output name: a failed or killed run leaves the previous outputs as they were,
two runs writing the same name leave one complete copy, and a later run sweeps what a killed one
left behind.
"""

from __future__ import annotations

import contextlib
import dataclasses
import importlib
import json
import threading
import time
from collections.abc import Callable
from concurrent.futures import FIRST_COMPLETED, ThreadPoolExecutor, wait
from pathlib import Path
from types import MappingProxyType
from typing import Any

from .engine import checks as checks_mod, faults, graph, paths, toolchains, web_page
from .engine.cache import XLA, Cache, DamagedEntry, Memo, code_hash, digest, direct_imports, stage_key
from .engine.config import Config
from .engine.publishing import output_lock, publish


class StageContractError(RuntimeError):
    """A stage returned other fields than it declares in `pipeline.engine.graph` (a programming error)."""


@dataclasses.dataclass
class RunOutcome:
    results: dict[str, dict[str, Any]]
    keys: dict[str, str]
    computed: list[str]
    checks: list[checks_mod.Check]
    out_dir: Path | None
    config: Config

    @property
    def failed(self) -> list[checks_mod.Check]:
        return [c for c in self.checks if c.verdict == checks_mod.FAIL]


def stage_inputs(stage: graph.Stage, config: Config, results) -> tuple[dict[str, Any], dict[str, Any]]:
    """(config values, input field values) that `stage` reads."""
    inputs = {}
    for path in stage.inputs:
        upstream, field = path.split(".", 1)
        inputs[path] = results[upstream][field]
    return config.subset(stage.reads), inputs


def stage_code(stage: graph.Stage) -> str:
    """What a stage's key takes of its code: the source of its module and of every `pipeline` module
    it imports, and, for a stage that reads the lobe registry itself, the registry's entries (a lobe
    may be registered at run time, outside any source file), and, for a stage that runs an outside
    tool, the tool as found here (a result computed without it is not reused once it is installed)."""
    code = code_hash(stage.module)
    if "pipeline.optics.registry" in direct_imports(stage.module):
        from .optics import registry
        code = digest(code, registry.fingerprint())
    if stage.tools:
        code = digest(code, toolchains.fingerprint(stage.tools))
    return code


def key_of(stage: graph.Stage, config: Config, results) -> str:
    values, inputs = stage_inputs(stage, config, results)
    return stage_key(stage.name, values, inputs, stage_code(stage))


_setup_lock = threading.Lock()
_compile_cache_on = False


def _compute(stage: graph.Stage, values, inputs, cache: Cache, log=None) -> dict[str, Any]:
    global _compile_cache_on
    module = importlib.import_module(stage.module)      # imports JAX only when something is computed
    with _setup_lock:
        if not _compile_cache_on:
            from .optics.numerics import use_compilation_cache
            use_compilation_cache(paths.XLA_CACHE or cache.root / XLA)
            _compile_cache_on = True
    memo = Memo(cache, log)
    result = module.run(values, inputs, memo)
    declared, returned = set(stage.outputs), set(result)
    if declared != returned:
        missing, extra = sorted(declared - returned), sorted(returned - declared)
        raise StageContractError(f"stage '{stage.name}' returned other fields than it declares: "
                                 f"missing {missing}, undeclared {extra}")
    return result


def _compute_and_store(stage, values, inputs, cache, key, label, log) -> dict[str, Any]:
    log(f"{label} computing ...")
    start = time.perf_counter()
    cache.store(stage.name, key, _compute(stage, values, inputs, cache, lambda text: log(f"{label} {text}")))
    # Read back what was stored, so a computed run and a cached run see identical values.
    result = cache.load(stage.name, key)
    log(f"{label} computed in {time.perf_counter() - start:.1f} s ({key[:12]})")
    return result


def run_stages(config: Config, cache: Cache, log: Callable[[str], None] = print,
               stages: tuple[str, ...] | None = None, workers: int = 2,
               on_result: Callable[[dict, dict], None] | None = None):
    """Each stage's result (every stage by default), from cache where its key matches.

    Returns (results, keys, computed), `computed` in graph order. `stages` (names) must include
    every stage they read from. A stage starts as soon as the stages it reads are done, up to
    `workers` at a time: independent stages overlap (one waits in XLA while another imports or
    runs Python), and since each depends only on its inputs, the results do not depend on the order.
    `on_result(results, keys)` is called after each stage is done (the figures start from it).
    The outside tools are found first (`toolchains.prepare`), and one line is logged for each tool
    that the chosen stages run and that is missing.
    """
    chosen = [s for s in graph.STAGES if stages is None or s.name in stages]
    missing = sorted({u for s in chosen for u in s.upstream} - {s.name for s in chosen})
    if missing:
        raise ValueError(f"stages {', '.join(s.name for s in chosen)} read stages that are not asked for: "
                         f"{', '.join(missing)} (graph.closure gives every stage they read)")
    toolchains.prepare()
    for warning in toolchains.warnings({t for s in chosen for t in s.tools}):
        log(warning)
    with cache.in_use():            # `cache --prune` waits for no run: it refuses while one holds this
        swept = cache.sweep()
        if swept:
            log(f"removed {swept} temporary folder(s) that killed runs left in the cache")
        results, keys, computed = _run_graph(chosen, config, cache, log, workers, on_result)
    return {s.name: results[s.name] for s in chosen}, {s.name: keys[s.name] for s in chosen}, computed


def _run_graph(chosen, config, cache, log, workers, on_result):
    order = {s.name: i for i, s in enumerate(chosen, 1)}
    width = max(len(s.name) for s in chosen)
    # Every stage's code hash before any stage runs: hashing parses source (`ast`), and CPython
    # 3.11 can fail ("AST constructor recursion depth mismatch") when that overlaps Dr.Jit parsing
    # Mitsuba's integrators in a stage thread.
    codes = {stage.name: stage_code(stage) for stage in chosen}
    results, keys, computed = {}, {}, []
    pending = list(chosen)
    pool = ThreadPoolExecutor(workers)
    try:
        running = {}
        while pending or running:
            progress = True
            while progress:
                progress = False
                for stage in list(pending):
                    if len(running) >= workers or not all(u in results for u in stage.upstream):
                        continue
                    pending.remove(stage)
                    progress = True
                    values, inputs = stage_inputs(stage, config, results)
                    key = stage_key(stage.name, values, inputs, codes[stage.name])
                    keys[stage.name] = key
                    label = f"[{order[stage.name]:>2}/{len(chosen)}] {stage.name:<{width}}"
                    try:
                        result = cache.load(stage.name, key)
                    except DamagedEntry as e:
                        log(f"{label} cache entry {key[:12]} is damaged ({e}); recomputing")
                        cache.discard(stage.name, key)
                        result = None
                    if result is not None:
                        log(f"{label} cached ({key[:12]})")
                        results[stage.name] = result
                        if on_result is not None:
                            on_result(results, keys)
                    else:
                        future = pool.submit(_compute_and_store, stage, values, inputs, cache, key, label, log)
                        running[future] = stage
            if running:
                done = ()
                while not done:         # woken twice a second, to act on a signal whose exception was lost
                    done, _ = wait(running, timeout=0.5, return_when=FIRST_COMPLETED)
                    faults.check_interrupted()
                for future in done:
                    stage = running.pop(future)
                    results[stage.name] = future.result()      # a stage's error propagates here
                    computed.append(stage.name)
                    if on_result is not None:
                        on_result(results, keys)
    except BaseException:
        # An error or an interrupt: stages not started are dropped, and running ones are not waited for.
        pool.shutdown(wait=False, cancel_futures=True)
        raise
    pool.shutdown()
    computed.sort(key=order.get)
    return results, keys, computed


def explain(config: Config, cache: Cache, only: tuple[str, ...] | None = None) -> list[tuple[str, str]]:
    """What a run of `config` would do, stage by stage, without computing: (stage, what).

    A stage whose key is in the cache is "cached"; a stage whose inputs are all known but whose key
    is not, "recomputes"; below a recomputed stage the inputs are not known until it runs, so the
    stage "recomputes if <fields> change" (early cutoff stops there when they come out identical).
    With `only` (stage names), the plan of `--only`: those stages and what they read.
    """
    chosen = graph.closure(only) if only else tuple(s.name for s in graph.STAGES)
    results: dict[str, dict[str, Any]] = {}
    unknown: set[str] = set()
    out = []
    for stage in (s for s in graph.STAGES if s.name in chosen):
        pending = [p for p in stage.inputs if p.split(".", 1)[0] in unknown]
        if pending:
            unknown.add(stage.name)
            out.append((stage.name, "recomputes if " + ", ".join(pending) + " change"))
            continue
        key = key_of(stage, config, results)
        try:
            result = cache.load(stage.name, key)
        except DamagedEntry:
            result = None
        if result is None:
            unknown.add(stage.name)
            changed = config.changed_from_file(config.subset(stage.reads))
            why = f" (reads {', '.join(changed)})" if changed else ""
            out.append((stage.name, "recomputes" + why))
        else:
            results[stage.name] = result
            out.append((stage.name, "cached"))
    return out


def file_results(config: Config, cache: Cache, results, keys) -> dict[str, dict[str, Any]]:
    """The results of the stages of `results` under the config file's own settings (before `--set`),
    where they are known without computing: a stage whose key is the run's has the run's result, any
    other is read from the cache (absent: unknown, and so is every stage that reads it)."""
    if not config.changed_from_file(config.values):
        return dict(results)
    own = Config(MappingProxyType(dict(config.file_values)), config.expectations, config.source,
                 config.file_values)
    found: dict[str, dict[str, Any]] = {}
    for stage in graph.STAGES:
        if stage.name not in results or not all(u in found for u in stage.upstream):
            continue
        key = key_of(stage, own, found)
        if key == keys[stage.name]:
            found[stage.name] = results[stage.name]
            continue
        try:
            result = cache.load(stage.name, key)
        except DamagedEntry:
            result = None
        if result is not None:
            found[stage.name] = result
    return found


def _outputs_key(config: Config, keys: dict[str, str], baseline: RunOutcome | None) -> str:
    code = "".join(code_hash(m) for m in ("pipeline.publish.figures", "pipeline.publish.plots",
                                          "pipeline.publish.report",
                                          "pipeline.publish.results", "pipeline.publish.shader",
                                          "pipeline.publish.tables", "pipeline.publish.summary",
                                          "pipeline.publish.paper_page", "pipeline.engine.web_page",
                                          "pipeline.engine.checks")) + web_page.assets_digest()
    return digest("outputs", keys, baseline.keys if baseline else None, dict(config.values), config.source,
                  json.dumps([dataclasses.asdict(e) for e in config.expectations], sort_keys=True, default=str),
                  code)


def run_derivation(config: Config, cache_dir: Path = paths.CACHE, outputs: Path = paths.OUTPUTS,
                   log: Callable[[str], None] = print, write_outputs: bool = True,
                   baseline: RunOutcome | None = None, only: tuple[str, ...] | None = None) -> RunOutcome:
    """Runs every stage (with `only`, those stages and what they read), evaluates the checks and
    (re)writes `outputs/<name>/` if anything changed."""
    stages = graph.closure(only) if only else None
    cache = Cache(cache_dir)
    out_dir = paths.output_dir(config.name, outputs) if write_outputs else None
    drawer = None
    if out_dir is not None:
        from .publish.figures import FigureDrawer
        # Figures are drawn in a second process while later stages compute.
        drawer = FigureDrawer(config, cache.root, log)
    try:
        # One run at a time writes a folder: a second one waits here, and says so.
        with output_lock(out_dir, log) if out_dir is not None else contextlib.nullcontext():
            results, keys, computed = run_stages(config, cache, log, stages=stages,
                                                 on_result=drawer.update if drawer else None)
            checks = checks_mod.evaluate(config, results, file_results(config, cache, results, keys))
            faults.check_interrupted()
            if out_dir is not None:
                publish(out_dir, _outputs_key(config, keys, baseline), log,
                        lambda tmp: _write_outputs(tmp, config, results, keys, checks, baseline, drawer),
                        locked=True)
    except BaseException:
        if drawer is not None:
            drawer.close(now=True)      # the figure being drawn is not waited for
        raise
    else:
        if drawer is not None:
            drawer.close()
    return RunOutcome(results, keys, computed, checks, out_dir, config)


def _write_outputs(tmp: Path, config, results, keys, checks, baseline, drawer) -> str:
    from .publish import paper_page, report, results as results_mod, shader, summary, tables

    doc = results_mod.write(tmp / "results.json", config, keys, results, checks)
    drawn = drawer.collect(tmp, results, keys)
    tables.write(tmp, config, results)
    if len(results) < len(graph.STAGES):
        # A targeted run (`--only`): what it computed, and a short report that says what it did not.
        report.write_targeted(tmp / "report.md", config, doc, checks, drawn)
    else:
        shader.write(tmp, config, results, keys)
        top = summary.write(tmp / "summary.md", config, results)
        report.write(tmp / "report.md", config, doc, results, checks, drawn, baseline, top)
        paper_page.write(tmp / "report.html", config, doc, results, checks, drawn)
    return f"{sum(len(v) for v in drawn.values())} figures, report.md, results.json"
