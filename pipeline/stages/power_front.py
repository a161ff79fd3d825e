"""The family's accuracy/cost front (beyond the paper): the paper's derivation repeated for every
power m of `front.powers` (f_Q2, f_Q3, f_Q4, f_Q8 by default), each with its own best Q (the best of
the paper's grids for the run's metric, whatever Q the run itself uses) and its own fitted line (the
run's fit), on the run's zone and n range:
max d and max D over n and per n range, the energy with the exact normalization of that power
(the largest directional albedo over n and incidence angles, Phong and Blinn forms), and the
multiplies the power costs. Each power is one memoized call: a change of `lobe.power` or of the
list keeps the powers already computed.
"""

import numpy as np

from ..optics.numerics import jax
from ..optics import integrals, operations, registry
from ..optics.albedo import albedo_table
from ..optics.lobes import k_Q
from ..optics.roots import SolverSettings
from .common import measures, n_range, require_converged
from .family import best_Q, fit_line

RANGES = ((2, 10), (10, 100), (100, 1000))


def member(n, level, metric, fit, power, coarse_step, fine_step, rtol, atol, max_steps, nodes, angles):
    """One power's derivation: best Q, line, d and D per n, and the exact-coef albedo maxima."""
    settings = SolverSettings(rtol, atol, int(max_steps))
    power = int(power)
    Q = best_Q(n, level, settings, metric, power, coarse_step, fine_step, continuous=False)["Q_scan_best"]
    k_Q_n = np.asarray(jax.jit(k_Q, static_argnames="power")(n, float(Q), power=power))
    slope, intercept = fit_line(n, k_Q_n, fit, settings)
    k = slope * n + intercept
    m = measures(n, k, level, settings, power)
    require_converged(m["ok"], f"max D of f_Q{power}", n=n)
    theta = np.linspace(0.0, 0.5 * np.pi, int(angles))
    albedo = {}
    for form in registry.FORMS:
        coef_fn, _ = integrals.exact_coef_code(form, power)
        coef = np.asarray(coef_fn(n, slope, intercept))
        table = coef[:, None] * albedo_table(form, "linear_power", n, k, 1.0 / k, theta, int(nodes), power)
        i, j = np.unravel_index(np.argmax(table), table.shape)
        albedo[form] = dict(max=float(table[i, j]), n=float(n[i]), theta_deg=float(np.degrees(theta[j])),
                            normal_max_abs_dev=float(np.max(np.abs(table[:, 0] - 1.0))))
    return dict(Q=float(Q), slope=float(slope),
                intercept=float(intercept), d=np.asarray(m["d"]), D=np.asarray(m["D"]), albedo=albedo)


def ops_pixel(power: int) -> dict:
    """The sympy operation count per pixel of the family's lobe at `power` (n per material)."""
    p = registry.Parameters(slope=0.5, intercept=0.1, power=power)
    return operations.count_operations(registry.LOBES["f_Q2"].expression(p))[0]


def run(config, inputs, memo):
    n = np.asarray(n_range(config))
    level = inputs["zone.level"]
    powers = list(config["front.powers"])
    members, d_curves, D_curves = [], [], []
    for power in powers:
        m = memo("front_member", member, n=n, level=level, metric=config["derivation.metric"],
                 fit=config["derivation.fit"], power=power,
                 coarse_step=config["scan.coarse_step"], fine_step=config["scan.fine_step"],
                 rtol=config["solver.rtol"], atol=config["solver.atol"], max_steps=config["solver.max_steps"],
                 nodes=config["albedo.quadrature_nodes"], angles=config["comparison.albedo_angles"])
        d, D = m["d"], m["D"]
        by_range = []
        for lo, hi in RANGES:
            inside = (n >= max(lo, n[0])) & (n <= min(hi, n[-1]))
            if lo <= n[-1] and hi >= n[0] and inside.any():
                by_range.append(dict(n_range=[float(n[inside][0]), float(n[inside][-1])], d=float(d[inside].max()),
                                     D=float(D[inside].max())))
        members.append(dict(power=power, name=registry.family_name(power), Q=m["Q"], slope=m["slope"],
                            intercept=m["intercept"],
                            d=float(d.max()), D=float(D.max()), d_n_at_max=float(n[d.argmax()]),
                            D_n_at_max=float(n[D.argmax()]), by_range=by_range,
                            phong_albedo_max=m["albedo"]["phong"]["max"], blinn_albedo_max=m["albedo"]["blinn"]["max"],
                            normal_albedo_max_abs_dev=max(a["normal_max_abs_dev"] for a in m["albedo"].values()),
                            multiplies=registry.multiplies(power), ops_pixel=ops_pixel(power)))
        d_curves.append(d)
        D_curves.append(D)
    return dict(powers=powers, members=members, d_curves=np.stack(d_curves), D_curves=np.stack(D_curves))
