"""Other cheap lobes, side by side (beyond the paper): on the run's zone, error measures and n range,
the shape errors d and D of every lobe of `pipeline.cheap_lobes`, the energy each reflects with the
normalization an engine pairs it with (albedo at normal incidence and its largest value over
incidence angles), and the operations each costs.

The quadratic lobes' d and D are found here by the generic grid-and-bisection search of
`pipeline.extrema`; the tests check it against the closed-form measures of `pipeline.error_measures`.
"""

import jax
import jax.numpy as jnp
import numpy as np

from .. import cheap_lobes
from ..albedo import albedo_table
from ..extrema import lobe_errors
from ..roots import SolverSettings
from .common import RANGE_KEYS, n_range, require_converged

READS = RANGE_KEYS + ("solver.*", "albedo.quadrature_nodes", "comparison.*")
UPSTREAM = ("zone", "q_scan", "linear_coefficient", "exact_normalization")
QUADRATURE_CHECK_N = (2.0, 10.0, 100.0, 1000.0)

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


def run(config, upstream):
    zone, q, lin = upstream["zone"], upstream["q_scan"], upstream["linear_coefficient"]
    e = upstream["exact_normalization"]
    a, b = lin["slope_used"], lin["intercept_used"]
    n = n_range(config)
    n_np = np.asarray(n)
    settings = SolverSettings.from_config(config)
    lobes = cheap_lobes.shape_lobes(q["Q_used"], q["Q_continuous_best"], a, b)
    keyed = dict(zip(("cos^n", "f_2", "f_Q used", "f_Q best", "f_Q2", "Schlick", "SG", "SG (Lagarde)"), lobes))
    norms = cheap_lobes.normalizations(a, b, e["coef_scale_used"], e["coef_offset_used"])
    cells = config["comparison.grid_cells"]

    shapes = {}
    for key, lobe in keyed.items():
        m = jax.jit(jax.vmap(lambda n_, fn=lobe.fn: lobe_errors(fn, n_, zone["level"], cells, settings)))(n)
        require_converged(m["ok"], f"extrema of {lobe.name}", n=n)
        d, D = np.asarray(m["d"]), np.asarray(m["D"])
        pixel, material = cheap_lobes.count_operations(lobe.expr)
        shapes[key] = dict(name=lobe.name, formula=lobe.formula, d=float(d.max()), D=float(D.max()),
                           d_n_at_max=float(n_np[d.argmax()]), D_n_at_max=float(n_np[D.argmax()]),
                           d_curve=d, D_curve=D, ops_pixel=pixel, ops_material=material)

    theta = np.linspace(0.0, 0.5 * np.pi, config["comparison.albedo_angles"])
    nodes = config["albedo.quadrature_nodes"]
    check = np.array([m for m in QUADRATURE_CHECK_N if n_np[0] <= m <= n_np[-1]])
    rows, quad_error = [], 0.0
    for label, form, lobe_key, norm_key in ENERGY_ROWS:
        lobe, norm = keyed[lobe_key], norms[norm_key]
        # A shader clamps t = max(dot, 0): lobes other than the quadratics hold their value at t = 0
        # past it (which matters only for the spherical Gaussians' exp(-n)).
        quadratic = lobe_key.startswith("f_")
        fn = lobe.fn if quadratic else (lambda u, n_, f=lobe.fn: f(jnp.minimum(u, 1.0), n_))
        u_end = lobe.u_end(n) if quadratic else 2.0 + 0.0 * n
        coef = norm.fn(n)
        table = np.asarray(albedo_table(form, fn, n, u_end, coef, theta, nodes))
        if len(check):
            idx = np.searchsorted(n_np, check)
            fine = np.asarray(albedo_table(form, fn, check, np.asarray(u_end)[idx], np.asarray(coef)[idx],
                                           theta, 2 * nodes))
            quad_error = max(quad_error, float(np.max(np.abs(table[idx] - fine))))
        normal = table[:, 0]
        i, j = np.unravel_index(np.argmax(table), table.shape)
        norm_ops, _ = cheap_lobes.count_operations(norm.expr, cheap_lobes.n_sym)
        shape = shapes[lobe_key]
        per_pixel_n = {op: shape["ops_pixel"][op] + shape["ops_material"][op] + norm_ops[op]
                       for op in cheap_lobes.OPERATIONS}
        rows.append(dict(label=label, form=form, lobe=lobe.name, formula=lobe.formula,
                         normalization=norm.formula, d=shape["d"], D=shape["D"],
                         albedo_normal_max_abs_dev=float(np.max(np.abs(normal - 1.0))),
                         albedo_normal_n_at_max=float(n_np[np.argmax(np.abs(normal - 1.0))]),
                         albedo_max=float(table[i, j]), albedo_max_n=float(n_np[i]),
                         albedo_max_theta_deg=float(np.degrees(theta[j])),
                         ops_pixel=shape["ops_pixel"], ops_with_n_per_pixel=per_pixel_n,
                         ops_pixel_text=_short(shape["ops_pixel"]), ops_with_n_text=_short(per_pixel_n)))

    out = dict(n=n_np, rows=rows, quadrature_error=quad_error, zone_level=zone["level"],
               Q_used=q["Q_used"], Q_best=q["Q_continuous_best"])
    for key, s in shapes.items():
        tag = tag_of(key)
        out[f"d_{tag}"], out[f"D_{tag}"] = s["d"], s["D"]
        out[f"d_{tag}_curve"], out[f"D_{tag}_curve"] = s["d_curve"], s["D_curve"]
    out["lobe_names"] = {key: s["name"] for key, s in shapes.items()}
    out["lobe_tags"] = {key: tag_of(key) for key in shapes}
    return out
