"""Checks of the reproduced numbers against the values the paper reports (config [expectations]).

Verdicts: "pass" (within the stated tolerance), "differs (documented)" (outside it, but the config
documents the disagreement and its cause and the reproduced value equals the documented one within
`known_tolerance`: the difference is reported, not hidden by a wider tolerance), and "FAIL"
(anything else). A run exits non-zero if any check FAILs.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np

from .config import Expectation

PASS, DIFFERS, FAIL = "pass", "differs (documented)", "FAIL"


@dataclasses.dataclass(frozen=True)
class Check:
    expectation: Expectation
    reproduced: Any
    deviation: float
    verdict: str


def lookup(results: dict[str, dict[str, Any]], path: str) -> Any:
    """The value at 'stage.key' in the run's results; KeyError names what is missing."""
    stage, _, key = path.partition(".")
    if stage not in results or key not in results[stage]:
        raise KeyError(f"expectation refers to result '{path}', which this run does not produce")
    value = results[stage][key]
    return value.tolist() if isinstance(value, np.ndarray) else value


def _deviation(reproduced, paper) -> float:
    if isinstance(paper, bool):
        return 0.0 if bool(reproduced) == paper else math.inf
    r, p = np.atleast_1d(np.asarray(reproduced, float)), np.atleast_1d(np.asarray(paper, float))
    if r.shape != p.shape:
        return math.inf
    return float(np.max(np.abs(r - p)))


def evaluate(expectations, results) -> list[Check]:
    out = []
    for e in expectations:
        value = lookup(results, e.result)
        if e.compare == "at_most":
            dev = float(value) - e.paper
            ok = dev <= e.tolerance
        else:
            dev = _deviation(value, e.paper)
            ok = dev <= e.tolerance
        if ok:
            verdict = PASS
        elif e.known_difference and _deviation(value, e.known_value) <= e.known_tolerance:
            verdict = DIFFERS
        else:
            verdict = FAIL
        out.append(Check(e, value, dev, verdict))
    return out


def fmt(value: Any) -> str:
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, list):
        return "[" + ", ".join(fmt(v) for v in value) + "]"
    if isinstance(value, float | int):
        return f"{value:.6g}"
    return str(value)


def table(checks: list[Check]) -> str:
    """The check table as Markdown (also printed to the terminal)."""
    rows = ["| id | quantity | paper | reproduced | tolerance | verdict |", "|---|---|---|---|---|---|"]
    for c in checks:
        e = c.expectation
        tol = ("<= paper + " if e.compare == "at_most" else "± ") + f"{e.tolerance:.3g}"
        rows.append(f"| {e.id} | {e.quantity} | {fmt(e.paper)} | {fmt(c.reproduced)} | {tol} | {c.verdict} |")
    return "\n".join(rows)
