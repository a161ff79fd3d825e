"""`pipeline regress`: the exhaustive symbolic regression of `pipeline.symbolic` on a researcher's
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

from . import expressions

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
    forms = expressions.enumerate_forms(max_complexity, ops)
    if not forms:
        raise RegressError(f"no expression of complexity <= {max_complexity} uses only the operations {' '.join(ops)}")
    most = max(expressions.constants(e) for e in forms)
    if x.size <= most:
        raise RegressError(f"{path}: {x.size} data points, but expressions up to complexity {max_complexity} have up "
                           f"to {most} constants; give at least {most + 1} points or a lower --max-complexity")
    log(f"{path}: {x.size} points; searching {len(forms)} expressions up to complexity {max_complexity} "
        f"with operations {' '.join(ops)}")
    import sympy as sp

    from . import symbolic

    name = variable_name(x_column)
    symbol = sp.Symbol(name)
    found = symbolic.search(x, y, max_complexity, ops, starts, iterations, refine, polish_starts, seed, progress=log)
    front = []
    for i in found["front"]:
        e, c = found["forms"][i], found["constants"][i][:found["constant_count"][i]]
        front.append(dict(complexity=int(found["complexity"][i]), rms=float(found["rms"][i]),
                          form=symbolic.show(e, name), expression=symbolic.show(e, name, c),
                          canonical=symbolic.canonical(symbolic.to_sympy(e, c, symbol), symbol),
                          converged=found["converged"].get(i, False)))
    _write(Path(out), front, f"{Path(path).name}: {y_column} against {x_column}", x, y, found, name)
    return front


def _write(out: Path, front, title, x, y, found, name) -> None:
    """front.csv and front.png, published together (`pipeline.run.publish`: a temporary folder
    renamed into place under a lock, so a failure or a second writer leaves nothing half written)."""
    from .cache import digest
    from .publish.plots import symbolic_front_figure
    from .publish.tables import write_front_csv
    from .run import publish

    def write(tmp: Path) -> str:
        write_front_csv(tmp / "front.csv", front)
        symbolic_front_figure(tmp / "front.png", front, found, title)
        return f"{len(front)} front members"

    publish(out, digest("regress", title, x, y, front), lambda s: None, write)
