"""Other cheap lobes, side by side (beyond the paper): on the run's zone, error measures and n range,
the shape errors d and D of every lobe of the registry (`pipeline.optics.registry`), the energy each
reflects with the normalizations an engine pairs it with (albedo at normal incidence and its largest
value over incidence angles), and the operations each costs.

Every registry lobe is compared at the run's parameters; a lobe that depends on Q (f_Q) also at the
continuous optimum of Q, as the instance `<key> (Q best)`. The quadratic lobes' d and D are found
here by the generic grid-and-bisection search of `pipeline.optics.extrema`; the tests check it
against the closed-form measures of `pipeline.optics.error_measures`. Each lobe's error curves and
each energy row's albedo table are memoized calls keyed on their values: a refit that changes Q or
the line recomputes only the lobes and rows that depend on them.
"""

from ..optics.numerics import jax  # noqa: F401  (float64 before any array)
import jax.numpy as jnp
import numpy as np

from ..optics import operations, registry
from ..optics.albedo import albedo_table
from ..optics.extrema import error_curves
from ..optics.lobes import support_end
from ..optics.normalizations import normalizations
from ..optics.roots import SolverSettings
from .common import n_range, require_converged, runs_of

QUADRATURE_CHECK_N = (2.0, 10.0, 100.0, 1000.0)
LARGE_N = (1e4, 1e6)        # where the errors are reported as their limits
Q_BEST = " (Q best)"        # the instance of a Q-dependent lobe at the continuous optimum of Q


def _short(ops: dict) -> str:
    parts = [f"{v} {k}" for k, v in ops.items() if v and k != "madd"]
    if ops["madd"]:
        parts.append(f"{ops['madd']} mul/add")
    return ", ".join(parts) or "none"


def shape_errors(shape, n, p, level, cells, rtol, atol, max_steps, power=2):
    """d and D per n of the lobe `SHAPES[shape](u, p, power)` (p per n)."""
    m = error_curves(shape, n, p, level, cells, SolverSettings(rtol, atol, max_steps), int(power))
    require_converged(m["ok"], f"extrema of the {shape} lobe", n=n)
    return dict(d=np.asarray(m["d"]), D=np.asarray(m["D"]))


def energy_table(form, shape, n, p, u_end, theta, nodes, check_n, power=2):
    """Albedo table (unnormalized: coef = 1) over n x theta, and the same at `check_n` with twice
    the nodes."""
    idx = np.searchsorted(n, check_n)
    return dict(table=albedo_table(form, shape, n, p, u_end, theta, nodes, int(power)),
                check=albedo_table(form, shape, n[idx], p[idx], u_end[idx], theta, 2 * nodes, int(power)) if len(idx)
                else np.zeros((0, len(theta))))


def instances(used: registry.Parameters, best: registry.Parameters):
    """(instance, lobe, parameters) of every compared lobe, in registry order."""
    out = []
    for lobe in registry.LOBES.values():
        out.append((lobe.key, lobe, used))
        if "Q" in lobe.depends_on:
            out.append((lobe.key + Q_BEST, lobe, best))
    return out


