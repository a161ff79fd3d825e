"""Sparse regression (Figs. 9, 10): coef(n) recovered from the 50-point sample with pysindy.

The paper used TuringBot (symbolic regression, RMS error, operations + x /). Here the candidate
terms are a library in n (by default 1, n, 1/n, 1/n^2) and STLSQ's threshold is swept over a
log-spaced range; each distinct support it selects is one model of the complexity/error front.
The two-term model c_1 + c_n n is reported as scale (offset + n) with scale = c_n,
offset = c_1 / c_n, the paper's form. TuringBot's size-1 row (a constant) is not a sparse
subset of the library; the front reports it as the sample mean, computed directly.
"""

import warnings

import numpy as np
import pysindy as ps

from ..optics.roots import SolverError
from .common import alternative_samples, n_range, same_kind

TERMS = {
    "1": lambda n: np.ones_like(n), "n": lambda n: n, "1/n": lambda n: 1.0 / n,
    "1/n^2": lambda n: 1.0 / n**2, "n^2": lambda n: n**2, "sqrt(n)": np.sqrt, "log(n)": np.log,
}


def stlsq_fit(n, y, terms, threshold):
    """Coefficients (one per term) of pysindy's STLSQ at one threshold on the library matrix of
    `terms`; all zero if it removes every term."""
    theta = np.column_stack([TERMS[t](n) for t in terms])
    optimizer = ps.STLSQ(threshold=threshold, alpha=0.0)
    with warnings.catch_warnings():
        # STLSQ warns when the threshold removes every term; that is one end of the sweep.
        warnings.filterwarnings("ignore", message="Sparsity parameter is too big")
        optimizer.fit(theta, y.reshape(-1, 1))
    return np.asarray(optimizer.coef_[0], dtype=np.float64)


def sweep(n, y, terms, thresholds):
    """The front: one model per distinct support, fewest terms first, as a list of dicts."""
    models = {}
    for th in thresholds:
        c = stlsq_fit(n, y, terms, th)
        support = tuple(int(i) for i in np.flatnonzero(c))
        if support and support not in models:
            theta = np.column_stack([TERMS[t](n) for t in terms])
            rms = float(np.sqrt(np.mean((theta @ c - y) ** 2)))
            models[support] = dict(terms=[terms[i] for i in support],
                                   coefficients=[float(c[i]) for i in support],
                                   rms=rms, threshold=float(th))
    return sorted(models.values(), key=lambda m: (len(m["terms"]), m["rms"]))


def two_term(front):
    """(scale, offset, rms) of the model c_1 + c_n n on the front, written as scale (offset + n)."""
    for m in front:
        if sorted(m["terms"]) == ["1", "n"]:
            c = dict(zip(m["terms"], m["coefficients"]))
            return c["n"], c["1"] / c["n"], m["rms"]
    return None


def expression(model) -> str:
    return " + ".join(f"{c:.6g}" + ("" if t == "1" else f"*{t}") for t, c in
                      zip(model["terms"], model["coefficients"]))


def run(config, inputs, memo):
    n_s, y_s = inputs["sample.sample_n"], inputs["energy_dataset.sample_y"]
    y_all = inputs["energy_dataset.y"]
    n_all = n_range(config)
    terms = config["regression.library"]
    thresholds = np.geomspace(config["regression.threshold_min"], config["regression.threshold_max"],
                              config["regression.threshold_count"])
    front = sweep(n_s, y_s, terms, thresholds)
    found = two_term(front)
    if found is None:
        raise SolverError("sparse regression: no threshold in [regression.threshold_min, "
                          "regression.threshold_max] selected the two-term model 1 + n; widen the range")
    scale, offset, rms = found
    for m in front:
        m["expression"] = expression(m)
        m["rms_all_n"] = float(np.sqrt(np.mean(
            (np.column_stack([TERMS[t](n_all) for t in m["terms"]]) @ m["coefficients"] - y_all) ** 2)))

    # How the two-term constants move with the sample.
    size = len(n_s)
    alternatives = alternative_samples(config, n_s, y_s, y_all)
    sensitivity = []
    for label, (ns, ys) in alternatives.items():
        alt_front = sweep(ns, ys, terms, thresholds)
        alt = two_term(alt_front)
        sensitivity.append(dict(sample=label, size=int(len(ns)), mean_y=float(np.mean(ys)),
                                scale=alt[0] if alt else float("nan"),
                                offset=alt[1] if alt else float("nan"),
                                rms=alt[2] if alt else float("nan"),
                                three_term_rms=_three_term(alt_front)["three_term_rms"],
                                one_term_scale=_one_term(alt_front)[0], one_term_rms=_one_term(alt_front)[1]))
    same = [row for row in sensitivity if same_kind(row["sample"], row["size"], size)]
    mean = float(np.mean(y_s))
    return dict(front=front, coef_scale=scale, coef_offset=offset, coef_rms=rms,
                constant_model=mean, constant_model_rms=float(np.sqrt(np.mean((y_s - mean) ** 2))),
                sample_sensitivity=sensitivity,
                **{f"sensitivity_{name}_range": [min(r[name] for r in same), max(r[name] for r in same)]
                   for name in ("offset", "rms", "three_term_rms", "one_term_scale", "one_term_rms")},
                one_term_scale=_one_term(front)[0], one_term_rms=_one_term(front)[1],
                **_three_term(front))


def _one_term(front):
    """(c, rms) of the model c n on the front (nan if absent)."""
    for m in front:
        if m["terms"] == ["n"]:
            return m["coefficients"][0], m["rms"]
    return float("nan"), float("nan")


def _three_term(front):
    for m in front:
        if sorted(m["terms"]) == sorted(["1", "n", "1/n"]):
            c = dict(zip(m["terms"], m["coefficients"]))
            return dict(three_term_n=c["n"], three_term_1=c["1"], three_term_inv_n=c["1/n"],
                        three_term_rms=m["rms"])
    nan = float("nan")
    return dict(three_term_n=nan, three_term_1=nan, three_term_inv_n=nan, three_term_rms=nan)
