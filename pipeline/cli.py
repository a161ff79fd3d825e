"""Command line: `pipeline reproduce`, `refit`, `explain`, `graph`, `keys`, `tools`, `cache`, `regress`, `derive`, `costs`, `compare`, `sweep`.

Exit codes (`pipeline.engine.faults`): 0 every check passes, differs with a documented cause or is
not comparable; 1 a check failed or a solver did not converge; 2 bad config, arguments or CSV
(nothing computed, nothing written); 3 an environment fault (a full disk, a file size limit, a path
that is a file, no permission); 130 interrupted by Ctrl-C or SIGTERM. Each ends with one line
naming the cause, never a traceback. `keys`, `graph`, `explain` and config errors answer without
importing JAX, sympy or pysindy.
"""

from __future__ import annotations

import argparse
import math
import multiprocessing.util
import os
import signal
import sys
import time
from concurrent.futures.process import BrokenProcessPool
from pathlib import Path

from .engine import checks as checks_mod, faults, graph, paths, toolchains
from .engine.config import ConfigError, key_table, load_config
from .publish.compare import CompareError
from .symbolic import grammar
from .isa.architectures import ARCHITECTURES
from .symbolic.regress import BUDGET_SECONDS, DEFAULT_OPERATIONS, MAX_COMPLEXITY, RegressError
from .approximate.targets import DeriveError
from .shaders.definitions import ShaderError


def _print_checks(outcome) -> None:
    if outcome.checks:
        print()
        print(checks_mod.table(outcome.checks))
        for c in outcome.checks:
            if c.verdict == checks_mod.DIFFERS:
                print(f"  {c.expectation.id} differs from the paper: {c.expectation.known_difference}")
        skipped = [c for c in outcome.checks if c.verdict == checks_mod.NOT_COMPARABLE]
        if skipped:
            print(f"  {len(skipped)} check(s) not comparable: this run's settings differ from those the expected "
                  "values were reported for (the report shows both values)")
    if outcome.failed:
        print(f"\n{len(outcome.failed)} check(s) FAILED: " + ", ".join(c.expectation.id for c in outcome.failed))


def _refit_config(args):
    config = load_config(args.config, tuple(args.overrides), name=args.out)
    if config.name == "paper":
        raise ConfigError("config key 'run.name' = 'paper' is not allowed for a refit: "
                          "the paper's outputs are written only by `make reproduce`; set run.name or --out")
    return config


def _only(text: str | None) -> tuple[str, ...] | None:
    """`--only STAGE[,STAGE...]`: the stage names, checked against the graph."""
    if text is None:
        return None
    names = tuple(t for t in (part.strip() for part in text.split(",")) if t)
    unknown = [t for t in names if t not in graph.BY_NAME]
    if unknown or not names:
        raise ConfigError(f"--only {text!r}: {'unknown stage ' + repr(unknown[0]) if unknown else 'no stage named'}; "
                          "the stages are " + ", ".join(graph.BY_NAME))
    return names


def _explain(config, only=None) -> int:
    from .engine.cache import Cache
    from .runner import explain

    rows = explain(config, Cache(paths.CACHE), only)
    changed = config.changed_from_file(config.values)
    print(f"config {config.source}" + (f", with {', '.join(changed)} changed" if changed else "") + ":")
    width = max(len(name) for name, _ in rows)
    for name, what in rows:
        print(f"  {name:<{width}}  {what}")
    print("Nothing was computed. A stage below a recomputed one is skipped when the fields it reads come "
          "out identical.")
    return 0


def _tools() -> int:
    """`pipeline tools`: each outside tool as `toolchains` finds it, the stages that run it, and
    the Mitsuba variant that a run's "auto" takes here (probed by a render in a child process)."""
    from .mitsuba import bsdf

    rows = []
    for tool in toolchains.FINDERS:
        found = toolchains.locate(tool)
        stages = ", ".join(s.name for s in graph.STAGES if tool in s.tools) or "-"
        rows.append((tool, found.version or "-", found.path or "not found", found.how if found.found
                     else found.missing, stages))
    widths = [max(len(r[i]) for r in rows) for i in range(3)]
    for tool, version, path, how, stages in rows:
        print(f"{tool:<{widths[0]}}  {version:<{widths[1]}}  {path:<{widths[2]}}  {how}; stages: {stages}")
    variant = bsdf.choose_variant()
    print(f"Mitsuba variant (mitsuba.variant = auto): {variant}")
    warning = bsdf.fallback_warning(variant)
    if warning:
        print(warning)
    return 0


