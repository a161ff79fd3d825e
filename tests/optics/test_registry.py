"""The lobe registry: every lobe declared once; a lobe added at run time reaches the comparison table,
the comparison figure and the cost table with no other file touched."""


import jax.numpy as jnp
import matplotlib
import numpy as np
import pytest
import sympy as sp

from pipeline.engine.cache import Cache
from pipeline.optics.numerics import jax  # noqa: F401  (float64 before any array)
from pipeline.engine.graph import BY_NAME
from pipeline.optics import lobes, registry
from pipeline.publish import plots, report_beyond
from pipeline.runner import run_stages

from ..helpers import copy_cache
from ..oracles import k_Q_np

PARAMS = registry.Parameters(Q=0.64, slope=0.448, intercept=0.099, coef_scale=0.214, coef_offset=0.807)


def test_one_parameter_function_serves_numpy_jax_and_sympy():
    n = np.array([2.0, 20.0, 1000.0])
    t, n_sym = registry.symbols()
    for lobe in registry.LOBES.values():
        with_numpy = np.asarray(lobe.parameter(np, n, PARAMS))
        with_jax = np.asarray(lobe.parameter(jnp, n, PARAMS))
        with_sympy = np.array([float(sp.sympify(lobe.parameter(registry.SYMPY, n_sym, PARAMS)).subs(n_sym, v))
                               for v in n])
        np.testing.assert_allclose(with_jax, with_numpy, rtol=1e-14)
        np.testing.assert_allclose(with_sympy, with_numpy, rtol=1e-12)
    # Against the formulas written out independently.
    np.testing.assert_allclose(registry.LOBES["f_Q"].parameter(np, n, PARAMS), k_Q_np(n, 0.64), rtol=1e-14)
    np.testing.assert_allclose(registry.LOBES["f_Q2"].parameter(np, n, PARAMS), 0.448 * n + 0.099, rtol=1e-15)
    np.testing.assert_allclose(registry.LOBES["f_2"].parameter(np, n, PARAMS), n / 2, rtol=0)


def test_each_lobes_sympy_form_is_its_jax_evaluation():
    t, n_sym = registry.symbols()
    for lobe in registry.LOBES.values():
        expr = lobe.expression(PARAMS).doit()
        for n in (2.0, 50.0):
            for c in (0.2, 0.9, 0.999):
                p = float(lobe.parameter(np, n, PARAMS))
                jax_value = float(lobes.SHAPES[lobe.shape](1.0 - c, p))
                assert float(expr.subs({t: c, n_sym: n})) == pytest.approx(jax_value, rel=1e-12, abs=1e-300)


def test_registry_entries_are_consistent():
    assert list(registry.LOBES)[0] == registry.REFERENCE
    assert tuple(lobes.SHAPES) == registry.SHAPE_NAMES
    for lobe in registry.LOBES.values():
        assert lobe.shape in registry.SHAPE_NAMES and matplotlib.colors.is_color_like(lobe.style["color"])
        assert {form for form, _ in lobe.energy} <= set(registry.FORMS)
    with pytest.raises(ValueError, match="registered already"):
        registry.register(registry.LOBES["f_2"])
    with pytest.raises(ValueError, match="shape 'cubic' is not one of"):
        registry.register(registry.Lobe("x", "t^3", "cubic", lambda m, n, p: n, "return t;", {}))


def with_upstream(names) -> tuple[str, ...]:
    """The stages `names` and every stage they read from, transitively."""
    out = set(names)
    while more := {u for s in out for u in BY_NAME[s].upstream} - out:
        out |= more
    return tuple(out)


TOY = registry.Lobe("f_toy", "((n/3)(t - 1) + 1)^2", "linear_power", lambda m, n, p: n / 3.0,
                    None, dict(color="C9", ls="-."), energy=(("phong", "phong_cos_n"),))


@pytest.fixture()
def toy_lobe():
    registry.register(TOY)
    try:
        yield TOY
    finally:
        registry.unregister(TOY.key)


def test_a_registered_lobe_reaches_the_comparison_its_figure_and_the_cost_table(toy_lobe, light_run, light_cache,
                                                                                light_config, tmp_path,
                                                                                monkeypatch):
    copy_cache(light_cache, tmp_path / "cache")
    results, _, computed = run_stages(light_config, Cache(tmp_path / "cache"), log=lambda s: None,
                                      stages=with_upstream({"lobe_comparison", "shader_cost"}))
    # The two registry stages recompute (the registry is part of their key); nothing upstream does.
    assert set(computed) == {"lobe_comparison", "shader_cost"}
    c = results["lobe_comparison"]
    # Its d: f_toy = ((n/3)(t - 1) + 1)^2 is f_2's family with a smaller k, so it errs more than f_2 at n >= 3.
    assert "f_toy" in c["d_max"] and c["d_max"]["f_toy"] > c["d_max"]["f_2"]
    table = "\n".join(report_beyond.comparison_section(light_config, results, {}))
    assert "| f_toy (phong) | ((n/3)(t - 1) + 1)^2 | (n + 2) / (2 pi) |" in table
    # The figure labels each curve at its end: the toy's label is drawn, in its registry colour.
    drawn = {}
    monkeypatch.setattr(plots, "_save", lambda fig, out, name, **kw: drawn.setdefault(name, fig) and name)
    plots.lobe_comparison(tmp_path, light_config, results)
    texts = [(t.get_text(), t.get_color()) for ax in drawn["lobe_comparison.png"].axes for t in ax.texts]
    assert ("f_toy", "C9") in texts
    if not results["shader_cost"]["available"]:
        pytest.skip(f"the cost table's part: the shader compilers are missing ({results['shader_cost']['tools']})")
    cost = {row["lobe"]: row for row in results["shader_cost"]["lobes"]}
    assert cost["f_toy"]["arithmetic"] == cost["f_Q2"]["arithmetic"] and cost["f_toy"]["transcendental"] == 0
    assert "| f_toy |" in "\n".join(report_beyond.cost_section(light_config, results))
