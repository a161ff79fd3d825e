"""Symbolic regression (Fig. 9, P14): the complexity/error front of coef(n), found as the paper's
TuringBot found it, by an exhaustive search (`pipeline.symbolic.search`).

Every expression in n of the grammar (fitted constants, n, +, -, *, /) up to
`symbolic.max_complexity` is fitted to the sample by least squares; the front holds the best
expression at each complexity that beats every simpler one. Each front member is set beside the
exact normalization of `exact_normalization`, for the run's power m
coef = (m + 1)(m + 2) k^2 / (2 pi ((m + 2) k - 1)), k = a n + b (m = 2: 6k^2 / (pi (4k - 1))): its
largest relative difference over the n range and the energy it creates there. With c = 1/(m + 2),
coef = ((m + 1) / (2 pi)) (k + c + c^2 / (k - c)), so the exact form in partial fractions is
scale (offset + n + residue / (n - pole)) for every m, with scale = (m + 1) a / (2 pi),
offset = (b + c) / a, residue = c^2 / a^2, pole = (c - b) / a (m = 2: 3a / (2 pi), (4b + 1) / (4a),
1 / (16 a^2), (1 - 4b) / (4a)); the member that matches it within what the sample's rounding
allows is written in those constants.

The paper's five rows (sizes 1, 3, 5, 10, 12) are fitted as forms of their own, so each is checked
whether or not it is the front's member at its size.
"""

import numpy as np
import sympy as sp

from ..symbolic import search
from ..symbolic.regress import select
from ..optics.roots import SolverError
from .common import alternative_samples, n_range, same_kind

N = sp.Symbol("n", positive=True)
# The paper's five rows (TuringBot's front, P14): size, form, and the names of its constants.
PAPER_ROWS = ((1, "c", ("constant",)), (3, "c*n", ("c",)), (5, "c*(c + n)", ("scale", "offset")),
              (10, "c*n + c + c/n", ("n", "1", "inv_n")),
              (12, "c*(c + c/(n - c) + n)", ("scale", "offset", "residue", "pole")))


EXACT_FORM_COMPLEXITY = 12      # c*(c + c/(n - c) + n), the paper's size-12 row


def exact_constants(a, b, power: int = 2) -> dict:
    """The exact coef's partial-fraction constants for the line k = a n + b at power m."""
    c = 1.0 / (power + 2.0)
    return dict(scale=(power + 1.0) * a / (2.0 * np.pi), offset=(b + c) / a, residue=c * c / (a * a),
                pole=(c - b) / a)


def partial_fractions(expression) -> dict | None:
    """scale (offset + n + residue / (n - pole)) constants of a rational expression whose
    numerator has degree 2 and denominator degree 1; None for any other shape."""
    numerator, denominator = sp.fraction(sp.cancel(sp.together(expression)))
    num, den = sp.Poly(numerator, N), sp.Poly(denominator, N)
    if den.degree() != 1 or num.degree() != 2:
        return None
    quotient, remainder = sp.div(num, den)
    d1, d0 = (float(c) for c in den.all_coeffs())
    p1, p0 = (float(c) for c in quotient.all_coeffs())
    r = float(remainder.as_expr()) / d1
    return dict(scale=p1, offset=p0 / p1, residue=r / p1, pole=-d0 / d1)


