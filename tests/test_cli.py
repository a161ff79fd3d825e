"""The command line: the graph, dry runs, fast errors, exit codes, and recovery from kills."""

import json
import os
import random
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from pipeline.engine import paths
from pipeline.engine.config import load_config
from pipeline.publish import results as results_file
from pipeline.runner import run_derivation

from .conftest import LIGHT_CONFIG
from .helpers import cli_env, copy_cache

HEAVY = ("jax", "sympy", "pysindy", "matplotlib", "optimistix")


def run_cli(args, tmp_path, **kwargs):
    return subprocess.run([sys.executable, "-m", "pipeline", *args], capture_output=True, text=True,
                          env=cli_env(tmp_path), cwd=paths.ROOT, **kwargs)


def imported_after(code: str) -> list[str]:
    """Which heavy libraries a fresh interpreter has imported after running `code`."""
    probe = f"import sys\n{code}\nprint('imported:' + ','.join(m for m in {HEAVY!r} if m in sys.modules))"
    done = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, cwd=paths.ROOT)
    assert done.returncode == 0, done.stderr
    return [m for m in done.stdout.strip().splitlines()[-1].removeprefix("imported:").split(",") if m]


@pytest.mark.parametrize("args", [["keys"], ["graph"],
                                  ["refit", "--config", "configs/paper.toml", "--set", "derivation.Q=2", "--out", "x"],
                                  ["explain", "nosuch.key=1"]])
def test_fast_answers_import_no_numerical_library(args):
    code = f"from pipeline.cli import main\ntry:\n    main({args!r})\nexcept SystemExit:\n    pass"
    assert imported_after(code) == []


@pytest.mark.parametrize("args,message", [
    (["refit", "--config", "configs/paper.toml", "--set", "nosuch.key=1", "--out", "x"],
     "section 'nosuch' does not exist; allowed sections are run, derivation, lobe, paper_model"),
    (["refit", "--config", "configs", "--out", "x"], "config file 'configs' is a directory"),
])
def test_bad_config_paths_and_sections_exit_2(args, message, tmp_path):
    done = run_cli(args, tmp_path)
    assert done.returncode == 2 and message in done.stderr and "Traceback" not in done.stderr


def test_a_config_that_is_not_utf8_exits_2(tmp_path):
    bad = tmp_path / "latin1.toml"
    bad.write_bytes("[run]\nquestion = \"r\xe9flexion\"\n".encode("latin-1"))
    done = run_cli(["refit", "--config", str(bad), "--out", "x"], tmp_path)
    assert done.returncode == 2 and "is not UTF-8 text" in done.stderr and "Traceback" not in done.stderr


def test_a_misspelled_expectation_path_is_a_config_error(tmp_path):
    text = paths.PAPER_CONFIG.read_text().replace('result = "linear_coefficient.lin_slope"',
                                                  'result = "linear_coefficient.lin_slop"')
    bad = tmp_path / "bad.toml"
    bad.write_text(text)
    start = time.perf_counter()
    done = run_cli(["refit", "--config", str(bad), "--out", "x"], tmp_path)
    assert done.returncode == 2
    assert "'expectations.P5_slope.result' = 'linear_coefficient.lin_slop' is not allowed" in done.stderr
    assert "linear_coefficient.lin_slope" in done.stderr        # the allowed names are listed
    assert not (tmp_path / "cache").exists() and not (tmp_path / "out").exists()
    assert time.perf_counter() - start < 60      # nothing was computed (a loose bound, not a benchmark)


def test_a_solver_that_does_not_converge_exits_1_naming_its_inputs(tmp_path):
    config = tmp_path / "few_steps.toml"
    config.write_text('[run]\nname = "x"\n[solver]\nmax_steps = 8\n')
    done = run_cli(["reproduce", "--config", str(config)], tmp_path)
    assert done.returncode == 1
    assert "zone calibration: bisection on L did not converge for target 0.07924" in done.stderr
    assert "solver.max_steps = 8" in done.stderr
    assert not (tmp_path / "out" / "x").exists()


