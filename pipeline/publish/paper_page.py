"""report.html of the paper's run: the page's data (`engine.web_page` draws it in the browser).
The checks against the paper (filterable by verdict and by how each holds); the decision per
architecture and n range, each cell opening that range's lobe front; the lobe search's fronts per
architecture and range (its families' members against compiled cycles, the registry's lobes
placed; each exported form running live on a lit sphere beside cos^n) and the decision's candidates (max d against cycles, the budget, the winner); the coef(n)
fit and the directional albedo redrawn as plots; every other figure of the run as an
image inside the file. Every number from the run's results.
"""

from __future__ import annotations

import base64
import math
import re
from pathlib import Path

import numpy as np

COEF_POINTS = 400           # n values of the coef(n) plot's curves (log-spaced)


def _num(v):
    v = float(v)
    return v if math.isfinite(v) else ("inf" if v > 0 else "-inf" if v < 0 else "nan")


def _range_text(r) -> str:
    return f"n in [{r[0]:g}, {r[1]:g}]"


def _text(value) -> str:
    """A check's value as a table shows it: numbers to 6 digits, a list's first six and how many more."""
    if value is None:
        return "-"
    if isinstance(value, bool):
        return str(value).lower()
    if isinstance(value, float | int):
        return f"{value:.6g}"
    if isinstance(value, list | tuple | np.ndarray):
        values = [_text(v) for v in list(value)]
        return ", ".join(values[:6]) + (f", ... ({len(values)} values)" if len(values) > 6 else "")
    return str(value)


def _checks(checks) -> list[dict]:
    """Each check as report.md's table has it, and how a pass holds (independently or by construction)."""
    out = []
    for c in checks:
        e = c.expectation
        held = ("independently" if e.agreement == "independent" else "by construction") if c.verdict == "pass" else ""
        out.append(dict(id=e.id, quantity=e.quantity, paper=_text(e.paper), reproduced=_text(c.reproduced),
                        tolerance=("<= paper + " if e.compare == "at_most" else "± ") + f"{e.tolerance:.3g}",
                        verdict=c.verdict, held=held, reason=e.known_difference or e.reason or ""))
    return out


def _architectures(names) -> list[dict]:
    from ..isa.architectures import ARCHITECTURES, VENDORS
    from ..isa.machine_code import backend

    return [dict(name=a, title=ARCHITECTURES[a].title, vendor=ARCHITECTURES[a].vendor,
                 vendor_title=VENDORS[ARCHITECTURES[a].vendor], cost_model=backend(a).UNIT)
            for a in ARCHITECTURES if a in names]


def _lobe_fronts(r) -> dict:
    """{architecture: {range text: [point]}}: the lobe search's members (kind found) and the registry's
    lobes placed on the front (kind anchor), their max d against compiled cycles."""
    search = r.get("lobe_search") or {}
    out: dict = {}
    for c in search.get("candidates", []):
        key = _range_text(c["n_range"])
        name = c.get("grammar") or c["family"]
        out.setdefault(c["architecture"], {}).setdefault(key, []).append(dict(
            name=name, kind="found", cycles=_num(c["cycles"]), error=_num(c["d"]), on_front=bool(c["on_front"]),
            expression=str(c.get("formula") or c.get("expression") or name), front="", n_range=list(c["n_range"])))
    for p in search.get("placements", []):
        key = _range_text(p["n_range"])
        out.setdefault(p["architecture"], {}).setdefault(key, []).append(dict(
            name=p["label"], kind="exact" if p["lobe"] == "f_b" else "anchor", cycles=_num(p["cycles"]), error=_num(p["d"]), on_front=bool(p["on_front"]),
            expression=p["lobe"], front=""))
    return out