def _cache(args) -> int:
    from .engine.cache import Cache, leftovers

    cache = Cache(paths.CACHE)
    if args.prune:
        removed, freed = cache.prune(args.older_than * 86400.0)
        print(f"removed {removed} entries unused for more than {args.older_than:g} days ({freed / 1e6:.1f} MB)")
    entries = cache.entries()
    print(f"cache {cache.root}: {len(entries)} entries, "
          f"{(sum(e.bytes for e in entries) + cache.xla_bytes()) / 1e6:.1f} MB "
          f"(of which compiled XLA programs {cache.xla_bytes() / 1e6:.1f} MB)")
    kinds: dict[str, list] = {}
    for e in entries:
        kinds.setdefault(e.kind, []).append(e)
    now = time.time()
    for kind, items in kinds.items():
        newest = min(now - e.last_used for e in items) / 86400.0
        print(f"  {kind:<28} {len(items):>4} entries {sum(e.bytes for e in items) / 1e6:8.1f} MB, "
              f"last used {newest:.1f} days ago")
    left = leftovers(cache.root)
    size = sum(f.stat().st_size for folder in left for f in folder.rglob("*") if f.is_file())
    print(f"  {len(left)} temporary folders of interrupted writes ({size / 1e6:.1f} MB)"
          + (": the next run or `pipeline cache --prune` removes them" if left else ""))
    return 0


def _plan_option(args, error, *fixed):
    """The recorded plans of `--plan` (a `budgets.Budget`), or None; `error` (the command's bad-input
    exception) where the file holds no usable plan, where an option in `fixed` ((name, value) given,
    not None) would change what the plan fixes, or where `--timeout` is not a positive number. Arms
    the timeout."""
    from .symbolic import budgets

    if args.timeout is not None and not (math.isfinite(args.timeout) and args.timeout > 0):
        raise error(f"--timeout {args.timeout:g}: give a positive number of seconds")
    plan = None
    if args.plan is not None:
        given = [name for name, value in fixed if value is not None]
        if given:
            raise error(f"--plan fixes the work; {' and '.join(given)} would change it: give one or the other")
        try:
            plan = budgets.recorded(args.plan)
        except budgets.PlanError as e:
            raise error(str(e)) from None
    faults.stop_after(args.timeout)
    return plan


def _regress(args) -> int:
    from .engine.cache import XLA
    from .optics.numerics import use_compilation_cache
    from .symbolic.regress import parse_operations, regress

    start = time.perf_counter()
    plan = _plan_option(args, RegressError, ("--seconds", args.seconds), ("--engine", args.engine),
                        ("--seed", args.seed))
    # the fits' compiled programs kept with the pipeline's (a later search with the same operations
    # skips their compilation, about 6 s with the ten operations)
    use_compilation_cache(paths.XLA_CACHE or paths.CACHE / XLA)
    out = Path(args.out) if args.out else paths.OUTPUTS / "regress" / Path(args.file).stem
    front = regress(Path(args.file), args.x, args.y, out, args.max_complexity, parse_operations(args.ops),
                    seed=args.seed or 0, noise=args.noise, engine=args.engine or "auto", loss=args.loss, cost=args.cost,
                    gpu=args.gpu, seconds=args.seconds, plan=plan)
    engines = len({m["engine"] for m in front}) > 1 or front[0]["engine"] != "exhaustive"
    cycles = args.gpu is not None
    print(f"complexity  {'loss: ' + args.loss:<12} DL (nats)  " + ("cycles  " if cycles else "")
          + ("engine      " if engines else "") + "expression")
    for m in front:
        print(f"{m['complexity']:>10}  {m['loss']:<11.6g}  {m['description_length']:<9.4g}  "
              + (f"{m['cycles']:>6g}  " if cycles else "")
              + (f"{m['engine']:<10}  " if engines else "") + m["canonical"]
              + ("   <- selected" if m["selected"] else ""))
    print(f"wrote {out / 'front.csv'}, {out / 'front.png'} and {out / 'plan.json'}; {time.perf_counter() - start:.1f} s")
    return 0


