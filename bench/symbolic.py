"""The symbolic search side by side with pyoperon, one case and engine per process (so that its peak
memory, VmHWM, is its own): `python bench/symbolic.py CASE ENGINE` prints seconds, peak GB and the
best RMS at the case's complexity. `bench/bench.py` runs every case with both engines.

Cases (targets of the issue "Symbolic regression a researcher can trust"): 5,000 points of the
paper's coef to complexity 12 (60 s, 1 GB), 200 points to complexity 14 (60 s), two variables to
complexity 10 (60 s). pyoperon runs its `pipeline regress` settings (pipeline.symbolic.operon).

With the ten operations (targets of the issue "Symbolic regression with the operations science
uses"), `pipeline regress`'s default engine on 200 points of an exponential decay with an offset to
complexity 12 (60 s) and of a Schlick-type Fresnel curve to 16 (180 s), both within 1.5 GB, and
cos^n over (t, n) to complexity 10 (120 s); and (targets of the issue "regress never loses what a
narrower grammar finds") Schlick's rational t / (n - n t + t) over (t, n), 400 points, exactly
(RMS < 1e-9) within 120 s: `python bench/symbolic.py CASE default`, which prints the time the
search announced before it started too.
"""

from __future__ import annotations

import re
import sys
import time

import numpy as np

CASES = {
    "5000 points, complexity 12": 12,
    "200 points, complexity 14": 14,
    "2 variables, complexity 10": 10,
}
# case: (complexity, seconds allowed)
OPERATOR_CASES = {
    "ten operations, decay, complexity 12": (12, 60.0),
    "ten operations, Fresnel, complexity 16": (16, 180.0),
    "ten operations, cos^n over (t, n), complexity 10": (10, 120.0),
    "ten operations, Schlick's rational over (t, n), complexity 10": (10, 120.0),
}


def data(case: str):
    if "decay" in case:
        x = np.linspace(0.0, 4.0, 200)
        return x[None], 0.3 + 1.7 * np.exp(-1.3 * x)
    if "Fresnel" in case:
        t = np.linspace(0.0, 1.0, 200)
        return t[None], 0.04 + 0.96 * (1.0 - t) ** 5
    if "Schlick's rational" in case:
        rng = np.random.default_rng(0)
        t, n = rng.uniform(0.0, 1.0, 400), rng.uniform(1.0, 10.0, 400)
        return np.stack([t, n]), t / (n - n * t + t)
    if "cos^n" in case:
        rng = np.random.default_rng(0)
        t, n = rng.uniform(0.2, 1.0, 200), rng.uniform(1.0, 20.0, 200)
        return np.stack([t, n]), t ** n
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
    depth = CASES[case] if case in CASES else OPERATOR_CASES[case][0]
    start = time.perf_counter()
    estimate = float("nan")
    if engine == "default":
        import tempfile
        from pathlib import Path

        from pipeline.symbolic.regress import regress

        with tempfile.TemporaryDirectory() as tmp:
            names = ["t", "n"] if x.shape[0] == 2 else ["x"]
            csv = Path(tmp) / "data.csv"
            csv.write_text(",".join(names + ["y"]) + "\n" + "".join(
                ",".join(repr(float(v)) for v in row) + "\n" for row in zip(*x, y)))
            said = []
            front = regress(csv, ",".join(names), "y", Path(tmp) / "out", depth, log=said.append)
        best = min(m["rms"] for m in front)
        # the time printed before the search started
        estimate = float(re.search(r"about (\d+) s here", said[0]).group(1))
    elif engine == "exhaustive":
        from pipeline.symbolic import search

        found = search.search(x, y, depth)
        best = float(found["rms"].min())
    else:
        from pipeline.symbolic import operon

        models = operon.polished(operon.operon_models(x, y, depth), x, y)
        best = min((rms for *_, rms, _ in models), default=float("nan"))
    seconds = time.perf_counter() - start
    peak = next(int(line.split()[1]) for line in open("/proc/self/status") if line.startswith("VmHWM"))
    return seconds, peak / 1e6, best, estimate


if __name__ == "__main__":
    seconds, peak, best, estimate = run(sys.argv[1], sys.argv[2])
    print(f"{seconds:.2f} {peak:.3f} {best:.6g} {estimate:.1f}")
