"""The drawing functions of the figures (matplotlib). `pipeline.publish.figures` registers them:
each is passed only the config keys and stage results its entry declares, and returns the files
it wrote.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import matplotlib.layout_engine  # noqa: E402
import matplotlib.axis  # noqa: E402
import matplotlib.text  # noqa: E402
import matplotlib.ticker  # noqa: E402
import numpy as np  # noqa: E402

from ..engine.exponents import n_range  # noqa: E402
from ..isa import machine_code  # noqa: E402
from ..isa.architectures import VENDORS, vendor_groups  # noqa: E402
from ..optics import registry  # noqa: E402
from .report_beyond import at_power, family, keep  # noqa: E402

PAPER = dict(color="black", marker="*", markersize=12, linestyle="none", zorder=5)
# PNG compression level 1: files ~1.5x larger than the default 6, written several times faster.
FAST_PNG = {"compress_level": 1}
OBJECTIVE = {"relative_epicenter": "d", "absolute": "D", "rms": "rms"}


def paper_value(config, result_path):
    """The paper's value for a result, from the config's expectations (None if it has none)."""
    for e in config.expectations:
        if e.result == result_path:
            return e.paper
    return None


POWER = 2       # the run's lobe.power, set before each figure is drawn (`figures.draw_into_cache`)


def _texts(artist):
    """Every text under `artist` but its axes' tick labels: each draw writes those from the axis's
    formatter, so what they hold before is never drawn (and walking them would first make every
    minor tick of a log axis, most of the time of a figure of many panels)."""
    if isinstance(artist, matplotlib.text.Text):
        yield artist
    children = ((artist.label, artist.offsetText) if isinstance(artist, matplotlib.axis.Axis)
                else artist.get_children())
    for child in children:
        yield from _texts(child)


def _names_at_power(fig) -> None:
    """Every text of the figure through `at_power` (before any layout measures the texts)."""
    for text in _texts(fig):
        text.set_text(at_power(text.get_text(), POWER))


def _save(fig, out: Path, name: str, dpi: int = 110, tight: bool = True) -> str:
    """Writes the figure to out/name and closes it. tight=False keeps a layout set by hand (for large
    images, where tight_layout would draw everything once more just to measure it). At a power
    m != 2 every text names the fitted lobe f_Qm (`report_beyond.at_power`)."""
    _names_at_power(fig)
    if tight:
        fig.tight_layout()
    # The layout is done: tight_layout leaves a placeholder layout engine behind, for which savefig
    # would draw the whole figure once more before drawing it into the file.
    if isinstance(fig.get_layout_engine(), matplotlib.layout_engine.PlaceHolderLayoutEngine):
        fig.set_layout_engine(None)
    fig.savefig(out / name, dpi=dpi, pil_kwargs=FAST_PNG)
    plt.close(fig)
    return name


def fig2(out, config, r):
    s, d_f2 = r["q_scan"], r["f2_errors"]["d_f_2"]
    metric = config["derivation.metric"]
    fig, ax = plt.subplots(figsize=(7, 4.2))
    ax.plot(s["curve_Q"], 100 * s["curve_d"], label="max d of f_Q (this run)")
    ax.axhline(100 * d_f2, color="C1", ls="--", label=f"max d of f_2 = {100 * d_f2:.3f} %")
    if OBJECTIVE[metric] == "d":
        ax.plot(s["coarse_Q"], 100 * s["coarse_objective"], "o", ms=4, color="C2", label="coarse grid")
        ax.plot(s["fine_Q"], 100 * s["fine_objective"], ".", color="C3", label="fine grid")
    ax.axvline(s["Q_continuous_best"], color="grey", lw=0.8,
               label=f"continuous optimum of {metric}: Q = {s['Q_continuous_best']:.4f}")
    p, Q_paper = paper_value(config, "accuracy.d_f_Q"), paper_value(config, "q_scan.Q_scan_best")
    if p is not None and Q_paper is not None:
        ax.plot([Q_paper], [100 * p], **PAPER, label=f"paper: Q = {Q_paper:g}, d = {100 * p:.3f} %")
    ax.set(xlabel="Q (level at which f_Q = cos^n)", ylabel="max relative error d in epicenter zone (%)",
           title="Fig. 2: max d over n of f_Q and f_2 versus Q", ylim=(0, max(25, 110 * d_f2)))
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    return _save(fig, out, "fig2_d_vs_Q.png")


def fig3(out, config, r):
    s, D_f2, Q_used = r["q_scan"], r["f2_errors"]["D_f_2"], r["q_choice"]["Q_used"]
    fig, ax = plt.subplots(figsize=(7, 4.2))
    ax.plot(s["curve_Q"], s["curve_D"], label="max D of f_Q (this run)")
    ax.axhline(D_f2, color="C1", ls="--", label=f"max D of f_2 = {D_f2:.4f}")
    ax.axvline(Q_used, color="grey", lw=0.8, label=f"Q used = {Q_used:.4g}")
    ax.plot([s["curve_Q_at_D_min"]], [s["curve_D_min"]], "v", color="C0", ms=9,
            label=f"min D = {s['curve_D_min']:.4f} at Q = {s['curve_Q_at_D_min']:.3f} "
                  f"(there max d = {100 * s['curve_d_at_D_min']:.1f} %)")
    p = paper_value(config, "f2_errors.D_f_2")
    if p is not None:
        ax.plot([0.99], [p], **PAPER, label=f"paper: max D of f_2 = {p}")
    ax.set(xlabel="Q", ylabel="max absolute error D over x in [0, pi/2]",
           title="Fig. 3: max D over n of f_Q and f_2 versus Q")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    return _save(fig, out, "fig3_D_vs_Q.png")


def fig4(out, config, r):
    s, n = r["linear_coefficient"], n_range(config)
    fig, ax = plt.subplots(figsize=(7, 4.2))
    ax.plot(n, 100 * s["paper_line_rel_error"],
            label=f"paper's line {config['paper_model.slope']:g} n + {config['paper_model.intercept']:g}")
    ax.plot(n, 100 * s["lin_rel_error"], ls="--",
            label=f"this run's {config['derivation.fit']} line {s['lin_slope']:.6f} n + {s['lin_intercept']:.6f}")
    bound = 100 * config["paper_model.line_max_rel_error"]
    for b in (-bound, bound):
        ax.axhline(b, color="black", lw=0.8, ls=":")
    ax.set(xscale="log", xlabel="specular exponent n", ylabel="relative error of the line vs k_Q(n) (%)",
           title=f"Fig. 4: linear approximation of k_Q(n), Q = {r['q_choice']['Q_used']:.4g} "
                 f"(dotted: paper's {bound:g} % bound)")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    return _save(fig, out, "fig4_linear_coefficient.png")


def fig5(out, config, r):
    s, lin = r["accuracy"], r["linear_coefficient"]
    deg = np.degrees(s["fig5_x"])
    fig, ax = plt.subplots(figsize=(7, 4.2))
    ax.plot(deg, s["fig5_f_b"], "k", lw=2, label="f_b = cos^20 x (reference)")
    ax.plot(deg, s["fig5_f_2"], label="f_2")
    ax.plot(deg, s["fig5_f_Q2"], ls="--", label=f"f_Q2 (k = {lin['slope_used']:.4g} n + {lin['intercept_used']:.4g})")
    ax.axvline(np.degrees(s["fig5_zone_edge_x"]), color="grey", lw=0.8, label="edge of the epicenter zone")
    ax.set(xlim=(0, 45), xlabel="angle x (degrees)", ylabel="lobe value", title="Fig. 5: lobes at n = 20")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    return _save(fig, out, "fig5_lobes_n20.png")


def fig6(out, config, r):
    s, n = r["accuracy"], n_range(config)
    fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4.2))
    a.plot(n, 100 * s["d_f_Q2_curve"], label=f"f_Q2 (max {100 * s['d_f_Q2']:.3f} %)")
    f2 = r["f2_errors"]
    a.plot(n, 100 * f2["d_f_2_curve"], label=f"f_2 (max {100 * f2['d_f_2']:.3f} %)")
    p = paper_value(config, "accuracy.d_f_Q2")
    if p is not None:
        a.plot([n[-1]], [100 * p], **PAPER, label=f"paper: {100 * p:.3f} %")
    a.set(xscale="log", xlabel="n", ylabel="max relative error d in epicenter zone (%)",
          title="Fig. 6a: max d over x, per n")
    b.plot(n, s["D_f_Q2_curve"], label=f"f_Q2 (max {s['D_f_Q2']:.4f})")
    b.plot(n, f2["D_f_2_curve"], label=f"f_2 (max {f2['D_f_2']:.4f})")
    p = paper_value(config, "accuracy.D_f_Q2")
    if p is not None:
        b.plot([n[-1]], [p], **PAPER, label=f"paper: {p}")
    b.set(xscale="log", xlabel="n", ylabel="max absolute error D over [0, pi/2]",
          title="Fig. 6b: max D over x, per n")
    for ax in (a, b):
        ax.legend(fontsize=8)
        ax.grid(alpha=0.3)
    return _save(fig, out, "fig6_fQ2_errors.png")


def fig7(out, config, r):
    s = r["energy_dataset"]
    fig, ax = plt.subplots(figsize=(7, 4.2))
    ax.plot(n_range(config), s["y"], color="C0", lw=1, label="y(n) = 1 / (2 pi Int(n)), every n", zorder=2)
    ax.plot(r["sample"]["sample_n"], s["sample_y"], "o", ms=4, color="C1", zorder=4,
            label=f"{r['sample']['sample_size']}-point sample (newenergy.csv)")
    p = paper_value(config, "energy_dataset.y_n2_to_10")
    if p is not None:
        # Hollow and larger, so that the sample's points show through.
        ax.plot(np.arange(2, 2 + len(p)), p, marker="*", ms=13, mfc="none", mec="black", ls="none", zorder=5,
                label="paper's printed values, n = 2..10")
    ax.set(xscale="log", yscale="log", xlabel="n", ylabel="ideal normalization y(n) (1/sr)",
           title="Fig. 7: ideal energy-normalization coefficients of f_Q2")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3, which="both")
    return _save(fig, out, "fig7_dataset.png")


# TuringBot's complexity (PAPER.md, P14): constants, n, +, -, x count 1 and / counts 2.
TERM_COMPLEXITY = {"1": 1, "n": 1, "1/n": 4, "1/n^2": 6, "n^2": 3}


def turingbot_complexity(terms) -> int | None:
    """Complexity of sum_i c_i term_i as TuringBot counts it (None for terms it has no form for)."""
    sizes = []
    for t in terms:
        if t not in TERM_COMPLEXITY:
            return None
        sizes.append(TERM_COMPLEXITY[t] + (0 if t in ("1", "1/n", "1/n^2") else 2))   # c x: 2 more
    return sum(sizes) + len(terms) - 1


def fig9(out, config, r):
    sr, s = r["symbolic_regression"], r["sparse_regression"]
    fig, ax = plt.subplots(figsize=(11, 5.5))
    best = sorted((int(k), v) for k, v in sr["best_rms_by_complexity"].items())
    ax.plot([k for k, _ in best], [v for _, v in best], "o", color="0.75", ms=5, zorder=2,
            label=f"best expression at each complexity ({sr['forms_searched']} searched)")
    front = sr["front"]
    xs = [m["complexity"] for m in front]
    searched = max(k for k, _ in best)            # the axis ends at the largest complexity searched
    ax.step(xs + [searched + 0.5], [m["rms"] for m in front] + [front[-1]["rms"]], where="post", color="C0", lw=1.5,
            zorder=3, label=f"exhaustive front (this run, complexity <= {searched})")
    ax.plot(xs, [m["rms"] for m in front], "o", color="C0", ms=7, zorder=4)
    lines = ["front (size, RMS, sympy's canonical form):"]
    for m in front:
        mark = "  <- exact coef within the rounding step" if m["complexity"] == sr["sr_exact_complexity"] else ""
        text = m["canonical"].replace("**", "^").replace("*", " ").replace("1.0 n", "n")
        lines.append(f"{m['complexity']:>2}  {m['rms']:.3g}  {text}{mark}")
    ax.text(0.33, 0.62, "\n".join(lines), transform=ax.transAxes, fontsize=7.5, family="monospace",
            va="center", bbox=dict(facecolor="white", edgecolor="0.8", alpha=0.9))
    exact = [m for m in front if m["complexity"] == sr["sr_exact_complexity"]]
    if exact:
        ax.plot(exact[0]["complexity"], exact[0]["rms"], "o", ms=17, mfc="none", mec="C3", mew=2, zorder=5,
                label=f"smallest member within {sr['equivalence_tolerance']:g} of the exact coef (every n)")
    sparse = [(turingbot_complexity(m["terms"]), m["rms"]) for m in s["front"]]
    sparse = [p for p in sparse if p[0] is not None]
    ax.plot([p[0] for p in sparse], [p[1] for p in sparse], "s", ms=12, mfc="none", mec="C2", mew=1.5, zorder=7,
            label="pysindy STLSQ sweep (library 1, n, 1/n, 1/n^2)")
    rows = [(1, "size1_rms"), (3, "size3_rms"), (5, "size5_rms"), (10, "size10_rms"), (12, "size12_rms")]
    paper = [(size, paper_value(config, f"symbolic_regression.{field}")) for size, field in rows]
    paper = [p for p in paper if p[1] is not None]
    ax.plot([p[0] for p in paper], [p[1] for p in paper], marker="*", ms=16, mfc="none", mec="black", ls="none",
            zorder=6, label="paper: TuringBot's five rows")
    right = max([searched] + [p[0] for p in paper]) + 0.5
    floor = sr["rounding_rms_floor"]
    if floor > 0:
        ax.axhline(floor, color="C3", ls=":", lw=1)
        ax.text(right - 0.2, floor * 0.7, f"RMS of rounding y to {config['sample.y_decimals']} decimals alone: "
                f"{floor:.2g}", color="C3", fontsize=8, ha="right", va="top")
    ax.set(yscale="log", xlabel="complexity (TuringBot's: constants, n, +, -, x count 1; / counts 2)",
           ylabel="RMS error on the sample (1/sr)", title="Fig. 9: complexity / error front of coef(n)",
           xlim=(0, right))
    ax.set_xticks(range(0, int(right) + 1))
    ax.legend(fontsize=8, loc="upper right")
    ax.grid(alpha=0.3, which="both")
    return _save(fig, out, "fig9_front.png")


def fig10(out, config, r):
    s, e, h, n = r["sparse_regression"], r["energy_dataset"], r["hemispherical"], n_range(config)
    fig, (a, b) = plt.subplots(2, 1, figsize=(7, 6), sharex=True, height_ratios=(1, 1.3))
    a.plot(r["sample"]["sample_n"], e["sample_y"], "o", ms=4, label="sample")
    fitted = s["coef_scale"] * (s["coef_offset"] + n)
    used = h["coef_scale_used"] * (h["coef_offset_used"] + n)
    a.plot(n, fitted, label=f"fit: {s['coef_scale']:.6f} ({s['coef_offset']:.6f} + n)")
    a.plot(n, used, ls="--", label=f"used: {h['coef_scale_used']:.6g} ({h['coef_offset_used']:.6g} + n)")
    a.set(xscale="log", ylabel="coef(n) (1/sr)", title="Fig. 10: dataset and fitted coef(n)")
    a.legend(fontsize=8)
    # Relative residual: what matters for energy (coef / y - 1 = reflected / received - 1).
    b.plot(n, 100 * (fitted / e["y"] - 1), label="fit / y(n) - 1")
    b.plot(n, 100 * (used / e["y"] - 1), ls="--", label="used / y(n) - 1")
    b.axhline(0, color="black", lw=0.8)
    _asinh_percent(b, np.concatenate([100 * (fitted / e["y"] - 1), 100 * (used / e["y"] - 1)]))
    b.set(xlabel="n", ylabel="relative residual (%), > 0: energy created\n(asinh axis: linear near 0, log beyond 0.1 %)")
    b.legend(fontsize=8)
    for ax in (a, b):
        ax.grid(alpha=0.3, which="both")
    return _save(fig, out, "fig10_coef_fit.png")


def _asinh_percent(ax, values_percent) -> None:
    """An asinh y axis in percent, with plain ticks at 0 and +-0.1, 0.2, 0.5, 1, 2, 5, ... within the data."""
    ax.set_yscale("asinh", linear_width=0.1)
    top = float(np.nanmax(np.abs(values_percent)))
    steps = [m * 10.0**e for e in range(-1, 3) for m in (1, 2, 5)]
    ticks = [0.0] + [sign * t for t in steps if t <= 1.5 * top for sign in (1, -1)]
    ticks = [t for t in ticks if np.nanmin(values_percent) - 0.5 * abs(t) <= t <= np.nanmax(values_percent) + 0.5 * abs(t)
             or t == 0.0]
    ax.set_yticks(sorted(ticks))
    ax.yaxis.set_major_formatter(matplotlib.ticker.FuncFormatter(lambda v, _: f"{v:g}"))
    ax.yaxis.set_minor_locator(matplotlib.ticker.NullLocator())


def _excess_axis(ax, excess_ranges, values_percent):
    """Reflected / received - 1 in % on an asinh axis (linear near 0, logarithmic beyond 0.1 %, and
    smooth: a symlog axis would put kinks into smooth curves at +-0.1 %), so that a 0.1 % excess shows
    beside a 5 % deficit; the ranges of n where energy is created shaded."""
    ax.axhline(0, color="black", lw=1.2, ls=":", label="exact normalization (0 for every n)")
    for lo, hi in excess_ranges:
        ax.axvspan(lo, hi, color="C3", alpha=0.1, lw=0)
    if excess_ranges:
        ax.plot([], [], color="C3", alpha=0.3, lw=8, label="energy created: n = "
                + ", ".join(f"{lo:g} to {hi:g}" for lo, hi in excess_ranges))
    _asinh_percent(ax, values_percent)
    ax.set(xscale="log", xlabel="n", ylabel="reflected / received - 1 (%)\n(asinh axis: linear near 0, log beyond 0.1 %)")


def fig11(out, config, r):
    h = r["hemispherical"]
    fig, ax = plt.subplots(figsize=(7.5, 4.4))
    ax.plot(n_range(config), 100 * h["deviation"], color="C0", label="coef(n) 2 pi Int(n) - 1 (the paper's Int)")
    _excess_axis(ax, h["hemi_excess_ranges"], 100 * h["deviation"])
    p = paper_value(config, "hemispherical.hemi_max_abs_dev")
    if p is not None:
        ax.plot([2], [-100 * p], marker="*", ms=14, mfc="none", mec="black", ls="none",
                label=f"paper: max |deviation| = {p}")
    ax.set_title(f"Fig. 11: hemispherical reflectivity - 1; max |dev| {100 * h['hemi_max_abs_dev']:.2f} % "
                 f"at n = {h['hemi_n_at_max']:g}", fontsize=10)
    ax.legend(fontsize=7.5, loc="lower right")
    ax.grid(alpha=0.3, which="both")
    return _save(fig, out, "fig11_hemispherical.png")


def zone_sensitivity(out, config, r):
    s, f2, z = r["accuracy"], r["f2_errors"], r["zone"]
    levels = f2["zone_levels"]
    fig, (a, b) = plt.subplots(1, 2, figsize=(12, 4.2))
    a.plot(levels, 100 * f2["zone_d_f_2"], "s-", color="C1", label="f_2")
    a.plot(levels, 100 * s["zone_d_f_Q"], "x--", color="C2", ms=8, label="f_Q (Q used)")
    a.plot(levels, 100 * s["zone_d_f_Q2"], "o-", color="C0", mfc="none", label="f_Q2")
    for path, color in (("f2_errors.d_f_2", "C1"), ("accuracy.d_f_Q2", "C0")):
        p = paper_value(config, path)
        if p is not None:
            a.plot([z["level"]], [100 * p], marker="*", ms=14, mfc="none", mec="black", ls="none")
    a.plot([], [], marker="*", ms=10, mfc="none", mec="black", ls="none", label="paper's values (P9, P7)")
    a.set(xlabel="zone level L (epicenter = {cos^n x >= L})", ylabel="max d over n (%)", ylim=(0, None),
          title="Max relative error in the epicenter zone")
    b.plot(levels, s["zone_gain"], "o-", color="C0")
    p = paper_value(config, "accuracy.epicenter_gain")
    if p is not None:
        b.plot([z["level"]], [p], marker="*", ms=14, mfc="none", mec="black", ls="none", label=f"paper: {p}x (P11)")
        b.legend(fontsize=8)
    b.set(xlabel="zone level L", ylabel="gain: max d of f_2 / max d of f_Q2", ylim=(0, None),
          title="The accuracy gain depends on the zone level")
    for ax in (a, b):
        ax.axvline(z["level"], color="grey", lw=0.8, label=f"level used L = {z['level']:.4f}")
        ax.grid(alpha=0.3)
    a.legend(fontsize=8)
    return _save(fig, out, "zone_sensitivity.png")


def exact_normalization(out, config, r):
    e, h, n = r["exact_normalization"], r["hemispherical"], n_range(config)
    fig, (a, b) = plt.subplots(1, 2, figsize=(12.5, 4.6))
    a.plot(n, 100 * e["energy_run"], color="C0", label=f"run's coef {h['coef_scale_used']:g} ({h['coef_offset_used']:g} + n)")
    _excess_axis(a, e["excess_ranges"], np.concatenate([100 * e["energy_run"], 100 * e["asymptotic_phong_dev"]]))
    fam = family(POWER)
    a.plot(n, 100 * e["asymptotic_phong_dev"], ls="--", color="C2", label=f"{fam['two_term']} = exact (1 - {fam['under']})")
    a.set_title(f"Phong form (R.V): largest excess {100 * e['paper_coef_max_excess']:+.3f} % at n = "
                f"{e['paper_coef_n_at_max_excess']:g}", fontsize=10)
    b1, b0 = e["asymptotic_blinn_terms"]
    b.plot(n, 100 * e["asymptotic_blinn_dev"], ls="--", color="C2",
           label="(3 / (8 pi)) (k + 5/4)" if POWER == 2 else f"{b1:.4g} (k + {b0 / b1:.4g})")
    b.axhline(0, color="black", lw=1.2, ls=":", label="exact Blinn coef (0 for every n)")
    b.set(xscale="log", xlabel="n", ylabel="reflected / received - 1 (%)")
    b.set_title(f"Blinn form (N.H), its own coef: {e['blinn_to_phong_ratio_at_n_max']:.3f} x the Phong one "
                f"at n = {n[-1]:g}", fontsize=10)
    for ax in (a, b):
        ax.legend(fontsize=7.5, loc="lower right")
        ax.grid(alpha=0.3, which="both")
    return _save(fig, out, "exact_normalization.png")


def directional_albedo(out, config, r):
    s = r["directional_albedo"]
    deg = np.degrees(s["theta"])
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.4), sharey=True)
    panels = (("phong_run_coef", "Phong form, run's coef"), ("phong_exact_coef", "Phong form, exact coef"),
              ("blinn_exact_coef", "Blinn form, exact Blinn coef"))
    for ax, (name, title) in zip(axes, panels):
        for i, m in enumerate(s["curve_n"]):
            ax.plot(deg, s[f"{name}_curves"][i], label=f"n = {m:g}")
        ax.axhline(1.0, color="black", lw=0.8)
        ax.set(xlabel="incidence angle (degrees)", title=f"{title}: max {s[f'{name}_max']:.6f}")
        ax.grid(alpha=0.3)
    for ax, form in ((axes[1], "phong"), (axes[2], "blinn")):
        pts = [row for row in s["monte_carlo"] if row["form"] == form]
        ax.errorbar([p["theta_deg"] for p in pts], [p["monte_carlo"] for p in pts],
                    yerr=[3 * p["standard_error"] for p in pts], fmt="k.", ms=3, lw=0.8,
                    label="Monte Carlo (+- 3 s.e.)")
        ax.legend(fontsize=7)
    axes[0].legend(fontsize=7)
    axes[0].set_ylabel("directional albedo a(theta_i)")
    return _save(fig, out, "directional_albedo.png")


def lobe_style(row) -> dict:
    """A compared lobe's line style: its registry entry's (grey for a lobe this process does not know);
    a second instance of a lobe (f_Q at the continuous optimum of Q) dashed and thinner."""
    entry = registry.LOBES.get(row["registry_key"])
    style = dict(lw=1.5, color="0.45") | (dict(entry.style) if entry else {})
    if row["lobe"] != row["registry_key"]:
        style |= dict(ls="--", lw=1.0)
    return style


def _direct_labels(ax, ends, top):
    """Labels at the right end of the lines, nudged apart so that they do not overlap."""
    placed = []
    for y, text, color in sorted(ends):
        y = min(y, top)
        while any(abs(y - p) < 0.045 * top for p in placed):
            y += 0.045 * top
        placed.append(y)
        ax.text(1.02, y / top, text, color=color, fontsize=8, va="center", transform=ax.transAxes)


def lobe_comparison(out, config, r):
    c, n = r["lobe_comparison"], n_range(config)
    fig, (a, b) = plt.subplots(1, 2, figsize=(13, 4.8))
    tops = (12.0, 0.22)             # clipped linear axes: every lobe's curve is visible
    ends = ([], [])
    for i, lobe in enumerate(c["lobes"]):
        if lobe["registry_key"] == registry.REFERENCE:
            continue
        style = lobe_style(lobe)
        for ax, curve, end, scale in ((a, c["d_curves"][i], ends[0], 100.0), (b, c["D_curves"][i], ends[1], 1.0)):
            ax.plot(n, scale * curve, **style)
            end.append((scale * curve[-1], lobe["label"], style["color"]))
    for ax, end, top in ((a, ends[0], tops[0]), (b, ends[1], tops[1])):
        ax.set(xscale="log", xlabel="n", ylim=(0, top), xlim=(n[0], n[-1]))
        ax.grid(alpha=0.3, which="both")
        _direct_labels(ax, end, top)
    a.set(ylabel="max relative error d in the epicenter zone (%)", title="d per n (axis clipped at 12 %)")
    b.set(ylabel="max absolute error D over [0, pi/2]", title="D per n")
    fig.suptitle("Cheap lobes against cos^n, per n: the spherical Gaussians overtake f_Q2 as n grows", fontsize=11)
    fig.subplots_adjust(left=0.06, right=0.86, wspace=0.55, top=0.86, bottom=0.12)
    return _save(fig, out, "lobe_comparison.png", tight=False)


def renders(out, config, r):
    """One side-by-side image per exponent (rows: scenes; columns: lobes), at full resolution."""
    s = r["render"]
    names = []
    res = config["render.resolution"]
    normalization = config["render.normalization"]
    for j, n in enumerate(config["render.exponents"]):
        rows, cols = len(s["scenes"]), len(s["lobes"])
        height = rows * res / 100 + 0.8        # inches: the images at 100 dpi, and room for the titles
        fig, axes = plt.subplots(rows, cols, figsize=(cols * res / 100, height), dpi=100, squeeze=False)
        for i, scene in enumerate(s["scenes"]):
            for l, lobe in enumerate(s["lobes"]):
                ax = axes[i, l]
                ax.imshow(s["display"][i, j, l], interpolation="nearest")
                ax.set_axis_off()
                label = ("reference f_b = cos^n (Giesen)" if lobe == registry.REFERENCE else
                         f"{lobe} ({'Giesen' if normalization == 'reference' else 'exact Blinn coef'})")
                ax.set_title(f"{label}, {scene}", fontsize=9)
        fig.suptitle(f"n = {n:g}: Blinn form (t = N.H), normalization: {normalization}; Reinhard tone map, sRGB",
                     fontsize=10, y=1 - 0.1 / height)
        # A fixed layout: tight_layout would draw these large images once more just to measure them.
        fig.subplots_adjust(left=0.005, right=0.995, bottom=0.005, top=1 - 0.6 / height, wspace=0.02,
                            hspace=0.2 / (res / 100))
        name = f"render_n{n:g}.png"
        names.append(_save(fig, out, name, dpi=100, tight=False))
    return names


def render_shipped(out, config, r):
    """Per exponent (rows), the first scene: the reference cos^n with Giesen's coef, f_Q2 at equal peak
    (Giesen's coef) and f_Q2 as shipped (its own exact Blinn-form coef)."""
    s = r["render"]
    res = config["render.resolution"]
    exponents = list(config["render.exponents"])
    fig, axes = plt.subplots(len(exponents), 3, figsize=(3 * res / 100, len(exponents) * res / 100 + 0.8), dpi=100,
                             squeeze=False)
    f_Q2 = s["lobes"].index("f_Q2")
    for j, n in enumerate(exponents):
        row = next(x for x in s["shipped_statistics"] if x["scene"] == s["scenes"][0] and x["n"] == float(n))
        for col, (image, title) in enumerate((
                (s["display"][0, j, 0], "cos^n, Giesen's coef"),
                (s["display"][0, j, f_Q2], f"f_Q2, Giesen's coef (equal peak): FLIP {row['equal_peak_flip_highlight']:.3f}"),
                (s["shipped_display"][0, j], f"f_Q2, its exact coef ({row['coef_over_reference']:.3f}x): "
                                             f"FLIP {row['flip_highlight']:.3f}"))):
            ax = axes[j, col]
            ax.imshow(image, interpolation="nearest")
            ax.set_axis_off()
            ax.set_title(f"n = {n:g}: {title}", fontsize=8.5)
    height = len(exponents) * res / 100 + 0.8
    fig.suptitle(f"{s['scenes'][0]}: f_Q2 at equal peak and as shipped (its own normalization); FLIP over the visible "
                 "highlight against cos^n", fontsize=10, y=1 - 0.1 / height)
    fig.subplots_adjust(left=0.005, right=0.995, bottom=0.005, top=1 - 0.6 / height, wspace=0.02,
                        hspace=0.25 / (res / 100))
    _names_at_power(fig)
    return _save(fig, out, "render_shipped.png", dpi=100, tight=False)


def render_errors(out, config, r):
    """Per exponent: FLIP error maps and absolute luminance errors of each candidate, each kind on one
    colour scale shared by the lobes and scenes of the figure."""
    s = r["render"]
    names = []
    candidates = [l for l, lobe in enumerate(s["lobes"]) if lobe != registry.REFERENCE]
    for j, n in enumerate(config["render.exponents"]):
        absolute = {(i, l): np.abs(s["luminance"][i, j, l].astype(np.float64) - s["luminance"][i, j, 0])
                    for i in range(len(s["scenes"])) for l in candidates}
        vmax = max(float(v.max()) for v in absolute.values()) or 1.0
        fig, axes = plt.subplots(len(candidates), 2 * len(s["scenes"]),
                                 figsize=(4.2 * 2 * len(s["scenes"]), 3.8 * len(candidates)), squeeze=False)
        for row, l in enumerate(candidates):
            for i, scene in enumerate(s["scenes"]):
                flip = s["flip_maps"][i, j, l - 1].astype(np.float32)
                stats = next(x for x in s["statistics"] if x["scene"] == scene and x["n"] == n
                             and x["lobe"] == s["lobes"][l])
                panels = ((flip, f"FLIP (mean {stats['flip_frame']:.3f} frame, {stats['flip_highlight']:.3f} highlight)",
                           "magma", 1.0),
                          (absolute[i, l], "absolute luminance error (linear)", "viridis", vmax))
                for col, (data, label, cmap, top) in enumerate(panels):
                    ax = axes[row, 2 * i + col]
                    im = ax.imshow(data, cmap=cmap, vmin=0.0, vmax=top, interpolation="nearest")
                    ax.set_axis_off()
                    ax.set_title(f"{s['lobes'][l]}, {scene}:\n{label}", fontsize=8)
                    fig.colorbar(im, ax=ax, fraction=0.046, pad=0.02)
        fig.suptitle(f"n = {n:g}: error against the reference cos^n (each kind on one shared scale)", fontsize=10)
        fig.subplots_adjust(left=0.01, right=0.97, bottom=0.02, top=0.88, wspace=0.15, hspace=0.25)
        name = f"render_errors_n{n:g}.png"
        names.append(_save(fig, out, name, dpi=90, tight=False))
    return names


def render_crops(out, config, r):
    """Per exponent: the highlight of each lobe, cropped around the reference's peak, in linear luminance
    on one shared scale (no tone map, so the core does not saturate), and a profile through the peak."""
    s = r["render"]
    names = []
    half = 48
    for j, n in enumerate(config["render.exponents"]):
        rows = len(s["scenes"])
        fig, axes = plt.subplots(rows, len(s["lobes"]) + 1, figsize=(3.4 * (len(s["lobes"]) + 1), 3.2 * rows),
                                 squeeze=False, gridspec_kw=dict(width_ratios=[1] * len(s["lobes"]) + [1.4]))
        fig.subplots_adjust(left=0.02, right=0.98, bottom=0.1, top=0.86, wspace=0.15, hspace=0.4)
        for i, scene in enumerate(s["scenes"]):
            lum = s["luminance"][i, j].astype(np.float64)          # lobe x H x W
            y, x = np.unravel_index(np.argmax(lum[0]), lum[0].shape)      # the reference's peak
            y0, x0 = max(y - half, 0), max(x - half, 0)
            crops = lum[:, y0:y + half, x0:x + half]
            top = float(crops.max())
            for l, lobe in enumerate(s["lobes"]):
                ax = axes[i, l]
                ax.imshow(crops[l], cmap="inferno", vmin=0.0, vmax=top, interpolation="nearest")
                ax.set_axis_off()
                ax.set_title(f"{lobe}, {scene}\n(black 0, white {top:.2f}, as in the profile)", fontsize=8)
            ax = axes[i, -1]
            for l, lobe in enumerate(s["lobes"]):
                ax.plot(np.arange(x0, x0 + crops.shape[2]) - x, crops[l, y - y0], label=lobe,
                        lw=2.2 if lobe == registry.REFERENCE else 1.2, ls="-" if lobe != "f_2" else "--")
            ax.set(xlabel="pixels from the peak", ylabel="linear luminance", title="profile through the peak")
            ax.title.set_fontsize(8)
            ax.legend(fontsize=7)
            ax.grid(alpha=0.3)
        fig.suptitle(f"n = {n:g}: the highlight in linear luminance, one scale per row (no tone map)", fontsize=10)
        name = f"render_crops_n{n:g}.png"
        names.append(_save(fig, out, name, dpi=90, tight=False))
    return names


MITSUBA_LOBES = (registry.REFERENCE, "f_2", "f_Q2")
MITSUBA_PANELS = ("f_b = cos^n (reference)", "f_2", "f_Q2", "f_Q2, cosine-weighted sampling")


def mitsuba_renders(out, config, r):
    """The four Mitsuba renders, and the FLIP maps of f_2 and f_Q2 on one scale with the highlights outlined."""
    s = r["mitsuba_render"]
    fig, axes = plt.subplots(3, 2, figsize=(12, 9.2))
    for ax, image, title in zip(axes.flat[:4], s["display"], MITSUBA_PANELS):
        ax.imshow(image, interpolation="nearest")
        ax.set_title(f"{title}: {s['spp']} spp x 2 seeds ({s['variant']})", fontsize=9)
    for ax, fmap, name in zip(axes.flat[4:], s["flip_maps"], ("f_2", "f_Q2")):
        im = ax.imshow(fmap.astype(np.float32), cmap="magma", vmin=0.0, vmax=1.0, interpolation="nearest")
        ax.contour(s["highlight"] >= 0, levels=[0.5], colors="cyan", linewidths=0.6)
        ax.set_title(f"FLIP of {name} against cos^n (mean over the frame {s['flip_frame'][name]:.4f}); "
                     "cyan: sun highlights", fontsize=9)
        fig.colorbar(im, ax=ax, fraction=0.03, pad=0.02)
    for ax in axes.flat:
        ax.set_axis_off()
    fig.suptitle("Mitsuba 3 path tracer, lobes as BSDF plugins (Blinn form, exact normalization); spheres "
                 + ", ".join(f"n = {n:g}" for n in s["exponents"]), fontsize=10)
    return _save(fig, out, "mitsuba_renders.png", dpi=90)


def mitsuba_crops(out, config, r):
    """Per sphere: its sun highlight in the three lobes' displays, zoomed, and the FLIP maps there."""
    s = r["mitsuba_render"]
    stats = {(x["lobe"], x["n"]): x for x in s["statistics"]}
    fig, axes = plt.subplots(len(s["exponents"]), 5, figsize=(14, 3.5 * len(s["exponents"])), squeeze=False)
    fig.subplots_adjust(hspace=0.32, top=0.9)     # room for the two-line titles of the FLIP panels
    for i, n in enumerate(s["exponents"]):
        ys, xs = np.nonzero(s["highlight"] == i)
        cy, cx = int(ys.mean()), int(xs.mean())
        half = max(8, int(1.5 * max(ys.max() - ys.min(), xs.max() - xs.min()) / 2) + 4)
        window = (slice(max(cy - half, 0), cy + half), slice(max(cx - half, 0), cx + half))
        panels = [(s["display"][l][window], f"{name}", None) for l, name in enumerate(MITSUBA_LOBES)]
        panels += [(s["flip_maps"][l][window].astype(np.float32),
                    f"FLIP of {name}\n{stats[(name, n)]['flip_highlight']:.3f} mean over the highlight", "magma")
                   for l, name in enumerate(MITSUBA_LOBES[1:])]
        for ax, (image, title, cmap) in zip(axes[i], panels):
            if cmap:
                ax.imshow(image, cmap=cmap, vmin=0.0, vmax=1.0, interpolation="nearest")
            else:
                ax.imshow(image, interpolation="nearest")
            ax.contour((s["highlight"] == i)[window], levels=[0.5], colors="cyan", linewidths=0.6)
            ax.set_title(f"n = {n:g}: {title}", fontsize=8.5)
            ax.set_axis_off()
    fig.suptitle("Sun highlight of each sphere (cyan: pixels where some lobe's direct sun highlight adds >= 1 "
                 "display level); FLIP on one scale, 0 to 1",
                 fontsize=10)
    return _save(fig, out, "mitsuba_crops.png", dpi=90)


def error_cost_front(out, config, r):
    """The decision's common case (Phong or Blinn lobe, n per material, fp32), per architecture (rows)
    and n range (columns): max d against cycles per wave of every candidate with its d > 0: the
    registry's lobes (squares; the paper's f_Q2 starred), the family's other powers (circles), the lobe
    search's forms with their lines in n (triangles); cos^n's cost dotted, the budget max_d dashed, the
    winner ringed. Points of equal cost keep their cost: their labels are stacked. Bottom: the winner
    at each n of the grid, per architecture, by the same rule."""
    d = r["decision"]
    if not d["available"] or not d["table"]:
        fig, ax = plt.subplots(figsize=(8, 2))
        ax.axis("off")
        ax.text(0.5, 0.5, "No machine code, nothing decided: " + d["reason"], ha="center", va="center", wrap=True)
        return _save(fig, out, "error_cost_front.png", tight=False)
    cands = [m for m in d["candidates"] if m["use"] == "lobe"]
    architectures = list(dict.fromkeys(row["architecture"] for row in d["table"]))
    vendors = vendor_rows(architectures)
    ranges_ = list(dict.fromkeys(tuple(m["n_range"]) for m in cands))
    marker = {"registry": "s", "power": "o", "search": "^"}
    color = {"registry": "C3", "power": "C0", "search": "C2"}
    fig = plt.figure(figsize=(4.3 * len(ranges_), 3.3 * len(vendors) + 0.25 * len(architectures) + 2.0))
    grid = fig.add_gridspec(len(vendors) + 1, len(ranges_),
                            height_ratios=[3.3] * len(vendors) + [0.6 + 0.2 * len(architectures)])
    stacks = []
    for i, (vendor, archs) in enumerate(vendors):
        top = max(m["cycles"][a] for m in cands for a in archs if a in m["cycles"])
        for j, (lo, hi) in enumerate(ranges_):
            ax = fig.add_subplot(grid[i, j])
            labels: dict = {}
            for k, a in enumerate(archs):
                # The vendor's first architecture in its colours and labelled; the others in grey shades,
                # their names at the right of each one's reference line.
                main = k == 0
                shade = None if main else str(0.35 + 0.45 * k / len(archs))
                here = [m for m in cands if tuple(m["n_range"]) == (lo, hi) and a in m["cycles"]]
                row = next(x for x in d["table"] if x["architecture"] == a and tuple(x["n_range"]) == (lo, hi)
                           and x["use"] == "phong" and x["n_per"] == "material" and x["precision"] == "fp32")
                for m in here:
                    if m["kind"] == "reference":
                        ax.axvline(m["cycles"][a], color="black" if main else shade, ls=":", lw=1)
                        ax.text(m["cycles"][a], 1.0 - 0.07 * k, f" cos^n, {a}", transform=ax.get_xaxis_transform(),
                                fontsize=6, va="top", ha="left", color="black" if main else shade)
                        continue
                    star = m["name"] == "f_Q2"
                    x, y = m["cycles"][a], 100 * m["d"]
                    face = ("gold" if star else color[m["kind"]]) if main else shade
                    ax.plot(x, y, "*" if star else marker[m["kind"]], color=face, mec="black" if star else face,
                            ms=(13 if star else 5) if main else (9 if star else 3.5), zorder=5 if main else 4)
                    if m["name"] == row["winner"]:
                        ax.plot(x, y, "o", mfc="none", mec="black" if main else shade, ms=13, mew=1.2, zorder=6)
                    if not main:
                        continue
                    best_here = min(o["d"] for o in here if o["cycles"][a] == x and o["kind"] != "reference")
                    if star or m["name"] == row["winner"] or m["d"] == best_here:     # the others: by marker only
                        labels.setdefault(x, []).append((m["d"], keep(m["name"]) + (" (winner)" if m["name"] == row["winner"]
                                                                                   else ""), "black" if star else color[m["kind"]]))
            ax.axhline(100 * d["budgets"]["max_d"], color="0.4", ls="--", lw=0.9)
            ax.set(yscale="log", xlim=(-0.03 * top, top * 1.45))
            ax.grid(alpha=0.3, which="both")
            stacks.append((ax, labels))
            if i == 0:
                ax.set_title(f"n in [{lo:g}, {hi:g}]", fontsize=10)
            if j == 0:
                ax.set_ylabel(f"{VENDORS.get(vendor, vendor)}: {archs[0]} in colour\nmax d in the zone (%)", fontsize=9)
            ax.set_xlabel(cost_axis(vendor), fontsize=8)
    strip = fig.add_subplot(grid[len(vendors), :])
    n = np.asarray(d["per_n"]["n"])
    edges = np.concatenate([[n[0]], np.sqrt(n[1:] * n[:-1]), [n[-1]]])
    names = list(dict.fromkeys(w for a in architectures for w in d["per_n"]["winners"][a]))
    palette = {name: f"C{k % 10}" for k, name in enumerate(names)}
    for i, a in enumerate(architectures):
        for k, w in enumerate(d["per_n"]["winners"][a]):
            strip.barh(i, edges[k + 1] - edges[k], left=edges[k], color=palette[w], height=0.8, edgecolor="none")
    strip.set(xscale="log", yticks=range(len(architectures)), xlim=(n[0], n[-1]), yticklabels=architectures)
    strip.tick_params(axis="y", labelsize=7)
    strip.invert_yaxis()
    strip.set_xlabel("n: the winner at each n of the grid (same rule, the search's forms at their per-n fit)", fontsize=8)
    strip.legend(handles=[plt.Rectangle((0, 0), 1, 1, color=palette[w]) for w in names],
                 labels=[keep(w) for w in names], ncol=min(len(names), 6), fontsize=7, loc="upper center",
                 bbox_to_anchor=(0.5, -0.45), frameon=False)
    fig.suptitle("The decision, common case (Phong or Blinn lobe, n per material, fp32): max d against cost (net of "
                 "the wrapper, n per material), one row "
                 "per vendor (its first architecture in colour and labelled, the others grey, lighter in the registry's "
                 "order; dotted: cos^n's cost on each); dashed: the budget max_d; ringed: each architecture's winner. "
                 "Squares: the registry's lobes (the paper's f_Q2 starred); circles: the family's powers; triangles: "
                 "the lobe search's forms (parameters as lines in n). Labelled: the winner, f_Q2 and the best at each cost",
                 fontsize=9.5, wrap=True)
    _names_at_power(fig)
    fig.tight_layout(rect=(0, 0.02, 1, 0.95))
    _settle(fig)
    for ax, labels in stacks:
        _stacked_labels(fig, ax, labels)
    _names_at_power(fig)
    return _save(fig, out, "error_cost_front.png", tight=False)


NDF_LABELS = {"beckmann": "Beckmann (Mitsuba roughconductor)", "ggx": "GGX (Mitsuba roughconductor)",
              "f_b": "cos^n as NDF", "f_2": "f_2 as NDF", "f_Q2": "f_Q2 as NDF"}


def microfacet_renders(out, config, r):
    """Each NDF's render (Cook-Torrance, F = 1) and, beside it, its FLIP map against Beckmann."""
    s = r["microfacet_render"]
    stats = {(x["ndf"], x["n"]): x for x in s["statistics"]}
    names = s["ndfs"]
    fig, axes = plt.subplots(len(names), 2, figsize=(12, 2.9 * len(names)), squeeze=False)
    for i, name in enumerate(names):
        axes[i, 0].imshow(s["display"][i], interpolation="nearest")
        axes[i, 0].set_title(f"{NDF_LABELS[name]}: {s['spp']} spp x 2 seeds", fontsize=9)
        if i == 0:
            axes[i, 1].text(0.5, 0.5, "the reference:\nspheres n = " + ", ".join(f"{n:g}" for n in s["exponents"])
                            + "\nalpha = " + ", ".join(f"{a:.3f}" for a in s["alphas"]), ha="center", va="center",
                            fontsize=10, transform=axes[i, 1].transAxes)
        else:
            im = axes[i, 1].imshow(s["flip_maps"][i - 1].astype(np.float32), cmap="magma", vmin=0.0, vmax=1.0,
                                   interpolation="nearest")
            means = ", ".join(f"{stats[(name, n)]['flip_highlight']:.3f}" for n in s["exponents"])
            axes[i, 1].set_title(f"FLIP against Beckmann; mean over each sun highlight: {means}", fontsize=9)
            fig.colorbar(im, ax=axes[i, 1], fraction=0.03, pad=0.02)
    for ax in axes.flat:
        ax.set_axis_off()
    fig.suptitle("The lobes as microfacet NDFs (Cook-Torrance, F = 1, Smith G of Beckmann) beside Mitsuba's "
                 "Beckmann and GGX at alpha = sqrt(2 / (n + 2))", fontsize=10)
    fig.tight_layout(rect=(0, 0, 1, 0.97))
    return _save(fig, out, "microfacet_renders.png", dpi=90, tight=False)


def ndf_comparison(out, config, r):
    """d and D per n of each normalized lobe as an NDF against Beckmann at the matched alpha, GGX for
    scale; and the distributions themselves at n = 100 against theta / alpha."""
    from ..optics import distributions as ndf_mod
    s, n = r["ndf"], n_range(config)
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.6))
    labels = list(s["lobes"]) + ["ggx"]
    colors = {"f_b": "black", "f_2": "C1", "f_Q2": "C0", "ggx": "C3"}
    for key, d, D in zip(labels, s["d_curves"], s["D_curves"]):
        axes[0].plot(n, 100 * d, color=colors[key], label=NDF_LABELS.get(key, key).replace(" as NDF", ""))
        axes[1].plot(n, D, color=colors[key], label=NDF_LABELS.get(key, key).replace(" as NDF", ""))
    for ax in axes[:2]:
        ax.set(xscale="log", xlabel="n (alpha = sqrt(2 / (n + 2)))", xlim=(n[0], n[-1]))
        ax.grid(alpha=0.3, which="both")
        ax.legend(fontsize=8)
    axes[0].set(ylabel="max relative error where D_Beckmann >= L peak (%)",
                title="d against Beckmann, per n")
    axes[1].set(ylabel="max |D - D_Beckmann| / Beckmann's peak", title="D against Beckmann, per n")
    i = int(np.argmin(np.abs(n - 100.0)))
    alpha = float(s["alpha"][i])
    theta = np.linspace(0.0, 3.0 * alpha, 600)
    t = np.cos(theta)
    peak = 1.0 / (np.pi * alpha * alpha)
    axes[2].plot(theta / alpha, ndf_mod.beckmann(t, alpha) / peak, color="0.3", lw=2.4, label="Beckmann")
    axes[2].plot(theta / alpha, ndf_mod.ggx(t, alpha) / peak, color="C3", label="GGX")
    axes[2].plot(theta / alpha, s["coef_f_b"][i] * t ** n[i] / peak, color="black", ls="--", label="cos^n as NDF")
    k = r["linear_coefficient"]["slope_used"] * n[i] + r["linear_coefficient"]["intercept_used"]
    m = config["lobe.power"]
    axes[2].plot(theta / alpha, s["coef_f_Q2"][i] * np.maximum(k * (t - 1.0) + 1.0, 0.0) ** m / peak, color="C0",
                 label="f_Q2 as NDF")
    axes[2].set(xlabel="theta_h / alpha", ylabel="D / Beckmann's peak", title=f"the distributions at n = {n[i]:g}")
    axes[2].grid(alpha=0.3)
    axes[2].legend(fontsize=8)
    fig.suptitle("The lobes as normalized microfacet NDFs (int D (n.h) dw_h = 1) against Beckmann at the matched "
                 "roughness", fontsize=11)
    return _save(fig, out, "ndf_comparison.png")


