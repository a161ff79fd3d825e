"""summary.md: the adopter's answer in one screen, also at the top of report.md.

Written from the `decision` stage's table alone (`pipeline.stages.decision`: its rule, budgets and
winners): the answer per architecture and range of n for the common case (the Phong or Blinn lobe,
n per material, fp32), the scenarios whose answer differs (n per pixel, fp16, the NDF), and the facts
that change the answer, ranked by how many of the common case's scenarios they change. No verdict is
written here: every word that says which lobe to use comes from a row's winner or reason, and every
number is a field of the run's results (results.json).
"""

from __future__ import annotations

from ..engine import escape
from ..isa import machine_code
from ..isa.architectures import ARCHITECTURES, VENDORS
from .report_beyond import at_power

USE_NAMES = {"phong": "Phong lobe (t = R.V)", "blinn": "Blinn lobe (t = N.H)", "ndf": "microfacet NDF (against Beckmann)"}


def _range(r) -> str:
    return f"[{r[0]:g}, {r[1]:g}]"


def _pct(x: float) -> str:
    return f"{100 * x:.3g} %"


def _winner(rows) -> str:
    """The winner of scenarios that share it (one per architecture of a group) in a few words: its
    cycles over the group (a range where they differ), or that nothing qualifies."""
    row = rows[0]
    if not row["winner"]:
        return "nothing qualifies" if row["reason"].startswith(("nothing", "in float16")) else "not decided"
    route = {"u": ", u route", "t": ", t route"}.get(row["winner_fp16_route"], "")
    lo, hi = min(r["winner_cycles"] for r in rows), max(r["winner_cycles"] for r in rows)
    cycles = f"{lo:g}" if lo == hi else f"{lo:g}-{hi:g}"
    return f"{row['winner']}: {cycles} cycles, max d {_pct(max(r['winner_d'] for r in rows))}{route}"


def _rows(table, **where):
    return [r for r in table if all(r[k] == v for k, v in where.items())]


def _scenarios(table, architectures, n_range, n_per, precision, uses) -> dict[str, list[dict]]:
    """{use: its rows on `architectures`} of one range, place of n and precision."""
    out: dict[str, list[dict]] = {}
    for r in table:
        if (r["architecture"] in architectures and r["n_range"] == n_range and r["use"] in uses
                and r["n_per"] == n_per and r["precision"] == precision):
            out.setdefault(r["use"], []).append(r)
    return out


def _cell(table, group, n_range, n_per="material", precision="fp32", uses=("phong", "blinn")) -> str:
    """The winners of the given uses on a group of architectures in one table cell: one text when
    the uses agree; per architecture where the group's own winners differ."""
    scenarios = _scenarios(table, group, n_range, n_per, precision, uses)
    if any(len({r["winner"] for r in rows}) > 1 for rows in scenarios.values()):
        return "; ".join(f"{a} {_cell(table, [a], n_range, n_per, precision, uses)}" for a in group)
    texts = {use: _winner(rows) for use, rows in scenarios.items()}
    if len(set(texts.values())) == 1:
        return next(iter(texts.values()))
    return "; ".join(f"{use}: {text}" for use, text in texts.items())


def groups(table, architectures, ranges) -> list[list[str]]:
    """The architectures in groups: consecutive architectures of one vendor whose common-case winners
    (Phong and Blinn lobes, n per material, fp32) agree on every range; one group each otherwise."""
    def answer(a):
        return [(r["use"], r["winner"]) for n_range in ranges
                for rows in _scenarios(table, [a], list(n_range), "material", "fp32", ("phong", "blinn")).values()
                for r in rows]
    out: list[list[str]] = []
    for a in architectures:
        if out and ARCHITECTURES[out[-1][0]].vendor == ARCHITECTURES[a].vendor and answer(out[-1][0]) == answer(a):
            out[-1].append(a)
        else:
            out.append([a])
    return out


def group_name(group) -> str:
    """A group of architectures as its vendor and names: "NVIDIA sm_120 to sm_75", "AMD rdna3"."""
    vendor = VENDORS.get(ARCHITECTURES[group[0]].vendor, "") if group[0] in ARCHITECTURES else ""
    names = group[0] if len(group) == 1 else f"{group[0]}, {group[1]}" if len(group) == 2 else f"{group[0]} to {group[-1]}"
    return f"{vendor} {names}".strip()


