"""`make measure`: the runs too slow for the tests whose numbers the pages state, each recorded in
`docs/measured/<name>.json` with its command, date, commit, core count and wall time. The pages' numbers
are marked fields of these records (`make docs` fills them, a test fails where they differ), never
typed by hand. The records:

- `derive_<name>`: the `pipeline derive` runs of docs/derive.md (1 to 4 minutes each; `DERIVE_RUNS`:
  a registered target, or its arguments: schlick in fp16 on two phones, a cancelling expression): the
  run's results.json without the forms' internals, `verdict_rows`, one row per architecture and
  anchor (and the exact target), and `page`: its report.html's size and the seconds headless Chromium
  takes to draw it (schlick's: also the screenshot `docs/report_html.png`, the README's picture;
  env_brdf's renders.png is copied to `docs/derive_renders.png`, docs/derive.md's picture).
- `costs`: `pipeline costs` with its default 400 forms on every architecture (docs/gpu.md): the
  tables, their held-out errors, the time announced and taken, and one compiled form (c ^ t).
- `refits`: the example configs of docs/refits.md, each refitted up to its derivation's numbers, and
  the zone-level sweep after them (one cache for all, as a user runs them in a row).
- `lobe_refits`: refits of the lobe search alone (docs/lobe-search.md): formulas beyond lines, and
  Beckmann's D as the target.
- `power_regress`: docs/regress.md's coef over (n, m): the power sweep, its datasets joined into one
  file, and `pipeline regress` on it.
- `grammar`: how many forms the grammars hold at the complexities docs/regress.md names.
- `library`: `pipeline derive --shader` on the tests' library (`tests/shaders/library/`) for the
  android platform (fp16) and the desktop one (fp32), a run each (docs/shaders.md): their totals,
  the form each function ships per platform, and one savings figure of both,
  `docs/library_savings.png`.

A record no page reads fails a test (`tests/docs/test_generated.py`): a run added here is also
marked in a page. `python scripts/measure.py [NAME ...]` runs the named ones (default all, about 25
minutes here); each runs cold, in its own process with its own empty caches (the machine code
compiled before is kept in `.cache/machine_code/` for the derive runs, which do not time it).
"""

from __future__ import annotations

import csv
import datetime
import json
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
MEASURED = ROOT / "docs" / "measured"
PAGE_SHOT = ROOT / "docs" / "report_html.png"      # the README's picture of a derive run's report.html
RENDERS = ROOT / "docs" / "derive_renders.png"     # docs/derive.md's picture: env_brdf's renders.png
# {target: pipeline.derive's arguments}: every architecture for the one-variable targets, as the page
# says; the parametric ones on one architecture of each vendor family (AMD RDNA, NVIDIA, Intel, Mali,
# Adreno), with a 10 s grammar budget.
DERIVE_RUNS = {
    "schlick": dict(),
    "acos": dict(),
    "schlick_fp16": dict(target="schlick", precision="fp16", gpu="g610,a740"),
    "cancelling": dict(expr="sqrt(1 + x) - 1", var="x=1e-6:1e-3", metric="rel", gpu="rdna3"),
    "smith_ggx_visibility": dict(gpu="rdna3,sm_89,xe_hpg,g610,a740", seconds=10),
    "env_brdf": dict(gpu="rdna3,sm_89,xe_hpg,g610,a740", seconds=10),
    # rendered in their place and compared by FLIP (docs/derive.md's "The error as seen"): three
    # architectures, as the benchmark runs them
    "rendered_schlick": dict(target="schlick", gpu="rdna3,sm_89,xe_hpg", seconds=10),
    "rendered_smith_ggx_visibility": dict(target="smith_ggx_visibility", gpu="rdna3,sm_89,xe_hpg", seconds=10),
    "rendered_env_brdf": dict(target="env_brdf", gpu="rdna3,sm_89,xe_hpg", seconds=10),
}
REFIT_CONFIGS = ("q_0_5", "absolute_error", "minimax_line", "n_up_to_256")
# the stages the refits page states, and the stages they read
REFIT_STAGES = "q_choice,linear_coefficient,f2_errors,accuracy,sparse_regression"
LOBE_REFITS = {
    "formulas": ["--set", "lobe_search.formula_complexity=7"],
    "beckmann": ["--set", "lobe_search.target=beckmann"],
}
# {name: (operations, variables, complexities)}: each count is of the forms up to that complexity
GRAMMAR_COUNTS = {
    "fourteen_one_variable": ("all", 1, (8,)),
    "ten_one_variable": ("ten", 1, (8, 9)),
    "ten_two_variables": ("ten", 2, (7,)),
    "arithmetic_one_variable": ("+-*/", 1, (9, 10, 14, 15)),
    "arithmetic_two_variables": ("+-*/", 2, (9, 10)),
}


