"""The one writer of `results.json`: every reported number, and the `headline` object."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from ..engine import graph, toolchains

# The headline: the stage fields users script against (docs/reference/results.md lists them), each by its one
# name, `stage.field` as `pipeline graph` declares it. Fractions, not percent.
HEADLINE = (
    "zone.level", "q_scan.Q_scan_best", "q_scan.Q_continuous_best", "q_choice.Q_used",
    "accuracy.d_f_Q", "accuracy.D_f_Q",
    "linear_coefficient.lin_slope", "linear_coefficient.lin_intercept", "linear_coefficient.lin_max_rel_error",
    "accuracy.d_f_Q2", "accuracy.D_f_Q2", "f2_errors.d_f_2", "f2_errors.D_f_2", "accuracy.epicenter_gain",
    "sparse_regression.coef_scale", "sparse_regression.coef_offset", "sparse_regression.coef_rms",
    "hemispherical.hemi_max_abs_dev",
    # beyond the paper
    "exact_normalization.paper_coef_max_excess", "exact_normalization.exact_coef_max_abs_dev",
    "directional_albedo.phong_run_coef_max", "directional_albedo.blinn_exact_coef_max",
    "lobe_comparison.d_max", "lobe_comparison.D_max",
    "render.flip_f_Q2_max", "render.flip_f_2_max", "render.psnr_f_Q2_min", "render.psnr_f_2_min",
    "symbolic_regression.sr_exact_complexity",
    "mitsuba_render.flip_f_Q2_max", "mitsuba_render.flip_f_2_max",
    "ndf.d_f_Q2_vs_beckmann", "microfacet_render.flip_f_Q2_vs_beckmann_max", "gpu_isa.family_transcendental_max",
)


# Wall-clock times: the one kind of field that differs between two runs of the same config on one
# machine (everything else repeats bit for bit). results.json keeps them apart, under "timings".
TIMINGS = ("mitsuba_render.render_seconds", "microfacet_render.render_seconds")


def headline(results: dict[str, dict[str, Any]]) -> dict[str, Any]:
    """The headline fields of a run's results, by `stage.field` (those of the stages it computed)."""
    out = {}
    for path in HEADLINE:
        stage, field = path.split(".", 1)
        if stage in results:
            out[path] = results[stage][field]
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
    """Writes results.json (`document`); returns its content."""
    doc = document(config, stage_keys, results, checks)
    path.write_text(json.dumps(doc, indent=1, allow_nan=False))
    return doc


def document(config, stage_keys, results, checks) -> dict:
    """results.json's content: config, stage keys, the headline fields, every stage's scalars and
    small arrays, the checks, and (apart) the timings; plain JSON values (NaN and inf as None)."""
    timed = {tuple(path.split(".", 1)) for path in TIMINGS}
    scalars = {stage: {k: v for k, v in r.items()
                       if not (isinstance(v, np.ndarray) and v.size > 16) and (stage, k) not in timed}
               for stage, r in results.items()}
    timings = {f"{stage}.{k}": results[stage][k] for stage, k in sorted(timed) if stage in results}
    doc = dict(
        name=config.name, config_file=config.source, config=dict(config.values),
        headline=headline(results), stages=scalars, stage_keys=stage_keys,
        checks=[dict(id=c.expectation.id, quantity=c.expectation.quantity, paper=c.expectation.paper,
                     reproduced=c.reproduced, deviation=c.deviation, tolerance=c.expectation.tolerance,
                     verdict=c.verdict, reason=c.expectation.reason, known_difference=c.expectation.known_difference,
                     agreement=c.expectation.agreement,
                     settings_differ=list(c.settings_differ))
                for c in checks],
        timings=timings,
        # The outside tools as found for this run (the stages that ran them are keyed on them).
        toolchains=toolchains.report(),
    )
    not_run = [s.name for s in graph.STAGES if s.name not in results]
    if not_run:
        doc["not_run"] = not_run          # a targeted run (`--only`): these stages were not computed
    return _plain(doc)
