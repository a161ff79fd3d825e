"""`pipeline derive` on targets of several variables and a material parameter (`parametric`): the
templates, a planted law recovered exactly with its constants as formulas, the per-value optimum
as a bound, bad input (the whole command on the Smith-GGX visibility: test_derive_visibility.py)."""

import subprocess
import sys

import numpy as np
import pytest
import sympy as sp

from pipeline.approximate import engines, targets
from pipeline.approximate.engines import pairs, several_variables
from pipeline.approximate.search import anchor_refits, box_search as parametric_search, formulas, templates
from pipeline.approximate.search import per_value as fits
from pipeline.approximate.targets import Axis, DeriveError, Target
from pipeline.optics import brdf
from tests.helpers import cli_env

X, Y = sp.symbols("x y", real=True)


def test_symmetric_monomials_are_the_symmetric_sums():
    def terms(*args):
        out = templates._monomials([X, Y], *args)
        assert out[0] == 1 and len(set(out)) == len(out)         # (the constant first, no repeats)
        return set(out)

    assert terms(2, False, True) == {1, X + Y, X * Y, X**2 + Y**2}
    assert terms(1, True, True) == {1, X + Y, X * Y}
    assert terms(1, True, False) == {1, X, Y, X * Y}
    assert terms(2, False, False) == {1, X, Y, X * Y, X**2, Y**2}


PLANTED = Target("planted", "1/((0.5 + 1.5*a)*(x + y) + (2 - a)*x*y)", (Axis("x", 0.1, 1.0), Axis("y", 0.1, 1.0)),
                           Axis("a", 0.0, 1.0), "rel")


def test_an_anchors_numbers_refitted_on_the_box_come_back_exactly():
    """The planted law written as anchors with numbers off, refitted by minimax on the box:
    - "off" (0.4, 1.6 and 2.2 for 0.5, 1.5 and 2): its decimal numbers refitted, it is the law (error
      below 1e-9), a pixel form of its own; it has no factor of 0.5, 2 or 4 and no integer term, so
      no second refit;
    - "halved" (the law halved, its 1 written 2): with every decimal number refitted, and with its
      factors of 0.5 held exactly and the rest refitted (`_refitted_offsets`), the law both ways;
    - "integers" (no decimal number): no plain refit; its sums' integers refitted, (k0 + a) and
      (k1 - a), it errs less than as written but cannot be the law, whose a has slope 1.5."""
    import dataclasses

    from pipeline.approximate.targets import Anchor

    target = targets.check(dataclasses.replace(PLANTED, anchors=(
        Anchor("off", "1/((0.4 + 1.6*a)*(x + y) + (2.2 - a)*x*y)", "planted"),
        Anchor("halved", "0.5/((0.25 + 0.75*a)*(x + y) + (2 - 0.5*a)*x*y)", "planted"),
        Anchor("integers", "1/((1 + a)*(x + y) + (2 - a)*x*y)", "planted"))))
    f = target.numpy()
    found, coverage = anchor_refits.refitted_box_anchors(target, f, lambda s: None)
    names = ["off_refitted", "halved_refitted", "halved_refitted_offsets", "integers_refitted_offsets"]
    assert [r["name"] for r in found] == names == coverage["refitted_anchors"]
    by_name = {r["name"]: r for r in found}
    assert all(r["per"] == "pixel" and r["family"] == "anchor_refit" for r in found)
    for name in names[:3]:
        assert by_name[name]["errors"]["max_rel_error"] < 1e-9, name
    held = {float(v) for v in by_name["halved_refitted_offsets"]["expression"].atoms(sp.Float)}
    assert {0.5, -0.5} <= held and 2.0 not in held
    written = {name: formulas.measure_box(e, target, f)["max_rel_error"]
               for name, e in target.anchor_expressions().items()}
    assert written["off"] > 0.05 and written["halved"] > 0.05
    integers = by_name["integers_refitted_offsets"]
    assert 1e-3 < integers["errors"]["max_rel_error"] < written["integers"] * (1 - 1e-6)
    assert len(integers["expression"].atoms(sp.Float)) == 2


def test_offsets_free_holds_amds_free_factors_and_frees_the_sums_integers():
    """Filament's fast V: its 0.5 (an output modifier on AMD) held exactly, each 1 of (1 - alpha) a
    decimal number to refit (one number: both are the same 1), exponents and the -1 of -alpha as they
    are; a factor that is no power of two stays a number to refit."""
    from pipeline.approximate.search import anchor_refits

    nov, nol, alpha = sp.symbols("NoV NoL alpha", real=True)
    filament = sp.Float(0.5) / (nov * (nol * (1 - alpha) + alpha) + nol * (nov * (1 - alpha) + alpha))
    free = anchor_refits.offsets_free(filament)
    assert {float(v) for v in free.atoms(sp.Float)} == {1.0} and sp.Rational(1, 2) in free.atoms(sp.Rational)
    assert sp.simplify(free - filament) == 0
    other = anchor_refits.offsets_free(sp.Float(0.6) * nov**2 + 3 - alpha)
    assert {float(v) for v in other.atoms(sp.Float)} == {0.6, 3.0} and other.has(nov**2)


