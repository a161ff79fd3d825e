"""The error as seen (`rendered`): forms rendered in their term's place and compared by FLIP, the
rule that calls a render invisible, and the roles a target declares."""

import numpy as np
import pytest
import sympy as sp

from pipeline.approximate import targets
from pipeline.approximate.measures import rendered
from pipeline.approximate.targets import DeriveError
from pipeline.optics.images import flip_map

SIZE = 24                       # pixels per sphere: small, the same scene otherwise


def _x():
    return sp.Symbol("x", real=True)


def test_flip_of_the_exact_term_against_itself_is_zero():
    schlick = targets.registry()["schlick"]
    drawn = rendered.render(schlick, {"exact": schlick.sympy()}, size=SIZE, log=lambda s: None)
    assert flip_map(drawn["exact"], drawn["exact"]).max() == 0.0
    # the exact term computed in float32 instead of float64: at most a display level here and there
    assert drawn["statistics"]["exact"]["flip_max"] <= drawn["threshold"]


def test_a_fresnel_too_high_at_grazing_is_visible_and_one_equal_to_it_is_not():
    """A member 0.1 too high at VoH = 0 (0.1 (1 - x)^3 added) against one equal to Schlick's term up
    to float32's rounding (its expression expanded: another order of operations)."""
    schlick = targets.registry()["schlick"]
    x = _x()
    forms = {"high": (1 - x) ** 5 + sp.Float(0.1) * (1 - x) ** 3, "expanded": sp.expand((1 - x) ** 5)}
    drawn = rendered.render(schlick, forms, size=SIZE, log=lambda s: None)
    high, expanded, threshold = drawn["statistics"]["high"], drawn["statistics"]["expanded"], drawn["threshold"]
    assert 0.02 < threshold < 0.1           # (FLIP of one display level everywhere)
    assert high["flip_max"] > 2 * threshold and high["flip_mean"] > 0.004
    assert rendered.invisible(expanded, threshold) and not rendered.invisible(high, threshold)
    assert high["flip_mean"] <= high["flip_p99"] <= high["flip_max"]


def test_each_registered_role_renders_its_exact_term_invisibly_and_a_known_fit_visibly():
    """The visibility, the environment BRDF and the lobe: the target's own expression evaluated in
    float32 is invisible; a fit that errs by tenths somewhere (Hammon's visibility, 0.29 relative;
    Karis's EnvBRDFApprox, 0.18 absolute; the paper's f_Q2 lobe outside its zone) is not invisible by
    nothing: its FLIP is above 0."""
    visibility = targets.several_variable_targets()["smith_ggx_visibility"]
    hammon = visibility.anchor_expressions()["Hammon"]
    drawn = rendered.render(visibility, {"exact": visibility.sympy(), "Hammon": hammon}, size=SIZE, log=lambda s: None)
    assert rendered.invisible(drawn["statistics"]["exact"], drawn["threshold"])
    assert drawn["statistics"]["Hammon"]["flip_max"] > drawn["threshold"]

    pair = targets.pairs()["env_brdf"]
    F0 = sp.Symbol("F0", real=True)
    karis = F0 * pair.scale.anchor_expressions()["Karis"] + pair.bias.anchor_expressions()["Karis"]
    drawn = rendered.render(pair, {"Karis": karis}, size=SIZE, log=lambda s: None)
    assert drawn["statistics"]["Karis"]["flip_max"] > drawn["threshold"]

    lobe = targets.several_variable_targets()["cos_n"]
    drawn = rendered.render(lobe, {"exact": lobe.sympy()}, size=SIZE, log=lambda s: None)
    assert rendered.invisible(drawn["statistics"]["exact"], drawn["threshold"])


def test_the_spheres_span_the_target_s_roughness():
    """The parameter's range in roughness: alpha = roughness^2, n = 2 / alpha^2 - 2; its low end a column."""
    visibility = targets.several_variable_targets()["smith_ggx_visibility"]
    assert rendered.scene_of(visibility).roughness[0] == pytest.approx(0.02 ** 0.5)
    lobe = targets.several_variable_targets()["cos_n"]
    lo, hi = rendered.roughness_range(lobe, rendered.role_of(lobe))
    assert 2.0 / (lo ** 4) - 2.0 == pytest.approx(1000.0) and 2.0 / (hi ** 4) - 2.0 == pytest.approx(2.0)


def _rows(flips, cycles, errors, kinds=None):
    kinds = kinds or {}
    return [dict(architecture="a", name=n, kind=kinds.get(n, "found"), cycles=cycles[n], max_abs_error=errors[n])
            for n in flips], {n: dict(flip_max=f, flip_mean=f / 10, flip_p99=f / 2) for n, f in flips.items()}