def _lobe_functions(out_dir: Path) -> dict[str, str]:
    """{function name: its whole text} of shader/lobe_search.glsl (the lobe search's exported forms,
    each of t = cos x and n), for the live sphere; {} where the run wrote none."""
    path = out_dir / "shader" / "lobe_search.glsl"
    if not path.exists():
        return {}
    functions, lines = {}, path.read_text().splitlines()
    for i, line in enumerate(lines):
        match = re.match(r"float (cosfit_\w+)\(float t, float n\)$", line)
        if match:
            end = next(j for j in range(i, len(lines)) if lines[j] == "}")
            functions[match.group(1)] = "\n".join(lines[i:end + 1])
    return functions


def function_of(name: str, n_range) -> str:
    """The exported function of a lobe search form over a range: cosfit_<form>_n<lo>_<hi>."""
    return f"cosfit_{name}_n{n_range[0]:g}_{n_range[1]:g}"


def _decision(r) -> dict:
    decision = r.get("decision") or {}
    rows = []
    for t in decision.get("table", []):
        rows.append(dict(architecture=t["architecture"], range=_range_text(t["n_range"]), use=t["use"], n_per=t["n_per"],
                         precision=t["precision"], winner=t.get("winner") or "", runner_up=t.get("runner_up") or "",
                         reason=t.get("reason") or "",
                         cycles=_num(t["winner_cycles"]) if t.get("winner_cycles") is not None else None,
                         d=_num(t["winner_d"]) if t.get("winner_d") is not None else None))
    return dict(available=bool(decision.get("available")), reason=decision.get("reason") or "",
                rule=decision.get("rule") or "", rows=rows)


def _coef_plot(config, r) -> dict | None:
    """Fig. 10 as data: the ideal normalization y(n) (at COEF_POINTS log-spaced n), the sample, the
    run's fit, the coef the run uses, the paper's 0.214 (0.807 + n), and each line's relative
    residual against y(n) (> 0: energy created)."""
    from ..engine.exponents import n_range

    if not all(k in r for k in ("energy_dataset", "sparse_regression", "hemispherical", "sample")):
        return None
    n_all = n_range(config.values)
    y_all = np.asarray(r["energy_dataset"]["y"], dtype=np.float64)
    keep = np.unique(np.geomspace(1, n_all.size, min(COEF_POINTS, n_all.size)).astype(int) - 1)
    n, y = n_all[keep], y_all[keep]
    s, h = r["sparse_regression"], r["hemispherical"]
    lines = [(f"fit {s['coef_scale']:.6f} ({s['coef_offset']:.6f} + n)", s["coef_scale"], s["coef_offset"]),
             (f"used {h['coef_scale_used']:.6g} ({h['coef_offset_used']:.6g} + n)", h["coef_scale_used"],
              h["coef_offset_used"])]
    curves = [dict(name="y(n), the ideal normalization", n=n.tolist(), coef=y.tolist(), residual=None)]
    for name, scale, offset in lines:
        value = float(scale) * (float(offset) + n)
        curves.append(dict(name=name, n=n.tolist(), coef=value.tolist(), residual=(100 * (value / y - 1)).tolist()))
    return dict(curves=curves, sample=dict(n=np.asarray(r["sample"]["sample_n"], dtype=np.float64).tolist(),
                                           y=np.asarray(r["energy_dataset"]["sample_y"], dtype=np.float64).tolist()))


ALBEDO_VARIANTS = {"phong_run_coef": "Phong form, the run's coef", "phong_exact_coef": "Phong form, the exact coef",
                   "blinn_exact_coef": "Blinn form (t = N.H), its exact coef",
                   "blinn_asymptotic_coef": "Blinn form, its asymptotic coef",
                   "blinn_with_phong_coef": "Blinn form with the Phong coef"}