def test_a_pairs_anchor_is_refitted_as_one_keeping_its_shared_number_shared():
    """A pair whose anchor writes one number (1.2) in both parts: refitted together, the number stays
    one, and the planted pair (1 / (1 + a x), x / (2 (1 + a x))) comes back exactly."""
    from pipeline.approximate.targets import Anchor

    def part(name, law, anchor):
        return targets.check(Target(name, law, (Axis("x", 0.0, 1.0),), Axis("a", 0.5, 1.0), "abs",
                                                 anchors=(Anchor("off", anchor, "planted"),)))

    pair = targets.pair("planted", part("s", "1/(1 + a*x)", "1/(1 + 1.2*a*x)"),
                                 part("b", "x/(2*(1 + a*x))", "0.4*x/(1 + 1.2*a*x)"))
    (found,) = pairs.refitted_pair_anchors(pair, lambda s: None)
    assert found["name"] == "off_refitted"
    assert max(e["max_abs_error"] for e in found["errors"].values()) < 1e-9
    shared = {float(v) for v in found["scale"].atoms(sp.Float)} & {float(v) for v in found["bias"].atoms(sp.Float)}
    assert len(shared) == 1 and abs(shared.pop() - 1.0) < 1e-9


def test_a_planted_law_comes_back_exactly_with_lines_in_the_parameter():
    """1/(k0 (x + y) + k1 x y) with k0 = 0.5 + 1.5 a, k1 = 2 - a: the symmetric reciprocal template is
    exact at every value, and its constants' lines, polished together, are the planted ones."""
    target = targets.check(PLANTED)
    f = target.numpy()
    assert targets.is_symmetric(target, f)
    template = next(t for t in templates.family_templates(target, True)
                    if t.name == "reciprocal_polynomial_bilinear_no_constant_symmetric")
    per_value = fits.fit_per_value(template, target, f)
    assert per_value.errors.max() < 1e-10
    coefficients, error = formulas.polish_formulas(template, per_value, ("line", "line"), target, f)
    assert error < 1e-10
    np.testing.assert_allclose(coefficients[:, 1:3], [[0.5, 1.5], [2.0, -1.0]], atol=1e-8)     # (p^0, p^1)
    assert np.all(coefficients[:, [0, 3]] == 0)     # (a line has no 1 / p and no square term)
    # the same with k0 proportional: not the law, measurably worse, never better than per value
    reduced_coefficients, reduced = formulas.polish_formulas(template, per_value, ("proportional", "line"), target, f)
    assert reduced > 1e-3
    # written with k0's factor in the numerator: the same function
    k, (x, y, a) = templates.constant_symbols(2), target.symbols()
    pixel = template.expression.xreplace(dict(zip(k, formulas.formula_expressions(reduced_coefficients, a))))
    fitted = formulas.Fitted(template, "formulas_pl", reduced_coefficients, per_value, {}, pixel, None)
    scaled = parametric_search._scaled(fitted, a)
    assert scaled != pixel and sp.srepr(scaled).count("Float") == sp.srepr(pixel).count("Float")
    points = np.random.default_rng(2).uniform(0.1, 1.0, (3, 50))
    np.testing.assert_allclose(sp.lambdify((x, y, a), scaled)(*points), sp.lambdify((x, y, a), pixel)(*points), rtol=1e-13)


