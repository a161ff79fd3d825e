"""`report.md`: the check table, the stated choices, what differs from the paper, the figures."""

from __future__ import annotations

from pathlib import Path

from ..engine import checks as checks_mod
from ..engine import escape
from .report_beyond import at_power, embed, family, ns, pct as _pct
from .report_beyond import sections as beyond_sections
from .results import HEADLINE, headline
from .tables import front_markdown


def _paper(config, result: str) -> str:
    """The paper's value for a result, from the config's expectations ("not given" if none)."""
    return next((checks_mod.fmt(e.paper) for e in config.expectations if e.result == result), "not given")


def _choices(config, r) -> list[str]:
    z, q, lin, e, reg, h, f2 = (r[s] for s in ("zone", "q_scan", "linear_coefficient", "energy_dataset",
                                                 "sparse_regression", "hemispherical", "f2_errors"))
    Q_used = r["q_choice"]["Q_used"]
    sample = [int(v) for v in r["sample"]["sample_n"]]
    zone = (f"calibrated so that max d of f_2 over n in [{config['derivation.n_min']}, "
            f"{config['derivation.n_max']}] equals zone.calibration_target = "
            f"{_pct(config['zone.calibration_target'])} (the paper's P9)" if z["calibrated"]
            else "set in the config (zone.level)")
    return [
        "## Stated choices",
        f"- **Epicenter zone**: {{x : cos(x)^n >= L}} with L = {z['level']:.10f}, {zone}. "
        f"At this level max d of f_2 is {_pct(f2['d_f_2'])}, attained at n = {f2['d_f_2_n_at_max']:g}.",
        f"- **Q**: derivation.Q = {config['derivation.Q']!r}, metric {config['derivation.metric']}: coarse grid best "
        f"{q['Q_scan_coarse']:g}, fine grid best {q['Q_scan_best']:g}, continuous optimum "
        f"{q['Q_continuous_best']:.8f} (objective there {q['objective_at_continuous']:.6g}, "
        f"at the grid best {q['objective_at_scan_best']:.6g}); used: Q = {Q_used:g}. The two error measures "
        f"pull Q apart: on Fig. 3's curve max D is smallest, {q['curve_D_min']:.4f}, at Q = "
        f"{q['curve_Q_at_D_min']:.3f}, where max d is {_pct(q['curve_d_at_D_min'])} (configs/absolute_error.toml "
        "asks that question).",
        f"- **Linear coefficient**: {config['derivation.fit']} over every integer n in range: "
        f"k_Q(n) ~ {lin['lin_slope']:.8f} n + {lin['lin_intercept']:.8f} (max relative error "
        f"{_pct(lin['lin_max_rel_error'])}); large-n asymptote of k_Q: {lin['asymptotic_slope']:.8f} n + "
        f"{lin['asymptotic_intercept']:.8f}. Other least-squares fits of the same line: "
        + "; ".join(f"{v['variant']}: {v['slope']:.6f} n + {v['intercept']:.6f}" for v in lin["intercept_variants"])
        + f". The intercept that puts slope {config['paper_model.slope']:g} exactly on the 0.5 % bound at "
        f"n = {config['derivation.n_min']} is {lin['intercept_at_bound']:.6f}. Downstream constants: "
        f"**{config['derivation.constants']}**, k = {lin['slope_used']:g} n + {lin['intercept_used']:g}.",
        f"- **f_Q at large n**: max d of f_Q (Q = {Q_used:g}) grows with n; at n = 10^6 it is "
        f"{_pct(next(row['d'] for row in r['lobe_comparison']['large_n'] if row['lobe'] == 'f_Q' and row['n'] == 1e6))}"
        ", its supremum to 1e-6 (`lobe_comparison.large_n`).",
        f"- **Energy dataset**: Int(n) by {config['energy.quadrature_nodes']}-node Gauss-Legendre "
        f"quadrature over [0, gran(n)] for every n; the lobe's zero crossing lies past the horizon "
        f"(k < 1) for n = {ns(e['lobe_below_horizon_n'])}, where the paper's integral "
        f"includes a negative-cosine part.",
        f"- **Sample** ({r['sample']['sample_size']} points, y rounded to {config['sample.y_decimals']} decimals as in "
        f"newenergy.txt): n = {ns(sample)}. This design (every n up to {config['sample.consecutive_to']}, then "
        f"{config['sample.spread_count']} evenly spaced from {config['sample.spread_from']}) is chosen so "
        f"that the sample's mean y and RMS spread match TuringBot's size-1 row: here "
        f"{e['sample_mean_y']:.4f} and {e['sample_std_y']:.4f} (paper "
        f"{_paper(config, 'symbolic_regression.size1_constant')} and {_paper(config, 'symbolic_regression.size1_rms')}).",
        f"- **Sparse regression**: pysindy STLSQ over the library {', '.join(config['regression.library'])}, "
        f"{config['regression.threshold_count']} thresholds log-spaced in [{config['regression.threshold_min']:g}, "
        f"{config['regression.threshold_max']:g}]; two-term model {reg['coef_scale']:.8f} "
        f"({reg['coef_offset']:.8f} + n), RMS {reg['coef_rms']:.6g}.",
        f"- **Hemispherical check** with coef(n) = {h['coef_scale_used']:g} ({h['coef_offset_used']:g} + n).",
    ]