def fact_text(fact, decision) -> str:
    """One fact of `decision.facts` in a sentence, from its fields."""
    count, of = fact["count"], fact["of"]
    if not fact["changed"]:
        return ""
    first = fact["changed"][0]
    where = f"{first['architecture']}, n in {_range(first['n_range'])}, {first['use']}"
    if fact["fact"] == "n_per_pixel":
        return (f"**n per pixel** (the coef computed in the shader) changes {count} of {of}: e.g. {where}: "
                f"{first['before']} ({first['before_cycles']:g} cycles) gives way to {first['after']} "
                f"({first['after_cycles']:g} cycles, coef included).")
    if fact["fact"] == "exp_class":
        after = first["after"] or "nothing"
        return (f"**The spherical Gaussian's class** (exp or exp2 of a function of t) decides {count} of {of}: "
                f"without it, e.g. {where}, the answer would be {after} at {first['after_cycles']:g} cycles "
                f"instead of {first['before']} at {first['before_cycles']:g}.")
    if fact["fact"] == "normalized_peak":
        return (f"**The normalized peak** differs from cos^n's by more than max d in {count} of {of}: e.g. {where}: "
                f"{first['after']}'s peak, each normalized exactly, is {first['peak_ratio']:.3f}x cos^n's; a material "
                f"switched to it keeps its highlight's peak with its specular colour scaled by "
                f"{first['retune_scale']:.3f} (its albedo then that much more or less than 1), or by retuning n.")
    if fact["fact"] == "fp16":
        return (f"**Half precision** changes {count} of {of}: e.g. {where}: {first['after'] or 'nothing qualifies'} "
                f"instead of {first['before']} ({first['reason']}).")
    return ""


def fp16_execution(d) -> str:
    """How the fp16 errors were computed, and how many fp16 answers differ from the emulated errors'."""
    changed = d.get("fp16_changed_by_execution", [])
    executed = "lavapipe" in d.get("fp16_executed_by", "")
    return (f" (Float16 errors {'as lavapipe executes each candidate' if executed else 'by the emulation'}: "
            + (f"{len(changed)} fp16 answer{'s' * (len(changed) != 1)} differ{'s' * (len(changed) == 1)} from the "
               "emulated errors', in `decision.fp16_changed_by_execution`.)" if changed and executed else
               "no fp16 answer differs from the emulated errors'.)" if executed else "lavapipe did not run.)"))


def lines(config, results) -> list[str]:
    d = results["decision"]
    out = ["## Summary: which specular lobe to use, per GPU and range of n", ""]
    question = f"**Question.** {escape.markdown(config['run.question'])} " if config["run.question"] else ""
    out += [f"{question}**Rule** (`decision.*`): {d['rule']}. Candidates: cos^n, the registry's lobes, the family's "
            "powers and the lobe search's forms with their parameters as lines in n (`shader/lobe_search.glsl`).", ""]
    if not d["available"]:
        return out + [f"**No answer**: machine-code cost not measured ({d['reason']}), so no scenario is decided.", ""]
    table = d["table"]
    architectures = list(dict.fromkeys(r["architecture"] for r in table))
    ranges = list(dict.fromkeys(tuple(r["n_range"]) for r in table))
    widest = list(max(ranges, key=lambda r: r[1] - r[0]))
    grouped = groups(table, architectures, ranges)
    out += ["**The answer** for the common case (Phong or Blinn lobe, n per material, fp32; cycles by each "
            f"vendor's model: {machine_code.models_text(architectures)}; the largest max d over the range; "
            "architectures of one vendor share a row where their winners agree):", "",
            "| GPU | " + " | ".join(f"n in {_range(r)}" for r in ranges) + " |",
            "|---|" + "---|" * len(ranges)]
    for group in grouped:
        out.append(f"| {group_name(group)} | " + " | ".join(_cell(table, group, list(r)) for r in ranges) + " |")
    out += ["", f"**Where it differs** (n in {_range(widest)}; fp16 routes: u = 1 - N.H from the cross product, as "
            "`cosquad_u`, or t = N.H in float16; every scenario's reason is in `decision.table`):", ""]
    for label, kwargs in (("n per pixel, fp32", dict(n_per="pixel")), ("n per material, fp16", dict(precision="fp16")),
                          ("n per pixel, fp16", dict(n_per="pixel", precision="fp16")),
                          ("NDF, n per material, fp32", dict(uses=("ndf",))),
                          ("NDF, n per pixel, fp32", dict(uses=("ndf",), n_per="pixel"))):
        cells = [f"{group_name(group)} {_cell(table, group, widest, **kwargs)}" for group in grouped]
        out.append(f"- {label}: " + "; ".join(cells) + "." + (fp16_execution(d) if label == "n per material, fp16" else ""))
    seen = results.get("lobe_renders")
    if seen and seen["table"]:
        out.append(f"- As seen (`lobe_renders`: Blinn, n per material, fp32, each lobe rendered on material balls against "
                   f"cos^n; {seen['rule']}): the cheapest invisible candidate differs from the answer in "
                   f"{seen['differs']} of {len(seen['table'])} scenarios"
                   + (" (the report's section \"The decision's lobes as seen\")." if seen["differs"] else "."))
    changing = [f for f in d["facts"] if f["count"]]
    still = [f["fact"] for f in d["facts"] if not f["count"]]
    none = "; none of them: " + ", ".join(s.replace("_", " ") for s in still) if still else ""
    out += ["", f"**What changes the answer**, most first (scenarios of the common case it changes{none}):", ""]
    out += [f"{i}. {fact_text(f, d)}" for i, f in enumerate(changing, 1)]
    return out + [""]


def write(path, config, results) -> list[str]:
    """Writes summary.md; returns its lines as written before `at_power` (report.md applies it once)."""
    text = lines(config, results)
    path.write_text(at_power("\n".join(text), config["lobe.power"]))
    return text
