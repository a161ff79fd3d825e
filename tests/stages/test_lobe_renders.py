"""The decision's lobes as seen (`lobe_renders`): the lobe as the material balls' D, normalized by its
own coef; planted candidates whose rendered answer differs from the max-d one; the paper run's
section and summary line follow its numbers."""

import copy

import numpy as np
import pytest

from pipeline.optics import material_balls as balls
from pipeline.publish import report_beyond, summary
from pipeline.optics.lobe_candidates import cos_power
from pipeline.stages import lobe_renders


def test_cos_n_as_the_lobe_is_blinn_phong_s_normalized_ndf():
    """cos^n normalized by its own coef (a quadrature) is (n + 2) / (2 pi) cos^n: Blinn-Phong's NDF."""
    scene = balls.Scene((0.3, 0.6), size=12)
    key, D = lobe_renders.lobe_factor(scene, cos_power)
    g = balls.geometry(scene)
    n = 2.0 / g["alpha"] ** 2 - 2.0
    expected = (n + 2.0) / (2.0 * np.pi) * np.clip(g["NoH"], 0.0, 1.0) ** n
    assert key == "D" and D == pytest.approx(expected, rel=1e-8, abs=1e-300)
    assert lobe_renders.roughness_of(2.0) == pytest.approx(0.5 ** 0.25)


def _inputs(n_range, winner):
    """Two candidates on one range: cos^n (the reference, 12 cycles) and a spherical Gaussian
    exp(0.05 n (t - 1)), far too wide (visible, 4 cycles); the decision's row names `winner`."""
    candidates = [dict(name="f_b", use="lobe", n_range=n_range, cycles={"a": 12.0}, descriptor=["cos_n"]),
                  dict(name="wide", use="lobe", n_range=n_range, cycles={"a": 4.0},
                       descriptor=["registry", "SG", {}])]
    table = [dict(architecture="a", n_range=n_range, use="blinn", n_per="material", precision="fp32", winner=winner,
                  winner_cycles=4.0 if winner == "wide" else 12.0)]
    return {"lobe_search.ranges": [n_range], "decision.candidates": candidates, "decision.table": table}


def test_a_visible_max_d_winner_is_reported_and_an_invisible_one_is_not():
    n_range = [10.0, 100.0]
    out = lobe_renders.run({}, _inputs(n_range, "wide"), None)
    (row,) = out["table"]
    assert row["rendered_winner"] == "f_b" and row["differs"] and out["differs"] == 1
    assert row["max_d_winner_flip"] > out["thresholds"][0]["threshold"] >= row["rendered_winner_flip"] == 0.0
    lines = report_beyond.rendered_differences(out["table"])
    assert len(lines) == 1 and "by max d wide" in lines[0] and "rendered, f_b" in lines[0]
    out = lobe_renders.run({}, _inputs(n_range, "f_b"), None)
    assert out["differs"] == 0 and report_beyond.rendered_differences(out["table"]) == []


def test_the_paper_run_s_lobes_as_seen(paper_run, paper_config):
    """The reference renders as itself (FLIP 0, invisible) in every range; each scenario's flag is its
    two winners' names compared; the summary's count is the stage's, and changes with it."""
    v = paper_run["lobe_renders"]
    assert {tuple(t["n_range"]) for t in v["thresholds"]} == {tuple(r) for r in paper_run["lobe_search"]["ranges"]}
    for c in v["candidates"]:
        if c["name"] == "f_b":
            assert c["flip_max"] == 0.0 and c["invisible"]
        assert 0.0 <= c["flip_mean"] <= c["flip_p99"] <= c["flip_max"] <= 1.0
    assert v["differs"] == sum(t["max_d_winner"] != t["rendered_winner"] for t in v["table"])
    text = "\n".join(summary.lines(paper_config, paper_run))
    assert f"differs from the answer in {v['differs']} of {len(v['table'])} scenarios" in text
    planted = copy.deepcopy(v)
    for t in planted["table"]:
        t.update(rendered_winner=t["max_d_winner"], differs=False)
    planted["differs"] = 0
    text = "\n".join(summary.lines(paper_config, dict(paper_run, lobe_renders=planted)))
    assert "differs from the answer in 0 of" in text and "lobes as seen" not in text
