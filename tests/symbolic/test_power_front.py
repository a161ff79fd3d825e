"""The symbolic search on the ideal coef of the family at powers m = 3 and 4 (y unrounded): its
size-12 member is the exact form, with the closed-form constants of
`pipeline.stages.symbolic_regression.exact_constants` to 1e-6."""

import numpy as np
import pytest

from pipeline.stages.energy_dataset import integrals
from pipeline.stages.family import asymptote
from pipeline.stages.symbolic_regression import EXACT_FORM_COMPLEXITY, N, exact_constants, partial_fractions
from pipeline.symbolic import search

# The paper's 50-point sample design: n = 2..31, then 20 evenly spaced n from 74 to 1000.
SAMPLE = np.unique(np.concatenate([np.arange(2, 32), np.round(np.linspace(74, 1000, 20))])).astype(float)


@pytest.mark.parametrize("power", (3, 4))
def test_the_front_holds_the_exact_form_with_its_closed_form_constants(power):
    a, b = asymptote(0.65, power)
    # Only n with k >= 1 (the exact coef's upper-hemisphere branch, which is the rational form).
    n = SAMPLE[a * SAMPLE + b >= 1.0]
    y = 1.0 / (2.0 * np.pi * np.asarray(integrals(a * n + b, 64, power)))     # the dataset's quadrature
    found = search.search(n, y, EXACT_FORM_COMPLEXITY, seed=0)
    members = [i for i in found["front"] if found["complexity"][i] == EXACT_FORM_COMPLEXITY]
    assert members, "the front has no member of the exact form's complexity"
    i = members[0]
    constants = found["constants"][i][:found["constant_count"][i]]
    fractions = partial_fractions(search.to_sympy(found["forms"][i], constants, N))
    assert fractions is not None, search.show(found["forms"][i], "n", constants)
    exact = exact_constants(a, b, power)
    for name, value in exact.items():
        assert fractions[name] == pytest.approx(value, rel=1e-6), name
    assert found["rms"][i] < 1e-9
