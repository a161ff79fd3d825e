"""Normalizations coef(n) that engines pair with a specular lobe, by key: each a JAX function of n
and a sympy form (for its operation count), with the run's `Parameters` filled in.

- `phong_cos_n`: (n + 2) / (2 pi), the Phong form of cos^n, exact;
- `giesen`: (n + 2)(n + 4) / (8 pi (2^(-n/2) + n)), the Blinn form of cos^n, exact at normal incidence;
- `blinn_approximate`: (n + 8) / (8 pi), its common approximation;
- `gotanda`: Gotanda's linear fit 0.0397436 n + 0.0856832 (2010);
- `run_coef`: the run's coef_scale (coef_offset + n) (the paper's 0.214 (0.807 + n));
- `exact_phong`, `exact_blinn`: the exact ones of the family's lobe at the run's power m
  (`pipeline.optics.integrals`);
- `asymptotic_phong`, `asymptotic_blinn`: their two-term large-k forms c_1 k + c_0 (at m = 2,
  (3/(2 pi))(k + 1/4) and (3/(8 pi))(k + 5/4)).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import numpy as np
import sympy as sp

from . import integrals
from .coef_forms import reciprocal_form
from .registry import Parameters, k_Q2, symbols

GOTANDA = (0.0397436, 0.0856832)


@dataclasses.dataclass(frozen=True)
class Normalization:
    """A normalization factor coef(n): key, formula as text, function of n, sympy form in n."""

    key: str
    formula: str
    fn: Callable
    expr: sp.Expr


def giesen(n):
    """Giesen's normalization of the Blinn form of cos^n, exact at normal incidence."""
    return (n + 2.0) * (n + 4.0) / (8.0 * np.pi * (2.0 ** (-n / 2.0) + n))


def normalizations(p: Parameters) -> dict[str, Normalization]:
    """Every normalization, by key, with the run's parameters."""
    _, n = symbols()
    unit = sp.UnevaluatedExpr
    a, b = p.slope, p.intercept
    power = int(p.power)
    k_expr = k_Q2(n, sp.Float(a), sp.Float(b))
    big = {which: integrals.coef_of_k(integrals.integral(which, power)).args[0][0] for which in ("phong", "blinn")}
    # As a shader computes them: in r = 1 / k, no pow and no power of k that overflows float16 (coef_forms).
    exact_phong = reciprocal_form(big["phong"], k_expr)
    exact_blinn = reciprocal_form(big["blinn"], k_expr)
    phong_fn, _ = integrals.exact_coef_code("phong", power)
    blinn_fn, _ = integrals.exact_coef_code("blinn", power)
    (p1, p0), (b1, b0) = integrals.asymptote("phong", power), integrals.asymptote("blinn", power)
    m1, m2 = power + 1, power + 2
    items = [
        Normalization("phong_cos_n", "(n + 2) / (2 pi)", lambda n: (n + 2.0) / (2.0 * np.pi), (n + 2) / (2 * sp.pi)),
        Normalization("giesen", "(n + 2)(n + 4) / (8 pi (2^(-n/2) + n))", giesen,
                      (n + 2) * (n + 4) / (8 * sp.pi * (2 ** (-n / 2) + n))),
        Normalization("blinn_approximate", "(n + 8) / (8 pi)", lambda n: (n + 8.0) / (8.0 * np.pi),
                      (n + 8) / (8 * sp.pi)),
        Normalization("gotanda", f"{GOTANDA[0]} n + {GOTANDA[1]}", lambda n: GOTANDA[0] * n + GOTANDA[1],
                      GOTANDA[0] * n + GOTANDA[1]),
        Normalization("run_coef", f"{p.coef_scale:g} ({p.coef_offset:g} + n)",
                      lambda n: p.coef_scale * (p.coef_offset + n), p.coef_scale * (p.coef_offset + n)),
        Normalization("exact_phong", ("6 k^2 / (pi (4 k - 1))" if power == 2 else
                                      f"{m1 * m2} k^2 / (2 pi ({m2} k - 1))") + ", k = a n + b (k >= 1)",
                      lambda n: phong_fn(n, a, b), exact_phong),
        Normalization("exact_blinn", ("15 k^4 / (2 pi (20 k^3 - 25 k^2 + 12 k - 2))" if power == 2 else
                                      sp.sstr(sp.factor(big["blinn"]))) + " (k >= 2 + sqrt 2)",
                      lambda n: blinn_fn(n, a, b), exact_blinn),
        Normalization("asymptotic_phong", f"{p1:.6g} (k + {p0 / p1:.6g})" if power != 2 else "(3 / (2 pi)) (k + 1/4)",
                      lambda n: p1 * k_Q2(n, a, b) + p0, p1 * k_expr + p0),
        Normalization("asymptotic_blinn", f"{b1:.6g} (k + {b0 / b1:.6g})" if power != 2 else "(3 / (8 pi)) (k + 5/4)",
                      lambda n: b1 * k_Q2(n, a, b) + b0, b1 * k_expr + b0),
    ]
    return {item.key: item for item in items}
