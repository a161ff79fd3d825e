"""Constants chosen among a format's values (`approximate.representable`): every chosen constant a
value of the format, never worse than rounding, and for Schlick's (1 - x)^5 by polynomials of
degree 2 to 4 in float16 as good as Sollya's `fpminimax` (Debian's sollya; skipped where absent)."""

import re
import shutil
import subprocess

import numpy as np
import pytest
import sympy as sp

from pipeline.approximate import targets
from pipeline.approximate.search import families, minimax, representable
from pipeline.approximate.forms import free_numbers


def remez_polynomial(target, degree):
    f = target.numpy()
    fit = minimax.remez([families._power(k) for k in range(degree + 1)], f, families.weight_of(target, f),
                        *target.domain)
    return families._horner(fit["coefficients"], target.symbol())


def sollya_fpminimax(expression: str, degree: int, lo: float, hi: float) -> tuple[list[float], float]:
    """(coefficients by increasing degree, the largest absolute error) of Sollya's fpminimax in half
    precision (HP) for every coefficient."""
    script = (f"f = {expression}; p = fpminimax(f, {degree}, [|HP...|], [{lo};{hi}], absolute);\n"
              f"for i from 0 to {degree} do print(coeff(p, i));\nprint(dirtyinfnorm(p - f, [{lo};{hi}]));\nquit;\n")
    done = subprocess.run(["sollya"], input=script, capture_output=True, text=True, timeout=120)
    numbers = [float(line) for line in done.stdout.split() if re.fullmatch(r"-?[\d.]+(e-?\d+)?", line)]
    assert done.returncode == 0 and len(numbers) == degree + 2, done.stdout + done.stderr
    return numbers[:-1], numbers[-1]


@pytest.mark.parametrize("degree", [2, 3, 4])
def test_float16_constants_are_as_good_as_sollyas_fpminimax(degree):
    """Sollya's fpminimax (its lattice reduction) and this integer search, the same problem: the
    polynomial of `degree` with float16 coefficients nearest (1 - x)^5 on [0, 1]. The search's error
    is at most Sollya's (1e-9 relative: both are evaluated in float64), and below the rounded Remez
    coefficients' by more than 1 % at degree 3 (rounding costs 17 % there)."""
    if shutil.which("sollya") is None:
        pytest.skip("Sollya is not installed (make installs Debian's sollya where it can)")
    schlick = targets.registry()["schlick"]
    chosen, search = representable.choose(remez_polynomial(schlick, degree), schlick, schlick.numpy(), "fp16")
    _, sollya_error = sollya_fpminimax("(1 - x)^5", degree, 0, 1)
    assert search["chosen_error"] <= sollya_error * (1 + 1e-9)
    assert search["chosen_error"] <= search["rounded_error"]
    if degree == 3:
        assert search["searched"] and search["chosen_error"] < 0.99 * search["rounded_error"]
    _, _, numbers = free_numbers(chosen)
    assert all(float(np.float16(float(v))) == float(v) for v in numbers)


def test_the_search_needs_nothing_where_rounding_costs_nothing():
    """float32's rounding of a degree-3 fit: no search (rounding costs less than NEGLIGIBLE), every
    constant a float32; a form without numbers comes back unchanged."""
    schlick = targets.registry()["schlick"]
    chosen, search = representable.choose(remez_polynomial(schlick, 3), schlick, schlick.numpy(), "fp32")
    assert not search["searched"] and search["chosen_error"] == search["rounded_error"]
    _, _, numbers = free_numbers(chosen)
    assert all(float(np.float32(float(v))) == float(v) for v in numbers)
    x = schlick.symbol()
    same, search = representable.choose((1 - x) ** 5, schlick, schlick.numpy(), "fp16")
    assert sp.simplify(same - (1 - x) ** 5) == 0 and search["rounded_error"] < 1e-15
