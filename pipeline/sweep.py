"""`pipeline sweep SWEEP.toml`: a grid of refits, run on Dask distributed.

A sweep file names a base config, fixed `--set` values, axes of values (their product, or zipped
lists) and optionally `only` (the stages of `--only`):

    [sweep]
    name = "q_metric"                   # outputs/q_metric/<point>/
    config = "configs/paper.toml"
    mode = "product"                    # or "zip"
    only = ["accuracy"]                 # optional
    set = { "derivation.constants" = "fitted" }
    [axes]
    "derivation.Q" = [0.55, 0.6, 0.65, 0.7]
    "derivation.metric" = ["relative_epicenter", "absolute"]

Every point is validated before anything runs. Each point is a refit into
`outputs/<sweep>/<point>/`, named from its values, and all points share the value-keyed cache.
The points run as Dask tasks: on a LocalCluster of this machine by default (one worker process per
core, one thread each, and XLA limited to one thread per worker), or on an existing cluster
(`--scheduler ADDRESS`, `--scheduler-file FILE`) started any way (`dask scheduler` and `dask worker`
in any directory, under nannies). A task carries what it needs: the point's resolved config (read
and validated here) and the absolute cache and outputs folders chosen here; a worker reads nothing
from its own directory or environment. Its figures are drawn in the worker's process where it is
daemonic (`pipeline.publish.figures`). A point that fails is reported with its message (naming
the worker where the failure is the worker's: a folder it cannot write) and does not stop the
others; a point whose worker died is run again by Dask. A lost scheduler ends the sweep with
one line (exit 3): the finished points are kept, and a rerun computes only the rest. A point whose
stages are all cached (a rerun) runs in this process, so a rerun with nothing to compute starts no
Dask cluster at all. At the end the sweep writes `compare.csv` and `compare.png` (`pipeline compare`)
into its folder.
"""

from __future__ import annotations

import dataclasses
import itertools
import os
import time
from pathlib import Path
from typing import Any

from .engine import faults, paths, toolchains
from .engine.cluster import WORKER_ENV, client as cluster_client
from .engine.config import ConfigError, load_config, parse_override

SWEEP_KEYS = ("name", "config", "mode", "only", "set", "plot")


@dataclasses.dataclass(frozen=True)
class Point:
    name: str
    overrides: tuple[str, ...]          # `--set` texts: the fixed ones, then this point's axis values


@dataclasses.dataclass(frozen=True)
class Sweep:
    name: str
    config: str
    points: tuple[Point, ...]
    only: tuple[str, ...] | None
    plot: str | None


def _literal(value: Any) -> str:
    """A TOML literal for `--set` (strings quoted, so that they stay strings)."""
    if isinstance(value, str):
        return '"' + value.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, list):
        return "[" + ", ".join(_literal(v) for v in value) + "]"
    return repr(value)


def _part(key: str, value: Any) -> str:
    """One axis value in a point's name: `Q-0p55`, `metric-absolute` (run.name allows letters,
    digits, '-' and '_')."""
    text = str(value).replace(".", "p").replace("-", "m").replace("+", "")
    text = "".join(c if c.isalnum() or c == "_" else "_" for c in text)
    return f"{key.split('.')[-1]}-{text}"