def test_a_template_no_better_than_a_constant_at_one_value_is_dropped_there(monkeypatch):
    """Planted bounds against a template's per-value errors on the planted law: a bound at the first
    value's error drops it after that value; one between the errors drops it at the first value (in
    the order they are fitted) whose error reaches it; one above them all gives every value's fit, bit
    for bit the unbounded one's. material_forms drops by the best constant's error and lists the
    template with the rule's numbers, and fits the others as before."""
    from pipeline.approximate.search.per_value import Dropped

    target = targets.check(PLANTED)
    f = target.numpy()
    template = next(t for t in templates.family_templates(target, True) if t.name == "polynomial_degree1_symmetric")
    full = fits.fit_per_value(template, target, f)
    grid, _ = targets.parameter_values(target.parameter)
    middle = grid.size // 2
    order = list(range(middle, grid.size)) + list(range(middle - 1, -1, -1)) + list(range(grid.size, full.values.size))
    first = fits.fit_per_value(template, target, f, give_up=full.errors[middle])
    assert isinstance(first, Dropped) and first.fitted == 1
    assert (first.value, first.error) == (full.values[middle], full.errors[middle])
    later = max(full.errors[order[:3]]) * (1 + 1e-9)            # above the first three values' errors
    assert later < full.errors.max()
    k = next(i for i, j in enumerate(order) if full.errors[j] >= later)
    dropped = fits.fit_per_value(template, target, f, give_up=later)
    assert isinstance(dropped, Dropped) and dropped.fitted == k + 1 and dropped.value == full.values[order[k]]
    kept = fits.fit_per_value(template, target, f, give_up=full.errors.max() * 1.01)
    assert np.array_equal(kept.constants, full.constants) and np.array_equal(kept.errors, full.errors)
    # the constant's error planted between the two templates' per-value errors: the worse one is dropped
    good = next(t for t in templates.family_templates(target, True)
                if t.name == "reciprocal_polynomial_bilinear_no_constant_symmetric")
    listed: list = []
    planted = full.errors.max() / 2
    monkeypatch.setattr(formulas, "_constant_error", lambda target, f: planted)
    forms = formulas.material_forms([template, good], target, f, lambda s: None, dropped=listed)
    assert [d["template"] for d in listed] == [template.name] and listed[0]["constant_error"] == planted
    assert listed[0]["per_value_error"] >= planted and {m.template.name for m in forms} == {good.name}


def test_the_per_value_optimum_bounds_the_formulas_on_the_visibility():
    """On V(NoV, NoL; alpha): the reciprocal bilinear template's lines are no better than its
    constants fitted at each value alone, and Hammon's error is its closed form 1 - sqrt(0.51)."""
    target = targets.several_variable_targets()["smith_ggx_visibility"]
    f = target.numpy()
    template = next(t for t in templates.family_templates(target, True)
                    if t.name == "reciprocal_polynomial_bilinear_no_constant_symmetric")
    per_value = fits.fit_per_value(template, target, f)
    _, line = formulas.polish_formulas(template, per_value, ("line", "line"), target, f)
    assert line >= per_value.errors.max() * (1 - 1e-9)
    hammon = formulas.measure_box(target.anchor_expressions()["Hammon"], target, f)["max_rel_error"]
    assert hammon == pytest.approx(brdf.hammon_largest_relative_error(0.02)[0], rel=1e-6)
    assert line < hammon / 2        # (measured 0.132 against 0.286)


@pytest.mark.parametrize("target, message", [
    (Target("t", "x*y", (Axis("x", 1.0, 0.0), Axis("y", 0, 1))), "x in [1.0, 0.0]"),
    (Target("t", "x*y", (Axis("x", 0, 1), Axis("x", 0, 1))), "repeat"),
    (Target("t", "x*z", (Axis("x", 0, 1), Axis("y", 0, 1))), "unknown name 'z'"),
    (Target("t", "1/x", (Axis("x", 0, 1),), Axis("a", 0, 1), "abs"), "is not finite at x = 0"),
    (Target("t", "x - a", (Axis("x", 0, 1),), Axis("a", 0, 1), "rel"), "is 0"),
    (Target("t", "x", (Axis("x", 0, 1), Axis("y", 0, 1), Axis("z", 0, 1)), Axis("a", 0, 1)), "at most 3"),
])
def test_bad_targets_are_named(target, message):
    with pytest.raises(DeriveError, match=message.replace("[", r"\[").replace("]", r"\]")):
        targets.check(target)


def test_the_environment_brdf_table_is_the_quadrature_between_its_points():
    """The tables (65 x 65 Chebyshev points, cubic splines) against `optics.brdf.env_brdf` itself at
    points off the grid (measured: 6e-7 in A, 1.7e-6 in B at 300 points), and the anchors as the
    targets write them against `optics.brdf`'s own (Karis's and Lazarov's A and B)."""
    scale, bias = targets.env_brdf_table()
    rng = np.random.default_rng(1)
    nov, roughness = rng.uniform(0.02, 1.0, 40), rng.uniform(0.05, 1.0, 40)
    A, B = brdf.env_brdf(nov, roughness)
    assert np.abs(scale(nov, roughness) - A).max() < 1e-5
    assert np.abs(bias(nov, roughness) - B).max() < 1e-5
    both = targets.env_brdf_targets()
    for part, name in enumerate(("env_brdf_scale", "env_brdf_bias")):
        target = both[name]
        for anchor, function in (("Karis", brdf.env_brdf_karis_mobile), ("Lazarov", brdf.env_brdf_lazarov)):
            written = targets.numpy_function(target.anchor_expressions()[anchor], target.symbols())
            np.testing.assert_allclose(written(nov, roughness), function(nov, roughness)[part], rtol=1e-12, atol=1e-14)