def _symbolic(config, r) -> list[str]:
    sr, ex = r["symbolic_regression"], r["exact_normalization"]
    fam = family(config["lobe.power"])
    exact = [m for m in sr["front"] if m["complexity"] == sr["sr_exact_complexity"]]
    rows = sr["paper_rows"]
    lines = [
        "## Symbolic regression: the paper's front, searched exhaustively", "",
        f"Every distinct expression in n built from fitted constants, n, {', '.join(config['symbolic.operations'])} "
        f"up to complexity {config['symbolic.max_complexity']} ({sr['forms_searched']} expressions; "
        "`pipeline/symbolic/grammar.py` lists the rules that drop duplicates) is fitted to the sample by least squares: "
        "the constants that enter linearly are solved exactly (variable projection) and the others screened from "
        f"{config['symbolic.starts']} deterministic starts of {config['symbolic.iterations']} Levenberg-Marquardt "
        f"steps each (more where the starts disagree), then the best {config['symbolic.refine']} of each complexity "
        f"refitted to convergence of the RMS from {config['symbolic.polish_starts']} starts. Complexity is "
        "TuringBot's as the paper's table implies it: constants, n, +, - and x count 1, / counts 2. Under this "
        "reading the paper's five rows have exactly their printed sizes: c (1), c n (3), c (c + n) (5), "
        "c n + c + c/n (10), c (c + c/(n - c) + n) (12).", "",
        "| complexity | RMS on the sample | sympy's canonical form | max rel. difference to the exact coef | "
        "max energy created | within the rounding step of the exact coef |", "|---|---|---|---|---|---|"]
    for m in sr["front"]:
        lines.append(f"| {m['complexity']} | {m['rms']:.4g} | {m['canonical']} | {m['max_rel_to_exact']:.3g} | "
                     f"{100 * max(m['max_energy_excess'], 0.0):.2g} % (n = {m['n_at_max_energy_excess']:g}) | "
                     f"{'yes' if m['equivalent_to_exact'] else 'no'} |")
    lines += ["", "The paper's rows, each fitted here as a form of its own:", "",
              "| size | form | constants here | RMS here | front's member at this size | its RMS |",
              "|---|---|---|---|---|---|"]
    for row in rows:
        consts = ", ".join(f"{k} {v:.6g}" for k, v in row["constants"])
        lines.append(f"| {row['size']} | {row['form']} | {consts} | {row['rms']:.4g} | "
                     f"{'the same form' if row['on_front'] else row['front_member']} | {row['front_rms']:.4g} |")
    lines += ["",
              f"**The paper's size-12 row is the exact normalization.** The exact coef = {fam['exact']}, "
              f"k = a n + b, is in partial fractions scale (offset + n + residue/(n - pole)) with scale = {fam['scale']} "
              f"= {sr['exact_scale']:.6f}, offset = {fam['offset']} = {sr['exact_offset']:.6f}, residue = {fam['residue']} "
              f"= {sr['exact_residue']:.6f}, pole = {fam['pole']} = {sr['exact_pole']:.6f}. TuringBot's printed row "
              f"differs from it by at most {sr['paper12_max_abs_to_exact']:.2g} (relative "
              f"{sr['paper12_max_rel_to_exact']:.2g}) over n in [{config['derivation.n_min']}, "
              f"{config['derivation.n_max']}], below the rounding step of y ({sr['equivalence_tolerance']:g}), and "
              f"creates at most {100 * max(sr['paper12_max_energy_excess'], 0.0):.2g} % energy. This run's size-12 member "
              f"has scale {sr['size12_scale']:.6f}, offset {sr['size12_offset']:.6f}, residue "
              f"{sr['size12_residue']:.6f}, pole {sr['size12_pole']:.6f} (RMS {sr['size12_rms']:.3g}; the rounding "
              f"alone gives {sr['rounding_rms_floor']:.2g}); the pole is the least determined constant, because it "
              "only shows at the few smallest n."]
    if exact:
        m = exact[0]
        lines += ["", f"The smallest front member within the rounding step of the exact coef at every n has complexity "
                  f"**{sr['sr_exact_complexity']}**: {m['expression']} = {m['canonical']}, i.e. scale "
                  f"{sr['sr_exact_scale']:.6f}, offset {sr['sr_exact_offset']:.6f}, residue "
                  f"{sr['sr_exact_residue']:.6f}, pole {sr['sr_exact_pole']:.6f} against the exact "
                  f"{sr['exact_scale']:.6f}, {sr['exact_offset']:.6f}, {sr['exact_residue']:.6f}, "
                  f"{sr['exact_pole']:.6f}; it stays within {m['max_abs_to_exact']:.2g} of the exact coef."]
    lines += ["", f"**Which member the sample supports.** By description length (the data at the noise of y's "
              f"rounding, the constants, the form; as `pipeline regress` selects), the size-"
              f"{sr['selected_complexity']} member {sr['selected_expression']}."]
    lines += ["", f"**What choosing size 5 cost.** The paper kept {config['paper_model.coef_scale']:g} "
              f"({config['paper_model.coef_offset']:g} + n) (P15). Against the exact coef it "
              f"reflects {_pct(-ex['paper_coef_max_abs_dev'])} at n = {ex['paper_coef_n_at_max_abs_dev']:g} and "
              f"creates up to {_pct(ex['paper_coef_max_excess'])} energy at n = {ex['paper_coef_n_at_max_excess']:g} "
              f"(`exact_normalization`); the size-12 row, or the exact coef itself, costs two more constants and "
              "one division."]
    return lines


