"""Nelder-Mead from several starts at once: scipy's bounded Nelder-Mead (`scipy.optimize.minimize(...,
method="Nelder-Mead", bounds=..., options=dict(initial_simplex=..., xatol=..., fatol=..., maxfev=...))`,
scipy 1.17, its default coefficients) step for step, with the function evaluated at every run's next
point in one call of a function of arrays.

Each run is scipy's algorithm written as a generator (`run`): it yields the point it needs, receives
the value, and returns its result; `minimize_all` advances every run to its next point, evaluates
them together and sends each its value. The runs are independent, so each run's steps, and its
result, are scipy's to the last bit where the function of arrays gives at each point the value the
function gives at that point alone (numpy's elementwise operations do); the tests check it. The
evaluations are what costs: the largest error of a form over a box (`brdf.largest`) refines four
peaks, about a hundred evaluations each, and one call of a form's numpy function on four points
costs what a call on one point costs.
"""

from __future__ import annotations

from collections.abc import Callable, Generator

import numpy as np

RHO, CHI, PSI, SIGMA = 1.0, 2.0, 0.5, 0.5        # scipy's (not the adaptive ones)


class _Exhausted(Exception):
    """The run asked for more evaluations than `maxfev` (scipy's _MaxFuncCallError)."""


def run(simplex, lower, upper, xatol: float, fatol: float, maxfev: int) -> Generator:
    """One bounded Nelder-Mead run from `simplex` ((n + 1, n)) for `minimize_all`: scipy's
    `_minimize_neldermead` with bounds and an initial simplex, as a generator of the points it
    evaluates; returns (x, f(x)) as scipy's result (its x and fun)."""
    lower, upper = np.asarray(lower, dtype=np.float64), np.asarray(upper, dtype=np.float64)
    calls = [0]

    def func(x):
        if calls[0] >= maxfev:
            raise _Exhausted
        calls[0] += 1
        value = yield x
        return value

    sim = np.asarray(simplex, dtype=np.float64).copy()
    n = sim.shape[1]
    sim = np.where(sim > upper, 2 * upper - sim, sim)
    sim = np.clip(sim, lower, upper)
    fsim = np.full((n + 1,), np.inf, dtype=float)
    try:
        for k in range(n + 1):
            fsim[k] = yield from func(sim[k])
    except _Exhausted:
        pass
    finally:
        ind = np.argsort(fsim)
        sim = np.take(sim, ind, 0)
        fsim = np.take(fsim, ind, 0)
    ind = np.argsort(fsim)
    fsim = np.take(fsim, ind, 0)
    sim = np.take(sim, ind, 0)
    while calls[0] < maxfev:
        try:
            if np.max(np.ravel(np.abs(sim[1:] - sim[0]))) <= xatol and np.max(np.abs(fsim[0] - fsim[1:])) <= fatol:
                break
            xbar = np.add.reduce(sim[:-1], 0) / n
            xr = np.clip((1 + RHO) * xbar - RHO * sim[-1], lower, upper)
            fxr = yield from func(xr)
            shrink = False
            if fxr < fsim[0]:
                xe = np.clip((1 + RHO * CHI) * xbar - RHO * CHI * sim[-1], lower, upper)
                fxe = yield from func(xe)
                if fxe < fxr:
                    sim[-1], fsim[-1] = xe, fxe
                else:
                    sim[-1], fsim[-1] = xr, fxr
            elif fxr < fsim[-2]:
                sim[-1], fsim[-1] = xr, fxr
            else:
                if fxr < fsim[-1]:
                    xc = np.clip((1 + PSI * RHO) * xbar - PSI * RHO * sim[-1], lower, upper)
                    fxc = yield from func(xc)
                    if fxc <= fxr:
                        sim[-1], fsim[-1] = xc, fxc
                    else:
                        shrink = True
                else:
                    xcc = np.clip((1 - PSI) * xbar + PSI * sim[-1], lower, upper)
                    fxcc = yield from func(xcc)
                    if fxcc < fsim[-1]:
                        sim[-1], fsim[-1] = xcc, fxcc
                    else:
                        shrink = True
                if shrink:
                    for j in range(1, n + 1):
                        sim[j] = np.clip(sim[0] + SIGMA * (sim[j] - sim[0]), lower, upper)
                        fsim[j] = yield from func(sim[j])
        except _Exhausted:
            pass
        ind = np.argsort(fsim)
        sim = np.take(sim, ind, 0)
        fsim = np.take(fsim, ind, 0)
    return sim[0], float(np.min(fsim))


def minimize_all(function: Callable, runs: list[Generator]) -> list:
    """Every run of `runs` (generators as `run`'s, or of several `run`s in turn) to its end, the
    points all runs need next evaluated together: function(points (count, dimensions)) -> values
    (count,). Returns each run's return value."""
    results: list = [None] * len(runs)
    pending = {}
    for i, run in enumerate(runs):
        try:
            pending[i] = next(run)
        except StopIteration as stop:
            results[i] = stop.value
    while pending:
        order = list(pending)
        values = function(np.array([pending[i] for i in order]))
        for i, value in zip(order, values):
            try:
                pending[i] = runs[i].send(float(value))
            except StopIteration as stop:
                results[i] = stop.value
                del pending[i]
    return results

