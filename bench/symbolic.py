"""The symbolic search side by side with pyoperon, one case and engine per process (so that its peak
memory, VmHWM, is its own): `python bench/symbolic.py CASE ENGINE` prints seconds, peak GB and the
best RMS at the case's complexity. `bench/bench.py` runs every case with both engines.

Cases (targets of the issue "Symbolic regression a researcher can trust"): 5,000 points of the
paper's coef to complexity 12 (60 s, 1 GB), 200 points to complexity 14 (60 s), two variables to
complexity 10 (60 s). pyoperon runs its `pipeline regress` settings (pipeline.symbolic.operon).
"""

from __future__ import annotations

import sys
import time

import numpy as np

CASES = {
    "5000 points, complexity 12": 12,
    "200 points, complexity 14": 14,
    "2 variables, complexity 10": 10,
}


def data(case: str):
    if case.startswith("2 variables"):
        rng = np.random.default_rng(0)
        t, q = rng.uniform(0.5, 6.0, 80), rng.uniform(0.2, 1.0, 80)
        return np.stack([t, q]), (2 * t + q) / (t + 3)
    points = 5000 if case.startswith("5000") else 200
    n = np.linspace(2.0, 1000.0, points)
    k = 0.448 * n + 0.099
    return n[None], np.round(6 * k**2 / (np.pi * (4 * k - 1)), 3)


def run(case: str, engine: str) -> tuple[float, float, float]:
    x, y = data(case)
    depth = CASES[case]
    start = time.perf_counter()
    if engine == "exhaustive":
        from pipeline.symbolic import search

        found = search.search(x, y, depth)
        best = float(found["rms"].min())
    else:
        from pipeline.symbolic import operon

        models = operon.polished(operon.operon_models(x, y, depth), x, y)
        best = min((rms for *_, rms, _ in models), default=float("nan"))
    seconds = time.perf_counter() - start
    peak = next(int(line.split()[1]) for line in open("/proc/self/status") if line.startswith("VmHWM"))
    return seconds, peak / 1e6, best


if __name__ == "__main__":
    seconds, peak, best = run(sys.argv[1], sys.argv[2])
    print(f"{seconds:.2f} {peak:.3f} {best:.6g}")