@pytest.mark.slow
def test_explain_says_what_a_change_recomputes_without_computing(paper_run, paper_cache, tmp_path):
    copy_cache(paper_cache, tmp_path / "cache")
    before = sorted(p.name for p in (tmp_path / "cache").rglob("*") if p.is_dir())
    done = run_cli(["explain", "scan.curve_points=200"], tmp_path)
    assert done.returncode == 0, done.stderr
    lines = {line.split()[0]: line for line in done.stdout.splitlines() if line.startswith("  ")}
    assert "zone" in lines and lines["zone"].split()[1] == "cached"
    assert "recomputes (reads scan.curve_points)" in lines["q_scan"]
    assert "recomputes if q_scan.Q_scan_best, q_scan.Q_continuous_best change" in lines["q_choice"]
    # The render reads the line, which is below the scan: known only once the scan has rerun.
    assert ("recomputes if linear_coefficient.slope_used, linear_coefficient.intercept_used, accuracy.d_f_Q2_curve "
            "change") in lines["render"]
    assert sorted(p.name for p in (tmp_path / "cache").rglob("*") if p.is_dir()) == before
    dry = run_cli(["refit", "--config", "configs/paper.toml", "--set", "render.resolution=64", "--out", "r",
                   "--dry-run"], tmp_path)
    assert dry.returncode == 0 and "recomputes (reads render.resolution)" in dry.stdout
    assert not (tmp_path / "out").exists()


def session_processes(sid: int) -> list[str]:
    """The processes still alive in session `sid` (a CLI started with start_new_session=True, and
    everything it started): (pid, command line) from /proc."""
    out = []
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            stat = Path(f"/proc/{entry}/stat").read_text()
            fields = stat[stat.rindex(")") + 2:].split()
            if fields[0] != "Z" and int(fields[3]) == sid:
                out.append(f"{entry}: " + Path(f"/proc/{entry}/cmdline").read_text().replace("\0", " ")[:120])
        except (OSError, ValueError, IndexError):
            continue
    return out


def left_behind(sid: int, within: float = 5.0) -> list[str]:
    """The session's processes that outlive `within` seconds after the run ended."""
    deadline = time.monotonic() + within
    while (alive := session_processes(sid)) and time.monotonic() < deadline:
        time.sleep(0.1)
    return alive


@pytest.mark.slow
def test_runs_killed_or_interrupted_at_random_moments_recover_with_identical_results(refit_cache, light_cache,
                                                                                     light_run, tmp_path):
    """SIGKILL, Ctrl-C (SIGINT to the process group, as a terminal sends it) and SIGTERM at random
    moments of a refit: an interrupt ends it within seconds with exit 130 and one line; no process
    of the run (the figure worker, its resource tracker) outlives it, SIGKILL included; the rerun
    gives the results of an uninterrupted run, byte for byte, with the folder modes of umask 022."""
    args = ["refit", "--config", str(LIGHT_CONFIG), "--set", "scan.curve_points=25",
            "--set", "regression.threshold_count=21", "--out", "killed"]
    rng = random.Random(0)
    # Each signal hits a run with work to do. The killed one is the run the final one recovers; the
    # interrupted ones change Q, so that most stages (renders, albedo, search) compute for seconds
    # after the first "computing" line, and the signal always comes before the run could finish.
    fitted = "derivation.constants=fitted"      # (the light config's are the paper's, for its settings only)
    for changes, sig in ((("scan.curve_points=25",), signal.SIGKILL), (("derivation.Q=0.62", fitted), signal.SIGINT),
                         (("derivation.Q=0.66", fitted), signal.SIGTERM)):
        sets = [word for change in changes for word in ("--set", change)]
        proc = subprocess.Popen([sys.executable, "-m", "pipeline", *args, *sets],
                                env=cli_env(tmp_path, PYTHONUNBUFFERED="1"), cwd=paths.ROOT,
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True)
        while "computing" not in (proc.stdout.readline() or "computing"):
            pass                                 # until a stage computes
        time.sleep(rng.uniform(0.0, 1.5))        # while stages compute
        os.killpg(proc.pid, sig) if sig == signal.SIGINT else proc.send_signal(sig)
        sent = time.monotonic()
        _, err = proc.communicate(timeout=60)
        if sig != signal.SIGKILL:
            assert time.monotonic() - sent < 10
            assert proc.returncode == 130, err
            assert "Traceback" not in err and err.strip().count("\n") == 0, err
            assert err.strip().startswith(f"interrupted ({sig.name})"), err
        assert left_behind(proc.pid) == [], sig.name
    done = subprocess.run(["sh", "-c", 'umask 022 && exec "$0" "$@"', sys.executable, "-m", "pipeline", *args],
                          capture_output=True, text=True, env=cli_env(tmp_path), cwd=paths.ROOT)
    assert done.returncode == 0, done.stderr
    folder = tmp_path / "out" / "killed"
    # It ends on one line: the checks by how they hold, the outputs, the time.
    last = done.stdout.strip().splitlines()[-1]
    assert last.startswith("0 checks: 0 pass independently") and f"outputs in {folder} (report.md); " in last
    recovered = (folder / "results.json").read_bytes()
    # The same run, never interrupted (here, in this process), in a fresh copy of the cache, and its
    # results.json as the outputs write it (written before the figures, which it does not hold).
    clean = tmp_path / "clean"
    copy_cache(light_cache, clean / "cache")
    config = load_config(str(LIGHT_CONFIG), ("scan.curve_points=25", "regression.threshold_count=21"), name="killed")
    outcome = run_derivation(config, cache_dir=clean / "cache", log=lambda s: None, write_outputs=False)
    results_file.write(clean / "results.json", config, outcome.keys, outcome.results, outcome.checks)
    assert recovered == (clean / "results.json").read_bytes()
    doc = json.loads(recovered)
    assert doc["stages"]["sparse_regression"]["coef_scale"] == light_run["sparse_regression"]["coef_scale"]
    # Nothing half written is left behind: no hidden folder beside the outputs, no temporary folder
    # of a killed write in the cache (the rerun swept them), and `pipeline cache` says so.
    assert [p.name for p in (tmp_path / "out").iterdir() if p.is_dir() and p.name.startswith(".")] == []
    assert list((tmp_path / "cache").rglob(".*.tmp.*")) == []
    assert "0 temporary folders" in run_cli(["cache"], tmp_path).stdout
    # Under umask 022 the outputs and the cache entries are readable by others: 0755 and 0644.
    assert folder.stat().st_mode & 0o777 == 0o755
    assert {p.stat().st_mode & 0o777 for p in folder.rglob("*")} == {0o644, 0o755}
    assert all(p.stat().st_mode & 0o777 == (0o755 if p.is_dir() else 0o644) for p in folder.rglob("*"))
    entries = [p for p in (tmp_path / "cache" / "q_scan").iterdir() if not p.name.startswith(".")]
    assert entries and {p.stat().st_mode & 0o777 for p in entries} == {0o755}


