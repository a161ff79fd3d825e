"""Runs the derivation: each stage from cache or computed, then checks, results, figures, report.

Outputs are written into a temporary folder beside `outputs/<name>/` and swapped in at the end,
so a failed run leaves the previous outputs as they were and never a half-written folder.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import shutil
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from . import checks as checks_mod
from . import paths, results as results_mod
from .cache import Cache, DamagedEntry, code_hash, stage_key
from .config import Config
from .stages import STAGES, stage_name


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


def run_stages(config: Config, cache: Cache, log: Callable[[str], None] = print, stages=STAGES):
    """Each stage's result (every stage by default, in order), from cache where its key matches.

    Returns (results, keys, computed). `stages` must list every stage before the ones it reads.
    """
    results, keys, computed = {}, {}, []
    for i, module in enumerate(stages, 1):
        name = stage_name(module)
        upstream = {u: keys[u] for u in module.UPSTREAM}
        key = stage_key(name, config.subset(module.READS), upstream, code_hash(module.__name__))
        keys[name] = key
        label = f"[{i}/{len(stages)}] {name:<19}"
        try:
            result = cache.load(name, key)
        except DamagedEntry as e:
            log(f"{label} cache entry {key[:12]} is damaged ({e}); recomputing")
            cache.discard(name, key)
            result = None
        if result is not None:
            log(f"{label} cached ({key[:12]})")
        else:
            log(f"{label} computing ...")
            start = time.perf_counter()
            result = module.run(config.subset(module.READS), {u: results[u] for u in module.UPSTREAM})
            cache.store(name, key, result)
            # Read back what was stored, so a computed run and a cached run see identical values.
            result = cache.load(name, key)
            computed.append(name)
            log(f"{label} computed in {time.perf_counter() - start:.1f} s ({key[:12]})")
        results[name] = result
    return results, keys, computed


def _outputs_key(config: Config, keys: dict[str, str], baseline: RunOutcome | None) -> str:
    code = "".join(code_hash(m) for m in ("pipeline.figures", "pipeline.report", "pipeline.report_beyond", "pipeline.results",
                                          "pipeline.shader",
                                          "pipeline.checks", "pipeline.export"))
    blob = json.dumps(dict(keys=keys, baseline=baseline.keys if baseline else None,
                           config=dict(config.values), source=config.source,
                           expectations=[dataclasses.asdict(e) for e in config.expectations], code=code),
                      sort_keys=True, default=str)
    return hashlib.sha256(blob.encode()).hexdigest()[:32]


def run_derivation(config: Config, cache_dir: Path = paths.CACHE, outputs: Path = paths.OUTPUTS,
                   log: Callable[[str], None] = print, write_outputs: bool = True,
                   baseline: RunOutcome | None = None) -> RunOutcome:
    """Runs every stage, evaluates the checks and (re)writes `outputs/<name>/` if anything changed."""
    cache = Cache(cache_dir)
    results, keys, computed = run_stages(config, cache, log)
    checks = checks_mod.evaluate(config.expectations, results)
    out_dir = paths.output_dir(config.name, outputs) if write_outputs else None
    if out_dir is not None:
        stamp_key = _outputs_key(config, keys, baseline)
        stamp = out_dir / ".stamp"
        if stamp.exists() and stamp.read_text() == stamp_key:
            log(f"outputs in {out_dir} are up to date")
        else:
            _write_outputs(out_dir, stamp_key, config, results, keys, checks, baseline, log)
    return RunOutcome(results, keys, computed, checks, out_dir, config)


def _write_outputs(out_dir, stamp_key, config, results, keys, checks, baseline, log):
    from . import export, figures, report, shader  # matplotlib is imported only when figures are drawn

    start = time.perf_counter()
    out_dir.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{out_dir.name}.", dir=out_dir.parent))
    try:
        doc = results_mod.write(tmp / "results.json", config, keys, results, checks)
        export.write_tables(tmp, results)
        figs = figures.draw_all(tmp, config, results)
        shader.write(tmp, config, results, stamp_key[:12])
        report.write(tmp / "report.md", config, doc, results, checks, figs, baseline)
        (tmp / ".stamp").write_text(stamp_key)
        old = out_dir.with_name(f".{out_dir.name}.old")
        if out_dir.exists():
            shutil.rmtree(old, ignore_errors=True)
            out_dir.rename(old)
        tmp.rename(out_dir)
        shutil.rmtree(old, ignore_errors=True)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    log(f"wrote {out_dir} ({len(figs)} figures, report.md, results.json) in "
        f"{time.perf_counter() - start:.1f} s")