def mitsuba_zoom(out, config, r):
    """The sphere of the largest n, rendered zoomed: each lobe's display and the FLIP maps, with the
    highlight outlined."""
    s = r["mitsuba_render"]
    z = s["zoom"]
    stats = {x["lobe"]: x for x in z["statistics"]}
    fig, axes = plt.subplots(1, 5, figsize=(16, 3.8))
    mask = s["zoom_highlight"] >= 0
    panels = [(s["zoom_display"][l], registry.LOBES[name].label(), None) for l, name in enumerate(MITSUBA_LOBES)]
    panels += [(s["zoom_flip_maps"][l].astype(np.float32),
                f"FLIP of {name}: {stats[name]['flip_highlight']:.3f}\nmean over the highlight", "magma")
               for l, name in enumerate(MITSUBA_LOBES[1:])]
    for ax, (image, title, cmap) in zip(axes, panels):
        if cmap:
            ax.imshow(image, cmap=cmap, vmin=0.0, vmax=1.0, interpolation="nearest")
        else:
            ax.imshow(image, interpolation="nearest")
        ax.contour(mask, levels=[0.5], colors="cyan", linewidths=0.6)
        ax.set_title(title, fontsize=9)
        ax.set_axis_off()
    fig.suptitle(f"Sphere n = {z['n']:g} rendered at {z['scale']}x the frame's resolution around its sun highlight "
                 f"({z['highlight_pixels']} highlight pixels, cyan)", fontsize=10)
    fig.tight_layout(rect=(0, 0, 1, 0.9))
    return _save(fig, out, "mitsuba_zoom.png", tight=False)


