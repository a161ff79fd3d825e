"""The rendered comparison against a direct numpy computation, and the exported shader against the
pipeline's own lobe (through its Python twin) and, where glslangValidator is installed, a compiler.
"""


import numpy as np




def test_half_precision_rows_against_a_direct_float16_evaluation(paper_run):
    h = paper_run["half_precision"]
    rows = {(r["n"], r["lobe"], r["route"]): r for r in h["rows"]}
    # At t = 1 - 2^-11 (the float16 step below 1) and n = 1000, k t + (1 - k) in float16 is far from the
    # float64 value 1 - k 2^-11: the cancellation the table reports.
    k = np.float16(0.448 * 1000 + 0.099)
    t = np.float16(1) - np.float16(2.0 ** -11)
    half = float(k * t + (np.float16(1) - k))
    # (float16 spaces numbers near 448 by 0.25, so k t alone may be off by 0.125).
    assert abs(half - (1 - float(k) * 2.0 ** -11)) > 0.02
    big = rows[(1000.0, "f_Q2", "1 - N.H")]
    assert big["max_abs_error"] > 0.5 and big["distinct"] < 20
    # The cross-product route keeps the lobe within a few percent of its peak and hundreds of levels.
    good = rows[(1000.0, "f_Q2", "dot(c, c) / (1 + N.H), c = N x H")]
    assert good["max_abs_error"] < 0.05 and good["distinct"] > 500
    # cos^n's levels are those of float16 t near 1 at every route: few at n = 1000.
    assert rows[(1000.0, "f_b", "1 - N.H")]["distinct"] < 30