def _albedo(r) -> dict | None:
    """The directional albedo at each incidence angle (degrees) for each drawn n, per form and coef."""
    a = r.get("directional_albedo")
    if not a or "theta" not in a:
        return None
    theta = np.degrees(np.asarray(a["theta"], dtype=np.float64))
    keep = np.unique(np.linspace(0, theta.size - 1, min(theta.size, 91)).round().astype(int))
    curves = {label: np.asarray(a[f"{v}_curves"], dtype=np.float64)[:, keep].round(6).tolist()
              for v, label in ALBEDO_VARIANTS.items() if f"{v}_curves" in a}
    return dict(theta=theta[keep].round(3).tolist(), n=np.asarray(a["curve_n"], dtype=np.float64).tolist(), curves=curves)


def _candidates(r) -> dict:
    """The decision's lobe candidates per range: name, label, kind (reference, registry, power,
    search), max d and cycles per architecture; and the budget max d."""
    decision = r.get("decision") or {}
    out: dict = {}
    for m in decision.get("candidates", []):
        if m.get("use") != "lobe":
            continue
        out.setdefault(_range_text(m["n_range"]), []).append(dict(
            name=m["name"], label=m.get("label") or m["name"], kind=m.get("kind", ""), d=_num(m["d"]),
            cycles={a: _num(c) for a, c in m.get("cycles", {}).items()}))
    return dict(by_range=out, max_d=(decision.get("budgets") or {}).get("max_d"))


def _images(out_dir: Path, drawn) -> list[dict]:
    """Every drawn figure but those the page redraws, as PNG data for an <img> inside the page."""
    redrawn = {"lobe_front.png", "fig10_coef_fit.png", "error_cost_front.png", "directional_albedo.png"}
    images = []
    for group in drawn.values():
        for file, caption in group:
            if file in redrawn or not (out_dir / file).exists():
                continue
            images.append(dict(file=file, caption=caption,
                               png=base64.b64encode((out_dir / file).read_bytes()).decode("ascii")))
    return images


def data(config, doc, results, checks, out_dir: Path, drawn) -> dict:
    """The page's data (module docstring)."""
    fronts = _lobe_fronts(results)
    functions = _lobe_functions(out_dir)
    for by_range in fronts.values():
        for points in by_range.values():
            for p in points:
                if p["kind"] == "found" and function_of(p["name"], p["n_range"]) in functions:
                    p["function"] = function_of(p["name"], p["n_range"])
    checks_rows = _checks(checks)
    counts = {}
    for c in checks_rows:
        key = c["verdict"] if c["verdict"] != "pass" else f"pass ({c['held']})"
        counts[key] = counts.get(key, 0) + 1
    search = results.get("lobe_search") or {}
    return dict(
        kind="paper",
        title=f"{config.name}: the cosine-quadratic lobe's derivation reproduced",
        summary=[["configuration", doc.get("config_file") or config.name],
                 ["checks", ", ".join(f"{v} {k}" for k, v in counts.items())],
                 ["architectures", ", ".join(fronts) or "none compiled here"]],
        checks=checks_rows,
        decision=_decision(results),
        architectures=_architectures(fronts),
        ranges=[_range_text(r) for r in search.get("ranges", [])],
        fronts=fronts,
        coef=_coef_plot(config, results),
        albedo=_albedo(results),
        candidates=_candidates(results),
        images=_images(out_dir, drawn),
        lobe_functions=functions,
        per_n=_per_n(results),
    )


def _per_n(r) -> dict | None:
    """Each lobe-search form's per-n optimum: max d at each n of the search's grid (`lobe_search.per_n`),
    beside which the page draws the shipped line's max d over the range."""
    search = r.get("lobe_search") or {}
    grid = search.get("n_grid")
    if grid is None or not search.get("per_n"):
        return None
    return dict(n=np.asarray(grid, dtype=np.float64).tolist(),
                d={row["family"]: [_num(v) for v in np.asarray(row["d"], dtype=np.float64)] for row in search["per_n"]})


def write(path: Path, config, doc, results, checks, drawn) -> None:
    """report.html at `path` (beside the figures it embeds)."""
    from ..engine import web_page

    page = data(config, doc, results, checks, path.parent, drawn)
    path.write_text(web_page.page(page["title"], page))
