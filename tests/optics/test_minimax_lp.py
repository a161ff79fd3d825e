"""The minimax step's linear program on a working set against the same program on every point."""

from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import linprog

from pipeline.optics import minimax_lp


def whole_program(J, r, radius):
    """(t, d) of the program with every point's two rows (the reference)."""
    k = J.shape[1]
    A = np.block([[J, -np.ones((J.shape[0], 1))], [-J, -np.ones((J.shape[0], 1))]])
    lp = linprog(np.r_[np.zeros(k), 1.0], A_ub=A, b_ub=np.concatenate([-r, r]),
                 bounds=[(-radius[j], radius[j]) for j in range(k)] + [(0, None)], method="highs",
                 options=minimax_lp.HIGHS | dict(maxiter=minimax_lp.ITERATIONS))
    assert lp.status == 0
    return lp.x[k], lp.x[:k]


@pytest.fixture
def rows_solved(monkeypatch):
    """The number of points of every program HiGHS solves (each point two rows): the first round's,
    then the program with each round's points added."""
    sizes = []
    optimum = minimax_lp._optimum

    def counted(highs):
        sizes.append(highs.getNumRow() // 2)
        return optimum(highs)

    monkeypatch.setattr(minimax_lp, "_optimum", counted)
    return sizes


def test_solve_is_linprog_bit_for_bit():
    """HiGHS called directly with linprog's options: the same solution to the last bit as linprog's,
    on 400 random minimax programs (1 to 6 constants, 5 to 80 points, scales 1e-3 to 1e3, a column of
    zeros in a fifth of them), and None where linprog finds no optimum (an infeasible program)."""
    rng = np.random.default_rng(0)
    for trial in range(400):
        k, points = int(rng.integers(1, 7)), int(rng.integers(5, 80))
        J = rng.normal(size=(points, k)) * rng.choice([1e-3, 1.0, 1e3])
        if trial % 5 == 0:
            J[:, 0] = 0.0
        r = rng.normal(size=points)
        radius = rng.uniform(0.01, 10.0, size=k)
        A = np.block([[J, -np.ones((points, 1))], [-J, -np.ones((points, 1))]])
        b = np.r_[-r, r]
        c = np.r_[np.zeros(k), 1.0]
        lp = linprog(c, A_ub=A, b_ub=b, bounds=[(-radius[j], radius[j]) for j in range(k)] + [(0, None)],
                     method="highs", options=minimax_lp.HIGHS | dict(maxiter=minimax_lp.ITERATIONS))
        x = minimax_lp.solve(c, A, b, np.r_[-radius, 0.0], np.r_[radius, np.inf])
        assert lp.status == 0 and np.array_equal(x, lp.x), trial
    # infeasible: x <= -1 and x >= 1
    A = np.array([[1.0], [-1.0]])
    assert linprog([1.0], A_ub=A, b_ub=[-1.0, -1.0], bounds=[(None, None)], method="highs").status == 2
    assert minimax_lp.solve(np.array([1.0]), A, np.array([-1.0, -1.0]), np.array([-np.inf]), np.array([np.inf])) is None


def test_one_variable_the_best_polynomial_of_the_whole_program(rows_solved):
    """exp on [-1, 1] by a cubic, 4,000 points: the working set's optimum is the whole program's,
    and its programs hold a small share of the points."""
    x = np.cos(np.linspace(0.0, np.pi, 4000))
    J = np.stack([x ** j for j in range(4)], axis=1)
    r = -np.exp(x)
    radius = np.full(4, 10.0)
    t, d = minimax_lp.linear_minimax(J, r, radius)
    t_all, d_all = whole_program(J, r, radius)
    assert t == pytest.approx(t_all, rel=1e-9)
    np.testing.assert_allclose(d, d_all, rtol=1e-7, atol=1e-9)
    # the classical value: the best cubic to exp on [-1, 1] errs 5.53e-3 (equioscillating at 5 points)
    assert t == pytest.approx(5.53e-3, rel=2e-3)
    assert max(rows_solved) < 200 and sum(rows_solved) < 4000


def test_two_variables_and_a_binding_trust_region(rows_solved):
    """A bilinear form in two variables against exp(x y) + y on a 60 x 60 grid, once with room and
    once with a trust region that binds (the optimum's step on its bounds)."""
    g = np.linspace(0.0, 1.0, 60)
    x, y = [a.ravel() for a in np.meshgrid(g, g)]
    J = np.stack([np.ones_like(x), x, y, x * y], axis=1)
    r = -(np.exp(x * y) + y)
    for radius in (np.full(4, 100.0), np.array([0.01, 0.02, 0.01, 0.05])):
        t, d = minimax_lp.linear_minimax(J, r, radius)
        t_all, _ = whole_program(J, r, radius)
        assert t == pytest.approx(t_all, rel=1e-9)
        assert np.all(np.abs(d) <= radius * (1 + 1e-9))
        assert np.max(np.abs(r + J @ d)) <= t * (1 + 1e-9)
    assert max(rows_solved) < 600


def test_every_template_of_the_visibility_gets_the_whole_program_s_optimum():
    """The first step of each family template's fit at the middle roughness, from its own start,
    on a 41 x 41 grid of (NoV, NoL)."""
    from pipeline.approximate import targets
    from pipeline.approximate.search import per_value
    from pipeline.approximate.search import templates as template_forms

    target = targets.several_variable_targets()["smith_ggx_visibility"]
    f = target.numpy()
    symbols = target.symbols()[:2]
    value = 0.5
    x = targets.variables_at(target, 41, value)
    y = f(*x, value)
    w = targets.weight_of(target)(y)
    templates = template_forms.family_templates(target, targets.is_symmetric(target, f), True)
    assert len(templates) == 18
    for template in templates:
        model = per_value.Model(template.expression, symbols, template_forms.constant_symbols(template.count))
        c = template.start if not template.basis else per_value._linear_start(template, x, y, w, symbols)
        r = w * (model(c, x) - y)
        J = w[:, None] * model.jacobian(c, x)
        scale = np.max(np.abs(r))
        radius = 0.1 * (np.abs(c) + 1e-3) / scale
        t, _ = minimax_lp.linear_minimax(J, r / scale, radius)
        t_all, _ = whole_program(J, r / scale, radius)
        assert t == pytest.approx(t_all, rel=1e-9), template.name


def test_a_program_the_dual_simplex_cycles_on_stops_at_the_iteration_limit(rows_solved):
    """A minimax step of a rational of degrees 3/1 fitted to 12.92 x on [0, 0.0031308] (sRGB
    encode's linear piece; the fit is exact for a line of constants, so the program is degenerate),
    kept as it was met: HiGHS's dual simplex cycles on it without end where no iteration limit is
    set; with ITERATIONS it has no optimum (no step), and the limit is a count, the same everywhere."""
    kept = np.load(Path(__file__).parent / "cycling_program.npz")
    assert minimax_lp.OPTIONS.simplex_iteration_limit == minimax_lp.ITERATIONS
    assert minimax_lp.linear_minimax(kept["J"], kept["r"], kept["radius"]) is None
    assert rows_solved           # (it was solved, and stopped: not refused before HiGHS ran)