def run(config, inputs, memo):
    n = np.asarray(n_range(config))
    level = inputs["zone.level"]
    solver = dict(rtol=config["solver.rtol"], atol=config["solver.atol"], max_steps=config["solver.max_steps"])
    used = registry.Parameters(Q=inputs["q_choice.Q_used"], slope=inputs["linear_coefficient.slope_used"],
                               intercept=inputs["linear_coefficient.intercept_used"],
                               coef_scale=inputs["hemispherical.coef_scale_used"],
                               coef_offset=inputs["hemispherical.coef_offset_used"], power=config["lobe.power"])
    best = used._replace(Q=inputs["q_scan.Q_continuous_best"])
    compared = instances(used, best)
    norms = normalizations(used)
    cells = config["comparison.grid_cells"]

    shapes, lobe_rows, large_n = {}, [], []
    # The large n are evaluated with the range, in one call (one compiled program).
    n_ext = np.concatenate([n, LARGE_N])
    for key, lobe, p in compared:
        m = memo("shape_errors", shape_errors, shape=lobe.shape, n=n_ext,
                 p=np.asarray(lobe.parameter(jnp, n_ext, p), dtype=np.float64), level=level, cells=cells,
                 power=lobe.power_of(p), **solver)
        large_n += [dict(lobe=key, n=float(v), d=float(d), D=float(D))
                    for v, d, D in zip(LARGE_N, m["d"][len(n):], m["D"][len(n):])]
        m = {name: m[name][: len(n)] for name in ("d", "D")}
        pixel, material = operations.count_operations(lobe.expression(p))
        shapes[key] = dict(d=float(m["d"].max()), D=float(m["D"].max()), d_curve=m["d"], D_curve=m["D"],
                           ops_pixel=pixel, ops_material=material)
        lobe_rows.append(dict(lobe=key, registry_key=lobe.key, name=lobe.name(p) + key[len(lobe.key):],
                              label=lobe.label(p), formula=lobe.formula_of(p), power=lobe.power_of(p),
                              d_n_at_max=float(n[m["d"].argmax()]), D_n_at_max=float(n[m["D"].argmax()]),
                              ops_pixel=pixel, ops_material=material))

    theta = np.linspace(0.0, 0.5 * np.pi, config["comparison.albedo_angles"])
    nodes = config["albedo.quadrature_nodes"]
    check = np.array([m for m in QUADRATURE_CHECK_N if n[0] <= m <= n[-1]])
    # Phong-form rows first, then the Blinn form; within a form, in registry order.
    pairs = [(key, lobe, p, form, norm_key) for form in registry.FORMS for key, lobe, p in compared
             for f, norm_key in lobe.energy if f == form]
    rows, quad_error = [], 0.0
    for key, lobe, p, form, norm_key in pairs:
        norm = norms[norm_key]
        param = np.asarray(lobe.parameter(jnp, n, p), dtype=np.float64)
        coef = np.asarray(norm.fn(n), dtype=np.float64)
        t = memo("energy_table", energy_table, form=form, shape=lobe.shape, n=n, p=param,
                 u_end=np.asarray(support_end(lobe.shape, param), dtype=np.float64),
                 theta=theta, nodes=nodes, check_n=check, power=lobe.power_of(p))
        # The albedo is linear in coef: rows sharing a form and a lobe share one table.
        table = coef[:, None] * t["table"]
        if len(check):
            idx = np.searchsorted(n, check)
            quad_error = max(quad_error, float(np.max(np.abs(table[idx] - coef[idx, None] * t["check"]))))
        normal = table[:, 0]
        i, j = np.unravel_index(np.argmax(table), table.shape)
        norm_ops, _ = operations.count_operations(norm.expr, operations.n_sym)
        shape = shapes[key]
        per_pixel_n = {op: shape["ops_pixel"][op] + shape["ops_material"][op] + norm_ops[op]
                       for op in operations.OPERATIONS}
        rows.append(dict(lobe=key, form=form, normalization=norm_key, formula=lobe.formula_of(p),
                         normalization_formula=norm.formula, d=shape["d"], D=shape["D"],
                         albedo_normal_max_abs_dev=float(np.max(np.abs(normal - 1.0))),
                         albedo_normal_n_at_max=float(n[np.argmax(np.abs(normal - 1.0))]),
                         albedo_max=float(table[i, j]), albedo_max_n=float(n[i]),
                         albedo_max_theta_deg=float(np.degrees(theta[j])),
                         ops_pixel=shape["ops_pixel"], ops_with_n_per_pixel=per_pixel_n,
                         ops_pixel_text=_short(shape["ops_pixel"]), ops_with_n_text=_short(per_pixel_n)))

    # Per n, for each pair of lobes (f_Q2 first): where each is better on d and on D.
    keys = [key for key, _, _ in compared]
    order = ["f_Q2"] + [key for key in keys if key not in (registry.REFERENCE, "f_Q2")]
    per_n = []
    for i, key_a in enumerate(order):
        for key_b in order[i + 1:]:
            for measure in ("d", "D"):
                a_, b_ = shapes[key_a][f"{measure}_curve"], shapes[key_b][f"{measure}_curve"]
                per_n.append(dict(lobe_a=key_a, lobe_b=key_b, measure=measure,
                                  a_better=runs_of(a_ < b_, n), b_better=runs_of(b_ < a_, n)))

    return dict(lobes=lobe_rows, rows=rows, quadrature_error=quad_error, per_n=per_n, large_n=large_n,
                d_max={key: shapes[key]["d"] for key in keys}, D_max={key: shapes[key]["D"] for key in keys},
                d_curves=np.stack([shapes[k]["d_curve"] for k in keys]),
                D_curves=np.stack([shapes[k]["D_curve"] for k in keys]))
