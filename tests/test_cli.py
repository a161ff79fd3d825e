"""The command line: the graph, dry runs, fast errors, exit codes, and recovery from kills."""

import json
import random
import shutil
import signal
import subprocess
import sys
import time

import pytest

from pipeline.engine import paths
from pipeline.engine.config import load_config
from pipeline.run import run_derivation

from .conftest import LIGHT_CONFIG
from .helpers import cli_env

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
     "section 'nosuch' does not exist; allowed sections are run, derivation, paper_model"),
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
    shutil.copytree(paper_cache, tmp_path / "cache")
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


@pytest.mark.slow
def test_runs_killed_at_random_moments_recover_with_identical_results(refit_cache, light_cache, light_run, tmp_path):
    args = ["refit", "--config", str(LIGHT_CONFIG), "--set", "scan.curve_points=25",
            "--set", "regression.threshold_count=21", "--out", "killed"]
    rng = random.Random(0)
    for _ in range(2):
        proc = subprocess.Popen([sys.executable, "-m", "pipeline", *args], env=cli_env(tmp_path), cwd=paths.ROOT,
                                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        time.sleep(rng.uniform(1.0, 4.0))    # startup, stages, or writing the outputs
        proc.send_signal(signal.SIGKILL)
        proc.wait()
    done = run_cli(args, tmp_path)
    assert done.returncode == 0, done.stderr
    recovered = (tmp_path / "out" / "killed" / "results.json").read_bytes()
    # The same run, never interrupted (here, in this process), in a fresh copy of the cache.
    clean = tmp_path / "clean"
    shutil.copytree(light_cache, clean / "cache")
    config = load_config(str(LIGHT_CONFIG), ("scan.curve_points=25", "regression.threshold_count=21"), name="killed")
    run_derivation(config, cache_dir=clean / "cache", outputs=clean / "out", log=lambda s: None)
    assert recovered == (clean / "out" / "killed" / "results.json").read_bytes()
    doc = json.loads(recovered)
    assert doc["stages"]["sparse_regression"]["coef_scale"] == light_run["sparse_regression"]["coef_scale"]
    # Nothing half written is left behind.
    assert [p.name for p in (tmp_path / "out").iterdir() if p.is_dir() and p.name.startswith(".")] == []
