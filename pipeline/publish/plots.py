"""The drawing functions of the figures (matplotlib). `pipeline.publish.figures` registers them:
each is passed only the config keys and stage results its entry declares, and returns the files
it wrote.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

PAPER = dict(color="black", marker="*", markersize=12, linestyle="none", zorder=5)
# PNG compression level 1: files ~1.5x larger than the default 6, written several times faster.
FAST_PNG = {"compress_level": 1}
OBJECTIVE = {"relative_epicenter": "d", "absolute": "D", "rms": "rms"}


def n_of(config) -> np.ndarray:
    """Every exponent n of the run, as the stages' per-n arrays hold them."""
    return np.arange(config["derivation.n_min"], config["derivation.n_max"] + 1, dtype=np.float64)


def paper_value(config, result_path):
    """The paper's value for a result, from the config's expectations (None if it has none)."""
    for e in config.expectations:
        if e.result == result_path:
            return e.paper
    return None


def _save(fig, out: Path, name: str) -> str:
    fig.tight_layout()
    fig.savefig(out / name, dpi=110, pil_kwargs=FAST_PNG)
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
    p = paper_value(config, "accuracy.d_f_Q")
    if p is not None:
        ax.plot([0.64], [100 * p], **PAPER, label=f"paper: Q = 0.64, d = {100 * p:.3f} %")
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
    p = paper_value(config, "f2_errors.D_f_2")
    if p is not None:
        ax.plot([0.99], [p], **PAPER, label=f"paper: max D of f_2 = {p}")
    ax.set(xlabel="Q", ylabel="max absolute error D over x in [0, pi/2]",
           title="Fig. 3: max D over n of f_Q and f_2 versus Q")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    return _save(fig, out, "fig3_D_vs_Q.png")


def fig4(out, config, r):
    s, n = r["linear_coefficient"], n_of(config)
    fig, ax = plt.subplots(figsize=(7, 4.2))
    ax.plot(n, 100 * s["paper_line_rel_error"], label="paper's line 0.448 n + 0.099")
    ax.plot(n, 100 * s["lin_rel_error"], ls="--",
            label=f"this run's {config['derivation.fit']} line {s['lin_slope']:.6f} n + {s['lin_intercept']:.6f}")
    for b in (-0.5, 0.5):
        ax.axhline(b, color="black", lw=0.8, ls=":")
    ax.set(xscale="log", xlabel="specular exponent n", ylabel="relative error of the line vs k_Q(n) (%)",
           title=f"Fig. 4: linear approximation of k_Q(n), Q = {r['q_choice']['Q_used']:.4g} "
                 "(dotted: paper's 0.5 % bound)")
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
    s, n = r["accuracy"], n_of(config)
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
    ax.plot(n_of(config), s["y"], label="y(n) = 1 / (2 pi Int(n)), every n")
    ax.plot(r["sample"]["sample_n"], s["sample_y"], "o", ms=4,
            label=f"{r['sample']['sample_size']}-point sample (newenergy.csv)")
    p = paper_value(config, "energy_dataset.y_n2_to_10")
    if p is not None:
        ax.plot(np.arange(2, 2 + len(p)), p, **{**PAPER, "markersize": 8}, label="paper's printed values, n = 2..10")
    ax.set(xscale="log", yscale="log", xlabel="n", ylabel="ideal normalization y(n)",
           title="Fig. 7: ideal energy-normalization coefficients of f_Q2")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3, which="both")
    return _save(fig, out, "fig7_dataset.png")


def fig9(out, config, r):
    s = r["sparse_regression"]
    fig, ax = plt.subplots(figsize=(8, 5.2))
    sizes = [len(m["terms"]) for m in s["front"]]
    ax.plot(sizes, [m["rms"] for m in s["front"]], "o-", label="this run: pysindy STLSQ sweep")
    ax.plot([1], [s["constant_model_rms"]], "s", color="C0", label="this run: constant (sample mean)")
    # TuringBot's rows by number of terms: constant, c n, c (a + n), c n + b + a / n.
    keys = [(1, "sparse_regression.constant_model_rms"), (1, "sparse_regression.one_term_rms"),
            (2, "sparse_regression.coef_rms"), (3, "sparse_regression.three_term_rms")]
    pts = [(size, paper_value(config, key)) for size, key in keys]
    pts = [(size, v) for size, v in pts if v is not None]
    if pts:
        ax.plot([p[0] for p in pts], [p[1] for p in pts], **{**PAPER, "markersize": 9},
                label="paper (TuringBot), by number of terms")
    ax.set(yscale="log", xlabel="number of terms", ylabel="RMS error on the sample",
           title="Fig. 9: complexity / error front of coef(n)")
    ax.set_xticks(sorted(set(sizes) | {1}))
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3, which="both")
    text = "\n".join(f"{len(m['terms'])} terms: {m['expression']}" for m in s["front"])
    fig.text(0.01, 0.01, text, fontsize=7, family="monospace", va="bottom")
    fig.tight_layout(rect=(0, 0.03 * (len(s["front"]) + 1), 1, 1))
    fig.savefig(out / "fig9_front.png", dpi=110, pil_kwargs=FAST_PNG)
    plt.close(fig)
    return "fig9_front.png"