def run(config, inputs, memo):
    n_s, y_s = inputs["sample.sample_n"], inputs["energy_dataset.sample_y"]
    coef_exact = inputs["exact_normalization.coef_exact"]
    # The dataset's own closed form: 1 / (2 pi Int) with the paper's integral up to gran(n), which is
    # the size-12 rational function for every n. Where the lobe reaches past the horizon (k < 1:
    # n = 2 at m = 2, n = 2..4 at m = 4) it differs from the upper-hemisphere coef_exact.
    closed_form = 1.0 / (2.0 * np.pi * np.asarray(inputs["exact_normalization.Int_gran"]))
    a, b = inputs["linear_coefficient.slope_used"], inputs["linear_coefficient.intercept_used"]
    n_all = n_range(config)
    decimals = config["sample.y_decimals"]
    # Two functions closer than the rounding step of y cannot be told apart by a fit to the
    # sample; without rounding, by the dataset's quadrature (1e-6 leaves a wide margin).
    tolerance = 10.0 ** -decimals if decimals >= 0 else 1e-6

    found = search.search(n_s, y_s, config["symbolic.max_complexity"], config["symbolic.operations"],
                            config["symbolic.starts"], config["symbolic.iterations"], config["symbolic.refine"],
                            config["symbolic.polish_starts"], config["symbolic.seed"])
    forms, rms, fitted = found["forms"], found["rms"], found["constants"]
    if not all(found["converged"][i] for i in found["front"]):
        bad = [search.show(forms[i], "n") for i in found["front"] if not found["converged"][i]]
        raise SolverError(f"symbolic regression: the least-squares fit of front member(s) {bad} did not "
                          f"converge; raise symbolic.polish_starts")

    front = []
    for i in found["front"]:
        e, c = forms[i], fitted[i][:found["constant_count"][i]]
        on_n = search.evaluate_numpy(e, c, n_all)
        ratio = on_n / coef_exact - 1.0
        expression = search.to_sympy(e, c, N)
        member = dict(complexity=int(found["complexity"][i]), form=search.show(e, "n"),
                      expression=search.show(e, "n", c), canonical=search.canonical(expression, N),
                      constants=[float(v) for v in c], rms=float(rms[i]),
                      max_rel_to_exact=float(np.max(np.abs(ratio))),
                      max_abs_to_exact=float(np.max(np.abs(on_n - coef_exact))),
                      max_energy_excess=float(np.max(ratio)), n_at_max_energy_excess=float(n_all[np.argmax(ratio)]))
        member["max_abs_to_closed_form"] = float(np.max(np.abs(on_n - closed_form)))
        member["equivalent_to_exact"] = bool(member["max_abs_to_closed_form"] <= tolerance)
        member["partial_fractions"] = partial_fractions(expression)
        member["constants_count"] = len(c)
        front.append(member)
    # Which member the data support: the least description length (`pipeline.symbolic.regress.select`)
    # with the noise of y's rounding (or, unrounded, the unknown-noise form).
    chosen = select([dict(rms=m["rms"], constants=m["constants_count"], complexity=m["complexity"]) for m in front],
                    len(n_s), 10.0 ** -decimals / np.sqrt(12.0) if decimals >= 0 else None,
                    len(config["symbolic.operations"]) + 2)
    for i, m in enumerate(front):
        m["selected"] = i == chosen

    exact = exact_constants(a, b, config["lobe.power"])
    equivalent = [m for m in front if m["equivalent_to_exact"]]
    nan = float("nan")
    found_constants = (equivalent[0]["partial_fractions"] if equivalent and equivalent[0]["partial_fractions"]
                       else dict(scale=nan, offset=nan, residue=nan, pole=nan))

    # The exact form itself, scale (offset + n + residue/(n - pole)) with four free constants: the
    # front's member at its complexity, if that member is that form and within the tolerance.
    at_exact = [m for m in front if m["complexity"] == EXACT_FORM_COMPLEXITY and m["partial_fractions"]
                and len(m["constants"]) == 4 and m["equivalent_to_exact"]]
    exact_form = at_exact[0] if at_exact else None

    # The paper's five rows as forms of their own, fitted the same way.
    rows, row_fields = [], {}
    paper_forms = [search.parse(text, "n") for _, text, _ in PAPER_ROWS]
    fits = search.fit_forms(paper_forms, n_s, y_s, seed=config["symbolic.seed"],
                              steps=config["symbolic.max_complexity"], width=found["width"])
    for (size, text, names), e, (c, row_rms, converged) in zip(PAPER_ROWS, paper_forms, fits):
        if not converged:
            raise SolverError(f"symbolic regression: the fit of the paper's size-{size} form {text!r} did not converge")
        at_size = [m for m in front if m["complexity"] == size]
        same = bool(at_size) and abs(at_size[0]["rms"] - row_rms) <= 1e-6 * row_rms
        rows.append(dict(size=size, form=text, constants=[[name, float(v)] for name, v in zip(names, c)], rms=row_rms,
                         on_front=same, front_member=at_size[0]["expression"] if at_size else None,
                         front_rms=at_size[0]["rms"] if at_size else nan))
        row_fields.update({f"size{size}_{name}": float(v) for name, v in zip(names, c)})
        row_fields[f"size{size}_rms"] = row_rms
        row_fields[f"size{size}_on_front"] = same

    # How the paper forms' constants move with the unknown sample: refitted on the other samples
    # of the configured kind (same size, y rounded).
    spread = {name: [value, value] for name, value in row_fields.items() if not name.endswith("_on_front")}
    others = [(ns, ys) for label, (ns, ys) in alternative_samples(config, n_s, y_s, inputs["energy_dataset.y"]).items()
              if label != "configured sample" and same_kind(label, len(ns), len(n_s))]
    if others:
        refits = search.fit_forms(paper_forms, np.array([o[0] for o in others]), np.array([o[1] for o in others]),
                                    seed=config["symbolic.seed"], steps=config["symbolic.max_complexity"],
                                    width=found["width"])
        for per_sample in refits:
            for (size, _, names), (c, row_rms, _) in zip(PAPER_ROWS, per_sample):
                for name, v in list(zip(names, c)) + [("rms", row_rms)]:
                    lo_hi = spread[f"size{size}_{name}"]
                    lo_hi[:] = [min(lo_hi[0], float(v)), max(lo_hi[1], float(v))]

    # The paper's printed size-12 row against the exact normalization.
    s12, o12, r12, p12 = config["paper_model.turingbot_size12"]
    paper12 = s12 * (o12 + n_all + r12 / (n_all - p12))
    below = [m for m in front if m["complexity"] < 12]
    return dict(
        front=front, forms_searched=len(forms),
        forms_by_complexity={int(k): int(np.sum(found["complexity"] == k)) for k in np.unique(found["complexity"])},
        front_complexities=[m["complexity"] for m in front], equivalence_tolerance=tolerance,
        rounding_rms_floor=tolerance / np.sqrt(12.0) if decimals >= 0 else 0.0,
        best_rms_by_complexity={int(k): float(np.min(rms[found["complexity"] == k])) for k in np.unique(found["complexity"])},
        sr_exact_complexity=equivalent[0]["complexity"] if equivalent else -1,
        selected_complexity=front[chosen]["complexity"], selected_expression=front[chosen]["expression"],
        sr_exact_expression=equivalent[0]["expression"] if equivalent else "",
        **{f"sr_exact_{name}": float(v) for name, v in found_constants.items()},
        **{f"exact_{name}": float(v) for name, v in exact.items()},
        exact_form_on_front=exact_form is not None, exact_form_expression=exact_form["expression"] if exact_form else "",
        exact_form_max_rel_dev=(float(max(abs(exact_form["partial_fractions"][name] / exact[name] - 1.0) for name in exact))
                                if exact_form else nan),
        paper_rows=rows, **row_fields, paper_row_sample_ranges=spread,
        paper_rows_on_front=int(sum(r["on_front"] for r in rows)),
        best_below_12_rms=min(m["rms"] for m in below) if below else nan,
        paper12_max_abs_to_exact=float(np.max(np.abs(paper12 - coef_exact))),
        paper12_max_rel_to_exact=float(np.max(np.abs(paper12 / coef_exact - 1.0))),
        paper12_max_energy_excess=float(np.max(paper12 / coef_exact - 1.0)),
    )