def vendor_rows(architectures) -> list[tuple[str, list[str]]]:
    """The architectures grouped by vendor, in the registry's order: a figure's rows."""
    return vendor_groups(architectures)


def cost_axis(vendor: str) -> str:
    """The x label of a vendor's cost: its model's unit."""
    return machine_code.vendor_backend(vendor).UNIT if vendor in VENDORS else "cycles"


LABEL_GAP_PX = 9        # smallest vertical distance between two labels of points of equal cost


def _settle(fig) -> None:
    """The axes' limits and positions as a draw would fix them (autoscaled limits, aspect), so that
    their transforms are final for `_stacked_labels` without drawing the figure one more time."""
    for ax in fig.axes:
        ax.apply_aspect()
        ax.get_xlim(), ax.get_ylim()        # (autoscales what is pending)


def _stacked_labels(fig, ax, labels, near: float = 3.5) -> None:
    """Labels of the points (x: [(d, text, color)]) on a drawn figure (its transforms final): the
    points of costs closer than `near` form one
    column of labels right of the column's largest cost, ordered by d and pushed apart vertically
    where they would overlap, each joined to its point by a thin line (the points keep their place)."""
    points = 72.0 / fig.dpi
    columns: list[list[float]] = []
    for x in sorted(labels):
        if columns and x - columns[-1][-1] < near:
            columns[-1].append(x)
        else:
            columns.append([x])
    for column in columns:
        right = ax.transData.transform((max(column), 1.0))[0] + 8
        placed = []
        for d, text, color, x in sorted((d, t, c, x) for x in column for d, t, c in labels[x]):
            x0, y0 = ax.transData.transform((x, 100 * d))
            y = y0 if not placed else max(y0, placed[-1] + LABEL_GAP_PX)
            placed.append(y)
            ax.annotate(text, (x, 100 * d), xytext=((right - x0) * points, (y - y0) * points - 2.5),
                        textcoords="offset points", fontsize=6.5, color=color,
                        arrowprops=dict(arrowstyle="-", lw=0.3, color=color, alpha=0.6))