def _differences(checks) -> list[str]:
    lines = ["## What differs from the paper"]
    differs = [c for c in checks if c.verdict in (checks_mod.DIFFERS, checks_mod.FAIL)]
    if not differs:
        lines.append("Every check is within its stated tolerance.")
    for c in differs:
        e = c.expectation
        lines.append(f"- **{e.id}** ({e.quantity}): paper {checks_mod.fmt(e.paper)}, reproduced "
                     f"{checks_mod.fmt(c.reproduced)} (deviation {c.deviation:.3g} > tolerance "
                     f"{e.tolerance:.3g}). {e.known_difference or 'No documented cause: this is a failure.'}")
    lines.append("")
    lines.append("Tolerances and their reasons:")
    lines += [f"- {c.expectation.id}: ± {c.expectation.tolerance:.3g}: {c.expectation.reason}" for c in checks]
    return lines


def _zone_table(r) -> list[str]:
    s, f2, z = r["accuracy"], r["f2_errors"], r["zone"]
    rows = ["| zone level L | max d f_2 | max d f_Q | max d f_Q2 | gain f_2 / f_Q2 |", "|---|---|---|---|---|"]
    for i, L in enumerate(f2["zone_levels"]):
        mark = " (used)" if abs(L - z["level"]) < 1e-12 else ""
        rows.append(f"| {L:.5f}{mark} | {_pct(f2['zone_d_f_2'][i])} | {_pct(s['zone_d_f_Q'][i])} | "
                    f"{_pct(s['zone_d_f_Q2'][i])} | {s['zone_gain'][i]:.2f} |")
    return rows


def _sample_table(reg) -> list[str]:
    rows = ["| sample | size | mean y | scale | offset | RMS |", "|---|---|---|---|---|---|"]
    for s in reg["sample_sensitivity"]:
        rows.append(f"| {s['sample']} | {s['size']} | {s['mean_y']:.4f} | {s['scale']:.6f} | "
                    f"{s['offset']:.6f} | {s['rms']:.3g} |")
    return rows


def _value(v) -> str:
    """A headline value in a table cell: numbers to 6 digits, a per-lobe dict as key value pairs."""
    if isinstance(v, dict):
        return ", ".join(f"{k} {_value(x)}" for k, x in v.items())
    return f"{v:.6g}" if isinstance(v, float | int) and not isinstance(v, bool) else str(v)


