"""Nelder-Mead from several starts at once against scipy's, run by run."""

import numpy as np
import pytest
from scipy.optimize import minimize

from pipeline.optics import nelder_mead


def functions():
    """Planted: a smooth bowl, a kinked peak (|.|, as the errors' min() gives), one whose optimum is
    on a bound, a flat one (the value test stops it), and one not finite on part of the box."""
    return {
        "bowl": lambda x: (x[0] - 0.3) ** 2 + 2 * (x[1] + 0.1) ** 2 + 0.5 * x[0] * x[1],
        "kink": lambda x: -np.abs(np.sin(3 * x[0]) - x[1] ** 2) - 0.1 * np.abs(x[0] - x[1]),
        "bound": lambda x: -(x[0] + 2 * x[1]),
        "flat": lambda x: 0.0 * x[0] + 1.0,
        "nan": lambda x: np.where(x[0] > 0.5, np.nan, (x[0] - 0.6) ** 2 + x[1] ** 2),
    }


@pytest.mark.parametrize("name", list(functions()))
@pytest.mark.parametrize("maxfev", [1000, 23])
def test_every_run_is_scipy_s_to_the_last_bit(name, maxfev):
    """Eight runs from random simplices in random boxes, evaluated together: each run's x and value
    equal scipy's minimize with the same bounds, simplex and tolerances, bit for bit, also where the
    evaluations run out (maxfev 23)."""
    f = functions()[name]
    rng = np.random.default_rng(len(name) * maxfev)
    runs, expected = [], []
    for _ in range(8):
        lower = rng.uniform(-1, 0, 2)
        upper = lower + rng.uniform(0.2, 2, 2)
        x0 = rng.uniform(lower, upper)
        steps = rng.uniform(-0.3, 0.3, 2) * (upper - lower)
        simplex = np.vstack([x0, x0 + np.diag(steps)])
        options = dict(initial_simplex=simplex, xatol=1e-8, fatol=1e-12, maxfev=maxfev)
        with np.errstate(invalid="ignore"):
            found = minimize(lambda x: float(f(x)), x0, method="Nelder-Mead", bounds=list(zip(lower, upper)),
                             options=options)
        expected.append((found.x, found.fun))
        runs.append(nelder_mead.run(simplex, lower, upper, 1e-8, 1e-12, maxfev))
    calls = []

    def batched(points):
        calls.append(len(points))
        return f(points.T)

    with np.errstate(invalid="ignore"):
        got = nelder_mead.minimize_all(batched, runs)
    for (x, fun), (want_x, want_fun) in zip(got, expected):
        assert np.array_equal(x, want_x) and (fun == want_fun or np.isnan(fun) and np.isnan(want_fun))
    assert max(calls) == 8                # (the runs' points evaluated together)
