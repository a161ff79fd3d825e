"""The certified bounds against tools that prove them independently: Sollya's `checkinfnorm` confirms
a polynomial member's real error bound in one variable, and Gappa proves the rounding bound of a
straight-line program in float32 that the pipeline's bound must not exceed (and that must not be below
the exhaustive maximum). Each skips, with its reason, where its tool is absent."""

import math
import re
import shutil
import subprocess

import numpy as np
import pytest
import sympy as sp

from pipeline.approximate.measures import certified_box, exhaustive
from pipeline.approximate.targets import reading

x = sp.Symbol("x", real=True)


def binary(value: float) -> str:
    """A float32 constant exactly, as Sollya and Gappa read it: an integer times a power of 2 (`13b-4`)."""
    numerator, denominator = float(np.float32(value)).as_integer_ratio()
    return f"{numerator}b-{denominator.bit_length() - 1}"


def run(tool: str, script: str) -> str:
    if shutil.which(tool) is None:
        pytest.skip(f"{tool} is not installed (Debian's {tool}; `make test` installs it where it can)")
    done = subprocess.run([tool] if tool == "gappa" else [tool, "--warnonstderr"], input=script, capture_output=True,
                          text=True, timeout=120)
    return done.stdout + done.stderr


def test_sollya_confirms_a_polynomial_member_s_real_error_bound():
    """sin on [0, 1] by an odd polynomial of float32 constants: the pipeline's bound (real error plus
    lavapipe's rounding) holds for Sollya's checkinfnorm, and 0.95 of the largest error found does not
    (the check can fail)."""
    a, b = 0.99977, -0.16305
    body = f"x*({a} + {b}*x*x)"
    done = certified_box.certify(body, ["x"], sp.sin(x), [x], [(0.0, 1.0)], ratio=1.01)
    assert done.status == "proven"
    polynomial = f"x*({binary(a)} + {binary(b)}*x^2)"

    def holds(bound: float) -> bool:
        out = run("sollya", f"prec = 200!;\nf = sin(x) - ({polynomial});\n"
                            f"checkinfnorm(f, [0;1], {binary(bound) if bound > 2 ** -120 else 0});\nquit;\n")
        said = re.findall(r"\b(true|false)\b", out)
        assert said, out
        return said[-1] == "true"

    assert holds(done.bound)
    assert not holds(0.95 * done.found)


def test_gappa_s_rounding_bound_is_at_least_the_pipeline_s_and_that_at_least_the_exhaustive_maximum():
    """x (a + b x) + c in float32, round to nearest at every operation, against the same expression in
    reals: Gappa proves |computed - exact| within its bound on [0.5, 1]; the pipeline's bound lies
    between the maximum over every float32 there (`exhaustive`: 2^23 of them) and Gappa's."""
    a, b, c = 0.7071, -0.3183, 0.1234
    body = f"x*({a} + {b}*x) + {c}"
    fa, fb, fc = (sp.Float(float(np.float32(v)), precision=53) for v in (a, b, c))
    exact = x * (fa + fb * x) + fc
    ours = certified_box.certify(body, ["x"], exact, [x], [(0.5, 1.0)], ratio=1.01, same=True)   # (rounding alone)
    script = (f"@rnd = float<ieee_32, ne>;\nx = rnd(xx);\ny rnd= x * ({binary(a)} + {binary(b)} * x) + {binary(c)};\n"
              f"Y = x * ({binary(a)} + {binary(b)} * x) + {binary(c)};\n{{ xx in [0.5, 1] -> |y - Y| in ? }}\n")
    out = run("gappa", script)
    found = re.search(r"\|y - Y\| in \[[^,]*,\s*([0-9]+)b(-?[0-9]+)", out)     # (its bound exactly: m 2^e)
    assert found, out
    gappa = int(found.group(1)) * 2.0 ** int(found.group(2))
    target = reading.from_expression(str(exact), "x=0.5:1")
    maximum = exhaustive.certify({"p": body}, target, "fp32", log=lambda s: None)["errors"]["p"]["max_abs_error"]
    assert maximum <= ours.bound <= gappa, (maximum, ours.bound, gappa)
    assert math.isfinite(gappa) and gappa < 1e-6