def _comparison(doc, baseline) -> list[str]:
    base = headline(baseline.results)
    changed = [f"`{k}`: {baseline.config[k]!r} -> {v!r}" for k, v in doc["config"].items()
               if k != "run.question" and baseline.config[k] != v]
    rows = ["## Compared with the paper's run", "", "Changed from the paper's config: " + "; ".join(changed) + ".",
            "", "| quantity | paper's run | this run |", "|---|---|---|"]
    for key in HEADLINE:
        rows.append(f"| {key} | {_value(base[key])} | {_value(doc['headline'][key])} |")
    return rows + [""]


# What each tool is for, and the name its version is given with.
TOOL_ROLES = {"llvm": ("LLVM, for Mitsuba's llvm_ad_rgb variant (Dr.Jit)", "LLVM "),
              "radv": ("Mesa's RADV, for AMD machine code (Vulkan ICD)", "Mesa "),
              "shader_tools": ("GLSL to SPIR-V", ""),
              "nvidia": ("NVIDIA's offline compiler, for NVIDIA machine code (`pipeline.isa.nvidia`)", ""),
              "intel": ("Intel's offline compiler (ocloc, IGA), for Intel machine code (`pipeline.isa.intel`)",
                        "intel-opencl-icd "),
              "mesa_mobile": ("Mesa's freedreno and panfrost compilers on drm-shim under qemu-user, for Adreno and "
                              "Mali machine code (`pipeline.isa.adreno`, `pipeline.isa.mali`)", "Mesa ")}


def tools_section(doc) -> list[str]:
    """What outside tools the run found (`results.json`'s `toolchains`) and the Mitsuba variant its
    renders ran, where it rendered."""
    lines = ["## Tools", ""]
    for tool, found in doc["toolchains"].items():
        role, named = TOOL_ROLES.get(tool, (tool, ""))
        if not found["missing"]:
            version = f"{named}{found['version']}, " if found["version"] else ""
            lines.append(f"- {role}: {version}`{found['path']}`")
        else:
            lines.append(f"- {role}: not usable: {found['missing']}")
    ran = {stage: doc["stages"][stage]["variant"] for stage in ("mitsuba_render", "microfacet_render")
           if stage in doc["stages"]}
    if ran:
        lines.append("- Mitsuba variant: " + ", ".join(f"{v} ({stage})" for stage, v in ran.items()))
    return lines


def write_targeted(path: Path, config, doc, checks, figures) -> None:
    """report.md of a targeted run (`--only`): what it computed, what it did not, its checks (those
    of stages it did not compute "not run"), the headline fields it has, and its figures."""
    ran = [stage for stage in doc["stages"]]
    lines = [f"# Targeted run `{config.name}`", ""]
    if config["run.question"]:
        lines += [f"**Question.** {escape.markdown(config['run.question'])}", ""]
    changed = [k for k in config.changed_from_file(config.values) if not k.startswith("run.")]
    if changed:
        lines += ["Settings changed from the config file: "
                  + ", ".join(f"`{k}` = {checks_mod.fmt(config[k])}" for k in changed) + ".", ""]
    lines += [f"Computed (`--only` and what it reads): {', '.join(ran)}.", "",
              f"Not run: {', '.join(doc['not_run'])}. Their fields, figures and tables are not in this "
              "folder, and the checks that read them are \"not run\". Run without `--only` for the whole "
              "derivation and its full report.", "",
              "## Checks", "", checks_mod.tally(checks) + ".", "", checks_mod.table(checks), "",
              "## Headline fields computed", "", "| field | value |", "|---|---|"]
    lines += [f"| `{path}` | {checks_mod.fmt(value)} |" for path, value in doc["headline"].items()
              if not isinstance(value, dict)]
    lines.append("")
    lines += tools_section(doc) + [""]
    drawn = [item for items in figures.values() for item in items]
    if drawn:
        lines += ["## Figures", ""] + [f"![{caption}]({name})\n" for name, caption in drawn]
    path.write_text(at_power("\n".join(lines), config["lobe.power"]))


