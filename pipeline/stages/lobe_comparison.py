"""Other cheap lobes, side by side (beyond the paper): on the run's zone, error measures and n range,
the shape errors d and D of every lobe of `pipeline.cheap_lobes`, the energy each reflects with the
normalization an engine pairs it with (albedo at normal incidence and its largest value over
incidence angles), and the operations each costs.

The quadratic lobes' d and D are found here by the generic grid-and-bisection search of
`pipeline.extrema`; the tests check it against the closed-form measures of `pipeline.error_measures`.
Each lobe's error curves and each energy row's albedo table are memoized calls keyed on their
values: a refit that changes Q or the line recomputes only the lobes and rows that depend on them.
"""

import numpy as np

from ..optics import cheap_lobes
from ..optics.albedo import albedo_table
from ..optics.extrema import error_curves
from ..optics.roots import SolverSettings
from .common import n_range, require_converged, runs_of

QUADRATURE_CHECK_N = (2.0, 10.0, 100.0, 1000.0)
LARGE_N = (1e4, 1e6)        # where the errors are reported as their limits
LOBE_KEYS = ("cos^n", "f_2", "f_Q used", "f_Q best", "f_Q2", "Schlick", "SG", "SG (Lagarde)")

# (row label, form, lobe name, normalization name): each approximation of cos^n is paired with
# cos^n's own normalization, as a shader replacing pow() would pair it; the paper's lobe with its
# coef(n), and with the exact one; the Blinn form with Blinn-Phong's normalizations.
ENERGY_ROWS = (
    ("cos^n", "phong", "cos^n", "(n+2)/(2pi)"),
    ("f_2", "phong", "f_2", "(n+2)/(2pi)"),
    ("f_Q (run's Q)", "phong", "f_Q used", "(n+2)/(2pi)"),
    ("f_Q (optimal Q)", "phong", "f_Q best", "(n+2)/(2pi)"),
    ("f_Q2, run's coef", "phong", "f_Q2", "paper coef"),
    ("f_Q2, exact coef", "phong", "f_Q2", "exact Phong coef"),
    ("f_Q2, (3/(2pi))(k + 1/4)", "phong", "f_Q2", "asymptotic Phong coef"),
    ("Schlick", "phong", "Schlick", "(n+2)/(2pi)"),
    ("SG", "phong", "SG", "(n+2)/(2pi)"),
    ("SG (Lagarde)", "phong", "SG (Lagarde)", "(n+2)/(2pi)"),
    ("Blinn: cos^n, Giesen", "blinn", "cos^n", "Giesen"),
    ("Blinn: cos^n, (n+8)/(8pi)", "blinn", "cos^n", "(n+8)/(8pi)"),
    ("Blinn: cos^n, Gotanda", "blinn", "cos^n", "Gotanda"),
    ("Blinn: f_Q2, exact Blinn coef", "blinn", "f_Q2", "exact Blinn coef"),
    ("Blinn: f_Q2, (3/(8pi))(k + 5/4)", "blinn", "f_Q2", "asymptotic Blinn coef"),
)


def tag_of(key: str) -> str:
    """A lobe's key as a result-name fragment: "SG (Lagarde)" -> "sg_lagarde", "cos^n" -> "cosn"."""
    return key.replace("^", "").replace(" ", "_").replace("(", "").replace(")", "").lower()


def _short(ops: dict) -> str:
    parts = [f"{v} {k}" for k, v in ops.items() if v and k != "madd"]
    if ops["madd"]:
        parts.append(f"{ops['madd']} mul/add")
    return ", ".join(parts) or "none"


def shape_errors(shape, n, p, level, cells, rtol, atol, max_steps):
    """d and D per n of the lobe `SHAPES[shape](u, p)` (p per n)."""
    m = error_curves(shape, n, p, level, cells, SolverSettings(rtol, atol, max_steps))
    require_converged(m["ok"], f"extrema of the {shape} lobe", n=n)
    return dict(d=np.asarray(m["d"]), D=np.asarray(m["D"]))


def energy_table(form, shape, n, p, u_end, theta, nodes, check_n):
    """Albedo table (unnormalized: coef = 1) over n x theta, and the same at `check_n` with twice
    the nodes."""
    idx = np.searchsorted(n, check_n)
    return dict(table=albedo_table(form, shape, n, p, u_end, theta, nodes),
                check=albedo_table(form, shape, n[idx], p[idx], u_end[idx], theta, 2 * nodes) if len(idx)
                else np.zeros((0, len(theta))))