def _derive(args) -> int:
    if args.shader is not None:
        return _derive_shader(args)
    shader_only = [f for f, v in (("--function", args.function), ("--lang", args.lang), ("-I", args.include),
                                  ("-D", args.define), ("--max-error", args.max_error), ("--exact", args.exact),
                                  ("--keep-reference", args.keep_reference or None), ("--scheduler", args.scheduler),
                                  ("--workers", args.workers)) if v is not None]
    if shader_only:
        raise DeriveError(f"{shader_only[0]} goes with --shader")
    if args.var is not None and len(args.var) > 1:
        raise DeriveError("--var: give one with --expr (several go with --shader)")
    args.var = args.var[0] if args.var else "x=0:1"
    from .approximate import api
    from .approximate.publishing import derive_files as publish
    from .engine import escape
    from .engine.cache import XLA
    from .isa.machine_code import CompilerMissing
    from .optics.numerics import use_compilation_cache
    from .optics.spirv import ToolMissing

    start = time.perf_counter()
    plan = _plan_option(args, DeriveError, ("--seconds", args.seconds))
    target = api.resolve(args.target, args.expr, args.var, args.metric, args.floor, args.table, args.x, args.parameter,
                         args.y, args.parameter_range, args.name)
    out = Path(args.out) if args.out else paths.OUTPUTS / "derive" / escape.folder_name(target.name)
    if out.exists() and not out.is_dir():
        raise DeriveError(f"--out {out}: a file, not a folder: give an output folder (the file is left as it is)")
    use_compilation_cache(paths.XLA_CACHE or paths.CACHE / XLA)
    try:
        found = api.derive(target, gpu=args.gpu, seconds=args.seconds, max_cycles=args.max_cycles,
                           max_complexity=args.max_complexity, formula_complexity=args.formula_complexity,
                           precision=args.precision, plan=plan, platforms=args.platforms, certify=args.certify,
                           contract=args.contract)
    except (CompilerMissing, ToolMissing) as e:
        print(f"error: the GPU compilers cannot run here: {e}", file=sys.stderr)
        return faults.EXIT_ENVIRONMENT
    written = found.write(out)
    results = found.raw
    error = results["error"]
    for a in results["architectures"]:
        for per in sorted({r["parameter_per"] for r in found.front if r["architecture"] == a}):
            front = sorted((r for r in found.front if r["architecture"] == a and r["parameter_per"] == per),
                           key=lambda r: r["cycles"])
            print(f"{a}{f' (parameter per {per})' if per else ''}: "
                  + ", ".join(f"{r['cycles']:g} cycles {r[error]:.3g} ({r['name']})" for r in front))
        for name, v in results["verdicts"][a].items():
            print(f"  {name} ({v['cycles']:g} cycles, {v['error']:.3g}): {v['verdict']}"
                  + (f" by {v['by']} ({v['ratio']:.3g} of its error)" if v["by"] else ""))
    if results["missing"]:
        print(publish.not_compiled_text(results))
    print(f"wrote {', '.join(str(p) for p in written)}; {time.perf_counter() - start:.1f} s")
    return 0


def _costs(args) -> int:
    from .isa import architectures, machine_code
    from .isa.machine_code import CompilerMissing
    from .optics.spirv import ToolMissing
    from .symbolic import gpu_costs

    out = Path(args.out) if args.out else paths.OUTPUTS / "costs"
    if not 20 <= args.forms <= 2000:
        print(f"error: --forms {args.forms}: give an integer in [20, 2000]", file=sys.stderr)
        return faults.EXIT_BAD_INPUT
    try:
        chosen = [a.name for a in architectures.named(args.gpu.split(","))] if args.gpu else list(architectures.ARCHITECTURES)
    except ValueError as e:
        print(f"error: --gpu {args.gpu}: {e}", file=sys.stderr)
        return faults.EXIT_BAD_INPUT
    print(f"compiling {args.forms} forms for {architectures.label(chosen)} "
          f"(about {machine_code.estimate_seconds(args.forms, chosen):.0f} s)")
    try:
        costs = gpu_costs.operation_costs(args.forms, chosen)
    except (CompilerMissing, ToolMissing) as e:
        print(f"error: the GPU compiler cannot run here: {e}", file=sys.stderr)
        return faults.EXIT_ENVIRONMENT
    print("cycles          " + " ".join(f"{op:>7}" for op in gpu_costs.OPERATIONS) + "   held-out error (mean, max)")
    for architecture, table in costs["tables"].items():
        held = costs["held_out"][architecture]
        print(f"{architecture:<15} " + " ".join(f"{table[op]:>7g}" for op in gpu_costs.OPERATIONS)
              + f"   {held['mean_abs_error']:.2f}, {held['max_abs_error']:.1f} of {held['mean_cycles']:.1f} on average")
    written = gpu_costs.write_tables(costs["tables"], out)
    print("wrote " + ", ".join(str(p) for p in written) + " (pipeline regress --cost FILE)")
    return 0