class Failed(RuntimeError):
    """A measured command that exited non-zero."""


def _pipeline(args: list[str], env: dict) -> tuple[float, str]:
    """Seconds and output of `python -m pipeline ARGS` in ROOT, raising Failed with its last lines."""
    started = time.perf_counter()
    done = subprocess.run([sys.executable, "-m", "pipeline", *args], cwd=ROOT, env=env, capture_output=True, text=True)
    seconds = time.perf_counter() - started
    if done.returncode != 0:
        raise Failed(f"pipeline {' '.join(args)}: exit {done.returncode}\n" + (done.stdout + done.stderr)[-2000:])
    return seconds, done.stdout


def _cold_env(tmp: str) -> dict:
    """The pipeline's environment with its own empty caches and outputs under `tmp`."""
    return dict(os.environ, PIPELINE_CACHE_DIR=os.path.join(tmp, "cache"),
                PIPELINE_XLA_CACHE_DIR=os.path.join(tmp, "xla"),
                PIPELINE_MACHINE_CODE_CACHE=os.path.join(tmp, "machine_code"),
                PIPELINE_DERIVE_CACHE=os.path.join(tmp, "derive"),
                PIPELINE_OUTPUTS_DIR=os.path.join(tmp, "outputs"), JAX_ENABLE_X64="1", JAX_PLATFORMS="cpu")


def scalars(value, longest: int = 16):
    """`value` without its long lists (a stage's per-n arrays and rows): numbers, text and lists of at
    most `longest` items, in nested dicts."""
    if isinstance(value, dict):
        kept = {k: scalars(v, longest) for k, v in value.items()}
        return {k: v for k, v in kept.items() if v is not None}
    if isinstance(value, list):
        return [scalars(v, longest) for v in value] if len(value) <= longest else None
    return value


def derive_record(target: str) -> dict:
    """One `pipeline derive` run, in this process, with its derive cache empty (the caller's env)."""
    sys.path.insert(0, str(ROOT))
    import pipeline

    with tempfile.TemporaryDirectory() as tmp:
        started = time.perf_counter()
        arguments = dict(DERIVE_RUNS[target])
        if "expr" not in arguments:
            arguments["target"] = arguments.get("target", target)
        found = pipeline.derive(log=lambda s: print(f"  {s}", flush=True), **arguments)
        seconds = time.perf_counter() - started
        found.write(Path(tmp) / "out")
        results = json.loads((Path(tmp) / "out" / "results.json").read_text())
        if target == "rendered_env_brdf":
            RENDERS.write_bytes((Path(tmp) / "out" / "renders.png").read_bytes())
        page = page_record(Path(tmp) / "out" / "report.html", PAGE_SHOT if target == "schlick" else None)
    results.pop("forms", None)
    verdicts = [dict(architecture=a, anchor=name, **v) for a, anchors in results["verdicts"].items()
                for name, v in anchors.items()]
    named = {} if "expr" in DERIVE_RUNS[target] else {"target": target}
    arguments = " ".join(f"--{k} {v!r}" if k == "expr" else f"--{k} {v}" for k, v in (named | DERIVE_RUNS[target]).items())
    return dict(command=f"pipeline derive {arguments}".strip(), wall_seconds=round(seconds, 1),
                verdict_rows=verdicts, results=results, page=page)