def fig10(out, config, r):
    s, e, h, n = r["sparse_regression"], r["energy_dataset"], r["hemispherical"], n_of(config)
    fig, (a, b) = plt.subplots(2, 1, figsize=(7, 6), sharex=True, height_ratios=(2, 1))
    a.plot(r["sample"]["sample_n"], e["sample_y"], "o", ms=4, label="sample")
    fitted = s["coef_scale"] * (s["coef_offset"] + n)
    used = h["coef_scale_used"] * (h["coef_offset_used"] + n)
    a.plot(n, fitted, label=f"fit: {s['coef_scale']:.6f} ({s['coef_offset']:.6f} + n)")
    a.plot(n, used, ls="--", label=f"used: {h['coef_scale_used']:.6g} ({h['coef_offset_used']:.6g} + n)")
    a.set(xscale="log", yscale="log", ylabel="coef(n)", title="Fig. 10: dataset and fitted coef(n)")
    a.legend(fontsize=8)
    b.plot(n, fitted - e["y"], label="fit - y(n)")
    b.plot(n, used - e["y"], ls="--", label="used - y(n)")
    b.set(xlabel="n", ylabel="residual")
    b.legend(fontsize=8)
    for ax in (a, b):
        ax.grid(alpha=0.3, which="both")
    return _save(fig, out, "fig10_coef_fit.png")


def fig11(out, config, r):
    h = r["hemispherical"]
    fig, ax = plt.subplots(figsize=(7, 4.2))
    ax.plot(n_of(config), h["deviation"], label="coef(n) 2 pi Int(n) - 1")
    p = paper_value(config, "hemispherical.hemi_max_abs_dev")
    if p is not None:
        ax.plot([2], [-p], **PAPER, label=f"paper: max |deviation| = {p}")
    ax.axhline(0, color="black", lw=0.8)
    ax.set(xscale="log", xlabel="n", ylabel="hemispherical reflectivity - 1",
           title=f"Fig. 11: deviation from 1 (max |dev| = {h['hemi_max_abs_dev']:.4g} at n = {h['hemi_n_at_max']:g})")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    return _save(fig, out, "fig11_hemispherical.png")


def zone_sensitivity(out, config, r):
    s, z = r["accuracy"], r["zone"]
    fig, ax = plt.subplots(figsize=(7, 4.2))
    for name in ("f_2", "f_Q", "f_Q2"):
        source = r["f2_errors"] if name == "f_2" else s
        ax.plot(r["f2_errors"]["zone_levels"], 100 * source[f"zone_d_{name}"], "o-", label=f"max d of {name}")
    ax.axvline(z["level"], color="grey", lw=0.8, label=f"level used L = {z['level']:.5f}")
    ax.set(yscale="log", xlabel="zone level L (epicenter = {cos^n x >= L})", ylabel="max d (%)",
           title="Epicenter figures versus the zone's level")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3, which="both")
    return _save(fig, out, "zone_sensitivity.png")


def exact_normalization(out, config, r):
    e, h, n = r["exact_normalization"], r["hemispherical"], n_of(config)
    fig, (a, b) = plt.subplots(1, 2, figsize=(12, 4.4))
    a.plot(n, e["energy_run"], label=f"run's coef {h['coef_scale_used']:g} ({h['coef_offset_used']:g} + n)")
    a.plot(n, e["asymptotic_phong_dev"], ls="--", label="(3 / (2 pi)) (k + 1/4)  [= -1/(16 k^2)]")
    a.axhline(0, color="black", lw=0.8, label="exact coef = 6 k^2 / (pi (4 k - 1))")
    if e["excess_ranges"]:
        lo, hi = e["excess_ranges"][0]
        a.axvspan(lo, hi, color="C3", alpha=0.08, label="energy created: n = " + ", ".join(f"{a:g} to {b:g}" for a, b in e["excess_ranges"]))
    a.set(xscale="log", xlabel="n", ylabel="coef(n) 2 pi Int(n) - 1 (reflected / received - 1)",
          title=f"Phong form: largest excess {e['paper_coef_max_excess']:+.2e} at n = "
                f"{e['paper_coef_n_at_max_excess']:g}", ylim=(-0.07, 0.01))
    b.plot(n, e["asymptotic_blinn_dev"], ls="--", color="C1", label="(3 / (8 pi)) (k + 5/4)")
    b.axhline(0, color="black", lw=0.8, label="exact Blinn coef (see report)")
    b.set(xscale="log", xlabel="n", ylabel="coef_B(n) 2 pi Int_B(n) - 1",
          title=f"Blinn form (N.H): own normalization; at n = {n[-1]:g} it is "
                f"{e['blinn_to_phong_ratio_at_n_max']:.4f} x the Phong one")
    for ax in (a, b):
        ax.legend(fontsize=7)
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


