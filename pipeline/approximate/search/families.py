"""The families the grammar's enumeration cannot reach in time, fitted by minimax directly
(`minimax`): polynomials of degree 1 to `POLYNOMIAL_DEGREES` by Remez's exchange, a polynomial
times sqrt(1 - x), and a constant plus such a product (where the domain ends at or below 1: acos,
asin and their kin) by the same exchange on those bases, exp2 of a polynomial (a target positive inside its domain), rationals of low degree and
clamped powers max(0, a + b x)^m (the paper's lobe family; a target never negative) by sequential
linear programming on the whole interval. Each member's constants are minimax for the
target's own measure (abs or rel), polynomials in Horner form.

A family stops rising in degree once a member is exact to rounding (a polynomial target).
"""

from __future__ import annotations

import math

import numpy as np
import sympy as sp

from . import minimax
from ..forms import Form

POLYNOMIAL_DEGREES = 7
SQRT_DEGREES = 5
EXP2_DEGREES = 4
CLAMPED_POWERS = 4
RATIONAL_DEGREES = ((1, 1), (2, 1), (1, 2), (2, 2), (3, 1), (3, 2))
EXP2_START_SHARE = 1e-3          # exp2's start fits log2 f where f exceeds this share of its largest value


def weight_of(target, f):
    """The weight of the target's measure: 1 (abs), 1 / max(|f|, floor) (rel)."""
    if target.metric == "abs":
        return lambda x: np.ones_like(np.asarray(x, dtype=np.float64))
    return lambda x: 1.0 / np.maximum(np.abs(f(x)), target.floor)


def _horner(coefficients, x):
    return sp.horner(sum(sp.Float(float(a), 17) * x ** k for k, a in enumerate(coefficients)), x) \
        if len(coefficients) > 1 else sp.Float(float(coefficients[0]), 17)


def _remez_family(name, degrees, basis_of, expression_of, source, f, weight, lo, hi) -> list[Form]:
    """The members `name`_d of a linear family for d in `degrees`, each by Remez's exchange on
    basis_of(d) (functions of x), its form expression_of(coefficients): until one is exact."""
    out = []
    for degree in degrees:
        try:
            fit = minimax.remez(basis_of(degree), f, weight, lo, hi)
        except minimax.MinimaxFailed:
            continue
        out.append(Form(f"{name}_{degree}", "found", name, expression_of(fit["coefficients"]),
                        f"Remez exchange{source}, degree {degree}", fit["converged"]))
        if fit["exact"]:
            break
    return out


def _power(k):
    return lambda s: np.asarray(s, dtype=np.float64) ** k


def _power_sqrt(k):
    return lambda s: np.asarray(s, dtype=np.float64) ** k * np.sqrt(1 - np.asarray(s, dtype=np.float64))


def polynomials(target, f, weight) -> list[Form]:
    x = target.symbol()
    return _remez_family("polynomial", range(1, POLYNOMIAL_DEGREES + 1),
                         lambda d: [_power(k) for k in range(d + 1)], lambda c: _horner(c, x), "", f, weight,
                         *target.domain)


def polynomials_sqrt(target, f, weight) -> list[Form]:
    if target.domain[1] > 1:
        return []
    x = target.symbol()
    return _remez_family("polynomial_sqrt", range(SQRT_DEGREES + 1),
                         lambda d: [_power_sqrt(k) for k in range(d + 1)], lambda c: _horner(c, x) * sp.sqrt(1 - x),
                         " on x^k sqrt(1 - x)", f, weight, *target.domain)


def offset_polynomials_sqrt(target, f, weight) -> list[Form]:
    """c + p(x) sqrt(1 - x) (asin, pi/2 - acos, and their kin), degree 0 to SQRT_DEGREES, by Remez's
    exchange on the basis 1, x^k sqrt(1 - x): with s = sqrt(1 - x) it spans 1 and odd powers of s,
    a Haar system on [0, 1] (Descartes' rule of signs)."""
    if target.domain[1] > 1:
        return []
    x = target.symbol()
    return _remez_family("offset_polynomial_sqrt", range(SQRT_DEGREES + 1),
                         lambda d: [_power(0)] + [_power_sqrt(k) for k in range(d + 1)],
                         lambda c: sp.Float(float(c[0]), 17) + _horner(c[1:], x) * sp.sqrt(1 - x),
                         " on 1, x^k sqrt(1 - x)", f, weight, *target.domain)


