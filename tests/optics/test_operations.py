"""Operation counts of the registry's lobes and of the normalizations (`pipeline.optics.operations`)."""

from pipeline.optics import operations, registry
from pipeline.optics.normalizations import normalizations

PARAMS = registry.Parameters(Q=0.64, slope=0.448, intercept=0.099, coef_scale=0.214, coef_offset=0.807)


def test_operation_counts():
    count = {key: operations.count_operations(lobe.expression(PARAMS))[0] for key, lobe in registry.LOBES.items()}
    assert count["f_b"] == dict(pow=1, **{"exp/log": 0}, div=0, sqrt=0, madd=0)
    # max(k t + (1 - k), 0)^2: multiply, add, max, square.
    assert count["f_Q2"] == count["f_2"] == dict(pow=0, **{"exp/log": 0}, div=0, sqrt=0, madd=4)
    assert count["Schlick"]["div"] == 1 and count["Schlick"]["pow"] == 0
    assert count["SG"]["exp/log"] == 1 and count["SG_Lagarde"]["exp/log"] == 1
    # k_Q(n) needs exp and divisions, but per material only.
    pixel, material = operations.count_operations(registry.LOBES["f_Q"].expression(PARAMS))
    assert pixel == count["f_Q2"] and material["exp/log"] == 1 and material["div"] >= 1


def test_normalization_counts():
    norms = normalizations(PARAMS)
    # As functions of n: the paper's coef is one multiply-add; the exact one, 6 k / (pi (4 - r)) in
    # r = 1 / k (optics.coef_forms: nothing overflows float16), two divisions and no pow.
    paper, _ = operations.count_operations(norms["run_coef"].expr, operations.n_sym)
    exact, _ = operations.count_operations(norms["exact_phong"].expr, operations.n_sym)
    assert paper["div"] == 0 and paper["pow"] == 0 and exact["div"] == 2 and exact["pow"] == 0
    blinn, _ = operations.count_operations(norms["exact_blinn"].expr, operations.n_sym)
    assert blinn["pow"] == 0 and blinn["exp/log"] == 0 and blinn["div"] == 2
    giesen, _ = operations.count_operations(norms["giesen"].expr, operations.n_sym)
    assert giesen["exp/log"] == 1 and giesen["div"] == 1      # 2^(-n/2) and the quotient