def lobe_comparison(out, config, r):
    c, n = r["lobe_comparison"], n_of(config)
    fig, (a, b) = plt.subplots(1, 2, figsize=(12, 4.6))
    for i, lobe in enumerate(c["lobes"]):
        if lobe["tag"] == "cosn":
            continue
        d, D = c["d_curves"][i], c["D_curves"][i]
        a.plot(n, 100 * d, label=f"{lobe['name']} ({100 * d.max():.3f} %)")
        b.plot(n, D, label=f"{lobe['name']} ({D.max():.4f})")
    a.set(xscale="log", yscale="log", xlabel="n", ylabel="max relative error d in epicenter zone (%)",
          title="Cheap lobes against cos^n: d per n (max in legend)")
    b.set(xscale="log", xlabel="n", ylabel="max absolute error D over [0, pi/2]",
          title="... and D per n")
    for ax in (a, b):
        ax.legend(fontsize=7)
        ax.grid(alpha=0.3, which="both")
    return _save(fig, out, "lobe_comparison.png")


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
                label = ("reference cos^n (Giesen)" if lobe == "cos^n" else
                         f"{lobe} ({'Giesen' if normalization == 'reference' else 'exact Blinn coef'})")
                ax.set_title(f"{label}, {scene}", fontsize=9)
        fig.suptitle(f"n = {n:g}: Blinn form (t = N.H), normalization: {normalization}; Reinhard tone map, sRGB",
                     fontsize=10, y=1 - 0.1 / height)
        # A fixed layout: tight_layout would draw these large images once more just to measure them.
        fig.subplots_adjust(left=0.005, right=0.995, bottom=0.005, top=1 - 0.6 / height, wspace=0.02,
                            hspace=0.2 / (res / 100))
        name = f"render_n{n:g}.png"
        fig.savefig(out / name, dpi=100, pil_kwargs=FAST_PNG)
        plt.close(fig)
        names.append(name)
    return names


def render_errors(out, config, r):
    """Per exponent: relative and absolute luminance error of each candidate, with colour bars."""
    s = r["render"]
    names = []
    candidates = [l for l, lobe in enumerate(s["lobes"]) if lobe != "cos^n"]
    for j, n in enumerate(config["render.exponents"]):
        fig, axes = plt.subplots(len(candidates), 2 * len(s["scenes"]),
                                 figsize=(4.2 * 2 * len(s["scenes"]), 3.8 * len(candidates)), squeeze=False)
        for row, l in enumerate(candidates):
            for i, scene in enumerate(s["scenes"]):
                ref = s["luminance"][i, j, 0].astype(np.float64)
                cand = s["luminance"][i, j, l].astype(np.float64)
                rel = np.where(ref > 1e-3, np.abs(cand - ref) / np.maximum(ref, 1e-3), 0.0)
                for col, (data, label, cmap) in enumerate(((100 * np.minimum(rel, 1.0), "relative error (%), capped at 100", "magma"),
                                                           (np.abs(cand - ref), "absolute error (linear luminance)", "viridis"))):
                    ax = axes[row, 2 * i + col]
                    im = ax.imshow(data, cmap=cmap, interpolation="nearest")
                    ax.set_axis_off()
                    ax.set_title(f"{s['lobes'][l]}, {scene}: {label}", fontsize=8)
                    fig.colorbar(im, ax=ax, fraction=0.046, pad=0.02)
        fig.suptitle(f"n = {n:g}: error against the reference cos^n", fontsize=10)
        fig.subplots_adjust(left=0.01, right=0.97, bottom=0.02, top=0.9, wspace=0.15, hspace=0.15)
        name = f"render_errors_n{n:g}.png"
        fig.savefig(out / name, dpi=90, pil_kwargs=FAST_PNG)
        plt.close(fig)
        names.append(name)
    return names
