"""summary.md: the adopter's answer in one screen, also at the top of report.md.

The run's question and a one-sentence answer, a decision table (one row per use: the function to
call from the exported shader, its normalization, the largest albedo, the accuracy, the cost, the
verdict) and the three facts that most change the decision. Every number is a field of the run's
results (results.json).
"""

from __future__ import annotations

from .report_beyond import at_power, machine_row, machine_text, pct


def _cost(results, key: str) -> str:
    """A lobe's cost per pixel: its RDNA3 machine code (gpu_isa), with the SPIR-V count after
    spirv-opt (shader_cost) as the second figure; SPIR-V alone where the machine code was not
    measured, said so."""
    sc, row = results["shader_cost"], machine_row(results, key)
    spirv = next((r for r in sc["lobes"] if r["lobe"] == key), None) if sc["available"] else None
    spirv_text = (f"SPIR-V: {spirv['arithmetic']} arithmetic, {spirv['division']} division, "
                  f"{spirv['transcendental']} transcendental" if spirv else "SPIR-V not counted")
    if row is None:
        return f"machine-code cost not measured; {spirv_text}"
    return f"RDNA3: {machine_text(row)} ({spirv_text})"


def _half(results):
    """(largest float16 error of f_Q2 by the 1 - N.H route, by the cross-product route, at n) at the
    largest rendered exponent."""
    rows = [r for r in results["half_precision"]["rows"] if r["lobe"] == "f_Q2"]
    n = max(r["n"] for r in rows)
    at = {r["route"]: r["max_abs_error"] for r in rows if r["n"] == n}
    t_route = next(v for route, v in at.items() if route.startswith("1 - "))
    u_route = next(v for route, v in at.items() if not route.startswith("1 - "))
    return t_route, u_route, n


def _ndf_cost(results, lobe: str) -> str:
    row = machine_row(results, lobe, "NDF")
    return f"{row['net_cycles_per_wave']:g}" if row else "?"


def _ndf_row(results, n_lo, n_hi) -> str:
    """The decision row for the lobe as the D of a Cook-Torrance BRDF."""
    nd, mr = results["ndf"], results["microfacet_render"]
    power = results["gpu_isa"].get("power", 2) if results["gpu_isa"]["available"] else 2
    f_Qm = f"f_Q{power}"
    cost = (f"RDNA3, D alone: {_ndf_cost(results, f_Qm)} cycles per wave; Beckmann {_ndf_cost(results, 'Beckmann')}, "
            f"GGX {_ndf_cost(results, 'GGX')}" if results["gpu_isa"]["available"] else "machine-code cost not measured")
    seen = mr["f_Q2_distinguishable_count"]
    verdict = (f"a look of its own: distinguishable from Beckmann on {seen} of {len(mr['exponents'])} spheres"
               if seen else "indistinguishable from Beckmann in these renders")
    return (f"| microfacet NDF (Cook-Torrance), D(h) of t = N.H | cosquad_ndf(max(dot(N, H), 0.0), n) * G * F / "
            f"(4 N.L N.V) | the exact Phong coef (int D (N.H) dw_h = 1; the Blinn-form coef would be "
            f"{nd['blinn_to_ndf_coef_ratio_at_n_max']:.3f}x of it at n = {n_hi}) | projected area 1 within "
            f"{nd['projected_area_max_abs_dev_f_Q2']:.1e} | against Beckmann at alpha = sqrt(2 / (n + 2)): d "
            f"{pct(nd['d_f_Q2_vs_beckmann'])}, D {nd['D_f_Q2_vs_beckmann']:.3f} of its peak (n = {n_lo} to {n_hi}); "
            f"FLIP over the highlights up to {mr['flip_f_Q2_vs_beckmann_max']:.3f} (GGX: "
            f"{mr['flip_ggx_vs_beckmann_max']:.3f}) | {cost} | {verdict} |")