def load_sweep(path: str | Path) -> Sweep:
    """Reads and checks a sweep file; every point's config is validated here, before anything runs."""
    from .engine import graph

    from .engine.toml_files import read_toml

    path = Path(path)
    raw = read_toml(path, "sweep file", ConfigError)
    unknown = set(raw) - {"sweep", "axes"}
    if unknown:
        raise ConfigError(f"sweep file '{path}': unknown section '[{sorted(unknown)[0]}]'; allowed: [sweep], [axes]")
    head, axes = raw.get("sweep", {}), raw.get("axes", {})
    extra = set(head) - set(SWEEP_KEYS)
    if extra:
        raise ConfigError(f"sweep file '{path}': unknown key 'sweep.{sorted(extra)[0]}'; allowed: "
                          + ", ".join(SWEEP_KEYS))
    name = head.get("name", path.stem)
    if not isinstance(name, str) or not name or not all(c.isalnum() or c in "-_" for c in name):
        raise ConfigError(f"sweep file '{path}': 'sweep.name' = {name!r} is not allowed: letters, digits, '-', '_'")
    config = str(head.get("config", paths.PAPER_CONFIG))
    mode = head.get("mode", "product")
    if mode not in ("product", "zip"):
        raise ConfigError(f"sweep file '{path}': 'sweep.mode' = {mode!r} is not allowed: \"product\" or \"zip\"")
    only = head.get("only")
    if only is not None:
        if isinstance(only, str):
            only = [only]
        bad = [s for s in only if s not in graph.BY_NAME] if isinstance(only, list) else [only]
        if bad or not only:
            raise ConfigError(f"sweep file '{path}': 'sweep.only' = {only!r}: the stages are " + ", ".join(graph.BY_NAME))
        only = tuple(only)
    fixed = head.get("set", {})
    if not isinstance(fixed, dict):
        raise ConfigError(f"sweep file '{path}': 'sweep.set' must be a table of config keys and values")
    if not isinstance(axes, dict) or not axes:
        raise ConfigError(f"sweep file '{path}': [axes] must name at least one config key with a list of values")
    for key, values in axes.items():
        if not isinstance(values, list) or not values:
            raise ConfigError(f"sweep file '{path}': axis '{key}' must be a non-empty list of values")
    if mode == "zip" and len({len(v) for v in axes.values()}) > 1:
        raise ConfigError(f"sweep file '{path}': with mode = \"zip\" every axis needs as many values; they have "
                          + ", ".join(f"{k}: {len(v)}" for k, v in axes.items()))
    combos = list(zip(*axes.values())) if mode == "zip" else list(itertools.product(*axes.values()))
    base = tuple(f"{k}={_literal(v)}" for k, v in fixed.items())
    points = []
    for combo in combos:
        point_name = "_".join(_part(k, v) for k, v in zip(axes, combo))
        overrides = base + tuple(f"{k}={_literal(v)}" for k, v in zip(axes, combo))
        for text in overrides:
            parse_override(text)
        try:
            load_config(config, overrides, name=point_name)
        except ConfigError as e:
            raise ConfigError(f"sweep file '{path}', point {point_name}: {e}") from None
        points.append(Point(point_name, overrides))
    if len({p.name for p in points}) != len(points):
        raise ConfigError(f"sweep file '{path}': two points have the same values")
    return Sweep(name, config, tuple(points), only, head.get("plot"))


def run_point(config, only, cache_dir: str, outputs_dir: str, xla_cache_dir: str | None) -> dict[str, Any]:
    """One point, in a Dask worker (or here): a refit of `config` (its resolved values, sent by the
    client: nothing is read from the worker's directory) into `outputs_dir/<point>/`, with the
    stage cache in `cache_dir` and compiled XLA programs in `xla_cache_dir` (None: the cache's
    own), all absolute and chosen by the client. Returns what happened (with the Mitsuba variant
    its renders ran, where it rendered, and the warnings of its run: a tool the worker lacks); a
    failure is a returned message, naming the worker, so that the others go on."""
    import sys

    if "jax" not in sys.modules:        # XLA is configured at its first use: one thread per task
        for name, value in WORKER_ENV.items():
            os.environ.setdefault(name, value)
    toolchains.prepare()        # on a cluster started by others: only PATH and HOME may be set
    paths.XLA_CACHE = xla_cache_dir
    from .optics.roots import SolverError
    from .runner import run_derivation

    start = time.perf_counter()
    warnings: list[str] = []

    def log(text: str) -> None:
        if "warning: " in text:
            warnings.append(text[text.index("warning: "):])
    try:
        outcome = run_derivation(config, cache_dir=Path(cache_dir), outputs=Path(outputs_dir), log=log, only=only)
    except (SolverError, ConfigError) as e:         # the point's own settings
        return dict(name=config.name, ok=False, message=f"{type(e).__name__}: {e}", seconds=time.perf_counter() - start,
                    warnings=warnings)
    except (OSError, faults.EnvironmentFault) as e:          # where it ran: which worker says
        return dict(name=config.name, ok=False, message=f"{type(e).__name__}{_on_worker()}: {e}",
                    seconds=time.perf_counter() - start, warnings=warnings)
    variants = {outcome.results[s]["variant"] for s in ("mitsuba_render", "microfacet_render") if s in outcome.results}
    return dict(name=config.name, ok=True, message=f"{len(outcome.computed)} stages computed"
                + (f", {len(outcome.failed)} checks FAILED" if outcome.failed else ""),
                seconds=time.perf_counter() - start, variant=", ".join(sorted(variants)) or None,
                warnings=warnings, worker=_on_worker())


