"""`pipeline sweep`: points on a LocalCluster, one failing without spoiling the others, a rerun that
computes nothing, the comparison table equal to the points' results.json; bad sweep files exit 2."""

import csv
import json
import subprocess
import sys

import pytest

from pipeline.engine import paths
from pipeline.engine.config import ConfigError
from pipeline.sweep import load_sweep

from .conftest import LIGHT_CONFIG
from .helpers import cli_env

# Four points zipped: three Q values, and one whose solver cap is too small to converge.
SWEEP = f"""
[sweep]
name = "s"
config = "{LIGHT_CONFIG}"
mode = "zip"
only = ["accuracy"]
[axes]
"derivation.Q" = [0.6, 0.62, 0.66, 0.68]
"solver.max_steps" = [256, 256, 256, 8]
"""


def sweep_cli(file, tmp_path, *extra):
    return subprocess.run([sys.executable, "-m", "pipeline", "sweep", str(file), "--workers", "2", *extra],
                          capture_output=True, text=True, env=cli_env(tmp_path), cwd=paths.ROOT, timeout=600)


@pytest.mark.slow
def test_a_sweep_on_a_local_cluster(refit_cache, tmp_path):
    file = tmp_path / "s.toml"
    file.write_text(SWEEP)
    done = sweep_cli(file, tmp_path)
    assert done.returncode == 1, done.stderr          # one point failed
    folder = tmp_path / "out" / "s"
    good = ["Q-0p6_max_steps-256", "Q-0p62_max_steps-256", "Q-0p66_max_steps-256"]
    assert {p.name for p in folder.iterdir() if p.is_dir()} == set(good)
    assert "Q-0p68_max_steps-8: FAILED (SolverError: zone calibration: bisection on L did not converge" in done.stdout
    assert "[4/4] done 3, failed 1" in done.stdout and "3 of 4 points done, failed: Q-0p68_max_steps-8" in done.stdout
    # The comparison: one row per complete point, equal to its results.json.
    with open(folder / "compare.csv") as f:
        rows = list(csv.DictReader(f))
    assert [r["run"] for r in rows] == good and (folder / "compare.png").is_file()
    for row in rows:
        doc = json.loads((folder / row["run"] / "results.json").read_text())
        assert float(row["derivation.Q"]) == doc["config"]["derivation.Q"]
        assert float(row["accuracy.d_f_Q2"]) == pytest.approx(doc["headline"]["accuracy.d_f_Q2"], rel=1e-5)
        assert doc["not_run"] and "accuracy" in doc["stages"]
    stamps = {name: (folder / name / "results.json").stat().st_mtime_ns for name in good}
    # A rerun computes nothing and rewrites nothing: the three complete points run in the sweep's own
    # process (every stage cached), and only the failing one goes to Dask again.
    again = sweep_cli(file, tmp_path)
    assert again.stdout.count(": ok (0 stages computed") == 3, again.stdout
    assert "1 points on 2 Dask workers" in again.stdout and "(3 with every stage cached run here)" in again.stdout
    assert stamps == {name: (folder / name / "results.json").stat().st_mtime_ns for name in good}


@pytest.mark.parametrize("text, message", [
    ('[sweep]\nspeed = 1\n[axes]\n"derivation.Q" = [0.5]', "unknown key 'sweep.speed'"),
    ('[axes]\n"derivation.Q" = []', "axis 'derivation.Q' must be a non-empty list"),
    ('[axes]\n"derivation.Q" = [0.5, 1.5]\n[sweep]\nset = { "derivation.constants" = "fitted" }',
     "point Q-1p5: config key 'derivation.Q' = 1.5 is not allowed"),
    ('[axes]\n"derivation.speed" = [1]', "config key 'derivation.speed' is unknown"),
    ('[sweep]\nmode = "zip"\n[axes]\n"derivation.Q" = [0.5, 0.6]\n"zone.level" = [0.5]', "every axis needs as many"),
    ('[sweep]\nonly = ["acuracy"]\n[axes]\n"zone.level" = [0.5]', "the stages are zone, q_scan"),
])
def test_bad_sweep_files_are_refused_before_anything_runs(tmp_path, text, message):
    file = tmp_path / "bad.toml"
    file.write_text(text)
    with pytest.raises(ConfigError, match=message.replace("(", r"\(").replace("[", r"\[")):
        load_sweep(file)


def test_a_scheduler_that_does_not_answer_exits_2_in_seconds_naming_it(tmp_path):
    file = tmp_path / "one.toml"
    file.write_text('[sweep]\nset = { "derivation.constants" = "fitted" }\n[axes]\n"derivation.Q" = [0.5]\n')
    done = sweep_cli(file, tmp_path, "--scheduler", "tcp://127.0.0.1:9")
    assert done.returncode == 2 and "no Dask scheduler answers at tcp://127.0.0.1:9" in done.stderr, done.stderr
    assert done.stderr.strip().count("\n") == 0
    assert not (tmp_path / "out").exists()


# Three points of other Q values (each computes), run on two workers; one worker is killed mid-point.
KILL_SWEEP = f"""
[sweep]
name = "k"
config = "{LIGHT_CONFIG}"
only = ["accuracy"]
[axes]
"derivation.Q" = [0.57, 0.58, 0.59]
"""


@pytest.mark.slow
def test_a_worker_killed_mid_point_spoils_no_other_point(refit_cache, tmp_path):
    """SIGKILL to a Dask worker process while it runs a point: Dask reruns the point on a new worker
    (or reports it failed with its message); the other points complete, no half-written folder is
    left, and a rerun computes nothing for the points that completed."""
    import os
    import signal
    import time

    import psutil

    file = tmp_path / "k.toml"
    file.write_text(KILL_SWEEP)
    proc = subprocess.Popen([sys.executable, "-m", "pipeline", "sweep", str(file), "--workers", "2"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=cli_env(tmp_path),
                            cwd=paths.ROOT)
    killed = None
    deadline = time.monotonic() + 120
    while killed is None and time.monotonic() < deadline and proc.poll() is None:
        # The workers: the processes under the nannies that compute (busy on a CPU), once a point runs.
        for child in psutil.Process(proc.pid).children(recursive=True):
            try:
                if child.cpu_percent(interval=0.2) > 50 and child.parent().pid != proc.pid:
                    os.kill(child.pid, signal.SIGKILL)
                    killed = child.pid
                    break
            except psutil.NoSuchProcess:
                continue
    out, err = proc.communicate(timeout=600)
    assert killed is not None, "no worker was seen computing"
    folder = tmp_path / "out" / "k"
    lines = [line for line in out.splitlines() if line.startswith("[")]
    assert len(lines) == 3, out + err                          # every point reported, ok or FAILED
    complete = {p.name for p in folder.iterdir() if p.is_dir() and (p / "results.json").is_file()}
    ok = {line.split(" | ")[1].split(":")[0] for line in lines if ": ok (" in line}
    assert ok <= complete and len(ok) >= 2, out
    assert not [p.name for p in folder.iterdir() if p.name.startswith(".") and "tmp" in p.name], list(folder.iterdir())
    again = sweep_cli(file, tmp_path)
    assert again.returncode == 0, again.stdout + again.stderr
    assert again.stdout.count(": ok (0 stages computed") >= len(ok), again.stdout
    if len(ok) == 3:            # nothing left to compute: no Dask cluster is started
        assert "every stage of its 3 points is cached: run here, without Dask" in again.stdout, again.stdout