def write(path: Path, config, doc, r, checks, figures, baseline=None, summary_lines=()) -> None:
    """Writes report.md; `figures` maps report sections to the (file, caption) drawn for them."""
    a = r["accuracy"]
    n_fail = sum(c.verdict == checks_mod.FAIL for c in checks)
    n_diff = sum(c.verdict == checks_mod.DIFFERS for c in checks)
    n_na = sum(c.verdict == checks_mod.NOT_COMPARABLE for c in checks)
    lines = [f"# Derivation of {family(config['lobe.power'])['title']}: run `{config.name}`", ""]
    lines += list(summary_lines)      # summary.md, the adopter's answer, first
    changed = [k for k in config.changed_from_file(config.values) if not k.startswith("run.")]
    if config["run.question"] and changed and "run.question" not in config.changed_from_file(["run.question"]):
        lines += [f"**Question of `{config.source}`** (this run changes {', '.join(changed)}): "
                  f"{escape.markdown(config['run.question'])}", ""]
    elif config["run.question"]:
        lines += [f"**Question.** {escape.markdown(config['run.question'])}", ""]
    lines += [f"Config: `{config.source}`. Checks: {len(checks) - n_fail - n_diff - n_na} pass, {n_diff} differ "
              f"with a documented cause, {n_fail} fail, {n_na} not comparable (this run's settings differ from "
              "those the expected value was reported for).", "",
              f"f_Q2 against f_2: max d {_pct(a['d_f_Q2'])} vs {_pct(r['f2_errors']['d_f_2'])} (gain "
              f"{a['epicenter_gain']:.3f}x), max D {a['D_f_Q2']:.5f} vs {r['f2_errors']['D_f_2']:.5f}. "
              f"f_Q2 ends where cos^n is still {_pct(a['cutoff_peak_fraction_at_n_max'])} of its peak at n = "
              f"{config['derivation.n_max']:g} ({_pct(a['cutoff_peak_fraction_limit'])} as n grows: exp(-1/a) for "
              "the line's slope a): its highlight has a sharp edge where the reference's still glows.", ""]
    if baseline is not None:
        lines += _comparison(doc, baseline)
    if checks:
        lines += ["## Checks against the paper", "", checks_mod.table(checks), ""]
    lines += _choices(config, r) + [""]
    if checks:
        lines += _differences(checks) + [""]
    lines += ["## Zone sensitivity", "",
              "How the epicenter figures move with the zone's level L. Where a lobe's max d comes from its "
              "interior stationary point, it does not depend on L at all.", ""] + _zone_table(r) + [""]
    lines += embed(figures, "zone")
    lines += _symbolic(config, r) + [""]
    reg = r["sparse_regression"]
    lines += ["## Sparse-regression front (pysindy)", "", front_markdown(reg), "",
              "## How the coef(n) constants move with the sample", "",
              f"Over the samples of {r['sample']['sample_size']} points below (y rounded), the two-term offset "
              f"ranges from {reg['sensitivity_offset_range'][0]:.4f} to {reg['sensitivity_offset_range'][1]:.4f} "
              f"and its RMS from {reg['sensitivity_rms_range'][0]:.2g} to {reg['sensitivity_rms_range'][1]:.2g}; the "
              f"one-term c n has c from {reg['sensitivity_one_term_scale_range'][0]:.6f} to "
              f"{reg['sensitivity_one_term_scale_range'][1]:.6f} and RMS from "
              f"{reg['sensitivity_one_term_rms_range'][0]:.4f} to {reg['sensitivity_one_term_rms_range'][1]:.4f}; "
              f"c n + c + c/n has RMS from {reg['sensitivity_three_term_rms_range'][0]:.2g} to "
              f"{reg['sensitivity_three_term_rms_range'][1]:.2g}. These spreads set the P14 tolerances.",
              ""] + _sample_table(reg)
    lines += ["", "## The paper's figures, reproduced", ""] + embed(figures, "paper")
    lines += beyond_sections(config, r, figures)
    lines += tools_section(doc) + [""]
    lines += ["## Files", "", "- `results.json`: every number (`headline` holds the main ones, as fractions)",
              "- `newenergy.csv`: the sample, like the paper's newenergy.txt; `energy_all_n.csv`: every n",
              "- `symbolic_front.csv`: the exhaustive symbolic-regression front; `regression_front.csv`: "
              "the pysindy front",
              "- `lobe_search_front.csv`: the lobe search's forms per architecture and range, and the registry's "
              "lobes placed among them, in the columns of `pipeline derive`'s front.csv", ""]
    path.write_text(at_power("\n".join(lines), config["lobe.power"]))
