"""The rendered comparison (`rendered`) in words and figures: report.md's section, `renders.png`
(the exact term's image, the anchors' and the FLIP front's, each beside its FLIP map) and
`rendered_front.png` (the largest FLIP against compiled cycles, one panel per vendor)."""

from __future__ import annotations

import math
import textwrap

import numpy as np

from ...engine import escape

SHOWN = 6                       # the FLIP front's members in renders.png (cheapest first, evenly chosen)


def _flip_text(v) -> str:
    return "-" if v is None else f"{v:.3g}"


def report_lines(results) -> list[str]:
    """report.md's section `As rendered`: every number a field of results.json's `rendered`."""
    r = results.get("rendered")
    if not r:
        return []
    lines = ["## As rendered", ""]
    if not r.get("role"):
        return lines + [f"Not rendered: {escape.markdown(r['why'])}.", ""]
    s = r["scene"]
    error = results["error"]
    lines += [f"Each form of the tables above replaces {escape.markdown(r['what'])}, in a scene of material balls "
              f"({len(s['roughness'])} roughness values from {s['roughness'][0]:.3g} to {s['roughness'][-1]:.3g}, a "
              f"dielectric (F0 0.04) and gold; {s['lights']}; {s['pixels'][1]} x {s['pixels'][0]} pixels; "
              f"{s['tone_map']}), every other factor exact; FLIP (flip-evaluator, LDR) against the exact term's image "
              f"over the spheres' pixels ({r['seconds']} s for all). The rule: {r['rule']} "
              f"({r['threshold']:.3g} here). The max-error budget: {r['budget']:.3g}, {r['budget_is']}.", "",
              "| architecture | cheapest invisible | cycles | largest FLIP | cheapest within the max-error budget | "
              "cycles | error |", "|---|---|---|---|---|---|---|"]
    for a, v in r["architectures"].items():
        seen, within = v["cheapest_invisible"], v["cheapest_within_budget"]
        least = v["least_flip"]
        lines.append(f"| {a} | " + (f"{escape.markdown(seen['name'])} ({seen['kind']}) | {seen['cycles']:g} | "
                                    f"{_flip_text(seen['flip'])}" if seen else
                                    "none; the least FLIP: " + (f"{escape.markdown(least['name'])} ({least['kind']}) | "
                                                                f"{least['cycles']:g} | {_flip_text(least['flip'])}"
                                                                if least else "- | - | -"))
                     + " | " + (f"{escape.markdown(within['name'])} ({within['kind']}) | {within['cycles']:g} | "
                                f"{within['error']:.3g} |" if within else "none | - | - |"))
    lines += ["", "The FLIP front of each architecture (the found forms no cheaper form renders closer; cycles, largest "
              "FLIP):", ""]
    for a, v in r["architectures"].items():
        rows = {x["name"]: x for x in results["rows"] if x["architecture"] == a}
        lines.append(f"- {a}: " + ("; ".join(f"{escape.markdown(name)} ({rows[name]['cycles']:g}, "
                                             f"{_flip_text(rows[name].get('flip_max'))})" for name in v["front"])
                                  or "no found form") + ".")
    verdicts = [(a, name, v, results["verdicts"].get(a, {}).get(name)) for a, x in r["architectures"].items()
                for name, v in x["anchors"].items()]
    if verdicts:
        lines += ["", "Each anchor by FLIP at its cycles (the found form of least FLIP at no more cycles; matched where "
                  "both are invisible or their FLIPs are within 1 %), beside its verdict by the largest error:", "",
                  "| architecture | anchor | cycles | its largest FLIP | verdict by FLIP | by | its FLIP | "
                  "verdict by error |", "|---|---|---|---|---|---|---|---|"]
        for a, name, v, by_error in verdicts:
            lines.append(f"| {a} | {escape.markdown(name)} | {v['cycles']:g} | {_flip_text(v['flip'])} | {v['verdict']} | "
                         f"{escape.markdown(v['by']) if v['by'] else '-'} | {_flip_text(v['rival_flip'])} | "
                         f"{by_error['verdict'] if by_error else '-'} |")
    lines += ["", f"front.csv gives each form's flip_mean, flip_p99 and flip_max; `renders.png` shows the images "
              f"and FLIP maps, `rendered_front.png` the largest FLIP against cycles ({error.replace('_', ' ')} is "
              "in front.png).", ""]
    return lines


def _chosen(results) -> list[str]:
    """The forms renders.png shows: the anchors, then up to SHOWN of the first architecture's FLIP front."""
    r = results["rendered"]
    first = r["architectures"][results["architectures"][0]]
    anchors = list(dict.fromkeys(row["name"] for row in results["rows"] if row["kind"] == "anchor"))
    front = first["front"]
    if len(front) > SHOWN:
        front = [front[round(i)] for i in np.linspace(0, len(front) - 1, SHOWN)]
    return anchors + [n for n in front if n not in anchors]