def _planted_csv(path, rows=None):
    x, a = np.linspace(0.0, 1.0, 9), np.linspace(0.5, 2.0, 7)
    lines = ["x,a,value"] + [f"{float(xi)!r},{float(ai)!r},{float(1 / (1 + ai * xi))!r}" for xi in x for ai in a]
    path.write_text("\n".join(lines if rows is None else rows(lines)) + "\n")
    return x, a


def test_a_csv_table_is_a_target_on_its_grid(tmp_path):
    x, a = _planted_csv(tmp_path / "law.csv")
    target = targets.from_csv(tmp_path / "law.csv", ["x"], "a")
    assert (target.variables[0], target.parameter) == (Axis("x", 0.0, 1.0), Axis("a", 0.5, 2.0))
    f = target.numpy()
    X, A = np.meshgrid(x, a, indexing="ij")
    np.testing.assert_allclose(f(X, A), 1 / (1 + A * X), rtol=1e-14)            # (its own values on the grid)
    assert abs(f(np.array(0.55), np.array(1.1)) - 1 / (1 + 1.1 * 0.55)) < 1e-3   # (a spline between them)


@pytest.mark.parametrize("rows, args, message", [
    (None, (["t"], "a"), "no column 't'"),
    (lambda lines: lines[:-1], (["x"], "a"), "do not fill the grid"),
    (lambda lines: lines[:-1] + [lines[1]], (["x"], "a"), "repeats"),
    (lambda lines: lines + ["0.5,oops,1"], (["x"], "a"), "row 65"),
    (lambda lines: [lines[0] + ",other"] + [r + ",0" for r in lines[1:]], (["x"], "a"), "name the value's column"),
])
def test_a_malformed_csv_table_is_named(tmp_path, rows, args, message):
    _planted_csv(tmp_path / "bad.csv", rows)
    with pytest.raises(DeriveError, match=message):
        targets.from_csv(tmp_path / "bad.csv", *args)


def test_pairs_take_the_larger_error_and_share_the_push_constants(monkeypatch):
    """`derive_pair` on two planted parts: each pair compiled as F0 A + B, its error the larger of its
    parts' (each in its own column), the bias's push constants numbered after the scale's, and the
    anchor's verdict by the rule (a planted pair at fewer cycles and smaller error beats it)."""
    if "rdna3" not in engines.available_architectures():
        pytest.skip("Mesa's RADV does not run here")
    from pipeline.approximate.forms import Form

    nov, r = sp.symbols("NoV roughness", real=True)
    c0, c1 = sp.symbols("c0 c1", real=True)

    def part(found, anchor):
        forms = {n: Form(n, "found", "planted", e) for n, (e, *_) in found.items()}
        forms["Karis"] = Form("Karis", "anchor", "anchor", anchor)
        members = {n: dict(kind="found", expression=str(e), max_abs_error=err, max_rel_error=err,
                           **({"constants": ["0.5"]} if per == "material" else {}))
                   for n, (e, err, per) in found.items()}
        members["Karis"] = dict(kind="anchor", expression=str(anchor), max_abs_error=0.2, max_rel_error=0.2)
        return dict(architectures=["rdna3"], forms=forms, members=members, error="max_abs_error",
                    fronts_by_parameter={"rdna3": {per: [n for n, v in found.items() if v[2] == per]
                                                   for per in ("pixel", "material")}},
                    constant_error=0.5, rounding_floor=1e-7, missing={}, coverage={}, families=["planted"],
                    seconds=0.0, target=dict(name="p", variables=[dict(name="NoV", lo=0.02, hi=1.0)],
                                             parameter=dict(name="roughness", lo=0.05, hi=1.0), metric="abs"),
                    verdicts={})

    parts = iter([part({"a1": (1 - nov * r, 0.01, "pixel"), "a2": (c0 * nov, 0.03, "material")},
                       1 - nov * nov * r * r * r),
                  part({"b1": (nov * r, 0.02, "pixel"), "b2": (c0 + nov, 0.04, "material")},
                       nov * nov * r * r * r)])
    monkeypatch.setattr(pairs, "derive", lambda *args, **kwargs: next(parts))
    monkeypatch.setattr(pairs, "searched", lambda searches, *args: [([], {}) for _ in searches])  # (derive's)
    monkeypatch.setattr(pairs, "refitted_pair_anchors", lambda *args: [])     # (the real anchors' refit)
    both = targets.env_brdf_targets()
    pair = targets.pair("planted", both["env_brdf_scale"], both["env_brdf_bias"])
    results = pairs.derive_pair(pair, gpu=["rdna3"], log=lambda s: None)
    pixel = results["members"]["a1 + b1"]
    assert (pixel["max_abs_error"], pixel["max_abs_error_scale"], pixel["max_abs_error_bias"]) == (0.02, 0.01, 0.02)
    material = results["forms"]["a2 + b2"].expression
    F0 = sp.Symbol("F0", real=True)
    assert sp.simplify(material - (F0 * c0 * nov + c1 + nov)) == 0        # (the bias's c0 is the pair's c1)
    assert results["members"]["a2 + b2"]["constants"] == ["0.5", "0.5"]
    assert results["verdicts"]["rdna3"]["Karis"]["verdict"] == "beaten"
    row = next(r for r in results["rows"] if r["name"] == "a1 + b1")
    assert row["parameter_per"] == "pixel" and row["cycles"] > 0


