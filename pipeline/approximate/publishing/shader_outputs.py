"""What `derive --shader FILE` writes into its folder, all at once: `functions.csv` (a row per function
and architecture: its status, reason, cycles and error as executed before and after, the budget),
`shader.patch` (the file's unified diff replacing the derived functions' bodies; `git apply` or
`patch -p1` from the folder the path is relative to), `report.md` (per function: its status, its
expression before and after, its cycles and errors per architecture) and, per derived function, its
derivation's own files under `functions/NAME/`. The user's file is never written."""

from __future__ import annotations

import csv
import io
import json
import os
from pathlib import Path

from ...engine import escape

COLUMNS = ("file", "function", "status", "reason", "architecture", "cycles_before", "cycles_after", "error_before",
           "error_after", "max_error", "metric")


def function_rows(path: Path, outcomes) -> list[dict]:
    """functions.csv's rows: per function and architecture asked for; a refused function one row."""
    rows = []
    for o in outcomes:
        base = dict(file=str(path), function=o.name, status=o.status, reason=o.reason, max_error=o.budget,
                    metric=o.metric)
        if not o.rows:
            rows.append(base | dict(architecture="", cycles_before=None, cycles_after=None, error_before=None,
                                    error_after=None))
        rows += [base | r for r in o.rows]
    return rows


def shown_path(path: Path) -> str:
    """The file as the patch names it: relative to the working folder where it lies under it (so that
    `git apply` there takes it), else its name."""
    try:
        return Path(os.path.relpath(Path(path).resolve(), Path.cwd())).as_posix() if \
            Path(path).resolve().is_relative_to(Path.cwd()) else Path(path).name
    except ValueError:
        return Path(path).name


def patch_text(path: Path, outcomes, keep_reference: bool = False) -> str:
    """The unified diff of the file with each derived function's body its replacement (empty where
    none was derived)."""
    from ...shaders import patch

    source = Path(path).read_bytes()
    bodies = {o.definition: o.expression for o in outcomes if o.status == "derived"}
    return patch.unified_diff(shown_path(path), source, patch.replaced(source, bodies, keep_reference)) if bodies else ""


def report(path: Path, outcomes, language: str) -> str:
    """report.md of a shader file's run."""
    counts = {s: sum(o.status == s for o in outcomes) for s in ("derived", "none cheaper", "refused")}
    lines = [f"# {escape.markdown(Path(path).name)}: its functions derived", "",
             f"{len(outcomes)} functions of `{escape.markdown(str(path))}` ({language.upper()}): "
             + ", ".join(f"{n} {s}" for s, n in counts.items()) + ". The file is unchanged; `shader.patch` replaces "
             "the derived functions' bodies.", ""]
    for o in outcomes:
        lines += [f"## {escape.markdown(o.name)} (line {o.line}): {o.status}", ""]
        if o.reason:
            lines += [escape.markdown(o.reason), ""]
        if o.check is not None:
            lines += [f"Read as the compiler means it and executed beside it ({o.check.how}"
                      + (f", {o.check.inputs} inputs: the same to the last bit" if o.check.checked and
                         o.check.mismatch is None else "") + ").", ""]
        if o.results is not None:
            shipped = o.results["members"]["as shipped"]["expression"]
            lines += [f"- As shipped: `{escape.markdown(shipped)}`"]
            if o.replacement:
                lines += [f"- Replacement ({escape.markdown(o.replacement)}): `{escape.markdown(o.expression)}`"]
            lines += [f"- Budget: {o.metric} {o.budget:.3g} (as executed)", "",
                      "| architecture | cycles before | cycles after | error before | error after |", "|---|---|---|---|---|"]
            lines += [f"| {r['architecture']} | {r['cycles_before']:g} | {r['cycles_after']:g} | {r['error_before']:.3g} | "
                      f"{r['error_after']:.3g} |" for r in o.rows]
            lines.append("")
    return "\n".join(lines)


def write(out: Path, path: Path, outcomes, language: str, keep_reference: bool = False, log=print) -> list[Path]:
    """Every file of the module docstring into `out`, published whole."""
    from ...engine.cache import digest
    from ...engine.publishing import publish
    from ...engine import faults
    from .derive_files import results_json, write_into

    rows = function_rows(path, outcomes)
    patch = patch_text(path, outcomes, keep_reference)

    def write_all(tmp: Path) -> str:
        text = io.StringIO()
        writer = csv.DictWriter(text, fieldnames=COLUMNS, lineterminator="\n")
        writer.writeheader()
        writer.writerows({k: ("" if v is None else v) for k, v in r.items()} for r in rows)
        for name, content in (("functions.csv", text.getvalue()), ("shader.patch", patch),
                              ("report.md", report(path, outcomes, language))):
            with faults.writing(out / name):
                (tmp / name).write_text(content)
        for o in outcomes:
            if o.results is not None:
                folder = escape.folder_name(o.name)
                write_into(tmp / "functions" / folder, o.results, out / "functions" / folder)
        return f"{len(outcomes)} functions"

    key = digest("derive shader", Path(path).read_text(errors="replace"), patch, json.dumps(rows, default=str),
                 json.dumps([results_json(o.results) for o in outcomes if o.results], sort_keys=True, default=str))
    publish(out, key, log, write_all)
    return [out / n for n in ("functions.csv", "shader.patch", "report.md")]
