"""`pipeline compare`: runs side by side, as `dvc exp show` does for experiments.

Each run is an output folder holding `results.json` (a folder of such folders, a sweep's, stands
for all of them). The table has one row per run: the config values that differ between the runs,
then the headline metrics (dicts of the headline, such as `lobe_comparison.d_max`, as one column per
key). It is printed as markdown and written as `compare.csv`; `--plot KEY:FIELD` draws a metric
against a setting, one line per value of the other settings that differ. Reads JSON only: no JAX.
"""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path
from typing import Any

IGNORED_KEYS = ("run.name", "run.question")


class CompareError(ValueError):
    """A folder that holds no run, or a results.json that cannot be read. The CLI exits with 2."""


def find_runs(folders) -> list[tuple[str, dict[str, Any]]]:
    """(name, results.json document) of each run under `folders`, in the order given (a sweep's
    points sorted by name)."""
    runs = []
    for folder in map(Path, folders):
        if (folder / "results.json").is_file():
            candidates = [folder]
        elif folder.is_dir():
            candidates = sorted(p for p in folder.iterdir() if (p / "results.json").is_file())
        else:
            raise CompareError(f"{folder}: no such folder")
        if not candidates:
            raise CompareError(f"{folder}: holds no results.json, directly or one folder down")
        for run in candidates:
            try:
                doc = json.loads((run / "results.json").read_text())
                doc["config"], doc["headline"]
            except (OSError, ValueError, KeyError, TypeError) as e:
                raise CompareError(f"{run / 'results.json'}: not a run's results ({type(e).__name__}: {e})") from None
            runs.append((run.name, doc))
    if len(runs) < 1:
        raise CompareError("no run to compare")
    return runs


def _metrics(doc) -> dict[str, Any]:
    """The headline's scalar fields, dicts flattened to `field.key`."""
    out = {}
    for path, value in doc["headline"].items():
        if isinstance(value, dict):
            out.update({f"{path}.{k}": v for k, v in value.items() if not isinstance(v, dict | list)})
        elif not isinstance(value, list):
            out[path] = value
    return out


def differing_keys(runs) -> list[str]:
    """The config keys whose values are not the same in every run."""
    keys = sorted(set().union(*(doc["config"] for _, doc in runs)) - set(IGNORED_KEYS))
    return [k for k in keys if len({json.dumps(doc["config"].get(k), sort_keys=True) for _, doc in runs}) > 1]


def table(runs) -> tuple[list[str], list[list[Any]]]:
    """(columns, rows): run, the differing config keys, every headline metric any run has."""
    keys = differing_keys(runs)
    metrics = list(dict.fromkeys(m for _, doc in runs for m in _metrics(doc)))
    rows = [[name] + [doc["config"].get(k) for k in keys] + [_metrics(doc).get(m) for m in metrics]
            for name, doc in runs]
    # A config key and a stage field can share a name (zone.level): the config's column says so.
    labels = [f"{k} (config)" if k in metrics else k for k in keys]
    return ["run"] + labels + metrics, rows


def cell(value) -> str:
    if value is None:
        return ""
    if isinstance(value, float):
        return f"{value:.6g}" if math.isfinite(value) else str(value)
    if isinstance(value, list | dict):
        return json.dumps(value)
    return str(value)


def markdown(columns, rows, metrics_that_differ_only: bool = True) -> str:
    """The table as markdown; the terminal's shows only the metrics that differ between runs."""
    keep = list(range(len(columns)))
    if metrics_that_differ_only and len(rows) > 1:
        keep = [i for i in keep if len({cell(r[i]) for r in rows}) > 1 or i == 0]
    lines = ["| " + " | ".join(columns[i] for i in keep) + " |", "|" + "---|" * len(keep)]
    lines += ["| " + " | ".join(cell(r[i]) for i in keep) + " |" for r in rows]
    return "\n".join(lines)


def write_csv(path: Path, columns, rows) -> None:
    with open(path, "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(columns)
        writer.writerows([[cell(v) for v in row] for row in rows])


def plot(path: Path, runs, key: str, field: str) -> None:
    """`field` (a headline metric) against config `key`, one line per value of the other differing keys."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    if all(key not in doc["config"] for _, doc in runs):
        raise CompareError(f"--plot {key}:{field}: '{key}' is not a config key of these runs")
    if all(field not in _metrics(doc) for _, doc in runs):
        raise CompareError(f"--plot {key}:{field}: '{field}' is not a headline metric of these runs; they have "
                           + ", ".join(_metrics(runs[0][1])))
    others = [k for k in differing_keys(runs) if k != key]
    lines: dict[str, list[tuple[Any, Any]]] = {}
    for _, doc in runs:
        label = ", ".join(f"{k} = {cell(doc['config'].get(k))}" for k in others) or field
        value = _metrics(doc).get(field)
        if value is not None:
            lines.setdefault(label, []).append((doc["config"].get(key), value))
    fig, ax = plt.subplots(figsize=(7, 4.2))
    for label, points in lines.items():
        points.sort(key=lambda p: (isinstance(p[0], str), p[0]))
        categorical = any(isinstance(p[0], str) for p in points)   # settings without an order: points, dotted
        ax.plot([cell(p[0]) if categorical else p[0] for p in points], [p[1] for p in points],
                "o:" if categorical else "o-", label=label)
    ax.set(xlabel=key, ylabel=field, title=f"{field} against {key} ({len(runs)} runs)")
    ax.grid(alpha=0.3)
    if len(lines) > 1 or others:
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.set_layout_engine(None)     # laid out: savefig need not draw it once more for tight_layout's placeholder
    fig.savefig(path, dpi=110)
    plt.close(fig)