def test_a_csv_table_runs_through_derive(tmp_path, monkeypatch):
    """A CSV table of 1 / (1 + a x) through `pipeline.derive` (the Python API), the templates cut to
    the reciprocal line and the grammar left out for time: its constants' formulas recover the law (k0 = 1, k1 = a) to the
    table's interpolation error, per material and per pixel, and no exact row (a table has no shader)."""
    if "rdna3" not in engines.available_architectures():
        pytest.skip("Mesa's RADV does not run here")
    from pipeline import derive

    _planted_csv(tmp_path / "law.csv")
    monkeypatch.setattr(templates, "BASES", {1: (("degree1", 1, False),)})
    monkeypatch.setattr(templates, "OUTERS", {"reciprocal": "reciprocal_polynomial"})
    # (the grammar's forms depend on how far its time budget reaches on a loaded machine: left out here)
    searched = dict(rungs=[], points=0, loss="max")
    monkeypatch.setattr(parametric_search, "_grammar_search", lambda *args: ([], dict(
        templates=searched | dict(count=0, seconds=0.0, at=1.25), pixel_search=searched)))
    monkeypatch.setattr(parametric_search, "worker_count", lambda parts: 0)     # (the planted templates: this process's)
    from pipeline.engine import paths

    monkeypatch.setattr(paths, "DERIVE_CACHE", tmp_path / "derive")
    found = derive(table=str(tmp_path / "law.csv"), x="x", parameter="a", gpu="rdna3", seconds=5, log=lambda s: None)
    rows = {r["name"]: r for r in found.rows}
    assert "exact" not in rows and {r["parameter_per"] for r in found.front} == {"material", "pixel"}
    best = min((r for r in found.front if r["parameter_per"] == "pixel"), key=lambda r: r["max_abs_error"])
    assert best["max_abs_error"] < 1e-3                 # (the spline between the table's 9 x 7 values)
    member = found.raw["members"][best["name"]]
    a = sp.Symbol("a", real=True)
    k0, k1 = (sp.sympify(c, locals={"a": a}) for c in member["constants"])
    assert float(k0.subs(a, 1.3)) == pytest.approx(1.0, abs=1e-3) and float(k1.subs(a, 1.3)) == pytest.approx(1.3, abs=1e-3)
    assert found.twin(best["name"])(0.3, 1.5) == pytest.approx(1 / (1 + 0.45), abs=1e-3)


GGX = """[target]
name = "ggx_d"
expression = "a2 / (pi * (NoH**2 * (a2 - 1) + 1)**2)"
metric = "rel"
[[variable]]
name = "NoH"
range = [0.0, 1.0]
[parameter]
name = "a2"
range = [0.01, 1.0]
[[anchor]]
name = "mine"
expression = "a2 / (pi * (1 - NoH**2 * (1 - a2))**2)"
"""


def test_a_toml_file_with_variables_is_a_parametric_target(tmp_path):
    from pipeline.approximate import api

    (tmp_path / "d.toml").write_text(GGX)
    target = api.resolve(str(tmp_path / "d.toml"))
    assert isinstance(target, Target)
    assert (target.variables, target.parameter, target.metric) == ((Axis("NoH", 0.0, 1.0),), Axis("a2", 0.01, 1.0), "rel")
    assert target.numpy()(np.array(1.0), np.array(0.25)) == pytest.approx(1 / (np.pi * 0.25))     # D(1) = 1 / (pi a2)
    mine = targets.numpy_function(target.anchor_expressions()["mine"], target.symbols())
    assert mine(np.array(0.3), np.array(0.5)) == pytest.approx(target.numpy()(np.array(0.3), np.array(0.5)))


