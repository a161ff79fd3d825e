"""The worker processes a run starts (`engine.workers`): a script that calls the package without an
`if __name__ == "__main__":` guard is not run again by its spawned workers."""

import subprocess
import sys

from pipeline.engine import paths

SCRIPT = """
import os
print("script ran in", os.getpid(), flush=True)
from pipeline.engine import workers
pool = workers.spawned_pool(2)
futures = [workers.submitted(pool, os.getpid) for _ in range(4)]
print("workers", sorted({f.result() for f in futures} - {os.getpid()}) != [], flush=True)
pool.shutdown()
"""


def test_a_script_without_a_main_guard_runs_once(tmp_path):
    """The script starts two spawned workers and has them report their process: it prints its first
    line once (multiprocessing alone would run it again in each worker, whose second start of a
    pool then fails), and the work ran in other processes."""
    (tmp_path / "job.py").write_text(SCRIPT)
    done = subprocess.run([sys.executable, str(tmp_path / "job.py")], capture_output=True, text=True, cwd=paths.ROOT,
                          timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.count("script ran in") == 1, done.stdout
    assert "workers True" in done.stdout
