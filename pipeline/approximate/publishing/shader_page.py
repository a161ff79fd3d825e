"""report.html of a `derive --shader FILE` run: the page's data (`engine.web_page` draws it with the
derive pages' code and style). Per function: its status and reason, the function as the compiler
reads it and its replacement in the file's language, the budget, its cycles before and after on
every architecture with its error as executed before and after and its FLIP where it has a role, its
branch's pieces where it has one, and a link to its own derive page (`functions/NAME/report.html`);
the cycles before and after drawn per architecture; the patch.
"""

from __future__ import annotations

from pathlib import Path

from ...engine import escape
from ..engines.pieces import PIECES
from ..engines.shader_file import DERIVED, NONE_CHEAPER, REFUSED, in_arguments
from ..targets.reading import SHIPPED


def text_of(expression, language: str, precision: str | None) -> str:
    """An expression in a function's arguments as the file's language writes it."""
    from ..forms import _GLSL, _HLSL, NoShaderForm, printed

    try:
        return printed(_HLSL() if language == "hlsl" else _GLSL(), expression, precision)
    except NoShaderForm as e:
        return f"({e})"


def _pieces(o, language: str) -> list[dict]:
    precision = (o.results or {}).get("precision")
    out = []
    for p in o.pieces:
        error = None
        if p.results is not None:
            key = p.results["error"]
            error = dict(before=p.results["members"][SHIPPED][key],
                         after=p.results["members"][p.chosen or SHIPPED][key])
        page = f"functions/{escape.folder_name(o.name)}_piece{p.index}/report.html" if p.results else None
        out.append(dict(index=p.index, where=p.where, argument=p.argument, page=page,
                        domain=list(p.domain) if p.domain else None, shipped=text_of(p.shipped, language, precision),
                        chosen=p.chosen, form=text_of(p.form, language, precision) if p.chosen else None,
                        reason=p.reason, error=error,
                        cycles={a: dict(before=p.results["cycles"][a][SHIPPED],
                                        after=p.results["cycles"][a][p.chosen or SHIPPED])
                                for a in p.results["architectures"]} if p.results else None))
    return out


def _branch(o) -> dict | None:
    """The branch of the pieces' replacements as the whole function's derivation costed and measured
    it (its cycles per architecture, its error), where there is one."""
    if o.results is None or PIECES not in o.results["members"]:
        return None
    return dict(name=PIECES, error=o.results["members"][PIECES][o.results["error"]],
                cycles={a: o.results["cycles"][a].get(PIECES) for a in o.results["architectures"]})


def function_data(o, language: str) -> dict:
    """One function's part of the page's data."""
    shipped = None
    if o.results is not None:
        shipped = text_of(in_arguments(o.results["forms"][SHIPPED].expression,
                                       [p.name for p in o.definition.parameters]), language,
                          o.results.get("precision"))
    checked = None
    if o.check is not None:
        checked = f"executed beside it: {o.check.how}" + (f", {o.check.inputs} inputs, the same to the last bit"
                                                          if o.check.checked and o.check.mismatch is None else "")
    return dict(name=o.name, line=o.line, status=o.status, reason=o.reason, read=shipped, checked=checked,
                replacement=o.replacement, expression=o.expression, budget=o.budget, metric=o.metric, rows=o.rows,
                saving=sum(r["cycles_before"] - r["cycles_after"] for r in o.rows) if o.status == DERIVED else 0,
                page=f"functions/{escape.folder_name(o.name)}/report.html" if o.results is not None else None,
                pieces=_pieces(o, language), pieces_reason=o.pieces_reason, branch=_branch(o), platforms=o.platforms)


def data(path: Path, outcomes, language: str, patch: str) -> dict:
    """The page's data (the module docstring)."""
    architectures = list(dict.fromkeys(r["architecture"] for o in outcomes for r in o.rows))
    counts = {s: sum(o.status == s for o in outcomes) for s in (DERIVED, NONE_CHEAPER, REFUSED)}
    bars = [dict(function=o.name, architecture=r["architecture"], when=when, cycles=r[f"cycles_{when}"])
            for o in outcomes for r in o.rows for when in ("before", "after")]
    return dict(kind="shader", title=f"{Path(path).name}: its functions derived", file=str(path),
                language=language.upper(), architectures=architectures,
                counts=", ".join(f"{n} {s}" for s, n in counts.items()),
                functions=[function_data(o, language) for o in outcomes], bars=bars, patch=patch)


def library_data(library: dict, languages: dict, folders: dict, patch: str, totals: dict) -> dict:
    """library.html's data: the page of a file's run (`data`) over every function of the library, each
    named with its file, sorted by its saving (cycles before less after, summed over the
    architectures; the greatest first), its links into its file's folder (`folders`: {path: the
    folder under files/}); the totals per architecture and per platform as facts."""
    functions = []
    for path, outcomes in library.items():
        for o in outcomes:
            f = function_data(o, languages[path])
            f["name"] = f"{Path(path).name}: {o.name}"
            if f["page"]:
                f["page"] = f"files/{folders[path]}/{f['page']}"
            for p in f["pieces"]:
                p["page"] = p["page"] and f"files/{folders[path]}/{p['page']}"
            functions.append(f)
    functions.sort(key=lambda f: -f["saving"])
    counts = {s: sum(f["status"] == s for f in functions) for s in (DERIVED, NONE_CHEAPER, REFUSED)}
    bars = [dict(function=f["name"], architecture=r["architecture"], when=when, cycles=r[f"cycles_{when}"])
            for f in functions for r in f["rows"] for when in ("before", "after")]
    facts = [[f"total cycles, {a}", f"{t['cycles_before']:g} → {t['cycles_after']:g} ({t['functions']} functions, "
                                    "each times its calls)"] for a, t in totals["architectures"].items()]
    facts += [[f"total worst cycles, platform {p}", f"{t['cycles_before']:g} → {t['cycles_after']:g}"]
              for p, t in totals["platforms"].items()]
    return dict(kind="shader", title=f"A shader library: {len(library)} files, {len(functions)} functions",
                file=f"{len(library)} files", language=", ".join(sorted({v.upper() for v in languages.values()})),
                architectures=list(dict.fromkeys(b["architecture"] for b in bars)),
                counts=", ".join(f"{n} {s}" for s, n in counts.items()), totals=facts,
                functions=functions, bars=[b for b in bars if any(f["saving"] > 0 and f["name"] == b["function"]
                                                                  for f in functions)], patch=patch)


def write(page: Path, path: Path, outcomes, language: str, patch: str) -> None:
    """report.html at `page`."""
    from ...engine import web_page

    content = data(path, outcomes, language, patch)
    page.write_text(web_page.page(content["title"], content))