@pytest.mark.parametrize("edit, message", [
    (lambda t: t.replace('range = [0.01, 1.0]', 'range = [0.01]'), "range = [0.01]"),
    (lambda t: t + "[other]\nx = 1\n", "unknown table 'other'"),
    (lambda t: t.replace('metric = "rel"', 'metric = "rel"\ncolour = 1'), "unknown key 'colour'"),
    (lambda t: t.replace('name = "NoH"\n', ''), "give name and range"),
    (lambda t: t.replace("(a2 - 1)", "(b - 1)"), "unknown name 'b'"),
])
def test_a_bad_toml_target_is_named(tmp_path, edit, message):
    (tmp_path / "d.toml").write_text(edit(GGX))
    with pytest.raises(DeriveError, match=message.replace("[", r"\[").replace("]", r"\]").replace("(", r"\(")):
        targets.from_file(tmp_path / "d.toml")


def test_ggx_d_comes_back_exactly_with_its_constants_in_one_over_a2(tmp_path):
    """GGX's D = a2 / (pi (1 + NoH^2 (a2 - 1))^2) is the reciprocal of a quartic in NoH whose
    constants are pi / a2, 2 pi (1 - 1 / a2) and pi (1 / a2 - 2 + a2): a + b p + c / p formulas
    (`laurent`) make it exact over the whole box; lines cannot (its k0 grows as 1 / a2)."""
    (tmp_path / "d.toml").write_text(GGX)
    target = targets.from_file(tmp_path / "d.toml")
    f = target.numpy()
    template = next(t for t in templates.family_templates(target, False, True)
                    if t.name == "reciprocal_polynomial_degree4")
    per_value = fits.fit_per_value(template, target, f)
    coefficients, error = formulas.polish_formulas(template, per_value, ("laurent",) * 5, target, f)
    assert error < 1e-9
    np.testing.assert_allclose(coefficients[[0, 2, 4], :3],
                               [[np.pi, 0, 0], [-2 * np.pi, 2 * np.pi, 0], [np.pi, -2 * np.pi, np.pi]], atol=1e-7)
    _, line = formulas.polish_formulas(template, per_value, ("line",) * 5, target, f)
    assert line > 0.1


def test_coefficients_at_rounding_level_are_dropped(tmp_path, monkeypatch):
    """GGX's quartic has no odd powers of NoH: the fitted template's k1 and k3 come back at rounding's
    level, and the member drops them (its material form has no c1, c3), no less accurate. (The
    formulas a + b p + c / p alone: the others are not what this tests.)"""
    monkeypatch.setattr(formulas, "formula_variants", lambda count, reduce, laurent=False: [("laurent",) * count])
    (tmp_path / "d.toml").write_text(GGX)
    target = targets.from_file(tmp_path / "d.toml")
    f = target.numpy()
    template = next(t for t in templates.family_templates(target, False, True)
                    if t.name == "reciprocal_polynomial_degree4")
    fitted = next(m for m in formulas.material_forms([template], target, f, lambda s: None) if m.formula == "laurent")
    assert np.all(fitted.coefficients[[1, 3]] == 0) and fitted.errors["max_rel_error"] < 1e-9
    names = {s.name for s in fitted.material.free_symbols}
    assert {"c0", "c2", "c4"} <= names and not names & {"c1", "c3"}


# ---- cos^n: a variable's range that moves with the parameter, and the lobe search's problem ----

def test_cos_n_s_zone_moves_with_n_and_the_spherical_gaussian_errs_its_closed_form():
    """cos_n's t lies in the epicenter zone [L^(1/n), 1] at every n of the mesh; the spherical
    Gaussian exp(n (t - 1)) errs most at the zone's edge of the smallest n (its ratio to t^n,
    exp(n (t - 1 - ln t)), falls in t and in n there): exp(2 (sqrt(L) - 1)) / L - 1, within 1e-9."""
    level = 0.5
    target = targets.cos_n_target(level)
    t, n = targets.mesh(target, 9)
    assert np.all(t >= level ** (1 / n) * (1 - 1e-15)) and np.all(t <= 1.0)
    assert np.any(np.isclose(t, level ** (1 / n), rtol=0, atol=1e-15)) and set(np.round(n, 9)) >= {2.0, 1000.0}
    sg = target.anchor_expressions()["SG"]
    measured = formulas.measure_box(sg, target, target.numpy())["max_rel_error"]
    assert measured == pytest.approx(np.exp(2 * (np.sqrt(level) - 1)) / level - 1, rel=1e-9)
    names = [t.name for t in templates.family_templates(target, False, True)]
    assert len(names) == 12 and not any("degree3" in n or "degree4" in n for n in names)    # (max_degree 2)
    with pytest.raises(DeriveError, match="lower end below 1"):
        targets.check(Target("bad", "t**n", (Axis("t", 0.5, 1.0, lo_of="2**(1/n)"),),
                                          Axis("n", 2.0, 10.0), "rel"))
    with pytest.raises(DeriveError, match="there is none"):
        targets.check(Target("bad", "t**2", (Axis("t", 0.5, 1.0, lo_of="0.5"),), None, "rel"))