@pytest.mark.parametrize("variable", ["PIPELINE_OUTPUTS_DIR", "PIPELINE_CACHE_DIR"])
def test_a_file_where_a_folder_is_needed_exits_3_before_computing(tmp_path, variable):
    blocker = tmp_path / "blocker"
    blocker.write_text("")
    env = cli_env(tmp_path) | {variable: str(blocker / "sub")}
    done = subprocess.run([sys.executable, "-m", "pipeline", "refit", "--config", str(LIGHT_CONFIG), "--out", "x"],
                          capture_output=True, text=True, env=env, cwd=paths.ROOT, timeout=120)
    assert done.returncode == 3, done.stderr
    assert done.stderr.strip().count("\n") == 0 and "Traceback" not in done.stderr
    assert f"({variable}) '{blocker / 'sub'}' cannot be created: '{blocker}' is a file, not a folder" in done.stderr
    assert done.stdout == ""                       # nothing started
    assert not (tmp_path / "cache").exists() and not (tmp_path / "out").exists()


@pytest.mark.slow
def test_a_file_size_limit_exits_3_with_one_line_and_leaves_no_output(refit_cache, tmp_path):
    """`ulimit -f 200` (at most 100-200 kB a file): writing the outputs fails; the run says so in one
    line, exits 3, and neither an output folder nor a temporary one is left."""
    command = f'ulimit -f 200 && exec "$0" -m pipeline refit --config {LIGHT_CONFIG} --out limited'
    done = subprocess.run(["sh", "-c", command, sys.executable], capture_output=True, text=True,
                          env=cli_env(tmp_path), cwd=paths.ROOT, timeout=300)
    assert done.returncode == 3, done.stderr
    assert done.stderr.strip().count("\n") == 0 and "Traceback" not in done.stderr, done.stderr
    assert "a file reached the size limit" in done.stderr and "ulimit -f" in done.stderr
    assert [p.name for p in (tmp_path / "out").iterdir() if p.is_dir()] == []


def test_only_naming_an_unknown_stage_exits_2_listing_the_stages(tmp_path):
    done = run_cli(["refit", "--config", str(LIGHT_CONFIG), "--only", "accuracy,acuracy", "--out", "x"], tmp_path)
    assert done.returncode == 2 and done.stderr.count("\n") == 1
    assert "--only 'accuracy,acuracy': unknown stage 'acuracy'; the stages are zone, q_scan" in done.stderr
    assert not (tmp_path / "out").exists()
    plan = run_cli(["explain", "derivation.Q=0.7", "derivation.constants=fitted", "--only", "accuracy"], tmp_path)
    assert plan.returncode == 0, plan.stderr
    listed = [line.split()[0] for line in plan.stdout.splitlines() if line.startswith("  ")]
    assert listed[-1] == "accuracy" and "render" not in listed and "zone" in listed


