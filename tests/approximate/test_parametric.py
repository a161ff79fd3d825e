"""`pipeline derive` on targets of several variables and a material parameter (`parametric`): the
templates, a planted law recovered exactly with its constants as formulas, the per-value optimum
as a bound, bad input, and one whole run of the command (the Smith-GGX visibility on RDNA3)."""

import csv
import importlib.util
import json
import subprocess
import sys

import numpy as np
import pytest
import sympy as sp

from pipeline.approximate import engine, parametric
from pipeline.approximate.parametric import Axis, ParametricTarget
from pipeline.approximate.targets import DeriveError
from pipeline.optics import brdf
from tests.helpers import cli_env

X, Y = sp.symbols("x y", real=True)


def test_symmetric_monomials_are_the_symmetric_sums():
    def terms(*args):
        out = parametric._monomials([X, Y], *args)
        assert out[0] == 1 and len(set(out)) == len(out)         # (the constant first, no repeats)
        return set(out)

    assert terms(2, False, True) == {1, X + Y, X * Y, X**2 + Y**2}
    assert terms(1, True, True) == {1, X + Y, X * Y}
    assert terms(1, True, False) == {1, X, Y, X * Y}
    assert terms(2, False, False) == {1, X, Y, X * Y, X**2, Y**2}


PLANTED = ParametricTarget("planted", "1/((0.5 + 1.5*a)*(x + y) + (2 - a)*x*y)", (Axis("x", 0.1, 1.0), Axis("y", 0.1, 1.0)),
                           Axis("a", 0.0, 1.0), "rel")


def test_a_planted_law_comes_back_exactly_with_lines_in_the_parameter():
    """1/(k0 (x + y) + k1 x y) with k0 = 0.5 + 1.5 a, k1 = 2 - a: the symmetric reciprocal template is
    exact at every value, and its constants' lines, polished together, are the planted ones."""
    target = parametric.check(PLANTED)
    f = target.numpy()
    assert parametric.is_symmetric(target, f)
    template = next(t for t in parametric.family_templates(target, True)
                    if t.name == "reciprocal_polynomial_bilinear_no_constant_symmetric")
    per_value = parametric.fit_per_value(template, target, f)
    assert per_value.errors.max() < 1e-10
    coefficients, error = parametric.polish_formulas(template, per_value, ("line", "line"), target, f)
    assert error < 1e-10
    np.testing.assert_allclose(coefficients[:, :2], [[0.5, 1.5], [2.0, -1.0]], atol=1e-8)
    assert np.all(coefficients[:, 2] == 0)          # (a line has no square term)
    # the same with k0 proportional: not the law, measurably worse, never better than per value
    _, reduced = parametric.polish_formulas(template, per_value, ("proportional", "line"), target, f)
    assert reduced > 1e-3


def test_the_per_value_optimum_bounds_the_formulas_on_the_visibility():
    """On V(NoV, NoL; alpha): the reciprocal bilinear template's lines are no better than its
    constants fitted at each value alone, and Hammon's error is its closed form 1 - sqrt(0.51)."""
    target = parametric.registry()["smith_ggx_visibility"]
    f = target.numpy()
    template = next(t for t in parametric.family_templates(target, True)
                    if t.name == "reciprocal_polynomial_bilinear_no_constant_symmetric")
    per_value = parametric.fit_per_value(template, target, f)
    _, line = parametric.polish_formulas(template, per_value, ("line", "line"), target, f)
    assert line >= per_value.errors.max() * (1 - 1e-9)
    hammon = parametric.measure_box(target.anchor_expressions()["Hammon"], target, f)["max_rel_error"]
    assert hammon == pytest.approx(brdf.hammon_largest_relative_error(0.02)[0], rel=1e-6)
    assert line < hammon / 2        # (measured 0.132 against 0.286)