def _on_worker() -> str:
    """` on worker ADDRESS (HOST)` inside a Dask worker, else ''."""
    try:
        from distributed import get_worker
        import socket

        return f" on worker {get_worker().address} ({socket.gethostname()})"
    except (ImportError, ValueError):
        return ""


class SchedulerLost(Exception):
    """The client lost its scheduler while points were pending."""

    def __init__(self, address: str, reason: str):
        super().__init__(address, reason)
        self.address, self.reason = address, reason


def _fully_cached(config, only, cache_dir: str) -> bool:
    """Whether every stage the point runs is in the cache (`pipeline explain` says "cached" for each):
    such a point only reads the cache and (re)publishes its folder, and runs here, not on Dask."""
    from .engine.cache import Cache, DamagedEntry
    from .runner import explain

    try:
        return all(what == "cached" for _, what in explain(config, Cache(Path(cache_dir)), only))
    except (DamagedEntry, ConfigError, OSError):        # the point's own run says what is wrong
        return False


def run_sweep(sweep: Sweep, scheduler: str | None = None, scheduler_file: str | None = None,
              workers: int | None = None, log=print) -> list[dict[str, Any]]:
    """Runs every point on Dask (a point whose stages are all cached here, without starting
    Dask); prints a progress line per finished point; writes the comparison."""
    # Absolute locations, chosen here: a worker may run in any directory.
    outputs = paths.OUTPUTS.absolute() / sweep.name
    cache_dir = str(paths.CACHE.absolute())
    xla_cache_dir = str(Path(paths.XLA_CACHE).absolute()) if paths.XLA_CACHE else None
    # Each point's resolved config (the file read here, the sweep's settings applied): what a worker gets.
    configs = {p.name: load_config(sweep.config, p.overrides, name=p.name) for p in sweep.points}
    done: list[dict[str, Any]] = []
    start = time.perf_counter()

    warned: set[str] = set()

    def report(result, running):
        done.append(result)
        for warning in result.get("warnings", ()):
            if warning not in warned:           # each once, said by the first point that met it
                warned.add(warning)
                log(f"{result['name']}{result.get('worker', '')}: {warning}")
        elapsed = time.perf_counter() - start
        left = len(sweep.points) - len(done)
        eta = elapsed / len(done) * left
        failed = sum(not r["ok"] for r in done)
        log(f"[{len(done)}/{len(sweep.points)}] done {len(done) - failed}, failed {failed}, running "
            f"{min(left, running)}, ETA {eta:.0f} s | {result['name']}: "
            f"{'ok' if result['ok'] else 'FAILED'} ({result['message']}, {result['seconds']:.1f} s)")

    here = {name for name, config in configs.items() if _fully_cached(config, sweep.only, cache_dir)}
    cached = [configs[p.name] for p in sweep.points if p.name in here]
    remote = [configs[p.name] for p in sweep.points if p.name not in here]
    if remote:
        try:
            _run_on_dask(sweep, remote, cached, outputs, (cache_dir, xla_cache_dir), scheduler, scheduler_file, workers,
                         log, report)
        except SchedulerLost as e:
            finished = sum(r["ok"] for r in done)
            raise faults.EnvironmentFault(
                f"the Dask scheduler at {e.address} was lost mid-sweep ({e.reason}): {finished} of "
                f"{len(sweep.points)} points done and kept in {outputs}; a rerun computes only the rest") from None
    else:
        log(f"sweep '{sweep.name}': every stage of its {len(cached)} points is cached: run here, without Dask")
        _run_here(sweep, cached, outputs, (cache_dir, xla_cache_dir), report, running=0)
    _compare(sweep, outputs, done, log)
    return done