def lobe_front(out, config, r):
    """Per architecture (rows) and n range (columns): max d against compiled cycles per wave, every
    searched family (circles; the front joined), the registry's lobes (squares; the paper's f_Q2
    starred). Points of equal cost keep their cost: their labels are stacked instead."""
    s = r["lobe_search"]
    if not s["candidates"]:
        fig, ax = plt.subplots(figsize=(8, 2))
        ax.axis("off")
        ax.text(0.5, 0.5, "No machine code, no fronts: " + s["reason"], ha="center", va="center", wrap=True)
        return _save(fig, out, "lobe_front.png", tight=False)
    architectures = list(dict.fromkeys(c["architecture"] for c in s["candidates"]))
    vendors = vendor_rows(architectures)
    ranges_ = s["ranges"]
    stacks = []
    fig, axes = plt.subplots(len(vendors), len(ranges_), figsize=(4.3 * len(ranges_), 3.8 * len(vendors)),
                             squeeze=False)
    for i, (vendor, archs) in enumerate(vendors):
        top = max(c["cycles"] for c in s["candidates"] if c["architecture"] in archs)
        for j, (lo, hi) in enumerate(ranges_):
            ax = axes[i, j]
            labels: dict = {}
            for k, architecture in enumerate(archs):
                # The vendor's first architecture in colour and labelled; the others' fronts in grey shades.
                main = k == 0
                shade = "C0" if main else str(0.35 + 0.45 * k / len(archs))
                rows = [c for c in s["candidates"] if c["architecture"] == architecture and c["n_range"] == [lo, hi]]
                front = sorted((c for c in rows if c["on_front"]), key=lambda c: c["cycles"])
                ax.step([c["cycles"] for c in front], [100 * c["d"] for c in front], where="post", color=shade,
                        lw=1.2 if main else 0.8, label=architecture if j == 0 else None)
                placed = [p for p in s["placements"] if p["architecture"] == architecture and p["n_range"] == [lo, hi]
                          and p["d"] > 0 and p["lobe"] != registry.REFERENCE]
                for c in rows:
                    if not c["admissible"]:     # below 0 somewhere: not a lobe, never on a front
                        ax.plot(c["cycles"], 100 * c["d"], "x", color="0.5", ms=4 if main else 3)
                        if main:
                            labels.setdefault(c["cycles"], []).append((c["d"], c["family"] + " (< 0)", "0.5"))
                        continue
                    ax.plot(c["cycles"], 100 * c["d"], "o", color=shade, ms=(5 if c["on_front"] else 3.5) if main else 3,
                            mfc=shade if c["on_front"] else "white")
                    if main:
                        labels.setdefault(c["cycles"], []).append((c["d"], c["family"], "C0"))
                for p in placed:
                    star = p["lobe"] == "f_Q2"
                    face = ("gold" if star else "C3") if main else shade
                    ax.plot(p["cycles"], 100 * p["d"], "*" if star else "s", color=face, mec="black" if star else face,
                            ms=(14 if star else 5) if main else (9 if star else 3.5), zorder=5 if main else 4)
                    if main:
                        labels.setdefault(p["cycles"], []).append((p["d"], p["label"], "black" if star else "C3"))
            ax.set(yscale="log", xlim=(-0.03 * top, top * 1.35))
            stacks.append((ax, labels))
            ax.grid(alpha=0.3, which="both")
            if i == 0:
                ax.set_title(f"n in [{lo:g}, {hi:g}]", fontsize=10)
            if j == 0:
                ax.set_ylabel(f"{VENDORS.get(vendor, vendor)}: {archs[0]} in colour\nmax d in the zone (%)", fontsize=9)
                if len(archs) > 1:
                    ax.legend(fontsize=6.5, loc="lower left", title="fronts", title_fontsize=6.5)
            ax.set_xlabel(cost_axis(vendor), fontsize=8)
    fig.suptitle("Cheap forms fitted per n (circles; filled: the front, joined; grey x: grammar forms below 0 "
                 "somewhere, not lobes) and the registry's lobes (squares; the paper's f_Q2 starred), one row per "
                 "vendor: its first architecture in colour and labelled, the others' points and fronts grey", fontsize=10,
                 wrap=True)
    fig.tight_layout(rect=(0, 0, 1, 0.97))
    _settle(fig)
    for ax, labels in stacks:
        _stacked_labels(fig, ax, labels)
    return _save(fig, out, "lobe_front.png", tight=False)