def test_the_rule_planted():
    """The cheapest invisible form moves with the planted FLIPs; the max-error budget's does not."""
    flips, cycles = dict(cheap=0.06, dear=0.01, exact=0.0), dict(cheap=2.0, dear=5.0, exact=8.0)
    errors = dict(cheap=1e-3, dear=1e-2, exact=0.0)
    rows, statistics = _rows(flips, cycles, errors, dict(exact="exact"))
    out = rendered.decide(rows, statistics, 0.05, "max_abs_error", 2e-3, ["a"])["a"]
    assert out["cheapest_invisible"]["name"] == "dear" and out["cheapest_within_budget"]["name"] == "cheap"
    assert out["front"] == ["cheap", "dear"]
    rows, statistics = _rows(dict(flips, cheap=0.04), cycles, errors, dict(exact="exact"))
    out = rendered.decide(rows, statistics, 0.05, "max_abs_error", 2e-3, ["a"])["a"]
    assert out["cheapest_invisible"]["name"] == "cheap" and out["front"] == ["cheap", "dear"]
    rows, statistics = _rows(dict(flips, cheap=0.2, dear=0.3), cycles, errors, dict(exact="exact"))
    out = rendered.decide(rows, statistics, 0.05, "max_abs_error", 2e-3, ["a"])["a"]
    assert out["cheapest_invisible"]["name"] == "exact"


def test_an_anchor_s_rendered_verdict_planted():
    cycles, errors = dict(fit=4.0, anchor=4.0), dict(fit=1e-3, anchor=1e-3)
    kinds = dict(anchor="anchor")
    for fit, anchor, verdict in ((0.1, 0.3, "beaten"), (0.3, 0.1, "missed"), (0.2, 0.201, "matched"),
                                 (0.01, 0.04, "matched")):      # (the last: both invisible)
        rows, statistics = _rows(dict(fit=fit, anchor=anchor), cycles, errors, kinds)
        out = rendered.decide(rows, statistics, 0.05, "max_abs_error", 1.0, ["a"])["a"]
        assert out["anchors"]["anchor"]["verdict"] == verdict, (fit, anchor)


def test_a_declared_role_must_fit_the_target(tmp_path):
    path = tmp_path / "t.toml"
    path.write_text('[target]\nexpression = "(1 - x)**5"\nrole = "fresnel"\n')
    assert targets.from_file(path).role == "fresnel"
    path.write_text('[target]\nexpression = "(1 - x)**5"\nrole = "shadow"\n')
    with pytest.raises(DeriveError, match="role 'shadow': give one of fresnel, visibility, env_brdf, lobe"):
        targets.from_file(path)
    path.write_text('[target]\nexpression = "(1 - x)**5"\nrole = "visibility"\n')
    with pytest.raises(DeriveError, match=r"role 'visibility' takes the variables NoV, NoL and the parameter alpha; "
                                          r"the target has 1 variable\(s\) and no parameter"):
        targets.from_file(path)
    path.write_text('[target]\nexpression = "a*b"\nrole = "lobe"\n[[variable]]\nname = "a"\nrange = [0, 1]\n'
                    '[parameter]\nname = "b"\nrange = [1, 2]\n')
    assert targets.from_file(path).role == "lobe"


def test_a_target_without_a_role_says_why_it_is_not_rendered():
    results = dict(rows=[], members={})
    rendered.compare(results, targets.registry()["acos"])
    assert results["rendered"]["role"] is None and "acos has no role" in results["rendered"]["why"]
    assert "renders" not in results


def test_the_exact_term_shaded_in_float16_throughout_is_invisible_by_the_rule():
    """Every factor and the composition in float16 (a phone's mediump), the exact Fresnel: its
    largest FLIP stays under the rule's threshold, as docs/derive.md says."""
    from pipeline.optics import material_balls as balls

    schlick = targets.registry()["schlick"]
    scene = rendered.scene_of(schlick, SIZE)
    base = balls.exact_terms(scene, rendered.table_env_brdf())
    exact = rendered.exact_factor(schlick, rendered.role_of(schlick), scene)
    drawn = rendered.compare_images(scene, base, exact, {})
    half = balls.display(balls.shade(scene, base | {exact[0]: exact[1]}, dtype=np.float16))
    fmap = flip_map(drawn["exact"], half)[balls.mask(scene)]
    assert 0.0 < fmap.max() <= drawn["threshold"]
