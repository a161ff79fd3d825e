"""Checks of the reproduced numbers against the values the paper reports (config [expectations]).

An expectation holds for the settings of the config file it is written in. It is checked where its
value is the one those settings give: where no config key that its result depends on (transitively,
through the stage graph) was changed by `--set`, or where one was and the value is still the one the
file's own settings give (known from the cache: a figure-only refit changes no checked value).
Otherwise it is "not comparable (settings differ: KEY, ...)", shown with the paper's value beside the
run's, and neither passes nor fails.

Verdicts: "pass" (within the stated tolerance), "differs (documented)" (outside it, but the config
documents the disagreement and its cause and the reproduced value equals the documented one within
`known_tolerance`: the difference is reported, not hidden by a wider tolerance), "not comparable",
and "FAIL" (anything else). A run exits non-zero if any check FAILs.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np

from . import graph
from .config import Expectation

PASS, DIFFERS, FAIL = "pass", "differs (documented)", "FAIL"
NOT_COMPARABLE = "not comparable"
NOT_RUN = "not run"          # a targeted run (`--only`) did not compute the stage the check reads


@dataclasses.dataclass(frozen=True)
class Check:
    expectation: Expectation
    reproduced: Any
    deviation: float
    verdict: str
    settings_differ: tuple[str, ...] = ()

    @property
    def verdict_text(self) -> str:
        if self.verdict == NOT_COMPARABLE:
            return f"{NOT_COMPARABLE} (settings differ: {', '.join(self.settings_differ)})"
        return self.verdict


def lookup(results: dict[str, dict[str, Any]], path: str) -> Any:
    """The value at 'stage.field' in the run's results (paths are validated against the graph when
    the config is loaded)."""
    stage, _, key = path.partition(".")
    value = results[stage][key]
    return value.tolist() if isinstance(value, np.ndarray) else value


def _deviation(reproduced, paper) -> float:
    if isinstance(paper, bool):
        return 0.0 if bool(reproduced) == paper else math.inf
    r, p = np.atleast_1d(np.asarray(reproduced, float)), np.atleast_1d(np.asarray(paper, float))
    if r.shape != p.shape:
        return math.inf
    return float(np.max(np.abs(r - p)))


def _same(a, b) -> bool:
    try:
        return bool(np.array_equal(np.asarray(a), np.asarray(b)))
    except (TypeError, ValueError):
        return a == b


def evaluate(config, results, file_results=None) -> list[Check]:
    """The checks of `config`'s expectations on the run's results. `file_results`: the results the
    config file's own settings give, of the stages known (`pipeline.runner.file_results`): where a
    check's value is the same there, the settings `--set` changed did not touch it, and it is
    checked."""
    out = []
    for e in config.expectations:
        if e.result.split(".", 1)[0] not in results:
            out.append(Check(e, None, math.nan, NOT_RUN))
            continue
        value = lookup(results, e.result)
        differ = tuple(config.changed_from_file(graph.config_dependencies(e.result, config.values)))
        if differ and file_results and e.result.split(".", 1)[0] in file_results:
            if _same(value, lookup(file_results, e.result)):
                differ = ()         # the value the file's settings give: comparable
        if differ:
            out.append(Check(e, value, _deviation(value, e.paper), NOT_COMPARABLE, differ))
            continue
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
    if value is None:
        return "-"
    if isinstance(value, float | int):
        return f"{value:.6g}"
    return str(value)


def table(checks: list[Check]) -> str:
    """The check table as Markdown (also printed to the terminal)."""
    rows = ["| id | quantity | paper | reproduced | tolerance | verdict | how it holds |",
            "|---|---|---|---|---|---|---|"]
    for c in checks:
        e = c.expectation
        tol = ("<= paper + " if e.compare == "at_most" else "± ") + f"{e.tolerance:.3g}"
        rows.append(f"| {e.id} | {e.quantity} | {fmt(e.paper)} | {fmt(c.reproduced)} | {tol} | {c.verdict_text} | "
                    f"{e.agreement} |")
    return "\n".join(rows)


def tally(checks) -> str:
    """One line: how many checks pass independently, pass by calibration or by design (agreements
    that hold by construction), differ with a documented cause, are not comparable, fail."""
    passed = [c for c in checks if c.verdict == PASS]
    independent = sum(c.expectation.agreement == "independent" for c in passed)
    parts = [f"{independent} pass independently",
             f"{len(passed) - independent} pass by construction (calibrated or designed to match)",
             f"{sum(c.verdict == DIFFERS for c in checks)} differ with a documented cause",
             f"{sum(c.verdict == NOT_COMPARABLE for c in checks)} not comparable",
             f"{sum(c.verdict == FAIL for c in checks)} failed"]
    not_run = sum(c.verdict == NOT_RUN for c in checks)
    if not_run:
        parts.append(f"{not_run} not run (their stages were not asked for)")
    return f"{len(checks)} checks: " + ", ".join(parts)