def _compare(args) -> int:
    from .publish import compare

    runs = compare.find_runs(args.folders)
    plot = None
    if args.plot is not None:
        if ":" not in args.plot:
            raise compare.CompareError(f"--plot {args.plot!r}: expected KEY:FIELD, e.g. derivation.Q:accuracy.d_f_Q2")
        plot = args.plot.split(":", 1)
    columns, rows = compare.table(runs)
    sweep = len(args.folders) == 1 and not (Path(args.folders[0]) / "results.json").is_file()
    out = Path(args.out) if args.out else Path(args.folders[0]) if sweep else paths.OUTPUTS / "compare"
    out.mkdir(parents=True, exist_ok=True)
    written = [out / "compare.csv"]
    if plot is not None:
        written.append(out / "compare.png")
    # Each file written beside its final name and renamed into place: none is left half written.
    compare.write_csv(out / ".compare.csv.tmp", columns, rows)
    if plot is not None:
        compare.plot(out / ".compare.tmp.png", runs, *plot)
        os.replace(out / ".compare.tmp.png", out / "compare.png")
    os.replace(out / ".compare.csv.tmp", out / "compare.csv")
    print(compare.markdown(columns, rows))
    print(f"\n{len(runs)} runs; config keys that differ: {', '.join(compare.differing_keys(runs)) or 'none'}; "
          f"wrote {', '.join(str(p) for p in written)}")
    return 0


def _sweep(args) -> int:
    from .sweep import load_sweep, run_sweep

    sweep = load_sweep(args.file)
    faults.check_folder(paths.CACHE, "the cache folder (PIPELINE_CACHE_DIR)")
    faults.check_folder(paths.OUTPUTS, "the outputs folder (PIPELINE_OUTPUTS_DIR)")
    start = time.perf_counter()
    done = run_sweep(sweep, args.scheduler, args.scheduler_file, args.workers)
    failed = [r["name"] for r in done if not r["ok"]]
    print(f"\nsweep '{sweep.name}': {len(done) - len(failed)} of {len(done)} points done"
          + (f", failed: {', '.join(failed)}" if failed else "") + f"; {time.perf_counter() - start:.1f} s")
    return faults.EXIT_FAILED if failed else faults.EXIT_DONE


def main(argv: list[str] | None = None) -> int:
    """Runs one command; every way it can end is an exit code and at most one line on stderr."""
    faults.stop_on_signals()
    toolchains.prepare()        # the outside tools, found here whatever shell started the command
    try:
        code = _main(argv)
        faults.check_interrupted()
        return code
    except (faults.Interrupted, faults.TimedOut, KeyboardInterrupt) as e:
        signal.setitimer(signal.ITIMER_REAL, 0)         # (a --timeout's repeated signal: not once more)
        if isinstance(e, faults.TimedOut):
            print(f"error: stopped at the --timeout of {e.seconds:g} s; nothing written", file=sys.stderr)
        else:
            name = e.signal_name if isinstance(e, faults.Interrupted) else "SIGINT"
            print(f"\ninterrupted ({name}): stopped; finished stages stay in the cache, nothing half written was kept",
                  file=sys.stderr)
        sys.stdout.flush()
        sys.stderr.flush()
        # Stages still running in threads cannot be stopped from Python: end the process now rather
        # than wait for them (their unfinished cache entries are temporary folders, swept later),
        # after multiprocessing's own exit handler (the figure worker's queues are released, so its
        # resource tracker has nothing to warn about).
        multiprocessing.util._exit_function()
        os._exit(faults.EXIT_TIMED_OUT if isinstance(e, faults.TimedOut) else faults.EXIT_INTERRUPTED)
    except faults.EnvironmentFault as e:
        print(f"error: {e}", file=sys.stderr)
    except BrokenProcessPool:
        print("error: the figure worker process died (killed, or out of memory): rerun; the cache keeps every "
              "finished stage", file=sys.stderr)
    except OSError as e:
        print(f"error: {faults.describe(e)}", file=sys.stderr)
    return faults.EXIT_ENVIRONMENT


