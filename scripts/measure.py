"""`make measure`: the `pipeline derive` runs that docs/derive.md states, each recorded in
`docs/measured/derive_<target>.json` (its command, date, commit, wall time, and the run's results.json
without the forms' internals; with `verdict_rows`, one row per architecture and anchor). The page's
numbers are marked fields of these records (`make docs` fills them, a test fails where they differ): a
run too long for the tests (1 to 4 minutes each), never typed by hand.

A record no page reads fails a test (`tests/docs/test_generated.py`): a run added here is also
marked in a page. `python scripts/measure.py [TARGET ...]` runs the named ones (default all, about 10 minutes here); each
runs cold (its own derive cache in a temporary folder), its machine code kept in `.cache/machine_code/`.
"""

from __future__ import annotations

import datetime
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
MEASURED = ROOT / "docs" / "measured"
# {target: pipeline.derive's arguments}: every architecture for the one-variable targets, as the page
# says; the parametric ones on the architectures the page names, with a 10 s grammar budget.
RUNS = {
    "schlick": dict(),
    "acos": dict(),
    "smith_ggx_visibility": dict(gpu="rdna3,sm_89,xe_hpg,g610,a740", seconds=10),
    "env_brdf": dict(gpu="rdna3,sm_89", seconds=10),
}


def measure(target: str) -> Path:
    """One run, in this process: PIPELINE_DERIVE_CACHE is the caller's (`main`: an empty folder)."""
    sys.path.insert(0, str(ROOT))
    import pipeline

    with tempfile.TemporaryDirectory() as tmp:
        started = time.perf_counter()
        found = pipeline.derive(target, log=lambda s: print(f"  {s}", flush=True), **RUNS[target])
        seconds = time.perf_counter() - started
        found.write(Path(tmp) / "out")
        results = json.loads((Path(tmp) / "out" / "results.json").read_text())
    results.pop("forms", None)
    verdicts = [dict(architecture=a, anchor=name, **v) for a, anchors in results["verdicts"].items()
                for name, v in anchors.items()]
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True,
                            text=True).stdout.strip()
    arguments = " ".join(f"--{k} {v}" for k, v in RUNS[target].items())
    record = dict(command=f"pipeline derive --target {target} {arguments}".strip(), date=datetime.date.today().isoformat(),
                  commit=commit, cores=os.cpu_count(), wall_seconds=round(seconds, 1), verdict_rows=verdicts,
                  results=results)
    path = MEASURED / f"derive_{target}.json"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(record, indent=1, sort_keys=True, default=str) + "\n")
    return path


def main(argv=None) -> int:
    names = (argv if argv is not None else sys.argv[1:]) or list(RUNS)
    unknown = [n for n in names if n not in RUNS]
    if unknown:
        print(f"unknown: {', '.join(unknown)}; measured are {', '.join(RUNS)}", file=sys.stderr)
        return 2
    if len(names) == 1 and os.environ.get("PIPELINE_DERIVE_CACHE", "").startswith(tempfile.gettempdir()):
        print(f"recorded in {measure(names[0]).relative_to(ROOT)}", flush=True)
        return 0
    for name in names:          # each cold, in its own process with an empty derive cache
        print(f"{name}:", flush=True)
        with tempfile.TemporaryDirectory() as tmp:
            done = subprocess.run([sys.executable, __file__, name],
                                  env=dict(os.environ, PIPELINE_DERIVE_CACHE=str(Path(tmp) / "derive")))
        if done.returncode != 0:
            return done.returncode
    return 0


if __name__ == "__main__":
    sys.exit(main())