def test_the_engine_and_the_lobe_search_fit_the_spherical_gaussian_s_class_alike():
    """One problem, two callers of one minimax (`minimax.along`): the engine's template exp2(k0 + k1 t)
    on cos_n (n in [10, 100], the zone at L = 0.6) and the lobe search's `exp2_linear` family. Per n
    the engine's error (13 zone points) is within 2 % below the search's (256 points) and at most 1e-4
    above it (the point sets are not nested: 256 Chebyshev points sample the interior peak to about
    (pi / 255)^2 / 2 = 8e-5 of its height);
    the engine's line formulas, polished on the whole box, err at least the search's per-n optimum
    at its worst n (measured exactly; within 2e-4: that fit is the minimax on 256 points, which errs
    up to 8e-5 above the true one); the search's lines (`lobe_search.parameter_formulas`, the same
    polish from its own per-n optima) err as much on the box (2e-4) and, measured at every integer n,
    no more than the least-squares lines through the per-n optima (numpy's polyfit here)."""
    from pipeline.optics.roots import SolverSettings
    from pipeline.stages import lobe_search

    level = 0.6
    target = targets.cos_n_target(level, (10.0, 100.0))
    f = target.numpy()
    template = next(t for t in templates.family_templates(target, False, True) if t.name == "exp2_polynomial_degree1")
    per_value = fits.fit_per_value(template, target, f)
    search = lobe_search.fit_family("exp2_linear", per_value.values, level, 256)
    ratio = per_value.errors / search["grid_zone_error"]
    assert np.all(ratio <= 1 + 1e-4) and np.all(ratio > 0.98), ratio
    _, line_error = formulas.polish_formulas(template, per_value, ("line", "line"), target, f)
    n = lobe_search.n_grid([(10.0, 100.0)], 6)
    fit = lobe_search.fit_family("exp2_linear", n, level, 256)
    settings = SolverSettings(1e-12, 1e-14, 200)
    d = lobe_search.exact_errors("exp2_linear", n, fit["grid_P"], level, 4096, settings)["d"].max()
    mids = lobe_search.midpoints(n)
    lines = lobe_search.parameter_formulas(
        "exp2_linear", "", np.r_[n, mids], np.r_[fit["grid_P"], fit["mid_P"]][:, :2],
        np.r_[fit["grid_zone_error"], fit["mid_zone_error"]], np.r_[np.ones(n.size, bool), np.zeros(mids.size, bool)],
        level, "cos_n", 10.0, 100.0)
    integers = np.arange(10.0, 101.0)

    def d_at_integers(slopes, intercepts):
        P = np.zeros((integers.size, 3))
        P[:, :2] = np.asarray(slopes) * integers[:, None] + np.asarray(intercepts)
        return lobe_search.exact_errors("exp2_linear", integers, P, level, 4096, settings)["d"].max()

    least_squares = np.array([np.polyfit(n, fit["grid_P"][:, j], 1) for j in range(2)])
    assert d * (1 - 2e-4) <= line_error
    assert lines["box_error"] == pytest.approx(line_error, rel=2e-4)
    assert d_at_integers(lines["slopes"], lines["intercepts"]) <= d_at_integers(least_squares[:, 0], least_squares[:, 1])


def test_a_parameter_s_range_is_replaced_as_the_lobe_search_splits_n(tmp_path):
    """`--range LO:HI` (`parameter_range`): cos_n over n in [100, 1000] has its zone's lowest end
    recomputed, L^(1/100); the environment BRDF's two parts both take it; bad ranges are named."""
    from pipeline.approximate import api

    target = api.resolve("cos_n", parameter_range="100:1000")
    assert (target.parameter.lo, target.parameter.hi) == (100.0, 1000.0)
    assert target.variables[0].lo == pytest.approx(targets.COS_N_LEVEL ** (1 / 100), rel=1e-12)
    pair = api.resolve("env_brdf", parameter_range=(0.5, 1.0))
    assert pair.scale.parameter.lo == pair.bias.parameter.lo == 0.5
    for bad, message in (("schlick", "has no parameter"), ("cos_n", "give LO:HI"), ("env_brdf", "the table covers")):
        with pytest.raises(DeriveError, match=message):
            api.resolve(bad, parameter_range="0.01:1" if bad == "env_brdf" else "1:2" if bad == "schlick" else "a:b")
    with pytest.raises(DeriveError, match="lo < hi"):
        api.resolve("cos_n", parameter_range="10:2")
    done = subprocess.run([sys.executable, "-m", "pipeline", "derive", "--target", "schlick", "--range", "1:2"],
                          capture_output=True, text=True, env=cli_env(tmp_path))
    assert done.returncode == 2 and "has no parameter" in done.stderr