@pytest.mark.parametrize("target, message", [
    (ParametricTarget("t", "x*y", (Axis("x", 1.0, 0.0), Axis("y", 0, 1))), "x in [1.0, 0.0]"),
    (ParametricTarget("t", "x*y", (Axis("x", 0, 1), Axis("x", 0, 1))), "repeat"),
    (ParametricTarget("t", "x*z", (Axis("x", 0, 1), Axis("y", 0, 1))), "unknown name 'z'"),
    (ParametricTarget("t", "1/x", (Axis("x", 0, 1),), Axis("a", 0, 1), "abs"), "is not finite at x = 0"),
    (ParametricTarget("t", "x - a", (Axis("x", 0, 1),), Axis("a", 0, 1), "rel"), "is 0"),
    (ParametricTarget("t", "x", (Axis("x", 0, 1), Axis("y", 0, 1), Axis("z", 0, 1)), Axis("a", 0, 1)), "at most 3"),
])
def test_bad_targets_are_named(target, message):
    with pytest.raises(DeriveError, match=message.replace("[", r"\[").replace("]", r"\]")):
        parametric.check(target)


def test_pipeline_derive_on_the_smith_ggx_visibility(tmp_path):
    """The whole command once, on RDNA3 with a small budget: the columns range and parameter_per,
    material rows with their constants' formulas, Hammon's V placed and beaten by a pixel form at no
    more cycles (measured: 0.166 at 8 cycles against 0.286 at 10), the twins equal to the members'
    values, and a rerun that keeps the search."""
    if "rdna3" not in engine.available_architectures():
        pytest.skip("Mesa's RADV does not run here: pipeline derive was not run")
    out = tmp_path / "v"
    command = [sys.executable, "-m", "pipeline", "derive", "--target", "smith_ggx_visibility", "--gpu", "rdna3",
               "--seconds", "10", "--max-complexity", "6", "--out", str(out)]
    env = cli_env(tmp_path, PIPELINE_DERIVE_CACHE=str(tmp_path / "derive"))
    done = subprocess.run(command, capture_output=True, text=True, env=env, timeout=900)
    assert done.returncode == 0, done.stdout + done.stderr
    with open(out / "front.csv") as f:
        rows = list(csv.DictReader(f))
    assert {r["parameter_per"] for r in rows} == {"material", "pixel"}
    assert {r["range"] for r in rows} == {"alpha in [0.02, 1]"}
    assert all("c0 = " in r["expression"] for r in rows if r["parameter_per"] == "material")
    results = json.loads((out / "results.json").read_text())
    hammon = results["verdicts"]["rdna3"]["Hammon"]
    assert hammon["verdict"] == "beaten", hammon
    by = results["members"][hammon["by"]]
    assert by["parameter_per"] == "pixel" and by["max_rel_error"] < hammon["error"]
    assert by["per_value_error"] <= by["max_rel_error"] * (1 + 1e-9)
    spec = importlib.util.spec_from_file_location("derive_twin", out / "derive_twin.py")
    twin = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(twin)
    target = parametric.registry()["smith_ggx_visibility"]
    symbols = {s.name: s for s in target.symbols()}
    points = [(0.1, 0.7, 0.3), (0.9, 0.05, 0.9), (0.5, 0.5, 0.02)]
    for name, member in results["members"].items():
        if member["kind"] != "found":
            continue
        function = getattr(twin, f"smith_ggx_visibility_{name}")
        for nov, nol, alpha in points:
            if member["parameter_per"] == "material":
                constants = getattr(twin, f"smith_ggx_visibility_{name}_constants")(alpha)
                got = function(nov, nol, *constants)
                text, _ = member["expression"].split(";", 1)
                formulas = {f"c{i}": sp.sympify(c, locals=symbols).subs(symbols["alpha"], alpha)
                            for i, c in enumerate(member["constants"])}
                expected = float(sp.sympify(text, locals=symbols).subs(formulas).subs({symbols["NoV"]: nov, symbols["NoL"]: nol}))
            else:
                got = function(nov, nol, alpha)
                expected = float(sp.sympify(member["expression"], locals=symbols).subs(
                    {symbols["NoV"]: nov, symbols["NoL"]: nol, symbols["alpha"]: alpha}))
            assert got == pytest.approx(expected, rel=1e-6)     # (the expression's text: 7 to 9 digits)
    again = subprocess.run(command, capture_output=True, text=True, env=env, timeout=900)
    assert again.returncode == 0 and "the search of an earlier run" in again.stdout, again.stdout + again.stderr
