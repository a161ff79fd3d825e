"""What `derive --shader DIR` (several files, a folder, a glob) writes, all at once: per file its
single-file run's files under `files/NAME/` (`shader_outputs`), `library.patch` (every file's diff in
one, applying with `git apply` from the working folder, or from the library's folder where it lies
outside it), `library.html` (the page of a file's run
over every function, sorted by saving, each opening its derivation's page), `library.md` and
`library.json` (per function its file, status, reason, and per architecture its cycles and error as
executed before and after; per function and platform `--gpu` names the form it ships there; the totals
per architecture and per platform, each function's cycles weighted by how many times a pixel calls it;
the cluster's workers and the wall time), `savings.png` (per platform each function's cycles before
and after)."""

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


def platform_rows(library: dict) -> list[dict]:
    """Per function and platform `--gpu` named: the form every architecture of the platform runs
    (`platform_answer`; None where none is within the budget), its worst cycles over them as shipped
    and of that form, each architecture's own cheapest, and what a variant per architecture would
    save; `calls` the function's weight."""
    out = []
    for path, outcomes in library.items():
        for o in outcomes:
            for name, answer in (o.platforms or {}).items():
                row = dict(file=str(path), function=o.name, platform=name, calls=o.calls, form=None,
                           cycles_before=None, cycles_after=None, error_after=None, own={}, variant_saving={})
                if answer is not None:
                    row.update(form=answer["name"], cycles_after=answer["worst"], error_after=answer["error"],
                               cycles_before=max(r["cycles_before"] for r in o.rows
                                                 if r["architecture"] in answer["cycles"]),
                               own={a: dict(form=n, cycles=c) for a, (n, c) in answer["own"].items()},
                               variant_saving=answer["variant_saving"])
                out.append(row)
    return out


def platform_totals(library_platform_rows: list[dict]) -> dict:
    """Per platform, over the functions it has an answer for (`platform_rows`): the worst cycles over
    its architectures of each function as shipped and of the platform's answer, each weighted by its
    `calls`, summed."""
    out: dict = {}
    for r in library_platform_rows:
        t = out.setdefault(r["platform"], dict(functions=0, cycles_before=0.0, cycles_after=0.0))
        if r["form"] is None:
            continue
        t["functions"] += 1
        t["cycles_before"] += r["calls"] * r["cycles_before"]
        t["cycles_after"] += r["calls"] * r["cycles_after"]
    return out