def _run_here(sweep: Sweep, configs, outputs: Path, caches: tuple[str, str | None], report, running: int) -> None:
    for config in configs:
        faults.check_interrupted()
        report(run_point(config, sweep.only, caches[0], str(outputs), caches[1]), running)


def _run_on_dask(sweep: Sweep, configs, cached, outputs: Path, caches: tuple[str, str | None], scheduler,
                 scheduler_file, workers, log, report) -> None:
    """The points of `configs` as Dask tasks; the `cached` points run here meanwhile."""
    from distributed import wait
    from distributed.client import FutureCancelledError, FuturesCancelledError

    client, cluster = cluster_client(scheduler, scheduler_file, workers)
    address = client.scheduler.address
    try:
        futures = {client.submit(run_point, c, sweep.only, caches[0], str(outputs), caches[1],
                                 key=f"point-{sweep.name}-{c.name}", pure=False, retries=1): c for c in configs}
        pending = set(futures)
        log(f"sweep '{sweep.name}': {len(futures)} points on {len(client.scheduler_info()['workers'])} Dask workers "
            f"into {outputs}" + (f" ({len(cached)} with every stage cached run here)" if cached else ""))
        _run_here(sweep, cached, outputs, caches, report, running=len(pending))
        while pending:
            try:                    # woken twice a second, to act on Ctrl-C
                finished = wait(pending, timeout=0.5, return_when="FIRST_COMPLETED").done
            except TimeoutError:
                finished = set()
            except FuturesCancelledError as e:       # the client gave up on the scheduler
                raise SchedulerLost(address, e.error_groups[0].reason) from None
            pending -= finished
            faults.check_interrupted()
            for future in finished:
                config = futures[future]
                try:
                    result = future.result()
                except FutureCancelledError as e:
                    raise SchedulerLost(address, e.reason) from None
                except Exception as e:          # the worker died twice, or the task could not run
                    result = dict(name=config.name, ok=False, message=f"{type(e).__name__}: {e}", seconds=0.0)
                report(result, len(pending))
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


def _compare(sweep: Sweep, outputs: Path, done, log) -> None:
    from .publish import compare

    finished = {r["name"] for r in done if r["ok"]}
    ok = [outputs / p.name for p in sweep.points if p.name in finished and (outputs / p.name / "results.json").is_file()]
    if not ok:
        return
    runs = compare.find_runs(ok)
    columns, rows = compare.table(runs)
    compare.write_csv(outputs / ".compare.csv.tmp", columns, rows)
    os.replace(outputs / ".compare.csv.tmp", outputs / "compare.csv")
    written = ["compare.csv"]
    keys = compare.differing_keys(runs)
    plot = sweep.plot.split(":", 1) if sweep.plot else None
    if plot is None and keys and len(runs) > 1:
        metrics = columns[1 + len(keys):]
        differ = [m for m in metrics if len({compare.cell(r[columns.index(m)]) for r in rows}) > 1]
        if differ:
            plot = [keys[0], differ[0]]
    if plot is not None:
        compare.plot(outputs / ".compare.tmp.png", runs, *plot)
        os.replace(outputs / ".compare.tmp.png", outputs / "compare.png")
        written.append(f"compare.png ({plot[1]} against {plot[0]})")
    log(compare.markdown(columns, rows))
    log(f"wrote {', '.join(written)} into {outputs}")
