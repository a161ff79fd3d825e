"""The derivation's stage graph, declared by fields: what each stage reads and what it returns.

Each stage names the config keys it reads (`reads`; `section.*` for a whole section), the upstream
fields it reads (`inputs`, as `stage.field`) and every field it returns (`outputs`: name -> meaning
and unit or range). The runner passes a stage exactly its declared config keys and input fields,
checks that it returned exactly its declared outputs, and keys its cache on those values
(`pipeline.engine.cache`) and on the outside tools it runs (`tools`, as
`pipeline.engine.toolchains` finds them). Nothing here imports JAX, sympy or pysindy: `pipeline graph`, `pipeline keys`
and config validation (which checks every expectation's result path against `OUTPUTS`) are
answered from this module alone.

The stages' code lives in `pipeline.stages.<name>` (a function `run(config, inputs, memo)`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from types import MappingProxyType

from . import toolchains

RANGE = ("derivation.n_min", "derivation.n_max")
POWER = ("lobe.power",)      # the family's power m: every stage that evaluates f_Q or f_Q2 reads it


@dataclasses.dataclass(frozen=True)
class Stage:
    """One stage: its name, the config keys and upstream fields it reads, and its outputs."""

    name: str
    paper: str
    reads: tuple[str, ...]
    inputs: tuple[str, ...]
    outputs: Mapping[str, str]
    # The outside tools it runs (`pipeline.engine.toolchains`): what was found enters its cache key.
    tools: tuple[str, ...] = ()

    @property
    def module(self) -> str:
        return f"pipeline.stages.{self.name}"

    @property
    def upstream(self) -> tuple[str, ...]:
        """The stages this one reads fields of, in first-read order."""
        return tuple(dict.fromkeys(path.split(".", 1)[0] for path in self.inputs))


def _stage(name, paper, reads, inputs, outputs, tools=()) -> Stage:
    return Stage(name, paper, tuple(reads), tuple(inputs), MappingProxyType(dict(outputs)), tuple(tools))


PER_N = "array over n in [n_min, n_max]"

STAGES: tuple[Stage, ...] = (
    _stage("zone", "undefined in the paper", RANGE + ("zone.level", "zone.calibration_target", "solver.*"), (), {
        "level": "level L of the epicenter zone {x : cos^n x >= L} [in (0, 1)]",
        "calibrated": "whether L was solved for from zone.calibration_target [bool]",
    }),
    _stage("q_scan", "Figs. 2, 3", RANGE + POWER + ("derivation.metric", "scan.*", "solver.*"), ("zone.level",), {
        "coarse_Q": "the coarse Q grid [array]",
        "coarse_objective": "the metric's objective on the coarse grid [array, fraction]",
        "Q_scan_coarse": "best Q on the coarse grid [in (0, 1)]",
        "fine_Q": "the refined Q grid around the coarse best [array]",
        "fine_objective": "the objective on the fine grid [array]",
        "Q_scan_best": "best Q on the fine grid [in (0, 1)]",
        "Q_continuous_best": "continuous optimum of the objective [in (0, 1)]",
        "objective_at_scan_best": "objective at Q_scan_best [fraction or absolute]",
        "objective_at_continuous": "objective at Q_continuous_best [fraction or absolute]",
        "d_f_Q_at_continuous": "max d of f_Q at Q_continuous_best [fraction]",
        "D_f_Q_at_continuous": "max D of f_Q at Q_continuous_best [absolute]",
        "curve_Q": "Q values of the Fig. 2/3 curves [array]",
        "curve_d": "max d over n of f_Q per curve_Q [array, fraction]",
        "curve_D": "max D over n of f_Q per curve_Q [array, absolute]",
        "curve_rms": "max relative RMS error over n of f_Q per curve_Q [array, fraction]",
        "curve_D_min": "smallest max D on the curve (Fig. 3's minimum) [absolute]",
        "curve_Q_at_D_min": "the curve's Q there [in (0, 1)]",
        "curve_d_at_D_min": "max d of f_Q at that Q [fraction]",
    }),
    _stage("q_choice", "Sec. 2", ("derivation.Q",), ("q_scan.Q_scan_best", "q_scan.Q_continuous_best"), {
        "Q_used": "Q of f_Q used downstream: the grid best, the continuous optimum or a set value [in (0, 1)]",
    }),
    _stage("sample", "newenergy.txt", RANGE + ("sample.consecutive_to", "sample.spread_from", "sample.spread_count"),
           (), {
        "sample_n": "the regression sample's exponents n [array]",
        "sample_size": "number of sample points [count]",
    }),
    _stage("linear_coefficient", "Fig. 4",
           RANGE + POWER + ("derivation.fit", "derivation.constants", "paper_model.slope", "paper_model.intercept",
                    "paper_model.line_max_rel_error", "solver.*"),
           ("q_choice.Q_used", "sample.sample_n"), {
        "k_Q": f"k_Q(n) at Q_used [{PER_N}]",
        "lin_slope": "slope of the fitted line through k_Q(n) [1]",
        "lin_intercept": "intercept of the fitted line [1]",
        "lin_max_rel_error": "max over n of |line / k_Q - 1| [fraction]",
        "lin_rel_error": f"line / k_Q - 1 [{PER_N}]",
        "paper_line_rel_error": f"paper's line / k_Q - 1 [{PER_N}]",
        "paper_line_max_rel_error": "max over n of |paper's line / k_Q - 1| [fraction]",
        "asymptotic_slope": "large-n slope of k_Q(n): (1 - Q^(1/m)) / (-ln Q) (m = 2: 1 - sqrt Q) [1]",
        "asymptotic_intercept": "large-n intercept of k_Q(n): (1 - Q^(1/m)) / 2 [1]",
        "slope_minus_asymptote": "lin_slope - asymptotic_slope: the fit against theory [1]",
        "intercept_variants": "slope and intercept of other least-squares fits (other n, relative weights) [list]",
        "intercept_at_bound": "intercept putting the paper's slope on its 0.5 % bound at n_min [1]",
        "slope_used": "slope a of k = a n + b used downstream (paper's or fitted) [1]",
        "intercept_used": "intercept b of k = a n + b used downstream [1]",
    }),
    _stage("f2_errors", "Figs. 6, P9, P10", RANGE + ("zone.sensitivity_levels", "solver.*"), ("zone.level",), {
        **{f"{m}_f_2": f"max over n of {what} of f_2 = ((n/2)(cos x - 1) + 1)^2 [{unit}]"
           for m, what, unit in (("d", "the relative error d in the zone", "fraction"),
                                 ("D", "the absolute error D on [0, pi/2]", "absolute"),
                                 ("rms", "the relative RMS error over the lobe", "fraction"))},
        "d_f_2_curve": f"d of f_2 per n [{PER_N}]", "D_f_2_curve": f"D of f_2 per n [{PER_N}]",
        "d_f_2_n_at_max": "n where max d of f_2 is attained [n]",
        "D_f_2_n_at_max": "n where max D of f_2 is attained [n]",
        "D_f_2_x_at_max": "angle x where max D of f_2 is attained [rad]",
        "zone_levels": "zone levels of the sensitivity table: zone.sensitivity_levels and the level used [array]",
        "zone_d_f_2": "max d of f_2 per zone level [array, fraction]",
    }),
    _stage("accuracy", "Figs. 5, 6", RANGE + POWER + ("solver.*",),
           ("zone.level", "q_choice.Q_used", "linear_coefficient.slope_used", "linear_coefficient.intercept_used",
            "f2_errors.d_f_2", "f2_errors.D_f_2", "f2_errors.zone_levels", "f2_errors.zone_d_f_2"),
           {
        **{f"{m}_{lobe}": f"max over n of {what} of {lobe} [{unit}]"
           for lobe in ("f_Q2", "f_Q")
           for m, what, unit in (("d", "the relative error d in the zone", "fraction"),
                                 ("D", "the absolute error D on [0, pi/2]", "absolute"),
                                 ("rms", "the relative RMS error over the lobe", "fraction"))},
        **{f"{m}_{lobe}_curve": f"{m} of {lobe} per n [{PER_N}]" for lobe in ("f_Q2", "f_Q") for m in "dD"},
        **{f"{m}_{lobe}_n_at_max": f"n where max {m} of {lobe} is attained [n]"
           for lobe in ("f_Q2", "f_Q") for m in "dD"},
        **{f"D_{lobe}_x_at_max": f"angle x where max D of {lobe} is attained [rad]" for lobe in ("f_Q2", "f_Q")},
        "epicenter_gain": "max d of f_2 / max d of f_Q2 [ratio]",
        "cutoff_peak_fraction_curve": f"cos^n at f_Q2's zero crossing 1 - 1/k, a fraction of its peak [{PER_N}]",
        "cutoff_peak_fraction_at_n_max": "the same at n_max [fraction]",
        "cutoff_peak_fraction_limit": "its large-n limit exp(-1/a), a the line's slope [fraction]",
        "zone_gain": "the same at each zone level of f2_errors.zone_levels [array, ratio]",
        "absolute_gain": "max D of f_2 / max D of f_Q2 [ratio]",
        "D_f_Q_zone_edge_x": "zone edge x at the n where f_Q's max D is attained [rad]",
        "D_f_Q_in_blooming_zone": "f_Q's max D lies outside the epicenter zone [bool]",
        "D_f_Q_below_f_2": "max D of f_Q < max D of f_2 [bool]",
        "D_f_Q_below_f_2_in_blooming_zone": "both of the above (the paper's P4) [bool]",
        **{f"zone_d_{lobe}": f"max d of {lobe} per zone level of f2_errors.zone_levels [array, fraction]"
           for lobe in ("f_Q2", "f_Q")},
        "fig5_x": "angles of Fig. 5 [array, rad]",
        "fig5_f_b": "cos^20 x [array]", "fig5_f_2": "f_2 at n = 20 [array]", "fig5_f_Q2": "f_Q2 at n = 20 [array]",
        "fig5_zone_edge_x": "zone edge at n = 20 [rad]",
    }),
    _stage("energy_dataset", "Fig. 7", RANGE + POWER + ("energy.*", "sample.y_decimals"),
           ("linear_coefficient.slope_used", "linear_coefficient.intercept_used", "sample.sample_n"), {
        "Int": f"Int(n) = int_0^gran f_Q2 cos sin dg [{PER_N}]",
        "y": f"ideal normalization y(n) = 1 / (2 pi Int(n)) [{PER_N}, 1/sr]",
        "gran": f"zero crossing gran(n) of f_Q2 [{PER_N}, rad]",
        "sample_y": "y at the sample's n, rounded to sample.y_decimals [array, 1/sr]",
        "sample_mean_y": "mean of sample_y [1/sr]",
        "sample_std_y": "RMS spread of sample_y about its mean [1/sr]",
        "y_n2_to_10": "y(n) for n = 2..10 in range [array, 1/sr]",
        "lobe_below_horizon_n": "n whose zero crossing lies past the horizon (k < 1) [array]",
    }),
    _stage("sparse_regression", "Figs. 9, 10", RANGE + ("regression.*", "sample.*"),
           ("sample.sample_n", "energy_dataset.sample_y", "energy_dataset.y"), {
        "front": "one model per distinct STLSQ support: terms, coefficients, RMS [list]",
        "coef_scale": "scale of the two-term model scale (offset + n) [1/sr]",
        "coef_offset": "offset of the two-term model [n]",
        "coef_rms": "RMS error of the two-term model on the sample [1/sr]",
        "constant_model": "size-1 model: the sample mean [1/sr]",
        "constant_model_rms": "RMS of the sample about its mean [1/sr]",
        "sample_sensitivity": "two-term constants for other samples of the same kind [list]",
        "sensitivity_offset_range": "[min, max] two-term offset over the samples of the configured size [n]",
        "sensitivity_rms_range": "[min, max] two-term RMS over the samples of the configured size [1/sr]",
        "sensitivity_three_term_rms_range": "[min, max] RMS of c n + c + c/n over the same samples [1/sr]",
        "sensitivity_one_term_scale_range": "[min, max] c of the model c n over the same samples [1/sr]",
        "sensitivity_one_term_rms_range": "[min, max] RMS of c n over the same samples [1/sr]",
        "one_term_scale": "coefficient c of the one-term model c n [1/sr]",
        "one_term_rms": "RMS error of c n on the sample [1/sr]",
        "three_term_n": "coefficient of n in c_n n + c_1 + c_-1/n [1/sr]",
        "three_term_1": "constant of the three-term model [1/sr]",
        "three_term_inv_n": "coefficient of 1/n of the three-term model [1/sr]",
        "three_term_rms": "RMS error of the three-term model [1/sr]",
    }),
    _stage("hemispherical", "Fig. 11",
           RANGE + ("derivation.constants", "paper_model.coef_scale", "paper_model.coef_offset"),
           ("energy_dataset.Int", "sparse_regression.coef_scale", "sparse_regression.coef_offset"), {
        "coef_scale_used": "scale of coef(n) used downstream (paper's or fitted) [1/sr]",
        "coef_offset_used": "offset of coef(n) used downstream [n]",
        "deviation": f"coef(n) 2 pi Int(n) - 1 [{PER_N}]",
        "hemi_max_abs_dev": "max over n of |coef(n) 2 pi Int(n) - 1| [fraction]",
        "hemi_n_at_max": "n where it is attained [n]",
        "hemi_max_excess": "max over n of coef(n) 2 pi Int(n) - 1 (> 0: energy created) [fraction]",
        "hemi_excess_ranges": "contiguous [first, last] n where it is > 0 [list]",
    }),
    _stage("exact_normalization", "beyond", RANGE + POWER + ("albedo.quadrature_nodes",),
           ("linear_coefficient.slope_used", "linear_coefficient.intercept_used", "energy_dataset.Int",
            "hemispherical.coef_scale_used", "hemispherical.coef_offset_used"), {
        "coef_exact": f"exact Phong-form coef(n) = 1 / (2 pi Int_hemisphere) [{PER_N}, 1/sr]",
        "coef_blinn": f"exact Blinn-form coef(n) at normal view [{PER_N}, 1/sr]",
        "Int_hemisphere": f"Int(n) over the upper hemisphere, closed form [{PER_N}]",
        "Int_gran": f"the paper's Int(n) up to gran, closed form [{PER_N}]",
        "energy_run": f"coef(n) 2 pi Int_hemisphere(n) - 1 with the run's coef [{PER_N}]",
        "paper_coef_max_excess": "max of energy_run (> 0: energy created) [fraction]",
        "paper_coef_n_at_max_excess": "n where it is attained [n]",
        "paper_coef_max_abs_dev": "max of |energy_run| [fraction]",
        "paper_coef_max_deficit": "min of energy_run (< 0: energy lost) [fraction]",
        "paper_coef_n_at_max_abs_dev": "n where it is attained [n]",
        "excess_ranges": "contiguous [first, last] n where energy_run > 0 [list]",
        "excess_count": "number of n where energy_run > 0 [count]",
        "exact_coef_max_abs_dev": "max |coef_exact 2 pi Int - 1| by the albedo quadrature at normal incidence [fraction]",
        "dataset_quadrature_max_rel_dev": "max |Int (quadrature) / Int_gran (closed form) - 1| [fraction]",
        "below_horizon_n": "n with k < 1 [array]",
        "below_horizon_Int_difference": "Int_hemisphere - Int_gran there [array]",
        "below_horizon_coef": "exact coef there [array, 1/sr]",
        "below_horizon_coef_gran": "coef from the paper's integral there [array, 1/sr]",
        "formula_Int": "Int(k), sympy [text]", "formula_Int_gran": "Int up to gran(k), sympy [text]",
        "formula_coef": "coef(k), sympy [text]", "formula_Int_blinn": "Int_B(k), sympy [text]",
        "formula_coef_blinn": "coef_B(k), sympy [text]",
        "formula_expansion_k": "large-k expansion of coef(k) [text]",
        "formula_expansion_blinn_k": "large-k expansion of coef_B(k) [text]",
        "formula_expansion_n": "large-n expansion of coef(n) [text]",
        "code_coef": "generated jax code of coef(n) [text]", "code_coef_blinn": "generated jax code of coef_B(n) [text]",
        "expansion_n": "coefficient of n in the expansion [1/sr]", "expansion_1": "its constant [1/sr]",
        "expansion_inv_n": "its coefficient of 1/n [1/sr]",
        "expansion_scale": "two-term expansion as scale (offset + n): scale [1/sr]",
        "expansion_offset": "... and offset [n]",
        "asymptotic_phong_dev": f"(c_1 k + c_0) / coef_exact - 1 (m = 2: (3/(2pi))(k + 1/4)) [{PER_N}]",
        "asymptotic_blinn_dev": f"(c_1 k + c_0) / coef_blinn - 1 (m = 2: (3/(8pi))(k + 5/4)) [{PER_N}]",
        "asymptotic_phong_terms": "[c_1, c_0] of the Phong form's two-term large-k coef [list]",
        "asymptotic_blinn_terms": "[c_1, c_0] of the Blinn form's two-term large-k coef [list]",
        "asymptotic_phong_max_abs_dev": "max |asymptotic_phong_dev| [fraction]",
        "asymptotic_phong_max_excess": "max asymptotic_phong_dev [fraction]",
        "asymptotic_blinn_max_abs_dev": "max |asymptotic_blinn_dev| [fraction]",
        "asymptotic_blinn_max_excess": "max asymptotic_blinn_dev [fraction]",
        "blinn_to_phong_ratio_at_n_max": "coef_blinn / coef_exact at n_max [ratio]",
    }),
    _stage("symbolic_regression", "Fig. 9, P14",
           RANGE + POWER + ("symbolic.*", "sample.*", "paper_model.turingbot_size12"),
           ("sample.sample_n", "energy_dataset.sample_y", "energy_dataset.y", "exact_normalization.coef_exact",
            "exact_normalization.Int_gran",
            "linear_coefficient.slope_used", "linear_coefficient.intercept_used"), {
        "front": "Pareto front of complexity against RMS: form, constants, canonical text, RMS, distance to the exact coef [list]",
        "forms_searched": "distinct expressions enumerated and fitted [count]",
        "forms_by_complexity": "expressions enumerated at each complexity [dict]",
        "front_complexities": "complexities of the front's members [list]",
        "best_rms_by_complexity": "lowest RMS at each complexity, on the front or not [dict, 1/sr]",
        "equivalence_tolerance": "max |member - 1/(2 pi Int_gran)| over n (the dataset's closed form; the exact coef "
                                 "where k >= 1) below which a member counts as the exact form: the rounding step of y [1/sr]",
        "rounding_rms_floor": "RMS that rounding y alone leaves, step / sqrt(12) (0 if y is not rounded) [1/sr]",
        "sr_exact_complexity": "smallest complexity whose front member is the exact coef within that tolerance (-1: none) [count]",
        "selected_complexity": "the front member of least description length (data at y's rounding noise, constants, "
                               "form; `pipeline regress`'s model selection) [count]",
        "selected_expression": "that member [text]",
        "sr_exact_expression": "that member [text]",
        "sr_exact_scale": "its scale in the form scale (offset + n + residue/(n - pole)) [1/sr]",
        "sr_exact_offset": "its offset [n]",
        "sr_exact_residue": "its residue [n^2]",
        "sr_exact_pole": "its pole [n]",
        "exact_form_on_front": "whether the front's size-12 member is the exact form scale (offset + n + residue/(n - pole)) "
                               "with four free constants, within the tolerance [bool]",
        "exact_form_expression": "that member (empty if not) [text]",
        "exact_form_max_rel_dev": "largest relative difference of its four constants from the closed-form ones "
                                  "(NaN if not on the front) [fraction]",
        "exact_scale": "the exact coef's scale, (m + 1) a / (2 pi) (m = 2: 3a/(2 pi)) [1/sr]",
        "exact_offset": "the exact coef's offset, (b + c)/a, c = 1/(m + 2) (m = 2: (4b + 1)/(4a)) [n]",
        "exact_residue": "the exact coef's residue, c^2/a^2 (m = 2: 1/(16 a^2)) [n^2]",
        "exact_pole": "the exact coef's pole, (c - b)/a (m = 2: (1 - 4b)/(4a)) [n]",
        "paper_rows": "the paper's five rows fitted as forms of their own, each beside the front's member at its size [list]",
        "size1_constant": "the paper's size-1 form fitted here: constant constant [1/sr, n]",
        "size1_rms": "RMS error of the paper's size-1 form on the sample [1/sr]",
        "size1_on_front": "whether the front's member of complexity 1 is that form (equal RMS) [bool]",
        "size3_c": "the paper's size-3 form fitted here: constant c [1/sr, n]",
        "size3_rms": "RMS error of the paper's size-3 form on the sample [1/sr]",
        "size3_on_front": "whether the front's member of complexity 3 is that form (equal RMS) [bool]",
        "size5_scale": "the paper's size-5 form fitted here: constant scale [1/sr, n]",
        "size5_offset": "the paper's size-5 form fitted here: constant offset [1/sr, n]",
        "size5_rms": "RMS error of the paper's size-5 form on the sample [1/sr]",
        "size5_on_front": "whether the front's member of complexity 5 is that form (equal RMS) [bool]",
        "size10_n": "the paper's size-10 form fitted here: constant n [1/sr, n]",
        "size10_1": "the paper's size-10 form fitted here: constant 1 [1/sr, n]",
        "size10_inv_n": "the paper's size-10 form fitted here: constant inv_n [1/sr, n]",
        "size10_rms": "RMS error of the paper's size-10 form on the sample [1/sr]",
        "size10_on_front": "whether the front's member of complexity 10 is that form (equal RMS) [bool]",
        "size12_scale": "the paper's size-12 form fitted here: constant scale [1/sr, n]",
        "size12_offset": "the paper's size-12 form fitted here: constant offset [1/sr, n]",
        "size12_residue": "the paper's size-12 form fitted here: constant residue [1/sr, n]",
        "size12_pole": "the paper's size-12 form fitted here: constant pole [1/sr, n]",
        "size12_rms": "RMS error of the paper's size-12 form on the sample [1/sr]",
        "size12_on_front": "whether the front's member of complexity 12 is that form (equal RMS) [bool]",
        "paper_row_sample_ranges": "[min, max] of each of those constants and RMS over the samples of the configured size [dict]",
        "paper_rows_on_front": "how many of the paper's five forms are the front's member at their size [count]",
        "best_below_12_rms": "lowest RMS of the front below complexity 12 [1/sr]",
        "paper12_max_abs_to_exact": "max over n of |the paper's printed size-12 row - exact coef| [1/sr]",
        "paper12_max_rel_to_exact": "max over n of |the paper's size-12 row / exact coef - 1| [fraction]",
        "paper12_max_energy_excess": "max over n of the paper's size-12 row / exact coef - 1 (> 0: energy created) [fraction]",
    }),
    _stage("directional_albedo", "beyond", RANGE + POWER + ("albedo.*",),
           ("linear_coefficient.slope_used", "linear_coefficient.intercept_used", "hemispherical.coef_scale_used",
            "hemispherical.coef_offset_used", "exact_normalization.coef_exact", "exact_normalization.coef_blinn"), {
        "theta": "incidence angles [array, rad]",
        "curve_n": "exponents of the drawn curves [array]",
        **{f"{v}_{m}": f"{what} ({v.replace('_', ' ')}) [{unit}]"
           for v in ("phong_run_coef", "phong_exact_coef", "blinn_exact_coef", "blinn_asymptotic_coef",
                     "blinn_with_phong_coef")
           for m, what, unit in (("max", "largest albedo over n and angle", "fraction of the received energy"),
                                 ("n_at_max", "n of the largest albedo", "n"),
                                 ("theta_at_max_deg", "angle of the largest albedo", "deg"),
                                 ("normal_max_abs_dev", "max |a(0) - 1| over n", "fraction"),
                                 ("curves", "albedo at curve_n x theta", "array"),
                                 ("normal", "albedo at normal incidence", PER_N),
                                 ("peak_at_normal", "albedo largest at normal incidence for every n", "bool"))},
        "quadrature_error": "largest change of a table with twice the nodes [absolute]",
        "monte_carlo": "Monte Carlo cross-check rows: form, n, angle, quadrature, estimate, s.e., z [list]",
        "monte_carlo_max_abs_z": "largest |z| of the Monte Carlo rows [standard errors]",
        "monte_carlo_worst_point": "that point drawn again with 16 independent seeds: the z of each, their mean "
                                   "and spread [dict]",
        "importance_sampling": "the same points estimated with the lobe's closed-form importance sampler: form, n, "
                               "angle, quadrature, estimate, s.e., z, and the uniform cap's s.e. [list]",
        "importance_sampling_max_abs_z": "largest |z| of those rows [standard errors]",
        "reciprocity_max_rel_dev": "max |f(L, V) / f(V, L) - 1| on random pairs [fraction]",
    }),
    _stage("lobe_comparison", "beyond", RANGE + POWER + ("solver.*", "albedo.quadrature_nodes", "comparison.*"),
           ("zone.level", "q_choice.Q_used", "q_scan.Q_continuous_best", "linear_coefficient.slope_used",
            "linear_coefficient.intercept_used", "hemispherical.coef_scale_used", "hemispherical.coef_offset_used"), {
        "lobes": "the compared lobes: registry key, label, formula, operations per pixel and per material [list]",
        "d_max": "max over n of d, per compared lobe (registry key; f_Q also at the continuous optimum of Q) "
                 "[dict, fraction]",
        "D_max": "max over n of D, per compared lobe [dict, absolute]",
        "rows": "energy rows: lobe, form, normalization key, d, D, albedo errors, operations [list]",
        "d_curves": "d per n of each lobe, in the order of `lobes` [array lobes x n, fraction]",
        "D_curves": "D per n of each lobe [array lobes x n, absolute]",
        "quadrature_error": "largest change of an albedo table with twice the nodes [absolute]",
        "per_n": "per pair of lobes and measure (d, D): the [first, last] n where each is better [list]",
        "large_n": "d and D of every lobe at n = 10^4 and 10^6, their limits as n grows (within 1e-6) [list]",
    }),
    _stage("half_precision", "beyond", POWER + ("render.exponents",),
           ("linear_coefficient.slope_used", "linear_coefficient.intercept_used"), {
        "rows": "per n, lobe and route for 1 - cos x: distinct float16 values over the visible highlight, and "
                "the largest absolute error against float64, executed, and by numpy's per-operation emulation; "
                "the largest at every float16 input in [0, 1] against the float64 lobe at that input "
                "(max_abs_error_every_input, every_input_at the input; and the emulation's) [list]",
        "samples": "angles sampled per n [count]",
        "every_input": "the float16 values of [0, 1], each executed per lobe and n [count]",
        "executed_by": "what computed the lobes in float16: lavapipe, or the emulation and why [text]",
    }, tools=("lavapipe",)),
    _stage("shader_cost", "beyond", POWER, (), {
        "available": "whether glslangValidator and spirv-opt were found [bool]",
        "tools": "their versions, or what is missing [text]",
        "lobes": "per lobe: GLSL body, optimized-SPIR-V instruction counts (arithmetic, division, "
                 "transcendental) and each opcode [list, instructions per pixel]",
    }),
    _stage("gpu_isa", "beyond", POWER + ("front.powers",), (), {
        "available": "whether any vendor's compiler ran (RADV: the Vulkan loader, the driver, the vulkan "
                     "package; NVIDIA: ptxas and cuobjdump) [bool]",
        "reason": "why none did, where none did [text]",
        "missing": "per vendor whose compiler did not run here: why [dict]",
        "power": "the run's power m, whose family row is the run's fitted lobe [count]",
        "devices": "what compiled each architecture (RADV's device name, ptxas's version) [dict]",
        "rows": "per shader and architecture: architecture (rdna3, ..., sm_120), vendor, family (the chip its "
                "compiler was told), lobe, what (a registry lobe alone at the paper's power 2, with a "
                "normalization and n per pixel, or the family at one power; an NDF per material, or Beckmann and "
                "GGX with n per pixel), n_per (material or pixel), instructions (math instructions, net of the "
                "wrapper), special (special-function or transcendental instructions, net), cycles (net, by "
                "cost_model: aco-perfinfo on AMD, nvidia-throughput on NVIDIA), the vendor's own counts and their "
                "net values, and the listing [list]",
        "pow_transcendental": "special-function instructions of cos^n = pow(t, n) (fewest over the architectures; "
                              "-1: not measured) [count]",
        "family_transcendental_max": "most special-function instructions of any power of the family (f_Q2, f_Q3, "
                                     "...; -1: not measured) [count]",
    }, tools=toolchains.MACHINE_CODE),
    _stage("power_front", "beyond",
           RANGE + ("derivation.metric", "derivation.fit", "front.powers", "scan.coarse_step",
                    "scan.fine_step", "solver.*", "albedo.quadrature_nodes", "comparison.albedo_angles"),
           ("zone.level",), {
        "powers": "the front's powers m [list]",
        "members": "per power: name f_Qm, its best Q and fitted line, max d and D over n and per n range, the "
                   "largest albedo with its exact coef (Phong, Blinn), the multiplies of its power [list]",
        "d_curves": "d per n of each power, in the order of `powers` [array powers x n, fraction]",
        "D_curves": "D per n of each power [array powers x n, absolute]",
    }),
    _stage("lobe_search", "beyond", RANGE + ("lobe_search.*", "solver.*", "comparison.grid_cells"),
           ("zone.level", "lobe_comparison.lobes", "lobe_comparison.d_curves", "lobe_comparison.D_curves",
            "gpu_isa.rows", "gpu_isa.power"), {
        "available": "whether any vendor's compiler compiled the families (cycles and fronts; without one, fits and "
                     "errors only) [bool]",
        "reason": "why not, where it did not [text]",
        "devices": "the driver's device name per chip family [dict]",
        "target": "what the forms approximate: cos_n, or beckmann (Beckmann's D over its peak, a^2 = 2/(n + 2)) [text]",
        "n_grid": "exponents at which every family is fitted: log-spaced points over each range, ends included [array]",
        "ranges": "the n ranges of the fronts, within [n_min, n_max] [list]",
        "families": "the searched families (optics.lobe_families) [list]",
        "grammar_searched": "forms of the grammar (in w = n (1 - t)) screened beside the families [count]",
        "grammar_kept": "those kept and fitted per n (grammar_1, grammar_2, ... in members) [list]",
        "per_n": "per form: scaled parameters q, shader parameters (A, B, C; families), d and D (exact for the "
                 "families, dense grids for the grammar's forms) and the fit's error on the zone's points at each n "
                 "of n_grid [list]",
        "members": "per form and range: formula, max d and D over the grid's n, the grid check, the parameters "
                   "as lines in n (derive's polish on the box; line_box_error, its error there) and the max d and D "
                   "of those lines over every integer n, whether it is a lobe (admissible: >= 0 on the whole "
                   "hemisphere at every n); where a line is not enough and formula_complexity > 0, the parameters "
                   "as derive's formulas (formulas, parameter_formulas in full precision, formula_complexity, "
                   "d_formula, D_formula; the lines' values otherwise) [list]",
        "line_enough": "a line in n is enough where its max d is at most this times the per-n optimum's [ratio]",
        "candidates": "the members per architecture with compiled cycles, predicted cycles and on_front [list]",
        "front": "per architecture and range, the members no cheaper or equal-cost member beats on d: architecture, "
                 "n_range, family, expression, cycles (compiled), cycles_predicted, d, D, parameters [list]",
        "placements": "the registry's lobes per architecture and range: cycles, d, D, on_front, the front member "
                      "that beats them at no more cycles and their d over its d [list]",
        "grid_check_max": "largest relative excess of a family's zone error halfway between grid points over its "
                          "maximum on the grid, over ranges and families [fraction]",
        "cycles_prediction_max_error": "per architecture, the largest |predicted - compiled| cycles over the "
                                       "families [dict, cycles per wave]",
        "cost_tables": "cycles per operation per architecture, fitted to its machine code of forms with uniform "
                       "constants (gpu_costs) [dict]",
        "cost_tables_held_out": "the tables' error on held-out forms [dict]",
    }, tools=toolchains.MACHINE_CODE),
    _stage("render", "beyond", ("render.*",) + RANGE + POWER,
           ("zone.level", "linear_coefficient.slope_used", "linear_coefficient.intercept_used",
            "f2_errors.d_f_2_curve", "accuracy.d_f_Q2_curve"), {
        "lobes": "rendered lobes, reference first [list]",
        "scenes": "rendered scenes [list]",
        "display": "displayed images: scene x n x lobe x H x W x RGB [array, uint8 sRGB]",
        "luminance": "linear luminance: scene x n x lobe x H x W [array, float32]",
        "statistics": "per scene, n, candidate lobe: image errors against the reference (epicenter relative "
                      "error and its analytic bound, the lobe's d at that n; FLIP over the frame and the visible "
                      "highlight, absolute error, PSNR) [list]",
        "flip_maps": "FLIP error maps: scene x n x candidate x H x W [array, float16 in [0, 1]]",
        "visible_areas": "per scene and n: pixels of each lobe's visible highlight [list, pixels]",
        "shipped_display": "f_Q2 with its own exact Blinn-form coef, as an adopter ships it: scene x n x H x W x RGB "
                           "[array, uint8 sRGB]",
        "shipped_statistics": "per scene and n: that coef, its ratio to the reference's (the normalized peaks' "
                              "ratio), and the mean FLIP over the visible highlight against the reference, as "
                              "shipped and at equal peak [list]",
        "visible_area_ratio_f_Q2": "f_Q2's visible highlight over the reference's, first scene, largest n [ratio]",
        "visible_area_ratio_n": "that n [1]",
        "visible_area_scene": "that scene [text]",
        "flip_f_Q2_max": "worst mean FLIP of f_Q2 over the visible highlight [in [0, 1]]",
        "flip_f_2_max": "worst mean FLIP of f_2 over the visible highlight [in [0, 1]]",
        "psnr_f_Q2_min": "worst PSNR of f_Q2's displayed images [dB]",
        "psnr_f_2_min": "worst PSNR of f_2's displayed images [dB]",
    }),
    _stage("ndf", "beyond", RANGE + POWER,
           ("zone.level", "linear_coefficient.slope_used", "linear_coefficient.intercept_used",
            "exact_normalization.coef_blinn"), {
        "alpha": f"Beckmann roughness matched to n, sqrt(2 / (n + 2)) [{PER_N}]",
        **{f"coef_{k}": f"NDF normalization of {k} (int D (n.h) dw_h = 1: the Phong-form coef) [{PER_N}, 1/sr]"
           for k in ("f_b", "f_2", "f_Q2")},
        **{f"projected_area_max_abs_dev_{k}": f"max over n of |int D (n.h) dw_h - 1| for {k}, by quadrature [fraction]"
           for k in ("f_b", "f_2", "f_Q2")},
        **{f"d_{k}_vs_beckmann": f"max over n of d of {k} as an NDF against Beckmann at the matched alpha [fraction]"
           for k in ("f_b", "f_2", "f_Q2", "ggx")},
        **{f"D_{k}_vs_beckmann": f"max over n of D of {k} against Beckmann, as a fraction of Beckmann's peak [fraction]"
           for k in ("f_b", "f_2", "f_Q2", "ggx")},
        **{f"d_{k}_vs_beckmann_at_n_max": f"d of {k} against Beckmann at n_max [fraction]"
           for k in ("f_b", "f_2", "f_Q2", "ggx")},
        **{f"D_{k}_vs_beckmann_at_n_max": f"D of {k} against Beckmann at n_max [fraction]"
           for k in ("f_b", "f_2", "f_Q2", "ggx")},
        "beckmann_projected_area_max_abs_dev": "the same quadrature on Beckmann's D, a check of it [fraction]",
        "lobes": "the lobes compared as NDFs (then GGX in the curves) [list]",
        "d_curves": "d per n against Beckmann: f_b, f_2, f_Q2, GGX [array 4 x n, fraction]",
        "D_curves": "D per n against Beckmann [array 4 x n, fraction of the peak]",
        "blinn_to_ndf_coef_ratio_at_n_max": "the Blinn-form coef over the NDF coef of f_Q2 at n_max: how much darker "
                                            "the Blinn-form coef would make the NDF [ratio]",
    }),
    _stage("microfacet_render", "beyond", POWER + ("mitsuba.*", "albedo.quadrature_nodes"),
           ("linear_coefficient.slope_used", "linear_coefficient.intercept_used"), {
        "variant": "Mitsuba variant that ran [text]",
        "spp": "samples per pixel of each render [count]",
        "render_seconds": "time of the renders [s]",
        "exponents": "n of the three spheres [list]",
        "alphas": "the matched Beckmann/GGX roughness of each sphere [list]",
        "ndfs": "the rendered NDFs: beckmann (the reference), ggx, f_b, f_2, f_Q2 [list]",
        "display": "8-bit display images, in the order of ndfs [array]",
        "flip_maps": "FLIP maps of each candidate against Beckmann [array]",
        "statistics": "per candidate NDF and n: mean FLIP over the sun highlight against Beckmann, the FLIP of "
                      "Beckmann's two seeds there (noise), and whether the candidate is distinguishable [list]",
        "flip_f_Q2_vs_beckmann_max": "largest mean FLIP of f_Q2 as an NDF against Beckmann over a highlight [in [0, 1]]",
        "flip_ggx_vs_beckmann_max": "largest mean FLIP of GGX against Beckmann over a highlight [in [0, 1]]",
        "f_Q2_distinguishable_count": "spheres where f_Q2 as an NDF is distinguishable from Beckmann [count]",
    }, tools=("llvm",)),
    _stage("mitsuba_render", "beyond", POWER + ("mitsuba.*", "albedo.quadrature_nodes"),
           ("linear_coefficient.slope_used", "linear_coefficient.intercept_used", "zone.level"), {
        "variant": "Mitsuba variant that ran (llvm_ad_rgb, or the scalar_rgb fallback) [text]",
        "spp": "samples per pixel of each render [count]",
        "render_seconds": "time of the path-traced renders [s]",
        "exponents": "n of the three spheres, left to right [list]",
        "display": "8-bit display images: cos^n, f_2, f_Q2, f_Q2 with cosine-weighted sampling [array]",
        "flip_maps": "FLIP error maps of f_2 and f_Q2 against cos^n [array]",
        "highlight": "per pixel, the sphere whose visible sun highlight (the sun's direct specular term of some lobe adds >= 1 display level) it is in, or -1 [array]",
        "epicenter": "pixels of the highlights where cos^n(N.H) >= L [array]",
        "statistics": "per lobe and n: mean FLIP over the highlight, its epicenter share, RMS difference and noise [list]",
        "flip_frame": "mean FLIP over the frame, per lobe [dict]",
        "sampling": "per n: variance over the sphere of f_Q2 with its sampler and with cosine-weighted sampling [list]",
        "flip_f_Q2_max": "largest mean FLIP of f_Q2 over a sphere's highlight [in [0, 1]]",
        "flip_f_2_max": "largest mean FLIP of f_2 over a sphere's highlight [in [0, 1]]",
        "f_Q2_closer_count": "spheres whose highlight f_Q2 renders closer to cos^n than f_2, by FLIP [count]",
        "zoom": "the sphere of the largest n rendered zoomed: its n, the scale, the crop window, its highlight "
                "pixels (>= 1500 where the scale allows) and per lobe the mean FLIP over them [dict]",
        "zoom_display": "the zoomed 8-bit displays: cos^n, f_2, f_Q2 [array]",
        "zoom_flip_maps": "FLIP maps of f_2 and f_Q2 against cos^n in the zoom [array]",
        "zoom_highlight": "per zoomed pixel, the sphere whose visible highlight it is in, or -1 [array]",
        "noise_to_difference_max": "largest ratio of Monte Carlo noise to the lobe difference over a highlight [ratio]",
    }, tools=("llvm",)),
    _stage("decision", "beyond", RANGE + POWER + ("decision.*",),
           ("q_choice.Q_used", "linear_coefficient.slope_used", "linear_coefficient.intercept_used",
            "hemispherical.coef_scale_used", "hemispherical.coef_offset_used",
            "lobe_comparison.lobes", "lobe_comparison.d_curves", "lobe_comparison.D_curves", "lobe_comparison.rows",
            "gpu_isa.available", "gpu_isa.reason", "gpu_isa.rows",
            "power_front.members", "power_front.d_curves", "power_front.D_curves",
            "lobe_search.ranges", "lobe_search.n_grid", "lobe_search.families", "lobe_search.members",
            "lobe_search.candidates", "lobe_search.per_n", "ndf.lobes", "ndf.d_curves", "ndf.D_curves"), {
        "available": "whether machine code was measured, so that scenarios could be decided [bool]",
        "reason": "why not, where it was not [text]",
        "rule": "the declared rule with the run's budgets, as text [text]",
        "budgets": "decision.max_d, decision.max_D and decision.max_energy_excess [dict]",
        "candidates": "per candidate, use (lobe: against cos^n; ndf: against Beckmann) and n range: max d and D at "
                      "equal peak, the normalized peak over the reference's, the float16 error and its route, cycles "
                      "per architecture with n per material, and per pixel each normalization's cycles, largest "
                      "albedo and float16 error, and its descriptor (what `optics/lobe_candidates.py` makes it from) [list]",
        "table": "per architecture, n range, use (phong, blinn, ndf), n_per (material, pixel) and precision (fp32, "
                 "fp16): winner, runner_up, reason, qualifying candidates and the winner's cycles, d, D, peak ratio "
                 "and float16 error [list]",
        "facts": "the facts that change the common case's answer (n per pixel, fp16, the spherical Gaussian's class, "
                 "the normalized peak), each with the scenarios it changes, most first [list]",
        "per_n": "the common case's winner per architecture at each n of the lobe search's grid, by the same rule "
                  "on the candidates' d and D at that n (the search's forms at their per-n fit) [dict]",
        "paper_line_vs_per_n_optimum": "per range: f_Q2's max d with the run's line, the per-n minimax optimum of its "
                                       "own family (square_peak1, Beaudoin and Guardado's table) and their ratio [list]",
        "fp16_executed_by": "what computed the candidates' float16 errors: lavapipe, or the emulation and why [text]",
        "fp16_changed_by_execution": "the fp16 scenarios whose winner differs between the float16 errors as executed "
                                     "and as numpy's per-operation emulation, with both winners [list]",
    }),
    _stage("lobe_renders", "beyond", (), ("lobe_search.ranges", "decision.candidates", "decision.table"), {
        "rule": "when a render counts as invisible (`approximate.measures.rendered.RULE`) [text]",
        "statistic": "the FLIP statistic the rule reads [text]",
        "thresholds": "per n range: the rule's threshold in its scene and the spheres' roughness [list]",
        "candidates": "per lobe candidate and n range: FLIP mean, 99th percentile and largest against cos^n over the "
                      "material balls, and whether invisible [list]",
        "table": "per architecture and n range (Blinn lobe, n per material, fp32): the decision's winner by max d and "
                 "the cheapest invisible candidate, their cycles and largest FLIP, and whether they differ [list]",
        "differs": "scenarios whose rendered answer differs from the max-d answer [count]",
        "seconds": "time of the renders [s]",
    }),
)

BY_NAME: Mapping[str, Stage] = MappingProxyType({s.name: s for s in STAGES})
PAPER_STAGES = ("zone", "q_scan", "q_choice", "sample", "linear_coefficient", "f2_errors", "accuracy", "energy_dataset",
                "sparse_regression", "hemispherical", "exact_normalization", "symbolic_regression")


def output_paths() -> tuple[str, ...]:
    """Every declared output as `stage.field`."""
    return tuple(f"{s.name}.{f}" for s in STAGES for f in s.outputs)


def validate() -> None:
    """Raises ValueError unless every input is an earlier stage's declared output (the graph is a DAG)."""
    seen: set[str] = set()
    for s in STAGES:
        for path in s.inputs:
            if path not in seen:
                raise ValueError(f"stage '{s.name}' reads '{path}', which no earlier stage declares")
        seen.update(f"{s.name}.{f}" for f in s.outputs)