def report(library: dict, library_rows: list[dict], summed: dict, run: dict, per_platform: dict,
           library_platform_rows: list[dict]) -> str:
    """library.md."""
    counts = {s: sum(r["status"] == s for r in {(r["file"], r["function"]): r for r in library_rows}.values())
              for s in ("derived", "none cheaper", "refused")}
    lines = [f"# A shader library: {len(library)} files, {sum(counts.values())} functions", "",
             ", ".join(f"{n} {s}" for s, n in counts.items()) + f"; on {run['workers']} Dask workers"
             + ("" if run.get("local", True) else f" of the cluster at {escape.code(str(run.get('scheduler')))}")
             + f" in {run['seconds']:.0f} s. The files are unchanged; `library.patch` replaces the derived functions' bodies.",
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
    if library_platform_rows:
        lines += ["", "## Per platform, the form each function ships", "",
                  "The one form every architecture of the platform runs (the least worst cycles within the budget), "
                  "its worst cycles before and after, and what a variant per architecture would save.", "",
                  "| file | function | platform | form | worst cycles | error | a variant per architecture saves |",
                  "|---|---|---|---|---|---|---|"]
        for r in library_platform_rows:
            where = f"| {escape.markdown(Path(r['file']).name)} | {escape.markdown(r['function'])} | " \
                    f"{escape.markdown(r['platform'])} |"
            if r["form"] is None:
                lines.append(f"{where} none within the budget | | | |")
                continue
            saving = ", ".join(f"{a} {c:g}" for a, c in r["variant_saving"].items() if c > 0) or "nothing"
            lines.append(f"{where} {escape.markdown(r['form'])} | {r['cycles_before']:g} → {r['cycles_after']:g} | "
                         f"{r['error_after']:.3g} | {saving} |")
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
    library_platform_rows = platform_rows(library)
    per_platform = platform_totals(library_platform_rows)
    root = Path(os.path.commonpath([str(Path(p).parent) for p in library])) if library else Path(".")
    patch = "".join(shader_outputs.patch_text(path, outcomes, shown=patch_path(path, root))
                    for path, outcomes in library.items())

    def write_all(tmp: Path) -> str:
        for path, outcomes in library.items():
            if outcomes:
                folder = folder_of(path, root)
                shader_outputs.write_files(tmp / "files" / folder, out / "files" / folder, path, outcomes,
                                           languages[path])
        text = report(library, library_rows, summed, run, per_platform, library_platform_rows)
        folders = {path: folder_of(path, root) for path in library}
        page = shader_page.library_data(library, languages, folders, patch,
                                        dict(architectures=summed, platforms=per_platform))
        with faults.writing(out / "library.html"):
            (tmp / "library.html").write_text(web_page.page(page["title"], page))
        data = dict(run=run, totals=summed, platforms=per_platform, rows=library_rows,
                    platform_rows=library_platform_rows)
        for name, content in (("library.patch", patch), ("library.md", text),
                              ("library.json", json.dumps(data, indent=1, default=str))):
            with faults.writing(out / name):
                (tmp / name).write_text(content)
        with faults.writing(out / "savings.png"):
            savings_figure(tmp / "savings.png", library_platform_rows, library_rows)
        return f"{len(library_rows)} rows"

    key = digest("derive library", patch, json.dumps(library_rows, default=str), json.dumps(summed),
                 report(library, library_rows, summed, run, per_platform, library_platform_rows),
                 web_page.assets_digest(), json.dumps(library_platform_rows, default=str), FIGURE_VERSION,
                 *(shader_outputs.report(p, o, languages[p]) for p, o in library.items()),
                 json.dumps([results_json(o.results) for outcomes in library.values() for o in outcomes if o.results],
                            sort_keys=True, default=str))
    publish(out, key, log, write_all)
    return [out / n for n in ("library.md", "library.json", "library.html", "library.patch", "savings.png")]


FIGURE_VERSION = "savings 2"       # (a change of the figure's drawing: written again)


def savings_figure(path: Path, library_platform_rows: list[dict], library_rows: list[dict]) -> None:
    """savings.png: a panel per platform (per architecture where `--gpu` named none), a bar per
    function with an answer there, its cycles (times its calls) as shipped and after, sorted by
    saving; the panel's title the totals."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    panels: dict = {}
    if library_platform_rows:
        for r in library_platform_rows:
            if r["form"] is not None:
                panels.setdefault(r["platform"], []).append(r)
    else:
        for r in library_rows:
            if r["cycles_before"] is not None:
                panels.setdefault(r["architecture"], []).append(r)
    count = max(len(panels), 1)
    height = 1.2 + 0.28 * max((len(v) for v in panels.values()), default=1)
    fig, axes = plt.subplots(1, count, figsize=(5.2 * count, height), squeeze=False)
    for ax, (name, shown) in zip(axes[0], panels.items()):
        shown = sorted(shown, key=lambda r: r["calls"] * (r["cycles_after"] - r["cycles_before"]))[::-1]
        labels = [r["function"] + (f" ×{r['calls']:g}" if r["calls"] != 1 else "") for r in shown]
        before = [r["calls"] * r["cycles_before"] for r in shown]
        after = [r["calls"] * r["cycles_after"] for r in shown]
        y = range(len(shown))
        ax.barh([v + 0.2 for v in y], before, height=0.4, color="#b0b0b0", label="as shipped")
        ax.barh([v - 0.2 for v in y], after, height=0.4, color="#2a7ab0", label="after")
        ax.set_yticks(list(y), labels, fontsize=8)
        ax.set_xlabel("cycles × calls" + (" (worst over the platform)" if library_platform_rows else ""))
        ax.set_title(f"{name}: {sum(before):g} → {sum(after):g} cycles", fontsize=10)
        ax.legend(fontsize=7, loc="best")
    for ax in axes[0][len(panels):]:
        ax.set_axis_off()
        ax.text(0.5, 0.5, "no function with cycles", ha="center", va="center")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