def exp2_polynomials(target, f, weight) -> list[Form]:
    """exp2(p(x)): a start by Remez on log2 f where f exceeds EXP2_START_SHARE of its largest value
    (the error of exp2(p) is about f ln2 (p - log2 f)), then minimax on the whole interval."""
    lo, hi = target.domain
    grid = np.linspace(lo, hi, 2049)
    values = f(grid)
    if np.any(values[1:-1] <= 0):
        return []
    inside = grid[values >= EXP2_START_SHARE * values.max()]
    a, b = float(inside.min()), float(inside.max())
    x = target.symbol()
    out = []
    for degree in range(1, EXP2_DEGREES + 1):
        basis = [lambda s, k=k: np.asarray(s, dtype=np.float64) ** k for k in range(degree + 1)]
        try:
            start = minimax.remez(basis, lambda s: np.log2(f(s)), lambda s: weight(s) * f(s) * math.log(2), a, b)
        except minimax.MinimaxFailed:
            continue
        powers = np.arange(degree + 1)

        def model(c, s, powers=powers):
            return np.exp2(np.power.outer(s, powers) @ c)

        def jacobian(c, s, powers=powers):
            v = np.power.outer(s, powers)
            return (np.exp2(v @ c) * math.log(2))[:, None] * v

        c, _ = minimax.slp(model, jacobian, start["coefficients"], f, weight, lo, hi)
        out.append(Form(f"exp2_polynomial_{degree}", "found", "exp2_polynomial",
                        sp.Pow(2, _horner(c, x)), f"exp2 of a degree-{degree} polynomial, minimax"))
    return out


def rationals(target, f, weight) -> list[Form]:
    """p(x) / (1 + q(x)) of degrees (len p - 1, len q): a start by linearized least squares
    (f (1 + q) - p = 0 on Chebyshev points), then minimax; a member whose denominator vanishes in
    the domain is dropped."""
    lo, hi = target.domain
    points = minimax.chebyshev_points(lo, hi, 200)
    y, w = f(points), weight(points)
    x = target.symbol()
    out = []
    for p_degree, q_degree in RATIONAL_DEGREES:
        P = np.power.outer(points, np.arange(p_degree + 1))
        Q = np.power.outer(points, np.arange(1, q_degree + 1))
        A = w[:, None] * np.column_stack([P, -y[:, None] * Q])
        start, *_ = np.linalg.lstsq(A, w * y, rcond=None)
        split = p_degree + 1

        def parts(c, s, p_degree=p_degree, q_degree=q_degree, split=split):
            s = np.asarray(s, dtype=np.float64)
            Ps, Qs = np.power.outer(s, np.arange(p_degree + 1)), np.power.outer(s, np.arange(1, q_degree + 1))
            return Ps, Qs, Ps @ c[:split], 1.0 + Qs @ c[split:]

        def model(c, s, parts=parts):
            _, _, num, den = parts(c, s)
            return num / den

        def jacobian(c, s, parts=parts):
            Ps, Qs, num, den = parts(c, s)
            return np.column_stack([Ps / den[:, None], -(num / den ** 2)[:, None] * Qs])

        c, value = minimax.slp(model, jacobian, start, f, weight, lo, hi)
        den = parts(c, np.linspace(lo, hi, 8193))[3]
        if not np.isfinite(value) or np.any(den <= 0) and np.any(den >= 0):
            continue
        numerator = _horner(c[:split], x)
        denominator = _horner(np.r_[1.0, c[split:]], x)
        out.append(Form(f"rational_{p_degree}_{q_degree}", "found", "rational", numerator / denominator,
                        f"rational of degrees {p_degree}/{q_degree}, minimax"))
    return out


def clamped_powers(target, f, weight) -> list[Form]:
    """max(0, a + b x)^m, m = 1 to CLAMPED_POWERS (the paper's family, a lobe's clamp; a target that
    is never negative): a start from the line through the target's largest value and its half, then
    minimax on the whole interval."""
    lo, hi = target.domain
    grid = np.linspace(lo, hi, 2049)
    values = f(grid)
    if np.any(values < 0):
        return []
    x = target.symbol()
    out = []
    top = int(np.argmax(values))
    half = int(np.argmin(np.abs(values - values[top] / 2)))
    for m in range(1, CLAMPED_POWERS + 1):
        # the start: (a + b x)^m through (x_top, f_top) and (x_half, f_half)
        r_top, r_half = values[top] ** (1 / m), values[half] ** (1 / m)
        slope = (r_top - r_half) / (grid[top] - grid[half]) if top != half else 1.0
        start = np.array([r_top - slope * grid[top], slope])

        def model(c, s, m=m):
            return np.maximum(c[0] + c[1] * s, 0.0) ** m

        def jacobian(c, s, m=m):
            inner = np.maximum(c[0] + c[1] * s, 0.0)
            d = m * inner ** (m - 1) * (inner > 0)
            return np.column_stack([d, d * s])

        c, value = minimax.slp(model, jacobian, start, f, weight, lo, hi)
        if not np.isfinite(value):
            continue
        line = sp.Float(float(c[0]), 17) + sp.Float(float(c[1]), 17) * x
        out.append(Form(f"clamped_power_{m}", "found", "clamped_power", sp.Max(line, 0) ** m,
                        f"max(0, a + b x)^{m}, minimax"))
    return out


FAMILIES = {"clamped_power": clamped_powers, "polynomial": polynomials, "polynomial_sqrt": polynomials_sqrt,
            "offset_polynomial_sqrt": offset_polynomials_sqrt, "exp2_polynomial": exp2_polynomials,
            "rational": rationals}


def fit_families(target, f, log=print) -> list[Form]:
    """Every family's members for the target (module docstring)."""
    weight = weight_of(target, f)
    out = []
    for name, family in FAMILIES.items():
        members = family(target, f, weight)
        out += members
        log(f"  {name}: {len(members)} member{'s' * (len(members) != 1)}")
    return out
