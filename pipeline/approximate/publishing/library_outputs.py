"""What `derive --shader DIR` (several files, a folder, a glob) writes, all at once: per file its
single-file run's files under `files/NAME/` (`shader_outputs`), `library.patch` (every file's diff in
one, applying with `git apply` from the working folder, or from the library's folder where it lies
outside it), `library.html` (the page of a file's run
over every function, sorted by saving, each opening its derivation's page), `library.md` and
`library.json` (per function its file, status, reason, and per architecture its cycles and error as
executed before and after; the totals per architecture and per platform `--gpu` names, each function's cycles weighted by
how many times a pixel calls it; the cluster's workers and the wall time)."""

from __future__ import annotations

import json
import os
from pathlib import Path

from ...engine import escape
from . import shader_outputs


def rows(library: dict) -> list[dict]:
    """functions.csv's rows of every file, in file order."""
    return [r for path, outcomes in library.items() for r in shader_outputs.function_rows(path, outcomes)]


def totals(library_rows: list[dict]) -> dict:
    """Per architecture, the cycles before and after summed over the functions derived or none cheaper
    (a refused function has no cycles), each weighted by how many times a pixel calls it (`calls`)."""
    out: dict = {}
    for r in library_rows:
        if r["cycles_before"] is None:
            continue
        t = out.setdefault(r["architecture"], dict(functions=0, cycles_before=0.0, cycles_after=0.0))
        t["functions"] += 1
        t["cycles_before"] += r["calls"] * r["cycles_before"]
        t["cycles_after"] += r["calls"] * r["cycles_after"]
    return out


def platform_totals(library: dict) -> dict:
    """Per platform `--gpu` named, over the functions it has an answer for: the worst cycles over its
    architectures of each function as shipped and of the platform's answer (`platform_answer`), each
    weighted by its `calls`, summed."""
    out: dict = {}
    for outcomes in library.values():
        for o in outcomes:
            for name, answer in (o.platforms or {}).items():
                t = out.setdefault(name, dict(functions=0, cycles_before=0.0, cycles_after=0.0))
                if answer is None:
                    continue
                shipped = max(r["cycles_before"] for r in o.rows if r["architecture"] in answer["cycles"])
                t["functions"] += 1
                t["cycles_before"] += o.calls * shipped
                t["cycles_after"] += o.calls * answer["worst"]
    return out


def report(library: dict, library_rows: list[dict], summed: dict, run: dict, per_platform: dict) -> str:
    """library.md."""
    counts = {s: sum(r["status"] == s for r in {(r["file"], r["function"]): r for r in library_rows}.values())
              for s in ("derived", "none cheaper", "refused")}
    lines = [f"# A shader library: {len(library)} files, {sum(counts.values())} functions", "",
             ", ".join(f"{n} {s}" for s, n in counts.items()) + f"; on {run['workers']} Dask workers in "
             f"{run['seconds']:.0f} s. The files are unchanged; `library.patch` replaces the derived functions' bodies.",
             "", "## Totals per architecture", "",
             "Cycles summed over the functions, each times the calls a pixel makes of it (`calls=`, 1 by default).", "",
             "| architecture | functions | cycles before | cycles after |", "|---|---|---|---|"]
    lines += [f"| {a} | {t['functions']} | {t['cycles_before']:g} | {t['cycles_after']:g} |" for a, t in summed.items()]
    if per_platform:
        lines += ["", "## Totals per platform", "",
                  "Per function, its worst cycles over the platform's architectures as shipped and of the one form "
                  "they all run (the least worst within the budget), times its calls, summed.", "",
                  "| platform | functions | cycles before | cycles after |", "|---|---|---|---|"]
        lines += [f"| {escape.markdown(p)} | {t['functions']} | {t['cycles_before']:g} | {t['cycles_after']:g} |"
                  for p, t in per_platform.items()]
    lines += ["", "## Every function", "", "| file | function | status | architecture | cycles | error | reason |",
              "|---|---|---|---|---|---|---|"]
    for r in library_rows:
        cycles = f"{r['cycles_before']:g} → {r['cycles_after']:g}" if r["cycles_before"] is not None else ""
        error = f"{r['error_before']:.3g} → {r['error_after']:.3g}" if r["error_before"] is not None else ""
        lines.append(f"| {escape.markdown(Path(r['file']).name)} | {escape.markdown(r['function'])} | {r['status']} | "
                     f"{r['architecture']} | {cycles} | {error} | {escape.markdown(r['reason'])} |")
    return "\n".join(lines) + "\n"


def patch_path(path: Path, root: Path) -> str:
    """A file as library.patch names it: relative to the working folder where the library lies under
    it, else to the library's common folder (`git apply` or `patch -p1` from there)."""
    resolved = Path(path).resolve()
    base = Path.cwd() if resolved.is_relative_to(Path.cwd()) and root.resolve().is_relative_to(Path.cwd()) else root
    return Path(os.path.relpath(resolved, base.resolve())).as_posix()


def folder_of(path: Path, root: Path) -> str:
    """A file's folder under files/: its path below the library's common folder, as one name."""
    try:
        relative = Path(path).relative_to(root)
    except ValueError:
        relative = Path(Path(path).name)
    return escape.folder_name(str(relative).replace("/", "__"))


def write(out: Path, library: dict, languages: dict, run: dict, log=print) -> list[Path]:
    """Every file of the module docstring into `out` (`languages`: {path: glsl or hlsl}; `run`: the
    cluster's workers and the wall time)."""
    from ...engine import faults, web_page
    from ...engine.cache import digest
    from ...engine.publishing import publish
    from .derive_files import results_json
    from . import shader_page

    library_rows = rows(library)
    summed = totals(library_rows)
    per_platform = platform_totals(library)
    root = Path(os.path.commonpath([str(Path(p).parent) for p in library])) if library else Path(".")
    patch = "".join(shader_outputs.patch_text(path, outcomes, shown=patch_path(path, root))
                    for path, outcomes in library.items())

    def write_all(tmp: Path) -> str:
        for path, outcomes in library.items():
            if outcomes:
                folder = folder_of(path, root)
                shader_outputs.write_files(tmp / "files" / folder, out / "files" / folder, path, outcomes,
                                           languages[path])
        text = report(library, library_rows, summed, run, per_platform)
        folders = {path: folder_of(path, root) for path in library}
        page = shader_page.library_data(library, languages, folders, patch,
                                        dict(architectures=summed, platforms=per_platform))
        with faults.writing(out / "library.html"):
            (tmp / "library.html").write_text(web_page.page(page["title"], page))
        for name, content in (("library.patch", patch), ("library.md", text),
                              ("library.json", json.dumps(dict(run=run, totals=summed, platforms=per_platform, rows=library_rows), indent=1,
                                                          default=str))):
            with faults.writing(out / name):
                (tmp / name).write_text(content)
        return f"{len(library_rows)} rows"

    key = digest("derive library", patch, json.dumps(library_rows, default=str), json.dumps(summed),
                 report(library, library_rows, summed, run, per_platform), web_page.assets_digest(),
                 *(shader_outputs.report(p, o, languages[p]) for p, o in library.items()),
                 json.dumps([results_json(o.results) for outcomes in library.values() for o in outcomes if o.results],
                            sort_keys=True, default=str))
    publish(out, key, log, write_all)
    return [out / n for n in ("library.md", "library.json", "library.html", "library.patch")]