def test_a_constant_no_line_holds_comes_from_the_symbolic_regression():
    """1 / (1 + sqrt(a) x): the reciprocal of a line whose slope is sqrt(a), a in [0.1, 4]. Lines in a
    err above 1e-2; the symbolic regression finds k0 = 1 and k1 = sqrt(a) from the per-value optima
    (`--formula-complexity`), and the member errs below 1e-6 over the whole box."""
    target = Target("sqrt_slope", "1/(1 + sqrt(a)*x)", (Axis("x", 0.0, 1.0),), Axis("a", 0.1, 4.0), "rel")
    f = target.numpy()
    template = next(t for t in templates.family_templates(target, False, True) if t.name == "reciprocal_polynomial_degree1")
    fitted = formulas.material_forms([template], target, f, lambda s: None, formula_complexity=4)
    line = next(m for m in fitted if m.formula == "line")
    found = next(m for m in fitted if m.formula.startswith("found"))
    assert line.errors["max_rel_error"] > 1e-2 and found.errors["max_rel_error"] < 1e-6, (line.errors, found.errors)
    a = sp.Symbol("a", real=True)
    assert sp.simplify(found.formulas[1] - sp.sqrt(a)).evalf(subs={a: 2.0}) == pytest.approx(0, abs=1e-8)
    record = parametric_search._records([found], target)[0]
    assert float(sp.sympify(record["formulas"]["constants"][1]).subs("a", 2.0)) == pytest.approx(np.sqrt(2.0), rel=1e-6)
    with pytest.raises(DeriveError, match="no parameter"):
        from pipeline.approximate import api
        api.derive("schlick", formula_complexity=3)


def test_a_pixel_form_costs_at_least_the_same_form_per_material():
    """cos^n written pow(t, n): per material (n a push constant) and per pixel (n an input, read by
    the form). Both are net of the shader writing t alone, so the pixel form pays the read of n and
    costs at least as much, on every architecture compiled here. Netted of the shader writing t and
    n, as every input it reads, it would cost less on RDNA3: its log hides n's interpolation, which
    that shader pays in sequence (the pitfall the netting avoids; 6 cycles against 12 measured)."""
    from pipeline.isa import machine_code

    architectures = [a for a in ("rdna3", "sm_89", "xe_hpg", "g610", "a740") if a in engines.available_architectures()]
    if not architectures:
        pytest.skip("no vendor's compiler runs here")
    target = targets.cos_n_target()
    t, n = target.symbols()
    forms = {"material": (t ** sp.Symbol("c0", real=True), "material"), "pixel": (t ** n, "pixel")}
    cycles, missing = several_variables.compile_forms(forms, target, architectures)
    assert not missing, missing
    for a in architectures:
        assert cycles[a]["pixel"] >= cycles[a]["material"] > 0, (a, cycles[a])
    if "rdna3" in architectures:
        netted_of_both, _, _ = machine_code.form_cycles({"pixel": ("return pow(t, n);", ["t", "n"])}, ["t", "n"],
                                                        ["rdna3"])
        assert netted_of_both["rdna3"]["pixel"] < cycles["rdna3"]["material"]


def test_a_refitted_anchor_is_the_tree_its_kept_text_reads_back():
    """Karis's A refitted: its numbers substituted leave c*(1 - r)*min(...) a product sympy never builds
    from text (it distributes a number over a sum), so the refit is taken as its kept text reads it
    (`anchor_refits._as_kept`): the same values, and a tree the derive cache keeps; a tree that reads
    back already is left as it is."""
    from pipeline.approximate.search import anchor_refits, kept
    from pipeline.approximate.forms import free_numbers

    target = targets.several_variable_targets()["env_brdf_scale"]
    symbols = {s.name: s for s in templates.kept_symbols(target)}
    (free,), q, numbers = free_numbers(target.anchor_expressions()["Karis"])
    refit = free.xreplace({qi: sp.Float(float(v) * 1.01, 17) for qi, v in zip(q, numbers)})
    with pytest.raises(kept.Unusable, match="does not read back to the same tree"):
        kept.text(refit, symbols)
    as_kept = anchor_refits._as_kept(refit, target)
    assert kept.expression(kept.text(as_kept, symbols), symbols) == as_kept
    nov, roughness = symbols["NoV"], symbols["roughness"]
    for point in ({nov: 0.3, roughness: 0.4}, {nov: 0.9, roughness: 0.05}):
        assert float(as_kept.subs(point)) == pytest.approx(float(refit.subs(point)), rel=1e-15)
    lazarov = target.anchor_expressions()["Lazarov"]
    assert sp.srepr(anchor_refits._as_kept(lazarov, target)) == sp.srepr(lazarov)