def page_record(html: Path, shot: Path | None) -> dict:
    """report.html's size, the seconds it takes to write (again, from the kept search's results: the
    run's own write included it) and to be drawn in headless Chromium from file://; with `shot`, a
    screenshot of it with its first front member opened (the README's picture). Without Playwright or
    Chromium: the size alone, and why."""
    import shutil

    out = dict(bytes=html.stat().st_size)
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        return out | dict(not_opened="playwright is not installed")
    browser_path = shutil.which("chromium") or shutil.which("chromium-browser")
    if browser_path is None:
        return out | dict(not_opened="Chromium is not installed")
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=browser_path, args=["--no-sandbox", "--disable-background-networking",
                                                                        "--use-angle=swiftshader", "--enable-unsafe-swiftshader"])
        page = browser.new_page(viewport={"width": 1280, "height": 1000})
        started = time.perf_counter()
        page.goto(f"file://{html}")
        page.wait_for_selector("body[data-ready='1']", state="attached", timeout=60000)
        out["drawn_seconds"] = round(time.perf_counter() - started, 2)
        if shot is not None:
            page.locator("#front-table tbody tr").first.click()
            page.wait_for_function("window.pageState.live !== null || document.getElementById('live-note')")
            page.screenshot(path=str(shot), clip=dict(x=0, y=0, width=1280, height=2400), full_page=True)
        browser.close()
    return out


def costs_record(env: dict) -> dict:
    """`pipeline costs` on every architecture, its machine code compiled afresh."""
    sys.path.insert(0, str(ROOT))
    os.environ.update(env)
    from pipeline.isa import architectures, machine_code
    from pipeline.symbolic import gpu_costs

    chosen = list(architectures.ARCHITECTURES)
    announced = machine_code.estimate_seconds(gpu_costs.CALIBRATION, chosen)
    started = time.perf_counter()
    costs = gpu_costs.operation_costs(gpu_costs.CALIBRATION, chosen)
    seconds = time.perf_counter() - started
    constant_base = gpu_costs.expression_cycles({"c ^ t": "pow(1.7, t)"}, ["rdna3"])["rdna3"]["c ^ t"]
    return dict(command="pipeline costs", wall_seconds=round(seconds, 1), announced_seconds=round(announced, 1),
                forms=gpu_costs.CALIBRATION, architectures=len(costs["tables"]), tables=costs["tables"],
                held_out=costs["held_out"], constant_base_pow_cycles_rdna3=constant_base)


def refits_record(env: dict) -> dict:
    """The example configs refitted in a row on one cold cache, then the zone-level sweep."""
    outputs = Path(env["PIPELINE_OUTPUTS_DIR"])
    configs = {}
    for name in REFIT_CONFIGS:
        args = ["refit", "--config", f"configs/{name}.toml", "--only", REFIT_STAGES, "--out", f"measure_{name}"]
        seconds, _ = _pipeline(args, env)
        results = json.loads((outputs / f"measure_{name}" / "results.json").read_text())
        configs[name] = dict(command="pipeline " + " ".join(args), wall_seconds=round(seconds, 1),
                             stages=scalars(results["stages"]))
    seconds, _ = _pipeline(["sweep", "configs/sweeps/zone_level.toml"], env)
    return dict(configs=configs, zone_level_sweep=dict(command="pipeline sweep configs/sweeps/zone_level.toml",
                                                       wall_seconds=round(seconds, 1), points=5))


