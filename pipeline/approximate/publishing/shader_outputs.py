"""What `derive --shader FILE` writes into its folder, all at once: `functions.csv` (a row per function
and architecture: its status, reason, cycles and error as executed before and after, the budget),
`shader.patch` (the file's unified diff replacing the derived functions' bodies; `git apply` or
`patch -p1` from the folder the path is relative to), `report.md` and `report.html` (per function:
its status, its expression before and after, its cycles, errors and FLIP per architecture, its
branch's pieces; the page `shader_page`'s) and, per derived function, its derivation's own files
under `functions/NAME/` (each piece of its branch under `functions/NAME_pieceK/`; their pages linked
from the run's). The user's file is never written."""

from __future__ import annotations

import csv
import io
import json
import os
from pathlib import Path

from ...engine import escape

COLUMNS = ("file", "function", "status", "reason", "architecture", "cycles_before", "cycles_after", "error_before",
           "error_after", "max_error", "metric", "flip_before", "flip_after", "calls")


def function_rows(path: Path, outcomes) -> list[dict]:
    """functions.csv's rows: per function and architecture asked for; a refused function one row."""
    rows = []
    for o in outcomes:
        base = dict(file=str(path), function=o.name, status=o.status, reason=o.reason, max_error=o.budget,
                    metric=o.metric, calls=o.calls)
        if not o.rows:
            rows.append(base | dict(architecture="", cycles_before=None, cycles_after=None, error_before=None,
                                    error_after=None, flip_before=None, flip_after=None))
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


def patch_text(path: Path, outcomes, keep_reference: bool = False, shown: str | None = None) -> str:
    """The unified diff of the file with each derived function's body its replacement (empty where
    none was derived), the file named `shown` (default `shown_path`)."""
    from ...shaders import patch

    source = Path(path).read_bytes()
    bodies = {o.definition: o.expression for o in outcomes if o.status == "derived"}
    return patch.unified_diff(shown or shown_path(path), source,
                              patch.replaced(source, bodies, keep_reference)) if bodies else ""


def report(path: Path, outcomes, language: str) -> str:
    """report.md of a shader file's run."""
    from .shader_page import function_data

    counts = {s: sum(o.status == s for o in outcomes) for s in ("derived", "none cheaper", "refused")}
    lines = [f"# {escape.markdown(Path(path).name)}: its functions derived", "",
             f"{len(outcomes)} functions of {escape.code(str(path))} ({language.upper()}): "
             + ", ".join(f"{n} {s}" for s, n in counts.items()) + ". The file is unchanged; `shader.patch` replaces "
             "the derived functions' bodies.", ""]
    for o in outcomes:
        f = function_data(o, language)
        lines += [f"## {escape.markdown(o.name)} (line {o.line}): {o.status}", ""]
        if o.reason:
            lines += [escape.markdown(o.reason), ""]
        if f["checked"]:
            lines += [f"Read as the compiler means it and {f['checked']}.", ""]
        if o.results is not None:
            lines += [f"- As shipped: {escape.code(f['read'])}"]
            if o.replacement:
                lines += [f"- Replacement ({escape.markdown(o.replacement)}): {escape.code(o.expression)}"]
            lines += [f"- Budget: {o.metric} {o.budget:.3g} (as executed)",
                      f"- Its derivation: [{f['page']}]({f['page']})", ""]
            flips = any(r["flip_before"] is not None for r in o.rows)
            lines += ["| architecture | cycles before | cycles after | error before | error after |"
                      + (" FLIP before | FLIP after |" if flips else ""), "|---|---|---|---|---|" + "---|---|" * flips]
            lines += [f"| {r['architecture']} | {r['cycles_before']:g} | {r['cycles_after']:g} | {r['error_before']:.3g} | "
                      f"{r['error_after']:.3g} |" + (f" {r['flip_before']:.3g} | {r['flip_after']:.3g} |" if flips else "")
                      for r in o.rows]
            lines.append("")
        if o.platforms:
            lines += ["Per platform, the one form every architecture of it runs (the least worst cycles within the "
                      "budget), and what a variant per architecture would save:", "",
                      "| platform | form | worst cycles | error | cycles per architecture | a variant per architecture saves |",
                      "|---|---|---|---|---|---|"]
            for name, a in o.platforms.items():
                if a is None:
                    lines.append(f"| {escape.markdown(name)} | none within the budget | | | | |")
                    continue
                lines.append(f"| {escape.markdown(name)} | {escape.markdown(a['name'])} | {a['worst']:g} | {a['error']:.3g} | "
                             + ", ".join(f"{k} {c:g}" for k, c in a["cycles"].items()) + " | "
                             + (", ".join(f"{k} {c:g}" for k, c in a["variant_saving"].items() if c > 0) or "nothing")
                             + " |")
            lines.append("")
        if f["pieces"]:
            branch = f["branch"]
            lines += ["Its branch, each piece derived on the interval where it is taken"
                      + (f": {escape.markdown(o.pieces_reason)}" if o.pieces_reason else "") + "."
                      + (" The branch of the pieces' replacements, costed and measured whole: "
                         + ", ".join(f"{a} {c:g} cycles" for a, c in branch["cycles"].items())
                         + f"; error {branch['error']:.3g}" + (" (the replacement)." if o.replacement == branch["name"]
                                                               else ".") if branch else ""), "",
                      "| piece | taken | interval | as shipped | replacement | error before | error after |",
                      "|---|---|---|---|---|---|---|"]
            for p in f["pieces"]:
                interval = f"[{p['domain'][0]:.6g}, {p['domain'][1]:.6g}]" if p["domain"] else "(a point)"
                error = (f"{p['error']['before']:.3g} | {p['error']['after']:.3g}" if p["error"] else " | ")
                lines.append(f"| {p['index']} | {escape.code(p['where'])} | {interval} | {escape.code(p['shipped'])} | "
                             + (escape.code(p["form"]) if p["form"] else escape.markdown(p["reason"]))
                             + f" | {error} |")
            lines.append("")
    return "\n".join(lines)