def run(config, inputs, memo):
    a, b = inputs["linear_coefficient.slope_used"], inputs["linear_coefficient.intercept_used"]
    n = np.asarray(n_range(config))
    level = inputs["zone.level"]
    solver = dict(rtol=config["solver.rtol"], atol=config["solver.atol"], max_steps=config["solver.max_steps"])
    lobes = dict(zip(LOBE_KEYS, cheap_lobes.shape_lobes(inputs["q_choice.Q_used"], inputs["q_scan.Q_continuous_best"],
                                                        a, b)))
    norms = cheap_lobes.normalizations(a, b, inputs["hemispherical.coef_scale_used"],
                                       inputs["hemispherical.coef_offset_used"])
    cells = config["comparison.grid_cells"]

    shapes, lobe_rows, large_n = {}, [], []
    # The large n are evaluated with the range, in one call (one compiled program).
    n_ext = np.concatenate([n, LARGE_N])
    for key, lobe in lobes.items():
        m = memo("shape_errors", shape_errors, shape=lobe.shape, n=n_ext,
                 p=np.asarray(lobe.param(n_ext), dtype=np.float64), level=level, cells=cells, **solver)
        large_n += [dict(lobe=lobe.name, n=float(v), d=float(d), D=float(D))
                    for v, d, D in zip(LARGE_N, m["d"][len(n):], m["D"][len(n):])]
        m = {name: m[name][: len(n)] for name in ("d", "D")}
        pixel, material = cheap_lobes.count_operations(lobe.expr)
        shapes[key] = dict(d=float(m["d"].max()), D=float(m["D"].max()), d_curve=m["d"], D_curve=m["D"],
                           ops_pixel=pixel, ops_material=material)
        lobe_rows.append(dict(key=key, tag=tag_of(key), name=lobe.name, formula=lobe.formula,
                              d_n_at_max=float(n[m["d"].argmax()]), D_n_at_max=float(n[m["D"].argmax()]),
                              ops_pixel=pixel, ops_material=material))

    theta = np.linspace(0.0, 0.5 * np.pi, config["comparison.albedo_angles"])
    nodes = config["albedo.quadrature_nodes"]
    check = np.array([m for m in QUADRATURE_CHECK_N if n[0] <= m <= n[-1]])
    rows, quad_error = [], 0.0
    for label, form, lobe_key, norm_key in ENERGY_ROWS:
        lobe, norm = lobes[lobe_key], norms[norm_key]
        # A shader clamps t = max(dot, 0): lobes other than the quadratics hold their value at t = 0
        # past it (which matters only for the spherical Gaussians' exp(-n)); their support is all of u.
        u_end = lobe.u_end(n) if lobe.shape == "quadratic" else 2.0 + 0.0 * n
        coef = np.asarray(norm.fn(n), dtype=np.float64)
        t = memo("energy_table", energy_table, form=form, shape=lobe.shape, n=n,
                 p=np.asarray(lobe.param(n), dtype=np.float64), u_end=np.asarray(u_end, dtype=np.float64),
                 theta=theta, nodes=nodes, check_n=check)
        # The albedo is linear in coef: rows sharing a form and a lobe share one table.
        table = coef[:, None] * t["table"]
        if len(check):
            idx = np.searchsorted(n, check)
            quad_error = max(quad_error, float(np.max(np.abs(table[idx] - coef[idx, None] * t["check"]))))
        normal = table[:, 0]
        i, j = np.unravel_index(np.argmax(table), table.shape)
        norm_ops, _ = cheap_lobes.count_operations(norm.expr, cheap_lobes.n_sym)
        shape = shapes[lobe_key]
        per_pixel_n = {op: shape["ops_pixel"][op] + shape["ops_material"][op] + norm_ops[op]
                       for op in cheap_lobes.OPERATIONS}
        rows.append(dict(label=label, form=form, lobe=lobe.name, formula=lobe.formula,
                         normalization=norm.formula, d=shape["d"], D=shape["D"],
                         albedo_normal_max_abs_dev=float(np.max(np.abs(normal - 1.0))),
                         albedo_normal_n_at_max=float(n[np.argmax(np.abs(normal - 1.0))]),
                         albedo_max=float(table[i, j]), albedo_max_n=float(n[i]),
                         albedo_max_theta_deg=float(np.degrees(theta[j])),
                         ops_pixel=shape["ops_pixel"], ops_with_n_per_pixel=per_pixel_n,
                         ops_pixel_text=_short(shape["ops_pixel"]), ops_with_n_text=_short(per_pixel_n)))

    # Per n, for each pair of lobes (f_Q2 first): where each is better on d and on D.
    order = ["f_Q2"] + [key for key in LOBE_KEYS if key not in ("cos^n", "f_Q2")]
    per_n = []
    for i, key_a in enumerate(order):
        for key_b in order[i + 1:]:
            for measure in ("d", "D"):
                a_, b_ = shapes[key_a][f"{measure}_curve"], shapes[key_b][f"{measure}_curve"]
                per_n.append(dict(lobe_a=lobes[key_a].name, lobe_b=lobes[key_b].name, measure=measure,
                                  a_better=runs_of(a_ < b_, n), b_better=runs_of(b_ < a_, n)))

    out = dict(lobes=lobe_rows, rows=rows, quadrature_error=quad_error, per_n=per_n, large_n=large_n,
               d_curves=np.stack([shapes[k]["d_curve"] for k in LOBE_KEYS]),
               D_curves=np.stack([shapes[k]["D_curve"] for k in LOBE_KEYS]))
    for key in ("cos^n", "Schlick", "SG", "SG (Lagarde)"):
        out[f"d_{tag_of(key)}"], out[f"D_{tag_of(key)}"] = shapes[key]["d"], shapes[key]["D"]
    return out