def lobe_refits_record(env: dict) -> dict:
    """The lobe search alone, refitted with each of LOBE_REFITS' settings."""
    outputs = Path(env["PIPELINE_OUTPUTS_DIR"])
    runs = {}
    for name, settings in LOBE_REFITS.items():
        args = ["refit", "--config", "configs/paper.toml", *settings, "--only", "lobe_search", "--out", f"measure_{name}"]
        seconds, _ = _pipeline(args, env)
        stage = json.loads((outputs / f"measure_{name}" / "results.json").read_text())["stages"]["lobe_search"]
        members = [scalars(m) for m in stage["members"]]
        runs[name] = dict(command="pipeline " + " ".join(args), wall_seconds=round(seconds, 1), members=members,
                          ranges=stage["ranges"], target=stage["target"])
    return runs


def power_regress_record(env: dict) -> dict:
    """The power sweep (coef(n) for each power m), joined into one CSV of (n, m, y), and `pipeline
    regress` over (n, m) with + - * / to complexity 10, as docs/regress.md states it."""
    outputs = Path(env["PIPELINE_OUTPUTS_DIR"])
    sweep_seconds, _ = _pipeline(["sweep", "configs/sweeps/power.toml"], env)
    rows = []
    for path in sorted(outputs.glob("power/*/energy_all_n.csv")):
        m = json.loads((path.parent / "results.json").read_text())["config"]["lobe.power"]
        with open(path) as f:
            rows += [(float(r["n"]), float(m), float(r["y"])) for r in csv.DictReader(f)]
    joined = outputs / "coef_n_m.csv"
    joined.write_text("n,m,y\n" + "".join(f"{n:g},{m:g},{y!r}\n" for n, m, y in rows))
    args = ["regress", str(joined), "--x", "n,m", "--y", "y", "--max-complexity", "10", "--ops", "+,-,*,/",
            "--out", str(outputs / "regress_coef_n_m")]
    seconds, printed = _pipeline(args, env)
    with open(outputs / "regress_coef_n_m" / "front.csv") as f:
        front = list(csv.DictReader(f))
    chosen = next(r for r in front if r["selected"].lower() in ("true", "1", "yes"))
    constants = [float(c) for c in re.findall(r"(?<![\w.])\d+\.\d+(?:e[-+]?\d+)?", chosen["expression"])]
    return dict(sweep=dict(command="pipeline sweep configs/sweeps/power.toml", wall_seconds=round(sweep_seconds, 1),
                           powers=sorted({m for _, m, _ in rows}), rows=len(rows),
                           y_min=min(y for *_, y in rows), y_max=max(y for *_, y in rows)),
                regress=dict(command="pipeline " + " ".join(args[:1] + ["coef_n_m.csv"] + args[2:-2]),
                             wall_seconds=round(seconds, 1), printed=printed.splitlines()[:8],
                             selected=dict(expression=chosen["expression"], form=chosen["form"], complexity=float(chosen["complexity"]),
                                           rms=float(chosen["rms"]), constants=constants)))


def grammar_record(env: dict) -> dict:
    """How many forms each grammar holds up to each complexity (GRAMMAR_COUNTS), and the growth per
    step between the last two."""
    sys.path.insert(0, str(ROOT))
    from pipeline.symbolic import grammar

    counts = {}
    for name, (ops, variables, complexities) in GRAMMAR_COUNTS.items():
        chosen = {"ten": grammar.TEN, "all": grammar.OPERATIONS}.get(ops, ops)
        by = {str(k): len(grammar.enumerate_forms(k, chosen, variables)) for k in complexities}
        counts[name] = dict(operations=" ".join(grammar.operations(chosen)), variables=variables, up_to=by)
        if len(complexities) > 1:
            counts[name]["growth"] = round(by[str(complexities[-1])] / by[str(complexities[-2])], 3)
    return dict(command="len(grammar.enumerate_forms(K, OPS, VARIABLES))", counts=counts)


LIBRARY_SHOT = ROOT / "docs" / "library_savings.png"     # docs/shaders.md's picture: the library's savings.png