def expand_patterns(patterns, keys) -> list[str]:
    """Config key names matched by `patterns` (exact names, or `section.*`), sorted."""
    out = set()
    for p in patterns:
        if p.endswith(".*"):
            out.update(k for k in keys if k.startswith(p[:-1]))
        else:
            out.add(p)
    return sorted(out)


def config_dependencies(path: str, keys) -> set[str]:
    """Every config key (of `keys`) that the field `stage.field` depends on, transitively."""
    stage = BY_NAME[path.split(".", 1)[0]]
    found = set(expand_patterns(stage.reads, keys))
    for upstream in stage.inputs:
        found |= config_dependencies(upstream, keys)
    return found


def closure(names) -> tuple[str, ...]:
    """The named stages and every stage they read, transitively, in graph order (`--only`)."""
    wanted, pending = set(), list(names)
    while pending:
        name = pending.pop()
        if name not in wanted:
            wanted.add(name)
            pending += BY_NAME[name].upstream
    return tuple(s.name for s in STAGES if s.name in wanted)


def downstream(stages: set[str]) -> list[str]:
    """The stages that read, directly or transitively, a field of `stages` (in order, excluding them)."""
    hit, out = set(stages), []
    for s in STAGES:
        if s.name not in hit and any(u in hit for u in s.upstream):
            hit.add(s.name)
            out.append(s.name)
    return out


def describe() -> str:
    """The graph as text: each stage, what it reads and what it returns (`pipeline graph`)."""
    lines = []
    for i, s in enumerate(STAGES, 1):
        lines.append(f"[{i}] {s.name}  ({s.paper})")
        lines.append("    config: " + (", ".join(s.reads) or "-"))
        lines.append("    reads:  " + (", ".join(s.inputs) or "-"))
        if s.tools:
            lines.append("    runs:   " + ", ".join(s.tools) + " (pipeline.engine.toolchains; in its cache key)")
        readers = [f"{r.name}" for r in STAGES if any(p.startswith(s.name + ".") for p in r.inputs)]
        lines.append("    read by: " + (", ".join(readers) or "- (outputs only)"))
        lines.append("    returns:")
        width = max(len(f) for f in s.outputs)
        lines += [f"      {f:<{width}}  {meaning}" for f, meaning in s.outputs.items()]
    return "\n".join(lines)
