"""The lobe as a microfacet normal distribution (beyond the paper): the NDF normalization of cos^n,
f_2 and f_Q2 (f_Qm at the run's power), checked by quadrature of int D (n.h) dw_h, and each
normalized lobe against Beckmann's D at the matched roughness alpha = sqrt(2 / (n + 2)) over n,
with GGX against Beckmann for scale (`pipeline.optics.distributions`).

d: the largest relative error where Beckmann's D is at least the zone level L of its peak (the
epicenter, as d is defined for the lobes); D: the largest absolute error over theta_h, as a
fraction of Beckmann's peak 1 / (pi alpha^2).
"""

import numpy as np

from ..optics import distributions as ndf, integrals, registry
from .common import n_range

LOBES = (registry.REFERENCE, "f_2", "f_Q2")


def run(config, inputs, memo):
    n = np.asarray(n_range(config))
    level = inputs["zone.level"]
    power = config["lobe.power"]
    alpha = ndf.alpha_of_n(n)
    a, b = inputs["linear_coefficient.slope_used"], inputs["linear_coefficient.intercept_used"]
    p = registry.Parameters(slope=a, intercept=b, power=power)
    coefs, lobes = {}, {}
    for key in LOBES:
        lobe = registry.LOBES[key]
        param = np.asarray(lobe.parameter(np, n, p), dtype=np.float64)
        m = lobe.power_of(p)
        if lobe.shape == "power":
            coefs[key] = (n + 2.0) / (2.0 * np.pi)
            lobes[key] = lambda t, q=param[:, None]: np.maximum(t, 0.0) ** q
        else:
            coef_fn, _ = integrals.exact_coef_code("phong", m)
            coefs[key] = np.asarray(coef_fn(param, 1.0, 0.0))        # coef of k = 1 k + 0
            lobes[key] = lambda t, k=param[:, None], m=m: np.where(k * (t - 1.0) + 1.0 > 0.0,
                                                                   np.maximum(k * (t - 1.0) + 1.0, 0.0) ** m, 0.0)
    out = dict(alpha=alpha)
    curves_d, curves_D = [], []
    candidates = {key: (lambda t, key=key: coefs[key][:, None] * lobes[key](t)) for key in LOBES}

    def ggx(t):
        return ndf.ggx(t, alpha[:, None])
    # One Beckmann grid and zone edge for the lobes and GGX.
    errors = ndf.errors_against_beckmann_of_each([*candidates.values(), ggx], n, alpha, level)
    for key, (d, D_abs) in zip(LOBES, errors):
        area = ndf.projected_area(candidates[key], alpha)
        out[f"coef_{key}"] = coefs[key]
        out[f"projected_area_max_abs_dev_{key}"] = float(np.max(np.abs(area - 1.0)))
        out[f"d_{key}_vs_beckmann"] = float(d.max())
        out[f"D_{key}_vs_beckmann"] = float(D_abs.max())
        out[f"d_{key}_vs_beckmann_at_n_max"] = float(d[-1])
        out[f"D_{key}_vs_beckmann_at_n_max"] = float(D_abs[-1])
        curves_d.append(d)
        curves_D.append(D_abs)
    d, D_abs = errors[-1]
    out |= dict(d_ggx_vs_beckmann=float(d.max()), D_ggx_vs_beckmann=float(D_abs.max()),
                d_ggx_vs_beckmann_at_n_max=float(d[-1]), D_ggx_vs_beckmann_at_n_max=float(D_abs[-1]),
                beckmann_projected_area_max_abs_dev=float(np.max(np.abs(
                    ndf.projected_area(lambda t: ndf.beckmann(t, alpha[:, None]), alpha) - 1.0))),
                lobes=list(LOBES), d_curves=np.stack(curves_d + [d]), D_curves=np.stack(curves_D + [D_abs]),
                blinn_to_ndf_coef_ratio_at_n_max=float(inputs["exact_normalization.coef_blinn"][-1]
                                                       / coefs["f_Q2"][-1]))
    return out
