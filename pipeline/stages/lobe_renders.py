"""The decision's lobes as seen (beyond the paper): each lobe candidate of the decision rendered as the
specular lobe of the material balls (`optics.material_balls`: each light's D = coef max(f(N.H; n), 0),
coef the lobe's own exact normalization, n = 2 / alpha^2 - 2 of each sphere's roughness, the spheres'
roughness spanning each n range of the lobe search), compared by FLIP with cos^n's render, and the
rule of `approximate.measures.rendered` (invisible: the largest FLIP over the spheres no more than that of
the exact image raised one display level). Per architecture and range, the common Blinn case (n per
material, fp32): the cheapest invisible candidate beside the decision's winner by max d, and whether
the two differ.
"""

from __future__ import annotations

import time

import numpy as np

from ..approximate.measures import rendered
from ..optics import material_balls as balls
from ..optics.lobe_candidates import cos_power, evaluator, phong_integral

USE = "blinn"                   # the lobe of t = N.H: the decision's scenarios that these renders answer


def roughness_of(n: float) -> float:
    """The perceptual roughness whose GGX alpha matches Phong's n: alpha = sqrt(2 / (n + 2)) (Walter et al. 2007)."""
    return (2.0 / (n + 2.0)) ** 0.25


def lobe_factor(scene: balls.Scene, make) -> tuple[str, np.ndarray]:
    """("D", each light's D at each pixel) of the lobe `make(n) -> (float64 of t, ...)` at each
    sphere's n, normalized as an NDF by its own exact coef, 1 / (2 pi int_0^1 f(t) t dt) (the
    decision's n per material: the coef computed exactly on the CPU; cos^n's is (n + 2) / (2 pi))."""
    g = balls.geometry(scene)
    n = 2.0 / g["alpha"] ** 2 - 2.0
    t = np.clip(g["NoH"], 0.0, 1.0)
    D = np.zeros_like(t)
    for value in np.unique(n):
        column = n == value
        lobe = make(float(value))[0]
        D[:, column] = np.maximum(lobe(t[:, column]), 0.0) / (2.0 * np.pi * phong_integral(lobe, float(value)))
    return "D", D


def render_range(descriptors: dict, n_range: list) -> dict:
    """FLIP statistics of each candidate ({name: decision descriptor}) against cos^n on the spheres
    spanning `n_range`, and the rule's threshold there."""
    lo, hi = n_range
    scene = balls.Scene(balls.roughness_grid(roughness_of(hi), roughness_of(lo)))
    base = balls.exact_terms(scene, rendered.table_env_brdf())
    drawn = rendered.compare_images(scene, base, lobe_factor(scene, cos_power),
                                    {name: lobe_factor(scene, evaluator(d)) for name, d in descriptors.items()})
    return dict(threshold=drawn["threshold"], statistics=drawn["statistics"], roughness=list(scene.roughness))


def run(config, inputs, memo):
    started = time.perf_counter()
    candidates = [c for c in inputs["decision.candidates"] if c["use"] == "lobe"]
    ranges = [list(r) for r in inputs["lobe_search.ranges"]]
    per_range, rows = {}, []
    for n_range in ranges:
        here = {c["name"]: c["descriptor"] for c in candidates if c["n_range"] == n_range}
        per_range[tuple(n_range)] = render_range(here, n_range)
        for name, s in per_range[tuple(n_range)]["statistics"].items():
            rows.append(dict(name=name, n_range=n_range, invisible=rendered.invisible(
                s, per_range[tuple(n_range)]["threshold"]), **s))
    table = []
    for row in inputs["decision.table"]:
        if (row["use"], row["n_per"], row["precision"]) != (USE, "material", "fp32") or not row["winner"]:
            continue
        drawn = per_range[tuple(row["n_range"])]
        options = [c for c in candidates if c["n_range"] == row["n_range"] and row["architecture"] in c["cycles"]]
        order = sorted(options, key=lambda c: (c["cycles"][row["architecture"]],
                                               drawn["statistics"][c["name"]][rendered.STATISTIC]))
        seen = next((c for c in order if rendered.invisible(drawn["statistics"][c["name"]], drawn["threshold"])), None)
        table.append(dict(architecture=row["architecture"], n_range=row["n_range"], max_d_winner=row["winner"],
                          max_d_winner_cycles=row["winner_cycles"],
                          max_d_winner_flip=drawn["statistics"][row["winner"]][rendered.STATISTIC],
                          rendered_winner=seen["name"] if seen else "",
                          rendered_winner_cycles=seen["cycles"][row["architecture"]] if seen else -1.0,
                          rendered_winner_flip=drawn["statistics"][seen["name"]][rendered.STATISTIC] if seen else -1.0,
                          differs=bool(seen is None or seen["name"] != row["winner"])))
    return dict(rule=rendered.RULE, statistic=rendered.STATISTIC,
                thresholds=[dict(n_range=list(r), threshold=v["threshold"], roughness=v["roughness"])
                            for r, v in per_range.items()],
                candidates=rows, table=table, differs=sum(r["differs"] for r in table),
                seconds=round(time.perf_counter() - started, 1))