def library_record(env: dict) -> dict:
    """`pipeline derive --shader` on the tests' library for each shipped platform in its own format
    (android in fp16, desktop in fp32: two runs, as platforms of two formats are), on a LocalCluster of
    this machine's cores: each run's command, wall time, totals and per-platform rows, and one
    savings figure of both platforms' rows (`library_outputs.savings_figure`) as `LIBRARY_SHOT`."""
    sys.path.insert(0, str(ROOT))
    from pipeline.approximate.publishing import library_outputs

    runs, rows = {}, []
    for platform in ("android", "desktop"):
        out = Path(env["PIPELINE_OUTPUTS_DIR"]) / f"measure_library_{platform}"
        args = ["derive", "--shader", "tests/shaders/library", "--gpu", platform, "--seconds", "10", "--out", str(out)]
        seconds, _ = _pipeline(args, env)
        summary = json.loads((out / "library.json").read_text())
        functions = {(r["file"], r["function"]): r["status"] for r in summary["rows"]}
        runs[platform] = dict(command="pipeline " + " ".join(args[:-2]), wall_seconds=round(seconds, 1),
                              run=summary["run"], functions=len(functions),
                              statuses={s: list(functions.values()).count(s) for s in sorted(set(functions.values()))},
                              platform=summary["platforms"][platform],
                              rows=[{k: r[k] for k in ("function", "form", "cycles_before", "cycles_after",
                                                       "error_after", "calls")} | dict(file=Path(r["file"]).name)
                                    for r in summary["platform_rows"]])
        rows += summary["platform_rows"]
    library_outputs.savings_figure(LIBRARY_SHOT, rows, [])
    return dict(runs=runs, wall_seconds=round(sum(r["wall_seconds"] for r in runs.values()), 1))


RECORDS = {**{f"derive_{target}": None for target in DERIVE_RUNS}, "costs": costs_record, "refits": refits_record,
           "lobe_refits": lobe_refits_record, "power_regress": power_regress_record, "grammar": grammar_record,
           "library": library_record}


def measure(name: str, tmp: str) -> Path:
    """Run one record's measurement in this process, with the cold caches under `tmp`; write it."""
    env = _cold_env(tmp)
    if name.startswith("derive_"):
        os.environ["PIPELINE_DERIVE_CACHE"] = env["PIPELINE_DERIVE_CACHE"]
        body = derive_record(name.removeprefix("derive_"))
    else:
        started = time.perf_counter()
        body = RECORDS[name](env)
        body.setdefault("wall_seconds", round(time.perf_counter() - started, 1))
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True,
                            text=True).stdout.strip()
    record = dict(date=datetime.date.today().isoformat(), commit=commit, cores=os.cpu_count(), **body)
    path = MEASURED / f"{name}.json"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(record, indent=1, sort_keys=True, default=str) + "\n")
    return path


def main(argv=None) -> int:
    names = (argv if argv is not None else sys.argv[1:]) or list(RECORDS)
    unknown = [n for n in names if n not in RECORDS]
    if unknown:
        print(f"unknown: {', '.join(unknown)}; the records are {', '.join(RECORDS)}", file=sys.stderr)
        return 2
    if len(names) == 1 and os.environ.get("PIPELINE_MEASURE_TMP"):
        try:
            path = measure(names[0], os.environ["PIPELINE_MEASURE_TMP"])
        except Failed as e:
            print(f"error: {e}", file=sys.stderr)
            return 1
        print(f"recorded in {path.relative_to(ROOT)}", flush=True)
        return 0
    for name in names:          # each cold, in its own process with empty caches
        print(f"{name}:", flush=True)
        with tempfile.TemporaryDirectory() as tmp:
            done = subprocess.run([sys.executable, __file__, name], env=dict(os.environ, PIPELINE_MEASURE_TMP=tmp))
        if done.returncode != 0:
            return done.returncode
    return 0


if __name__ == "__main__":
    sys.exit(main())
