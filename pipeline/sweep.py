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
(`--scheduler ADDRESS`, `--scheduler-file FILE`). A point that fails is reported with its message
and does not stop the others; a point whose worker died is retried once. A point whose stages are
all cached (a rerun) runs in this process, so a rerun with nothing to compute starts no Dask
cluster at all. At the end the sweep writes `compare.csv` and `compare.png` (`pipeline compare`)
into its folder.
"""

from __future__ import annotations

import dataclasses
import itertools
import os
import time
import tomllib
from pathlib import Path
from typing import Any

from .engine import faults, paths
from .engine.config import ConfigError, load_config, parse_override

SWEEP_KEYS = ("name", "config", "mode", "only", "set", "plot")
# One thread per worker for XLA: the workers are the parallelism (one per core).
WORKER_ENV = {"XLA_FLAGS": "--xla_cpu_multi_thread_eigen=false intra_op_parallelism_threads=1",
              "OMP_NUM_THREADS": "1"}


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

    path = Path(path)
    try:
        raw = tomllib.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise ConfigError(f"sweep file '{path}' does not exist") from None
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as e:
        raise ConfigError(f"sweep file '{path}' cannot be read as TOML: {e}") from None
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


def run_point(config_file: str, point: Point, only, cache_dir: str, outputs_dir: str) -> dict[str, Any]:
    """One point, in a Dask worker: a refit into `outputs_dir/<point>/`. Returns what happened; a
    failure is a returned message, so that the others go on."""
    from .optics.roots import SolverError
    from .run import run_derivation

    start = time.perf_counter()
    try:
        config = load_config(config_file, point.overrides, name=point.name)
        outcome = run_derivation(config, cache_dir=Path(cache_dir), outputs=Path(outputs_dir), log=lambda s: None,
                                 only=only)
    except (SolverError, ConfigError, OSError, faults.EnvironmentFault) as e:
        return dict(name=point.name, ok=False, message=f"{type(e).__name__}: {e}",
                    seconds=time.perf_counter() - start)
    return dict(name=point.name, ok=True, message=f"{len(outcome.computed)} stages computed"
                + (f", {len(outcome.failed)} checks FAILED" if outcome.failed else ""),
                seconds=time.perf_counter() - start)


def _client(scheduler: str | None, scheduler_file: str | None, workers: int | None):
    """A Dask client: of an existing cluster, or of a LocalCluster of this machine."""
    import dask
    from distributed import Client, LocalCluster

    if scheduler or scheduler_file:
        try:
            return Client(scheduler, scheduler_file=scheduler_file, timeout="3s"), None
        except (OSError, TimeoutError, ValueError) as e:
            where = scheduler or f"scheduler file {scheduler_file}"
            raise ConfigError(f"no Dask scheduler answers at {where}: {e}") from None
    # Worker processes must be allowed children: each point's figures are drawn in a second process.
    dask.config.set({"distributed.worker.daemon": False, "distributed.logging.distributed": "error"})
    cluster = LocalCluster(n_workers=workers or os.cpu_count() or 1, threads_per_worker=1, processes=True,
                           dashboard_address=None, env=dict(WORKER_ENV), silence_logs=50)
    return Client(cluster), cluster


def _fully_cached(config_file: str, point: Point, only, cache_dir: str) -> bool:
    """Whether every stage the point runs is in the cache (`pipeline explain` says "cached" for each):
    such a point only reads the cache and (re)publishes its folder, and runs here, not on Dask."""
    from .engine.cache import Cache
    from .run import explain

    from .engine.cache import DamagedEntry

    try:
        config = load_config(config_file, point.overrides, name=point.name)
        return all(what == "cached" for _, what in explain(config, Cache(Path(cache_dir)), only))
    except (DamagedEntry, ConfigError, OSError):        # the point's own run says what is wrong
        return False


def run_sweep(sweep: Sweep, scheduler: str | None = None, scheduler_file: str | None = None,
              workers: int | None = None, log=print) -> list[dict[str, Any]]:
    """Runs every point on Dask (a point whose stages are all cached here, without starting
    Dask); prints a progress line per finished point; writes the comparison."""
    outputs = paths.OUTPUTS / sweep.name
    cache_dir = str(paths.CACHE)
    done: list[dict[str, Any]] = []
    start = time.perf_counter()

    def report(result, running):
        done.append(result)
        elapsed = time.perf_counter() - start
        left = len(sweep.points) - len(done)
        eta = elapsed / len(done) * left
        failed = sum(not r["ok"] for r in done)
        log(f"[{len(done)}/{len(sweep.points)}] done {len(done) - failed}, failed {failed}, running "
            f"{min(left, running)}, ETA {eta:.0f} s | {result['name']}: "
            f"{'ok' if result['ok'] else 'FAILED'} ({result['message']}, {result['seconds']:.1f} s)")

    cached = [p for p in sweep.points if _fully_cached(sweep.config, p, sweep.only, cache_dir)]
    remote = [p for p in sweep.points if p not in cached]
    if remote:
        _run_on_dask(sweep, remote, cached, outputs, cache_dir, scheduler, scheduler_file, workers, log, report)
    else:
        log(f"sweep '{sweep.name}': every stage of its {len(cached)} points is cached: run here, without Dask")
        _run_here(sweep, cached, outputs, cache_dir, report, running=0)
    _compare(sweep, outputs, done, log)
    return done


def _run_here(sweep: Sweep, points, outputs: Path, cache_dir: str, report, running: int) -> None:
    for point in points:
        faults.check_interrupted()
        report(run_point(sweep.config, point, sweep.only, cache_dir, str(outputs)), running)


def _run_on_dask(sweep: Sweep, points, cached, outputs: Path, cache_dir: str, scheduler, scheduler_file, workers,
                 log, report) -> None:
    """`points` as Dask tasks; the `cached` points run here meanwhile."""
    from distributed import wait

    client, cluster = _client(scheduler, scheduler_file, workers)
    try:
        futures = {client.submit(run_point, sweep.config, p, sweep.only, cache_dir, str(outputs),
                                 key=f"point-{sweep.name}-{p.name}", pure=False, retries=1): p for p in points}
        pending = set(futures)
        log(f"sweep '{sweep.name}': {len(futures)} points on {len(client.scheduler_info()['workers'])} Dask workers "
            f"into {outputs}" + (f" ({len(cached)} with every stage cached run here)" if cached else ""))
        _run_here(sweep, cached, outputs, cache_dir, report, running=len(pending))
        while pending:
            try:                    # woken twice a second, to act on Ctrl-C
                finished = wait(pending, timeout=0.5, return_when="FIRST_COMPLETED").done
            except TimeoutError:
                finished = set()
            pending -= finished
            faults.check_interrupted()
            for future in finished:
                point = futures[future]
                try:
                    result = future.result()
                except Exception as e:          # the worker died twice, or the task could not run
                    result = dict(name=point.name, ok=False, message=f"{type(e).__name__}: {e}", seconds=0.0)
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