def write_files(folder: Path, shown: Path, path: Path, outcomes, language: str, keep_reference: bool = False) -> None:
    """Every file of the module docstring into `folder` (a temporary folder being published as
    `shown`, which an error names)."""
    from ...engine import faults
    from .derive_files import write_kept
    from . import shader_page

    rows = function_rows(path, outcomes)
    patch = patch_text(path, outcomes, keep_reference)
    folder.mkdir(parents=True, exist_ok=True)
    text = io.StringIO()
    writer = csv.DictWriter(text, fieldnames=COLUMNS, lineterminator="\n")
    writer.writeheader()
    writer.writerows({k: ("" if v is None else v) for k, v in r.items()} for r in rows)
    for name, content in (("functions.csv", text.getvalue()), ("shader.patch", patch),
                          ("report.md", report(path, outcomes, language))):
        with faults.writing(shown / name):
            (folder / name).write_text(content)
    for o in outcomes:
        if o.results is not None:
            name = escape.folder_name(o.name)
            write_kept(folder / "functions" / name, o.results, shown / "functions" / name)
        for p in (p for p in o.pieces if p.results is not None):
            piece = f"{escape.folder_name(o.name)}_piece{p.index}"
            write_kept(folder / "functions" / piece, p.results, shown / "functions" / piece)
    with faults.writing(shown / "report.html"):
        shader_page.write(folder / "report.html", path, outcomes, language, patch)


def write(out: Path, path: Path, outcomes, language: str, keep_reference: bool = False, log=print) -> list[Path]:
    """Every file of the module docstring into `out`, published whole."""
    from ...engine.cache import digest
    from ...engine.publishing import publish
    from ...engine import web_page
    from .derive_files import results_json

    rows = function_rows(path, outcomes)
    patch = patch_text(path, outcomes, keep_reference)

    def write_all(tmp: Path) -> str:
        write_files(tmp, out, path, outcomes, language, keep_reference)
        return f"{len(outcomes)} functions"

    key = digest("derive shader", Path(path).read_text(errors="replace"), patch, json.dumps(rows, default=str),
                 report(path, outcomes, language), web_page.assets_digest(),
                 json.dumps([results_json(o.results) for o in outcomes if o.results], sort_keys=True, default=str))
    publish(out, key, log, write_all)
    return [out / n for n in ("functions.csv", "shader.patch", "report.md", "report.html")]
