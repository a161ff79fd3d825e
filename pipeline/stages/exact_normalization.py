"""Exact normalization (beyond the paper): coef(n) = 1 / (2 pi Int(n)) in closed form (sympy), set
beside the paper's regressed 0.214 (0.807 + n), the run's own fit, and the quadrature dataset.

- Int(k) and coef(k) come from `pipeline.optics.integrals` (upper hemisphere only, so for k < 1 they differ
  from the paper's integral up to gran(n)); the stage evaluates sympy's generated jax code.
- The energy a normalized lobe reflects at normal incidence, coef(n) 2 pi Int(n), is 1 exactly
  with the exact coef; with the run's coef it is 1 + coef/coef_exact - 1: positive means energy
  is created. The exact coef is also checked against an independent route (the directional-albedo
  quadrature at normal incidence).
- The large-n expansion of the exact coef, in n, to set beside the sparse regression's models.
- The Blinn form's exact normalization at normal view, and the two-term asymptotic forms c_1 k + c_0
  (at m = 2, (3 / (2 pi)) (k + 1/4) (Phong) and (3 / (8 pi)) (k + 5/4) (Blinn)).

Everything is for the run's power m (`lobe.power`): sympy integrates the lobe of that power.
"""

import numpy as np
import sympy as sp

from ..optics import integrals
from ..optics.albedo import albedo_table
from .common import n_range, runs_of


def run(config, inputs, memo):
    a, b = inputs["linear_coefficient.slope_used"], inputs["linear_coefficient.intercept_used"]
    n = n_range(config)
    k = a * n + b
    n_np = np.asarray(n)

    power = config["lobe.power"]
    coef_fn, coef_source = integrals.exact_coef_code("phong", power)
    blinn_fn, blinn_source = integrals.exact_coef_code("blinn", power)
    Int_fn, _ = integrals.jax_function(integrals.phong_integral(power), (integrals.k,))
    gran_fn, _ = integrals.jax_function(integrals.phong_integral_gran(power), (integrals.k,))
    coef_exact = np.asarray(coef_fn(n, a, b))
    coef_blinn = np.asarray(blinn_fn(n, a, b))
    Int = np.asarray(Int_fn(k))
    Int_gran = np.asarray(gran_fn(k))

    # The run's coef (the paper's 0.214 (0.807 + n) with constants = "paper").
    scale, offset = inputs["hemispherical.coef_scale_used"], inputs["hemispherical.coef_offset_used"]
    coef_run = scale * (offset + n_np)
    energy_run = coef_run * 2.0 * np.pi * Int - 1.0
    excess = energy_run > 0.0

    # Independent route: the hemisphere quadrature of `pipeline.optics.albedo` at normal incidence.
    albedo0 = coef_exact * albedo_table("phong", "linear_power", n, k, 1.0 / k, np.zeros(1),
                                        config["albedo.quadrature_nodes"], power)[:, 0]
    exact_dev = np.asarray(albedo0) - 1.0
    # The paper-style dataset (quadrature up to gran) against the exact integral up to gran.
    dataset_dev = inputs["energy_dataset.Int"] / Int_gran - 1.0

    # Large-n expansions, numeric in this run's a, b.
    values = {integrals.slope: a, integrals.intercept: b}
    phong_k = integrals.large_k_expansion("phong", 3, power)
    blinn_k = integrals.large_k_expansion("blinn", 3, power)
    phong_n = integrals.expansion_in_n(phong_k)
    terms = {name: float(phong_n.coeff(integrals.n, p).subs(values)) for name, p in
             (("n", 1), ("1", 0), ("1/n", -1))}
    (p1, p0), (b1, b0) = integrals.asymptote("phong", power), integrals.asymptote("blinn", power)
    asym_phong = p1 * k + p0
    asym_blinn = b1 * k + b0
    asym_phong_dev = np.asarray(asym_phong) / coef_exact - 1.0
    asym_blinn_dev = np.asarray(asym_blinn) / coef_blinn - 1.0

    below = np.asarray(k) < 1.0
    i_max = int(np.argmax(energy_run))
    return dict(
        coef_exact=coef_exact, coef_blinn=coef_blinn, Int_hemisphere=Int, Int_gran=Int_gran,
        energy_run=energy_run,
        paper_coef_max_excess=float(energy_run[i_max]), paper_coef_n_at_max_excess=float(n_np[i_max]),
        paper_coef_max_abs_dev=float(np.max(np.abs(energy_run))), paper_coef_max_deficit=float(np.min(energy_run)),
        paper_coef_n_at_max_abs_dev=float(n_np[np.argmax(np.abs(energy_run))]),
        excess_ranges=runs_of(excess, n_np), excess_count=int(excess.sum()),
        exact_coef_max_abs_dev=float(np.max(np.abs(exact_dev))),
        dataset_quadrature_max_rel_dev=float(np.max(np.abs(dataset_dev))),
        below_horizon_n=n_np[below], below_horizon_Int_difference=Int[below] - Int_gran[below], below_horizon_coef=coef_exact[below], below_horizon_coef_gran=1.0 / (2.0 * np.pi * Int_gran[below]),
        formula_Int=sp.sstr(integrals.phong_integral(power)),
        formula_Int_gran=sp.sstr(integrals.phong_integral_gran(power)),
        formula_coef=sp.sstr(integrals.coef_of_k(integrals.phong_integral(power))),
        formula_Int_blinn=sp.sstr(integrals.blinn_integral(power)),
        formula_coef_blinn=sp.sstr(integrals.coef_of_k(integrals.blinn_integral(power))),
        asymptotic_phong_terms=[p1, p0], asymptotic_blinn_terms=[b1, b0],
        formula_expansion_k=sp.sstr(phong_k), formula_expansion_blinn_k=sp.sstr(blinn_k),
        formula_expansion_n=sp.sstr(phong_n),
        code_coef=coef_source, code_coef_blinn=blinn_source,
        expansion_n=terms["n"], expansion_1=terms["1"], expansion_inv_n=terms["1/n"],
        expansion_scale=terms["n"], expansion_offset=terms["1"] / terms["n"],
        asymptotic_phong_max_abs_dev=float(np.max(np.abs(asym_phong_dev))),
        asymptotic_phong_max_excess=float(np.max(asym_phong_dev)),
        asymptotic_blinn_max_abs_dev=float(np.max(np.abs(asym_blinn_dev))),
        asymptotic_blinn_max_excess=float(np.max(asym_blinn_dev)),
        asymptotic_phong_dev=asym_phong_dev, asymptotic_blinn_dev=asym_blinn_dev,
        blinn_to_phong_ratio_at_n_max=float(coef_blinn[-1] / coef_exact[-1]),
    )

