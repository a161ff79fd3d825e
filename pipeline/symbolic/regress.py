"""`pipeline regress`: the exhaustive symbolic regression of `pipeline.symbolic.search` on a researcher's
own two-column data, read from a CSV file with a header row.

Writes `front.csv` (one front member per row) and `front.png` into the output folder, both at once
(nothing is written if anything fails). Bad input raises `RegressError` naming the problem.
"""

from __future__ import annotations

import csv
import math
import re
from pathlib import Path

import numpy as np

from . import grammar

MAX_COMPLEXITY = 14


class RegressError(ValueError):
    """A bad CSV file or argument of `pipeline regress`."""


def parse_operations(text: str) -> str:
    """'+,-,*,/' (commas and spaces optional) -> '+-*/'."""
    ops = [t for t in re.split(r"[,\s]+", text.strip()) if t]
    if len(ops) == 1 and len(ops[0]) > 1:
        ops = list(ops[0])
    if not ops or any(op not in "+-*/" or len(op) != 1 for op in ops) or len(set(ops)) != len(ops):
        raise RegressError(f"--ops {text!r}: give distinct operations from + - * /, comma-separated (\"+,-,*,/\")")
    return "".join(ops)


def read_columns(path: Path, x_column: str, y_column: str) -> tuple[np.ndarray, np.ndarray]:
    """The two named columns of a CSV file as float arrays."""
    if not path.is_file():
        raise RegressError(f"{path}: no such file")
    try:
        with open(path, newline="", encoding="utf-8") as f:
            rows = list(csv.reader(f))
    except UnicodeDecodeError as e:
        raise RegressError(f"{path}: not a UTF-8 text file ({e.reason} at byte {e.start})") from None
    rows = [r for r in rows if any(cell.strip() for cell in r)]
    if not rows:
        raise RegressError(f"{path}: the file is empty")
    header = [h.strip() for h in rows[0]]
    for name, option in ((x_column, "--x"), (y_column, "--y")):
        if name not in header:
            raise RegressError(f"{path}: no column {name!r} ({option}); the header has " + ", ".join(repr(h) for h in header))
    if x_column == y_column:
        raise RegressError(f"--x and --y name the same column {x_column!r}")
    columns = {}
    for name in (x_column, y_column):
        j, values = header.index(name), []
        for line, row in enumerate(rows[1:], start=2):
            cell = row[j].strip() if j < len(row) else ""
            try:
                v = float(cell)
            except ValueError:
                raise RegressError(f"{path}, line {line}, column {name!r}: {cell!r} is not a number") from None
            if not math.isfinite(v):
                raise RegressError(f"{path}, line {line}, column {name!r}: {cell!r} is not a finite number")
            values.append(v)
        columns[name] = np.array(values, dtype=np.float64)
    return columns[x_column], columns[y_column]


def variable_name(column: str) -> str:
    """The column's name if it can name a variable in an expression, else x."""
    return column if re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", column) and column != "c" else "x"


def regress(path: Path, x_column: str, y_column: str, out: Path, max_complexity: int = 12, ops: str = "+-*/",
            starts: int = 1, iterations: int = 20, refine: int = 8, polish_starts: int = 4, seed: int = 0,
            log=print) -> list[dict]:
    """Runs the search on the file's two columns; writes out/front.csv and out/front.png; returns the front."""
    if not 1 <= max_complexity <= MAX_COMPLEXITY:
        raise RegressError(f"--max-complexity {max_complexity}: give an integer in [1, {MAX_COMPLEXITY}]")
    x, y = read_columns(Path(path), x_column, y_column)
    forms = grammar.enumerate_forms(max_complexity, ops)
    if not forms:
        raise RegressError(f"no expression of complexity <= {max_complexity} uses only the operations {' '.join(ops)}")
    most = max(grammar.constants(e) for e in forms)
    if x.size <= most:
        raise RegressError(f"{path}: {x.size} data points, but expressions up to complexity {max_complexity} have up "
                           f"to {most} constants; give at least {most + 1} points or a lower --max-complexity")
    log(f"{path}: {x.size} points; searching {len(forms)} expressions up to complexity {max_complexity} "
        f"with operations {' '.join(ops)}")
    import sympy as sp

    from . import search

    name = variable_name(x_column)
    symbol = sp.Symbol(name)
    found = search.search(x, y, max_complexity, ops, starts, iterations, refine, polish_starts, seed, progress=log)
    front = []
    for i in found["front"]:
        e, c = found["forms"][i], found["constants"][i][:found["constant_count"][i]]
        front.append(dict(complexity=int(found["complexity"][i]), rms=float(found["rms"][i]),
                          form=search.show(e, name), expression=search.show(e, name, c),
                          canonical=search.canonical(search.to_sympy(e, c, symbol), symbol),
                          converged=found["converged"].get(i, False)))
    _write(Path(out), front, f"{Path(path).name}: {y_column} against {x_column}", x, y, found, name)
    return front