def _derive_shader(args) -> int:
    """`derive --shader FILE`: every function derived (`approximate.api.derive_shader`), the run's
    files written; exit 2 where no function could be read."""
    from .approximate import api
    from .approximate.engines import shader_file
    from .engine import escape
    from .engine.cache import XLA
    from .optics.numerics import use_compilation_cache

    given = [f for f, v in (("--target", args.target), ("--expr", args.expr), ("--table", args.table)) if v is not None]
    if given:
        raise DeriveError(f"--shader and {given[0]}: give one of them")
    if args.certify:
        raise DeriveError("--certify goes with a target (--target, --expr): a shader's functions are derived with "
                          "their errors sampled")
    library = len(args.shader) > 1 or not Path(args.shader[0]).is_file()
    path = Path(args.shader[0])
    out = Path(args.out) if args.out else paths.OUTPUTS / "derive" / escape.folder_name(
        "library" if library else path.stem)
    if out.exists() and not out.is_dir():
        raise DeriveError(f"--out {out}: a file, not a folder: give an output folder (the file is left as it is)")
    use_compilation_cache(paths.XLA_CACHE or paths.CACHE / XLA)
    if library:
        return _derive_library(args, out)
    if args.scheduler is not None or args.workers is not None:
        raise DeriveError("--scheduler and --workers go with a library (a folder, several files or a glob)")
    found = api.derive_shader(path, args.function, lang=args.lang, include=args.include or (), define=args.define or (),
                              var=args.var, parameter=args.parameter, metric=args.metric, floor=args.floor,
                              max_error=args.max_error, exact=args.exact, gpu=args.gpu, seconds=args.seconds,
                              max_complexity=args.max_complexity, precision=args.precision,
                              keep_reference=args.keep_reference, platforms=args.platforms)
    if all(o.status == shader_file.REFUSED for o in found.outcomes):
        raise DeriveError(f"{path}: no function could be derived: "
                          + "; ".join(f"{o.name}: {o.reason}" for o in found.outcomes))
    written = found.write(out)
    for o in found.outcomes:
        print(f"{o.name}: {o.status}" + (f" ({o.replacement}: {o.expression})" if o.replacement else "")
              + (f": {o.reason}" if o.reason else ""))
    print(f"wrote {', '.join(str(p) for p in written)}")
    return faults.EXIT_DONE


def _derive_library(args, out: Path) -> int:
    """`derive --shader DIR` (several files, a folder, a glob): every function of every file derived as
    one batch on Dask (`approximate.api.derive_library`), the library's files written."""
    from .approximate import api
    from .approximate.publishing import library_outputs
    from .shaders import definitions

    if args.function is not None:
        raise DeriveError("--function goes with one file (a library derives every function of its files)")
    start = time.perf_counter()
    run: dict = {}
    found = api.derive_library(args.shader, lang=args.lang, include=args.include or (), define=args.define or (),
                               var=args.var, parameter=args.parameter, metric=args.metric, floor=args.floor,
                               max_error=args.max_error, exact=args.exact, gpu=args.gpu, seconds=args.seconds,
                               max_complexity=args.max_complexity, precision=args.precision, platforms=args.platforms,
                               scheduler=args.scheduler, workers=args.workers, run=run)
    outcomes = [o for file_outcomes in found.values() for o in file_outcomes]
    if all(o.status == "refused" for o in outcomes):
        raise DeriveError("no function of the library could be derived: "
                          + "; ".join(f"{o.name}: {o.reason}" for o in outcomes[:5]))
    run.update(seconds=round(time.perf_counter() - start, 1), local=args.scheduler is None)
    languages = {p: definitions.language_of(p, args.lang) for p in found}
    written = library_outputs.write(out, found, languages, run)
    print(f"wrote {', '.join(str(p) for p in written)} and files/")
    return faults.EXIT_DONE


def _plan_arguments(parser, written: str) -> None:
    parser.add_argument("--plan", default=None, metavar="FILE",
                        help=f"run exactly the plan of an earlier run (its {written}, or a plan file): the same front "
                             "on any machine")
    parser.add_argument("--timeout", type=float, default=None, metavar="S",
                        help="stop a run still going after S seconds (exit 124, nothing written); a run that finishes "
                             "is never shaped by it")


