"""`pipeline sweep`: points on a LocalCluster, one failing without spoiling the others, a rerun that
computes nothing, the comparison table equal to the points' results.json; bad sweep files exit 2;
a cluster of `dask scheduler` and `dask worker` processes started elsewhere, through a killed
worker and a lost scheduler."""

import csv
import json
import multiprocessing
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import psutil
import pytest
from distributed import Client

from pipeline.engine import paths, toolchains
from pipeline.engine.config import ConfigError, load_config
from pipeline.mitsuba import bsdf
from pipeline.sweep import load_sweep, run_point

from .conftest import LIGHT_CONFIG
from .helpers import cli_env

# Four points zipped: three Q values, and one whose solver cap is too small to converge.
SWEEP = f"""
[sweep]
name = "s"
config = "{LIGHT_CONFIG}"
mode = "zip"
only = ["accuracy"]
set = {{ "derivation.constants" = "fitted" }}
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


class PlainCluster:
    """`dask scheduler` and `dask worker --nworkers 2` started as a user starts them: in a folder of
    their own (not the project's), with none of the pipeline's or JAX's environment variables, the
    workers under their nannies (daemonic processes). `stop()` ends every process it started."""

    def __init__(self, folder):
        folder.mkdir(parents=True, exist_ok=True)
        self.folder, self.file = folder, folder / "scheduler.json"
        dask = str(Path(sys.executable).parent / "dask")
        env = {"PATH": os.environ["PATH"], "HOME": os.environ.get("HOME", str(folder))}
        start = dict(cwd=folder, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
        self.scheduler = subprocess.Popen([dask, "scheduler", "--scheduler-file", str(self.file), "--port", "0",
                                           "--no-dashboard"], **start)
        deadline = time.monotonic() + 60
        while not self.file.is_file() and time.monotonic() < deadline:
            time.sleep(0.1)
        self.workers = subprocess.Popen([dask, "worker", "--scheduler-file", str(self.file), "--nworkers", "2",
                                         "--nthreads", "1", "--no-dashboard"], **start)
        self.client = Client(scheduler_file=str(self.file), timeout="30s")
        self.client.wait_for_workers(2, timeout=60)

    def worker_processes(self):
        """The processes that run tasks: the children of the `dask worker` process (its nannies)."""
        return psutil.Process(self.workers.pid).children(recursive=False)

    def stop_scheduler(self):
        os.killpg(self.scheduler.pid, signal.SIGKILL)
        self.scheduler.wait()

    def stop(self):
        self.client.close(timeout=5)
        for proc in (self.workers, self.scheduler):
            try:
                os.killpg(proc.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
            proc.wait()


@pytest.fixture()
def plain_cluster(tmp_path):
    clusters = []

    def start():
        clusters.append(PlainCluster(tmp_path / f"elsewhere{len(clusters)}"))
        return clusters[-1]
    yield start
    for cluster in clusters:
        cluster.stop()
    # Nothing a cluster started outlives the test (a killed process may take a moment to go).
    deadline = time.monotonic() + 20
    while (left := [p.pid for p in psutil.process_iter(["cwd", "status"]) if p.info["status"] != psutil.STATUS_ZOMBIE
                    and p.info["cwd"] in {str(c.folder) for c in clusters}]) and time.monotonic() < deadline:
        time.sleep(0.2)
    assert left == []


# Four points of Q values no other test computes; with two workers, the third and fourth start only
# when the first two are done.
CLUSTER_SWEEP = f"""
[sweep]
name = "c"
config = "{LIGHT_CONFIG}"
only = ["accuracy"]
set = {{ "derivation.constants" = "fitted" }}
[axes]
"derivation.Q" = [0.53, 0.54, 0.56, 0.57]
"""


@pytest.mark.slow
def test_a_cluster_started_the_ordinary_way_runs_the_sweep_through_a_killed_worker_and_a_lost_scheduler(
        refit_cache, plain_cluster, tmp_path):
    """On `dask scheduler` / `dask worker` processes started elsewhere: SIGKILL to a worker while it
    computes a point (its nanny starts another; the point runs again), then SIGKILL to the scheduler
    once a point is done. The client exits 3 with one line; the completed points are complete
    folders, nothing half written is left; on a second cluster the rerun computes only the rest,
    on daemonic workers that draw the points' figures themselves."""
    cluster = plain_cluster()
    # What a worker sees (a function of this test, sent by value: the tests are not importable there).
    seen = cluster.client.run(lambda: (os.getcwd(), multiprocessing.current_process().daemon, sorted(
        k for k in os.environ if k.startswith(("PIPELINE_", "JAX_", "XLA_", "DRJIT_")))))
    assert len(seen) == 2 and all(cwd == str(cluster.folder) and daemon and env == []
                                  for cwd, daemon, env in seen.values()), seen
    # A worker that cannot write where the client asks fails the point in one line naming both.
    config = load_config(str(LIGHT_CONFIG), name="blocked")
    failed = cluster.client.submit(run_point, config, ("zone",), str(refit_cache), "/proc/blocked", None).result()
    assert not failed["ok"] and "/proc/blocked" in failed["message"] and " on worker tcp://" in failed["message"]
    # The workers find LLVM themselves: where one >= 15 is installed, a point rendered on a worker
    # (a frame no other test renders) runs llvm_ad_rgb, with no warning; elsewhere the fallback, with one.
    fast = toolchains.find_llvm({}).found
    expected = bsdf.FAST_VARIANT if fast else bsdf.FALLBACK_VARIANT
    assert set(cluster.client.run(bsdf.choose_variant).values()) == {expected}
    config = load_config(str(LIGHT_CONFIG), ("mitsuba.width=48", "mitsuba.height=16"), name="rendered")
    rendered = cluster.client.submit(run_point, config, ("mitsuba_render",), str(refit_cache), str(tmp_path / "r"),
                                     cli_env(tmp_path)["PIPELINE_XLA_CACHE_DIR"]).result()
    assert rendered["ok"] and rendered["variant"] == expected, rendered
    assert (rendered["warnings"] == []) == fast, rendered

    file = tmp_path / "c.toml"
    file.write_text(CLUSTER_SWEEP)
    proc = subprocess.Popen([sys.executable, "-m", "pipeline", "sweep", str(file), "--scheduler-file",
                             str(cluster.file)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env=cli_env(tmp_path, PYTHONUNBUFFERED="1"), cwd=paths.ROOT)
    killed = None
    deadline = time.monotonic() + 120
    while killed is None and time.monotonic() < deadline and proc.poll() is None:
        for worker in cluster.worker_processes():
            try:
                if worker.cpu_percent(interval=0.2) > 50:        # computing a point
                    worker.kill()
                    killed = worker.pid
                    break
            except psutil.NoSuchProcess:
                continue
    assert killed is not None, "no worker was seen computing"
    lines = []
    while not any(line.startswith("[1/4]") for line in lines):
        line = proc.stdout.readline()
        assert line, "the sweep ended before a point was done"
        lines.append(line)
    cluster.stop_scheduler()
    out, err = proc.communicate(timeout=120)
    assert proc.returncode == 3, out + err
    assert err.strip().count("\n") == 0 and "Traceback" not in err, err
    assert err.startswith(f"error: the Dask scheduler at {cluster.client.scheduler.address} was lost mid-sweep"), err
    # The workers go on with the points they hold; stopped now, one may be killed while it writes.
    cluster.stop()
    folder = tmp_path / "out" / "c"
    complete = {p.name for p in folder.iterdir() if p.is_dir() and not p.name.startswith(".")}
    assert "points done and kept in" in err and len(complete) >= 1
    assert all((folder / name / "results.json").is_file() and (folder / name / "report.md").is_file()
               for name in complete)

    second = plain_cluster()
    again = subprocess.run([sys.executable, "-m", "pipeline", "sweep", str(file), "--scheduler-file",
                            str(second.file)], capture_output=True, text=True, env=cli_env(tmp_path),
                           cwd=paths.ROOT, timeout=300)
    assert again.returncode == 0, again.stdout + again.stderr
    assert again.stdout.count(": ok (0 stages computed") >= len(complete), again.stdout
    rest = 4 - again.stdout.count(": ok (0 stages computed")
    # the points left are computed on the second cluster's workers; where the first cluster's workers
    # finished every point they held before they were stopped (a fast machine), none is left and the
    # sweep says it runs here
    if rest >= 1:
        assert f"{rest} points on 2 Dask workers" in again.stdout, again.stdout
    else:
        assert "every stage of its 4 points is cached: run here, without Dask" in again.stdout, again.stdout
    assert "4 of 4 points done" in again.stdout
    with open(folder / "compare.csv") as f:
        assert len(list(csv.DictReader(f))) == 4
    # No temporary folder of a killed write is left: the rerun swept them.
    assert not [p.name for p in folder.iterdir() if p.name.startswith(".") and "tmp" in p.name], list(folder.iterdir())
    # Every point's figures, those drawn on the daemonic workers included.
    for name in ("Q-0p53", "Q-0p54", "Q-0p56", "Q-0p57"):
        assert {"fig2_d_vs_Q.png", "fig6_fQ2_errors.png"} <= {p.name for p in (folder / name).glob("*.png")}