def _write(out: Path, front, title, x, y, found, name) -> None:
    """front.csv and front.png, published together (`pipeline.engine.publishing`: a temporary folder
    renamed into place under a lock, so a failure or a second writer leaves nothing half written)."""
    from ..engine.cache import digest
    from ..engine.publishing import publish

    def write(tmp: Path) -> str:
        write_front_csv(tmp / "front.csv", front)
        symbolic_front_figure(tmp / "front.png", front, found, title)
        return f"{len(front)} front members"

    publish(out, digest("regress", title, x, y, front), lambda s: None, write)


FRONT_COLUMNS = ("complexity", "rms", "form", "expression", "canonical", "max_rel_to_exact",
                 "max_energy_excess", "equivalent_to_exact")


def write_front_csv(path, front) -> None:
    """A symbolic-regression front as CSV, one member per row; columns a member lacks are left out."""
    columns = [c for c in FRONT_COLUMNS if all(c in m for m in front)]
    with open(path, "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(columns)
        for m in front:
            writer.writerow([f"{m[c]:.10g}" if isinstance(m[c], float) else m[c] for c in columns])


def symbolic_front_figure(path, front, found, title) -> None:
    """The front of `pipeline regress`: RMS against complexity, every complexity's best in grey."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(10, 5))
    sizes = sorted(set(int(k) for k in found["complexity"]))
    floor = 1e-16 * max(float(np.max(found["rms"][np.isfinite(found["rms"])])), 1e-300)
    best = [max(float(np.min(found["rms"][found["complexity"] == k])), floor) for k in sizes]
    ax.plot(sizes, best, "o", color="0.75", ms=5, label=f"best expression at each complexity ({len(found['forms'])} searched)")
    xs, ys = [m["complexity"] for m in front], [max(m["rms"], floor) for m in front]
    ax.step(xs + [sizes[-1] + 1], ys + [ys[-1]], where="post", color="C0", label="front")
    ax.plot(xs, ys, "o", color="C0", ms=7)
    lines = ["front (complexity, RMS, sympy's canonical form):"]
    lines += [f"{m['complexity']:>2}  {m['rms']:.3g}  {m['canonical'].replace('**', '^').replace('*', ' ')}" for m in front]
    ax.text(0.98, 0.97, "\n".join(lines), transform=ax.transAxes, fontsize=7.5, family="monospace", va="top",
            ha="right", multialignment="left", bbox=dict(facecolor="white", edgecolor="0.8", alpha=0.9))
    positive = [v for v in best if v > 0]
    ax.set(yscale="log" if positive and max(positive) / min(positive) > 20 else "linear",
           xlabel="complexity (constants, variable, +, -, x count 1; / counts 2)", ylabel="RMS error", title=title,
           xlim=(0, sizes[-1] + 1.5))
    ax.legend(fontsize=8, loc="lower left")
    ax.grid(alpha=0.3, which="both")
    fig.tight_layout()
    fig.savefig(path, dpi=110, pil_kwargs={"compress_level": 1})
    plt.close(fig)