def lines(config, results) -> list[str]:
    a, alb, e = results["accuracy"], results["directional_albedo"], results["exact_normalization"]
    h, lin = results["hemispherical"], results["linear_coefficient"]
    n_lo, n_hi = config["derivation.n_min"], config["derivation.n_max"]
    t_route, u_route, n_half = _half(results)
    whose = "paper's" if config["derivation.constants"] == "paper" else "run's fitted"
    accuracy = f"max d {pct(a['d_f_Q2'])}, max D {a['D_f_Q2']:.4f} (n = {n_lo} to {n_hi})"
    out = ["## Summary: should a renderer ship f_Q2?", ""]
    if config["run.question"]:
        out += [f"**Question.** {config['run.question']}", ""]
    out += [f"**Answer.** For n = {n_lo} to {n_hi}, f_Q2 = (({lin['slope_used']:.6g} n + {lin['intercept_used']:.6g})"
            f"(cos x - 1) + 1)^{config['lobe.power']} stays within {pct(a['d_f_Q2'])} of cos^n in the epicenter zone "
            f"({a['epicenter_gain']:.2f}x closer than f_2) and within {a['D_f_Q2']:.4f} anywhere, with no "
            "transcendental instruction; normalize it with the exact coefs, not a scale (offset + n) fit.", "",
            "| use | call (shader/cosquad.glsl) | normalization | largest albedo | accuracy | cost | verdict |",
            "|---|---|---|---|---|---|---|",
            f"| empirical Phong lobe, t = R.V | cosquad_coef_exact(n) * cosquad_lobe(max(dot(R, V), 0.0), n) "
            f"| exact Phong coef | {alb['phong_exact_coef_max']:.6f} | {accuracy} | {_cost(results, 'f_Q2')} "
            f"| ship; cos^n costs {_cost(results, 'f_b')} |",
            f"| empirical Blinn lobe, t = N.H | cosquad_coef_blinn(n) * cosquad_lobe(max(dot(N, H), 0.0), n) "
            f"| exact Blinn coef ({e['blinn_to_phong_ratio_at_n_max']:.3f}x the Phong one at n = {n_hi}) "
            f"| {alb['blinn_exact_coef_max']:.6f} | the same lobe of t | the same | ship with its own coef |",
            f"| half precision (mediump), Blinn form | cosquad_lobe_u(cosquad_u(N, H), n) | as above | as above "
            f"| largest float16 error at n = {n_half:g}: {u_route:.3g} (t route: {t_route:.3g}) | the same, and a "
            "cross product | ship the u route |",
            _ndf_row(results, n_lo, n_hi), "",
            "Three facts that change the decision:", "",
            f"1. The {whose} coef {h['coef_scale_used']:.6g} ({h['coef_offset_used']:.6g} + n) is not the exact one: "
            f"it reflects up to {pct(e['paper_coef_max_excess'])} more than arrives (n = "
            f"{e['paper_coef_n_at_max_excess']:g}) and {pct(-e['paper_coef_max_deficit'])} less at n = "
            f"{e['paper_coef_n_at_max_abs_dev']:g}.",
            f"2. The Blinn form needs its own coef: with the Phong coef it reflects up to "
            f"{alb['blinn_with_phong_coef_max']:.2f}x what arrives (n = {alb['blinn_with_phong_coef_n_at_max']:g}).",
            f"3. f_Q2 ends where cos^n is still {pct(a['cutoff_peak_fraction_at_n_max'])} of its peak at n = {n_hi} "
            f"({pct(a['cutoff_peak_fraction_limit'])} as n grows): its highlight has a sharp edge where the "
            f"reference's still glows, and its visible highlight is {results['render']['visible_area_ratio_f_Q2']:.2f} "
            f"of the reference's ({results['render']['visible_area_scene']}, n = "
            f"{results['render']['visible_area_ratio_n']:g}).", ""]
    return out


def write(path, config, results) -> list[str]:
    """Writes summary.md; returns its lines as written before `at_power` (report.md applies it once)."""
    text = lines(config, results)
    path.write_text(at_power("\n".join(text), config["lobe.power"]))
    return text
