"""The one writer of `results.json`: every reported number, and the `headline` object."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np

# The headline: names users script against (the README documents them), each the field that holds
# the quantity. Fractions, not percent. Several keep an older spelling of the field's name
# (d_fQ2 is accuracy.d_f_Q2): the names are an interface, the fields the one name inside.
HEADLINE = {
    "zone_level": "zone.level",
    "Q_scan_best": "q_scan.Q_scan_best",
    "Q_continuous_best": "q_scan.Q_continuous_best",
    "Q_used": "q_choice.Q_used",
    "d_fQ_at_Q": "accuracy.d_f_Q",
    "D_fQ_at_Q": "accuracy.D_f_Q",
    "lin_slope": "linear_coefficient.lin_slope",
    "lin_intercept": "linear_coefficient.lin_intercept",
    "lin_max_rel_error": "linear_coefficient.lin_max_rel_error",
    "d_fQ2": "accuracy.d_f_Q2",
    "D_fQ2": "accuracy.D_f_Q2",
    "d_f2": "f2_errors.d_f_2",
    "D_f2": "f2_errors.D_f_2",
    "epicenter_gain": "accuracy.epicenter_gain",
    "coef_scale": "sparse_regression.coef_scale",
    "coef_offset": "sparse_regression.coef_offset",
    "coef_rms": "sparse_regression.coef_rms",
    "hemi_max_abs_dev": "hemispherical.hemi_max_abs_dev",
    # beyond the paper
    "paper_coef_max_excess": "exact_normalization.paper_coef_max_excess",
    "exact_coef_max_abs_dev": "exact_normalization.exact_coef_max_abs_dev",
    "phong_albedo_max": "directional_albedo.phong_run_coef_max",
    "blinn_albedo_max": "directional_albedo.blinn_exact_coef_max",
    "schlick_d": "lobe_comparison.d_schlick",
    "schlick_D": "lobe_comparison.D_schlick",
    "sg_d": "lobe_comparison.d_sg",
    "sg_D": "lobe_comparison.D_sg",
    "render_flip_f_Q2_max": "render.flip_f_Q2_max",
    "render_flip_f_2_max": "render.flip_f_2_max",
    "render_psnr_f_Q2_min": "render.psnr_f_Q2_min",
    "render_psnr_f_2_min": "render.psnr_f_2_min",
    "sr_exact_complexity": "symbolic_regression.sr_exact_complexity",
    "mitsuba_flip_f_Q2_max": "mitsuba_render.flip_f_Q2_max",
    "mitsuba_flip_f_2_max": "mitsuba_render.flip_f_2_max",
}


def headline(results: dict[str, dict[str, Any]]) -> dict[str, float]:
    out = {}
    for name, path in HEADLINE.items():
        stage, field = path.split(".", 1)
        out[name] = results[stage][field]
    return out


def _plain(value):
    if isinstance(value, np.ndarray):
        return _plain(value.tolist())
    if isinstance(value, np.generic):
        return _plain(value.item())
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_plain(v) for v in value]
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def write(path: Path, config, stage_keys, results, checks) -> dict:
    """Writes results.json: config, stage keys, headline (and where each headline name comes from),
    every stage's scalars and small arrays, the checks."""
    scalars = {stage: {k: v for k, v in r.items() if not (isinstance(v, np.ndarray) and v.size > 16)}
               for stage, r in results.items()}
    doc = dict(
        name=config.name, config_file=config.source, config=dict(config.values),
        headline=headline(results), headline_fields=HEADLINE, stages=scalars, stage_keys=stage_keys,
        checks=[dict(id=c.expectation.id, quantity=c.expectation.quantity, paper=c.expectation.paper,
                     reproduced=c.reproduced, tolerance=c.expectation.tolerance, verdict=c.verdict,
                     agreement=c.expectation.agreement,
                     settings_differ=list(c.settings_differ))
                for c in checks],
    )
    doc = _plain(doc)
    path.write_text(json.dumps(doc, indent=1, allow_nan=False))
    return doc