def figure_renders(path, results) -> None:
    """renders.png: one line per form (the exact term first): its displayed image and its FLIP map
    against the exact term's (0 black to 1 yellow, magma), titled with its largest FLIP."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    renders, r = results["renders"], results["rendered"]
    names = _chosen(results)
    rows = [("exact", renders["exact"], None)] + [(n, renders["images"][n], renders["maps"][n]) for n in names]
    height, width = renders["exact"].shape[:2]
    panel = 4.2
    fig, axes = plt.subplots(len(rows), 2, figsize=(2 * panel + 0.6, len(rows) * panel * height / width + 0.9),
                             squeeze=False)
    cycles = {row["name"]: row["cycles"] for row in results["rows"] if row["architecture"] == results["architectures"][0]}
    for (name, image, fmap), (left, right) in zip(rows, axes):
        left.imshow(image, interpolation="nearest")
        member = results["members"].get(name, {})
        kind = "the exact term" if name == "exact" else member.get("kind", "")
        at = f", {cycles[name]:g} cycles" if name in cycles else ""
        left.set_title("\n".join(textwrap.wrap(escape.mathtext(f"{name} ({kind}{at})"), 60)), fontsize=9)
        if fmap is None:
            right.axis("off")
            right.text(0.5, 0.5, f"the reference\nthe rule's threshold: largest FLIP <= {r['threshold']:.3g}",
                       ha="center", va="center", fontsize=9, transform=right.transAxes)
        else:
            right.imshow(np.asarray(fmap, dtype=np.float32), cmap="magma", vmin=0.0, vmax=1.0, interpolation="nearest")
            stats = member
            seen = "invisible" if stats.get("flip_max", math.inf) <= r["threshold"] else "visible"
            right.set_title(f"FLIP: largest {stats.get('flip_max', math.nan):.3g} ({seen}), mean "
                            f"{stats.get('flip_mean', math.nan):.2g}", fontsize=9)
        for ax in (left, right):
            ax.set_xticks([])
            ax.set_yticks([])
    first = results["architectures"][0]
    title = (f"{results['target']['name']} rendered in its place ({r['role']}), columns of roughness "
             f"{r['scene']['roughness'][0]:.2g} to {r['scene']['roughness'][-1]:.2g}, a dielectric above gold; "
             f"the anchors and {first}'s FLIP front; FLIP maps from 0 (black) to 1 (light yellow)")
    fig.suptitle("\n".join(textwrap.wrap(escape.mathtext(title), 90)), fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def figure_front(path, results) -> None:
    """rendered_front.png: per vendor (its first architecture), the largest FLIP against cycles: the
    FLIP front joined, the other rows of front.csv as points, the anchors labelled, the rule's
    threshold a dashed line."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from ...isa.architectures import vendor_groups
    from ...isa.machine_code import backend

    r = results["rendered"]
    shown = [names[0] for _, names in vendor_groups(results["architectures"])]
    columns = min(3, len(shown))
    lines = math.ceil(len(shown) / columns)
    fig, axes = plt.subplots(lines, columns, figsize=(5.0 * columns, 3.9 * lines + 0.8), squeeze=False)
    for ax in axes.flat[len(shown):]:
        ax.axis("off")
    for ax, a in zip(axes.flat, shown):
        rows = [x for x in results["rows"] if x["architecture"] == a and "flip_max" in x]
        others = [x for x in rows if x["kind"] == "found" and x["name"] not in r["architectures"][a]["front"]]
        ax.plot([x["cycles"] for x in others], [x["flip_max"] for x in others], "o", mfc="none", color="C0", ms=5,
                alpha=0.6, label="found, off the FLIP front")
        front = sorted((x for x in rows if x["name"] in r["architectures"][a]["front"]), key=lambda x: x["cycles"])
        ax.step([x["cycles"] for x in front], [x["flip_max"] for x in front], where="post", color="C0", lw=1.2, alpha=0.6)
        ax.plot([x["cycles"] for x in front], [x["flip_max"] for x in front], "o", color="C0", ms=5,
                label="found: the FLIP front")
        for k, x in enumerate(x for x in rows if x["kind"] == "anchor"):
            ax.plot(x["cycles"], x["flip_max"], "s", color="C3", ms=7, label="anchors: the engines' fits" if k == 0 else None)
            ax.annotate(escape.mathtext(x["name"]), (x["cycles"], x["flip_max"]), textcoords="offset points",
                        xytext=(6, 4), fontsize=8, color="C3")
        for x in (x for x in rows if x["kind"] == "exact"):
            ax.axvline(x["cycles"], color="0.4", ls="--", lw=1, label="the target itself (its cycles)")
        ax.axhline(r["threshold"], color="C2", ls="--", lw=1, label="the rule's threshold: below, invisible")
        seen = r["architectures"][a]["cheapest_invisible"]
        if seen:
            ax.plot(seen["cycles"], seen["flip"], "o", mfc="none", mec="k", ms=12, mew=1.5,
                    label="the cheapest invisible form")
        ax.set_yscale("symlog", linthresh=1e-3)
        ax.set_ylim(0.0, 1.0)
        ax.set_xlabel(f"{a}: {backend(a).UNIT}")
        ax.set_ylabel("largest FLIP over the spheres")
        ax.grid(alpha=0.3)
    handles = {}
    for ax in axes.flat:
        for h, label in zip(*ax.get_legend_handles_labels()):
            handles.setdefault(label, h)
    ncol = 3 if columns > 1 else 1
    fig.legend(handles.values(), handles.keys(), loc="lower center", ncol=ncol, fontsize=9, frameon=False)
    title = f"{results['target']['name']} rendered in its place: largest FLIP against compiled cycles, one panel per vendor"
    fig.suptitle("\n".join(textwrap.wrap(escape.mathtext(title), 55 * columns)), fontsize=11)
    legend_rows = -(-len(handles) // ncol)
    fig.tight_layout(rect=(0, min(0.35, 0.28 * legend_rows / (3.9 * lines + 0.8)), 1, 1))
    fig.savefig(path, dpi=110)
    plt.close(fig)