def build_parser() -> argparse.ArgumentParser:
    """Every command's arguments: `pipeline --help`, and the command reference that `make docs` writes."""
    parser = argparse.ArgumentParser(prog="pipeline", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    rep = sub.add_parser("reproduce", help="run the paper's derivation (configs/paper.toml)")
    rep.add_argument("--config", default=str(paths.PAPER_CONFIG))
    only_help = "run only these stages (comma-separated) and the stages they read"
    rep.add_argument("--only", default=None, metavar="STAGE[,STAGE...]", help=only_help)
    ref = sub.add_parser("refit", help="rerun the derivation with another config and --set overrides")
    ref.add_argument("--config", required=True)
    ref.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE")
    ref.add_argument("--out", default=None, metavar="NAME", help="output folder name under outputs/")
    ref.add_argument("--dry-run", action="store_true", help="say which stages would recompute; compute nothing")
    ref.add_argument("--only", default=None, metavar="STAGE[,STAGE...]", help=only_help)
    exp = sub.add_parser("explain", help="which stages a change would recompute (nothing is computed)")
    exp.add_argument("changes", nargs="*", metavar="KEY=VALUE")
    exp.add_argument("--config", default=str(paths.PAPER_CONFIG))
    exp.add_argument("--only", default=None, metavar="STAGE[,STAGE...]", help=only_help)
    sub.add_parser("keys", help="print every config key with its default and allowed values")
    sub.add_parser("graph", help="print the stage graph: what each stage reads and returns")
    sub.add_parser("tools", help="the outside tools found here (LLVM, Mesa's RADV, the shader compilers) and the "
                                 "Mitsuba variant a run takes")
    reg = sub.add_parser("regress", help="symbolic regression of one CSV column against up to three others")
    reg.add_argument("file", metavar="FILE.csv")
    reg.add_argument("--x", required=True, metavar="COLUMN[,COLUMN...]", help="column(s) of the variable(s), up to 3")
    reg.add_argument("--y", required=True, metavar="COLUMN", help="column to fit")
    reg.add_argument("--max-complexity", type=int, default=12, metavar="N",
                     help="largest complexity searched (constants, variables, +, -, *, square, cube count 1; /, exp, "
                          "log, sqrt, pow, sin, cos, abs, inv count 2); default 12")
    reg.add_argument("--ops", default=",".join(DEFAULT_OPERATIONS), metavar="OP[,OP...]",
                     help=f'operations from {", ".join(grammar.OPERATIONS)}; default {",".join(DEFAULT_OPERATIONS)}')
    reg.add_argument("--loss", default="rms", choices=["rms", "relative", "max", "max-relative"],
                     help="what the front ranks by: RMS error (default), RMS of the relative error, largest absolute "
                          "or relative error (minimax)")
    reg.add_argument("--gpu", default=None, choices=list(ARCHITECTURES),
                     help="compile every front member for this GPU architecture and report its cycles (AMD: ACO's "
                          "cycles per wave; NVIDIA: cycles per warp by the throughput model)")
    reg.add_argument("--cost", default=None, metavar="FILE.toml",
                     help="a cost per operation ([cost] table: exp = 4, ...) to rank by instead of the default count")
    reg.add_argument("--seed", type=int, default=None, help="seed of the random starts and of pyoperon (default 0)")
    reg.add_argument("--engine", default=None, choices=["auto", "exhaustive", "operon", "both"],
                     help="auto (default): within --seconds, the exhaustive search of + - * / first and deepest, "
                          "then of --ops and of the operations the data suggest, then pyoperon, one merged front "
                          "(--ops searched whole where they reach --max-complexity); both: the same, pyoperon always; "
                          "exhaustive: every expression up to --max-complexity, however long; operon: pyoperon alone")
    reg.add_argument("--seconds", type=float, default=None, metavar="S",
                     help=f"budget of --engine auto, both and operon, planned as work before the search at the "
                          f"reference machine's rates: a forecast, never a cutoff (default, up to complexity 12 and "
                          f"beyond: {BUDGET_SECONDS[(1, 12)]:.0f} and {BUDGET_SECONDS[(1, MAX_COMPLEXITY)]:.0f} s for "
                          f"one variable, {BUDGET_SECONDS[(2, 12)]:.0f} and {BUDGET_SECONDS[(2, MAX_COMPLEXITY)]:.0f} s "
                          "for two or three)")
    _plan_arguments(reg, "plan.json")
    reg.add_argument("--noise", type=float, default=None, metavar="SIGMA",
                     help="the data's noise level, for model selection (default: the rounding floor of y where y "
                          "is rounded, else unknown)")
    reg.add_argument("--out", default=None, metavar="DIR",
                     help="output folder (default outputs/regress/<file name without .csv>)")
    cmp = sub.add_parser("compare", help="runs side by side: the config values that differ against the headline "
                                         "metrics (markdown, compare.csv)")
    cmp.add_argument("folders", nargs="+", metavar="DIR", help="run folders (outputs/<name>), or a folder of them")
    cmp.add_argument("--plot", default=None, metavar="KEY:FIELD",
                     help="also draw compare.png: headline FIELD against config KEY")
    cmp.add_argument("--out", default=None, metavar="DIR",
                     help="folder for compare.csv (default: the sweep folder given, else outputs/compare)")
    swp = sub.add_parser("sweep", help="a grid of refits from a sweep file, on Dask (a LocalCluster by default)")
    swp.add_argument("file", metavar="SWEEP.toml")
    swp.add_argument("--scheduler", default=None, metavar="ADDRESS", help="an existing Dask scheduler, tcp://host:port")
    swp.add_argument("--scheduler-file", default=None, metavar="FILE", help="an existing Dask cluster's scheduler file")
    swp.add_argument("--workers", type=int, default=None, metavar="N",
                     help="LocalCluster worker processes (default: one per core)")
    cst = sub.add_parser("costs", help="cycles of each symbolic-regression operation on each GPU architecture (AMD by "
                                       "RADV, NVIDIA by ptxas, Intel by ocloc, Adreno and Mali by Mesa's compilers): "
                                       "cost tables for regress --cost")
    cst.add_argument("--out", default=None, metavar="DIR", help="folder of the tables (default outputs/costs)")
    cst.add_argument("--gpu", default=None, metavar="ARCH[,ARCH...]",
                     help=f"architectures (default every one: {', '.join(ARCHITECTURES)})")
    cst.add_argument("--forms", type=int, default=400, metavar="N",
                     help="forms compiled to fit the tables, a quarter held out (default 400)")
    der = sub.add_parser("derive", help="the cheapest accurate forms of a function a shader approximates, ranked by "
                                        "compiled cycles per GPU architecture")
    der.add_argument("--target", default=None, metavar="NAME|FILE.toml",
                     help="a registered target (schlick, acos, cos_n20, cos_n, smith_ggx_visibility, env_brdf, "
                          "env_brdf_scale, env_brdf_bias) or a TOML file")
    der.add_argument("--expr", default=None, metavar="EXPR", help="the target as an expression (sympy), e.g. 'atan(x)'")
    der.add_argument("--var", default=None, action="append", metavar="NAME=LO:HI",
                     help="with --expr: its variable and domain (default x=0:1); with --shader: an argument's range, "
                          "once per argument, where a function's `// derive:` line gives none")
    der.add_argument("--name", default=None, metavar="NAME",
                     help="the run's name: its titles, its functions' names, its default folder (default the "
                          "target's name, or the expression)")
    der.add_argument("--table", default=None, metavar="FILE.csv",
                     help="the target as values on a full grid (a header, a row per point), interpolated by cubic splines")
    der.add_argument("--x", default=None, metavar="NAME[,NAME]", help="with --table: the variables' columns (per pixel)")
    der.add_argument("--parameter", default=None, metavar="NAME",
                     help="with --table: the parameter's column (per material: its constants become formulas of it); "
                          "with --shader: the argument that is a material parameter (NAME or NAME=LO:HI)")
    der.add_argument("--y", default=None, metavar="NAME", help="with --table: the value's column (default the one left)")
    der.add_argument("--range", default=None, metavar="LO:HI", dest="parameter_range",
                     help="the parameter's range, replacing the target's (e.g. cos_n's n, split as the lobe search "
                          "splits it: 2:10, 10:100, 100:1000)")
    der.add_argument("--formula-complexity", type=int, default=0, metavar="K",
                     help="with a parameter: each constant's residual from its line searched by the symbolic "
                          "regression up to K, as the paper found coef(n) (default 0: lines, quadratics and "
                          "a + b p + c / p alone)")
    der.add_argument("--metric", default=None, choices=("abs", "rel"), help="the error measured (default the target's)")
    der.add_argument("--floor", type=float, default=None, metavar="F",
                     help="with --metric rel: |f| below F counts as F")
    der.add_argument("--gpu", default=None, metavar="ARCH[,ARCH...]",
                     help="architectures, or platforms (desktop, android, all: named sets of them, with the "
                          "format their shaders compute in) (default every architecture whose compiler runs here)")
    der.add_argument("--platforms", default=None, metavar="FILE.toml",
                     help="platforms added to the shipped ones (a table per platform: architectures, precision, "
                          "description)")
    der.add_argument("--precision", default=None, choices=("fp32", "fp16"),
                     help="the format the shader computes in: every form costed and executed in it (default the "
                          "target's, fp32)")
    der.add_argument("--certify", action="store_true",
                     help="every front member's, anchor's and the exact target's largest error as executed proven "
                          "over the whole domain (one variable: every input of the format, 1,065,353,217 float32 "
                          "values of [0, 1], minutes; several: interval branch and bound), the fronts read off "
                          "those, and beside them the worst a conforming driver may give")
    der.add_argument("--contract", default="allowed", choices=("allowed", "never"),
                     help="never: every form costed and written with its value `precise` (GLSL and HLSL: no fused "
                          "multiply-add, no reordering by a driver; its cycles may rise), so that the worst a "
                          "conforming driver may give (--certify) bounds it (default allowed)")
    der.add_argument("--max-cycles", type=float, default=None, metavar="N", help="leave out forms above N cycles")
    der.add_argument("--seconds", type=float, default=None, metavar="S",
                     help="the grammar search's budget, planned as work before the search at the reference "
                          "machine's rates: a forecast, never a cutoff (default 60)")
    _plan_arguments(der, "results.json")
    der.add_argument("--max-complexity", type=int, default=12, metavar="K",
                     help="the grammar's largest complexity (default 12)")
    der.add_argument("--out", default=None, metavar="DIR", help="output folder (default outputs/derive/<target>)")
    der.add_argument("--shader", default=None, nargs="+", metavar="PATH",
                     help="the functions of a GLSL or HLSL file as targets, each read as its compiler means it; "
                          "writes functions.csv, report.md and shader.patch (the file itself is never written); "
                          "several files, a folder or a glob: a library, derived as one batch on Dask")
    der.add_argument("--scheduler", default=None, metavar="ADDRESS",
                     help="with a library: an existing Dask scheduler (default a LocalCluster of this machine)")
    der.add_argument("--workers", type=int, default=None, metavar="N",
                     help="with a library: LocalCluster worker processes (default one per core)")
    der.add_argument("--function", default=None, metavar="NAME[,NAME...]",
                     help="with --shader: the functions to derive (default every one)")
    der.add_argument("--lang", default=None, choices=("glsl", "hlsl"),
                     help="with --shader: the file's language (default HLSL for .hlsl, .hlsli, .fx, .fxh; else GLSL)")
    der.add_argument("-I", dest="include", action="append", default=None, metavar="DIR",
                     help="with --shader: a folder #include searches, as a shader compiler takes it")
    der.add_argument("-D", dest="define", action="append", default=None, metavar="NAME[=VALUE]",
                     help="with --shader: a macro defined, as a shader compiler takes it")
    der.add_argument("--max-error", type=float, default=None, metavar="E",
                     help="with --shader: the largest error a replacement may have as executed (default the "
                          "function's own as shipped: only rewrites no less accurate)")
    der.add_argument("--exact", default=None, metavar="EXPR",
                     help="with --shader: what the functions approximate, in their arguments (e.g. 'acos(x)'); "
                          "default each function's own mathematics")
    der.add_argument("--keep-reference", action="store_true",
                     help="with --shader: the patch keeps each replaced function beside it as NAME_reference")
    cch = sub.add_parser("cache", help="show the cache's size per stage; --prune removes unused entries")
    cch.add_argument("--prune", action="store_true")
    cch.add_argument("--older-than", type=float, default=14.0, metavar="DAYS",
                     help="with --prune: remove entries no run has used for this many days (default 14)")
    return parser


def _main(argv: list[str] | None) -> int:
    args = build_parser().parse_args(argv)
    try:
        if args.command == "keys":
            print(key_table())
            return 0
        if args.command == "graph":
            print(graph.describe())
            return 0
        if args.command == "tools":
            return _tools()
        if args.command == "compare":
            return _compare(args)
        if args.command == "sweep":
            return _sweep(args)
        if args.command == "cache":
            faults.check_folder(paths.CACHE, "the cache folder (PIPELINE_CACHE_DIR)")
            return _cache(args)
        if args.command == "costs":
            return _costs(args)
        if args.command == "regress":
            faults.raise_on_signals()       # its search runs in this thread
            return _regress(args)
        if args.command == "derive":
            faults.raise_on_signals()
            return _derive(args)
        only = _only(args.only) if args.command in ("explain", "reproduce", "refit") else None
        if args.command == "explain":
            return _explain(load_config(args.config, tuple(args.changes), name="explain"), only)
        if args.command == "reproduce":
            config, baseline_config = load_config(args.config), None
        else:
            config = _refit_config(args)
            if args.dry_run:
                return _explain(config, only)
            baseline_config = load_config(paths.PAPER_CONFIG)
    except (ConfigError, RegressError, CompareError, DeriveError, ShaderError) as e:
        print(f"error: {e}", file=sys.stderr)
        return faults.EXIT_BAD_INPUT
    # Both folders are checked before anything is computed.
    faults.check_folder(paths.CACHE, "the cache folder (PIPELINE_CACHE_DIR)")
    faults.check_folder(paths.OUTPUTS, "the outputs folder (PIPELINE_OUTPUTS_DIR)")

    from .optics.roots import SolverError
    from .runner import run_derivation

    start = time.perf_counter()
    try:
        print(f"config {config.source}: run '{config.name}'")
        baseline = None
        if baseline_config is not None:
            print("paper's run (for the comparison):")
            baseline = run_derivation(baseline_config, write_outputs=False, only=only)
            print(f"run '{config.name}':")
        outcome = run_derivation(config, baseline=baseline, only=only)
    except SolverError as e:
        print(f"error: {e}", file=sys.stderr)
        return faults.EXIT_FAILED
    _print_checks(outcome)
    print(f"\n{'recomputed: ' + ', '.join(outcome.computed) if outcome.computed else 'nothing recomputed'}")
    # The closing line: the checks by how they hold, where the outputs are, and the time.
    print(f"{checks_mod.tally(outcome.checks)}; outputs in {outcome.out_dir} (report.md); "
          f"{time.perf_counter() - start:.1f} s")
    return faults.EXIT_FAILED if outcome.failed else faults.EXIT_DONE


if __name__ == "__main__":
    sys.exit(main())
