"""`make bench`: wall time of a cold `pipeline reproduce` (empty cache and outputs, environment
installed) and of a warm one (nothing changed). Targets: cold < 30 s, warm < 3 s on 2 cores."""

import os
import subprocess
import sys
import tempfile
import time

TARGETS = {"cold": 30.0, "warm": 3.0}


def timed(env) -> float:
    start = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "pipeline", "reproduce"], env=env, capture_output=True, text=True)
    elapsed = time.perf_counter() - start
    if proc.returncode != 0:
        sys.exit(f"pipeline reproduce failed (exit {proc.returncode}):\n{proc.stdout}\n{proc.stderr}")
    return elapsed


def main() -> int:
    with tempfile.TemporaryDirectory() as tmp:
        env = dict(os.environ, PIPELINE_CACHE_DIR=os.path.join(tmp, "cache"),
                   PIPELINE_OUTPUTS_DIR=os.path.join(tmp, "outputs"))
        times = {"cold": timed(env), "warm": timed(env)}
    for name, seconds in times.items():
        verdict = "within" if seconds < TARGETS[name] else "OVER"
        print(f"{name:>4} make reproduce: {seconds:6.2f} s  ({verdict} the {TARGETS[name]:g} s target)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