@pytest.mark.slow
def test_the_cli_started_without_make_finds_llvm_and_renders_with_the_fast_variant(refit_cache, tmp_path):
    """As a user starts it: `.venv/bin/pipeline` with only PATH and HOME (and the pipeline's own
    folders) set, none of the variables a Makefile could pass (DRJIT_LIBLLVM_PATH, JAX_ENABLE_X64,
    JAX_PLATFORMS). Where an LLVM >= 15 is installed, `pipeline tools` names it and the probe picks
    llvm_ad_rgb; a refit that renders anew runs llvm_ad_rgb at mitsuba.spp (not the fallback's
    samples) without a warning, and its results.json names the LLVM."""
    from pipeline.engine import toolchains

    system = toolchains.find_llvm({})
    if not system.found:
        pytest.skip(f"no LLVM >= 15 installed here: {system.missing}")
    env = {"PATH": os.environ["PATH"], "HOME": os.environ.get("HOME", str(tmp_path)),
           "PIPELINE_CACHE_DIR": str(refit_cache), "PIPELINE_OUTPUTS_DIR": str(tmp_path / "out"),
           "PIPELINE_XLA_CACHE_DIR": cli_env(tmp_path)["PIPELINE_XLA_CACHE_DIR"]}
    pipeline = str(Path(sys.executable).parent / "pipeline")
    tools = subprocess.run([pipeline, "tools"], capture_output=True, text=True, env=env, cwd=tmp_path, timeout=300)
    assert tools.returncode == 0, tools.stderr
    assert f"llvm          {system.version}" in tools.stdout and system.path in tools.stdout, tools.stdout
    assert "Mitsuba variant (mitsuba.variant = auto): llvm_ad_rgb" in tools.stdout, tools.stdout
    done = subprocess.run([pipeline, "refit", "--config", str(LIGHT_CONFIG), "--set", "mitsuba.width=32", "--set",
                           "mitsuba.height=16", "--only", "mitsuba_render", "--out", "clean"],
                          capture_output=True, text=True, env=env, cwd=tmp_path, timeout=600)
    assert done.returncode == 0, done.stdout + done.stderr
    assert "mitsuba_render" in done.stdout.split("recomputed: ")[1] and "warning" not in done.stdout + done.stderr
    doc = json.loads((tmp_path / "out" / "clean" / "results.json").read_text())
    assert doc["stages"]["mitsuba_render"]["variant"] == "llvm_ad_rgb"
    assert doc["stages"]["mitsuba_render"]["spp"] == load_config(str(LIGHT_CONFIG))["mitsuba.spp"]
    assert doc["toolchains"]["llvm"]["path"] == system.path and doc["toolchains"]["llvm"]["version"] == system.version


def test_a_run_from_python_returns_what_results_json_holds(light_cache, light_run, tmp_path):
    """`pipeline.run(config, set=..., only=...)`: the light config with Q changed, the accuracy stage
    and what it reads, on a copy of the session's cache; the overrides as a dict or as `--set` text
    give the same results, which hold the changed Q, the stage's fields and the stages not run; a bad
    override is a ConfigError naming it."""
    import json

    import pipeline
    from tests.conftest import LIGHT_CONFIG
    from tests.helpers import copy_cache

    copy_cache(light_cache, tmp_path / "cache")
    results = pipeline.run(LIGHT_CONFIG, set={"derivation.Q": 0.7, "derivation.constants": "fitted"}, only="accuracy",
                           log=lambda s: None, cache_dir=tmp_path / "cache")
    again = pipeline.run(str(LIGHT_CONFIG), set=("derivation.Q=0.7", "derivation.constants=fitted"), only=["accuracy"],
                         log=lambda s: None, cache_dir=tmp_path / "cache")
    assert json.dumps(results, sort_keys=True) == json.dumps(again, sort_keys=True)
    assert results["config"]["derivation.Q"] == 0.7 and "accuracy" in results["stages"]
    assert "render" in results["not_run"] and results["headline"]
    json.dumps(results, allow_nan=False)            # plain JSON, as results.json
    with pytest.raises(pipeline.ConfigError, match="derivation.Q"):
        pipeline.run(LIGHT_CONFIG, set={"derivation.Q": 2.0, "derivation.constants": "fitted"}, only="accuracy",
                     log=lambda s: None, cache_dir=tmp_path / "cache")
