"""Symbolic regression with functions and powers (exp, log, sqrt, square, cube, pow, sin, cos, abs,
inv): exact laws come back with their constants, the enumeration's rules keep an equal form, a form that leaves its
domain on the data never enters the front, the losses, the cost tables and the description length."""

import numpy as np
import pytest

from pipeline.symbolic import grammar, search
from pipeline.symbolic.regress import RegressError, regress, select

TEN = "+,-,*,/,exp,log,sqrt,square,cube,pow"
FOURTEEN = ",".join(grammar.OPERATIONS)
# one form with every operation
EVERY_FORM = "exp(x) + log(x) - sqrt(x) * square(x) / cube(x) ^ x + sin(x) + cos(x) + abs(x) + inv(x)"
ALL_CODES = grammar.opcodes([grammar.parse(EVERY_FORM)])


def law_front(x, y, max_complexity, ops):
    # (each compiled for its own operations: every step of the interpreter computes each operation it
    # is compiled for, and a law's own few run its search in about half the time of the ten's)
    found = search.search(x, y, max_complexity, ops)
    return found, [(found["forms"][i], found["constants"][i][:found["constant_count"][i]], found["rms"][i],
                    found["complexity"][i]) for i in found["front"]]


@pytest.mark.parametrize("name, law, ops, size, data, beyond", [
    ("exponential decay", lambda x: 0.3 + 1.7 * np.exp(-1.3 * x), "+,-,*,exp,pow", 8, (0.1, 2.0), (2.1, 2.6)),
    ("power law", lambda x: 2.5 * x ** 1.7, "+,*,pow", 6, (0.1, 2.0), (2.1, 2.6)),
    ("Gaussian", lambda x: 1.2 * np.exp(-((x - 0.4) / 0.3) ** 2), "+,*,exp,square", 10, (0.1, 2.0), (-0.3, 0.05)),
    ("Schlick fifth power", lambda t: 0.04 + 0.96 * (1 - t) ** 5, "+,-,*,pow", 10, (0.2, 0.95), (0.0, 0.15)),
    ("rational, squared denominator", lambda t: 0.09 / (np.pi * (1 + (0.09 - 1) * t ** 2) ** 2), "+,*,/,square", 10,
     (0.05, 0.8), (0.85, 1.0)),
    ("sine with a phase", lambda x: 0.5 + 1.3 * np.sin(2.1 * x + 0.4), "+,*,sin", 11, (0.0, 3.0), (3.1, 4.0)),
    ("kink", lambda x: 0.2 + 1.5 * np.abs(x - 0.6), "+,*,abs", 9, (0.0, 2.0), (-1.0, -0.1)),
    ("reciprocal", lambda x: 0.3 + 1 / (x ** 2 + 0.5), "+,square,inv", 8, (-1.0, 2.0), (2.1, 3.0)),
])
def test_an_exact_law_comes_back_with_its_constants(name, law, ops, size, data, beyond):
    """The front's member at the law's complexity fits it to rounding (RMS < 1e-10 of its scale) and
    is the law: its fitted expression equals the law beyond the data (relative 1e-7: a near-miss
    of another family drifts apart there). The operations are the law's own (the ten together
    take minutes at these complexities; their enumeration rules are checked below). 24 points: four
    times the most constants a form has here, and the law's RMS is rounding whatever their number."""
    x = np.linspace(*data, 24)
    y = law(x)
    _, front = law_front(x, y, size, ops)
    exact = [(tree, c, k) for tree, c, rms, k in front if rms < 1e-10 * np.max(np.abs(y))]
    assert exact and exact[0][2] <= size, [(grammar.show(t, "x", c), r, k) for t, c, r, k in front]
    tree, c, _ = exact[0]
    beyond = np.linspace(*beyond, 20)
    assert grammar.evaluate_numpy(tree, c, beyond) == pytest.approx(law(beyond), rel=1e-7, abs=1e-12)


RULES = [   # (removed form, the kept form that equals it at equal or lower complexity)
    ("exp(log(x))", "x"), ("log(exp(x))", "x"), ("square(sqrt(x))", "x"),
    ("exp(x + c)", "c * exp(x)"), ("square(c * x)", "c * square(x)"), ("cube(c * x)", "c * cube(x)"),
    ("c + log(x)", "log(c * x)"), ("log(sqrt(x))", "c * log(x)"), ("log(x ^ c)", "c * log(x)"),
    ("sqrt(x ^ c)", "x ^ c"), ("square(x ^ c)", "x ^ c"), ("cube(x ^ c)", "x ^ c"),
    ("sqrt(x) ^ c", "x ^ c"), ("cube(x) ^ c", "x ^ c"), ("(x ^ c) ^ c", "x ^ c"),
    ("cube(square(x))", "square(cube(x))"), ("exp(x) ^ c", "exp(c * x)"),
    ("exp(x) * exp(square(x))", "exp(square(x) + x)"), ("exp(x) / exp(square(x))", "exp(x - square(x))"),
    ("sqrt(x) * sqrt(c + x)", "sqrt((c + x) * x)"), ("square(x) / square(c + x)", "square(x / (c + x))"),
    ("log(x) + log(c + x)", "log((c + x) * x)"), ("log(x) - log(c + x)", "log(x / (c + x))"),
]
# The rules of sin, cos, abs and inv, with the operations they are enumerated with (the removed forms
# written in the enumeration's order of operands, so that only the rule can leave them out).
WITHOUT_DIVISION = "+,-,*,exp,log,sqrt,square,cube,pow,sin,cos,abs,inv"
MORE_RULES = [
    ("abs(exp(x))", "exp(x)", FOURTEEN), ("abs(sqrt(x))", "sqrt(x)", FOURTEEN),
    ("abs(square(x))", "square(x)", FOURTEEN), ("abs(abs(x))", "abs(x)", FOURTEEN),
    ("abs(x ^ c)", "x ^ c", FOURTEEN), ("abs(c * x)", "abs(x) * c", FOURTEEN),
    ("square(abs(x))", "square(x)", FOURTEEN), ("cube(abs(x))", "abs(cube(x))", FOURTEEN),
    ("cos(abs(x))", "cos(x)", FOURTEEN), ("sqrt(square(x))", "abs(x)", FOURTEEN),
    ("abs(c + x) * abs(x)", "abs((c + x) * x)", FOURTEEN),
    ("inv(inv(x))", "x", FOURTEEN), ("inv(c * x)", "c * inv(x)", WITHOUT_DIVISION),
    ("inv(x ^ c)", "x ^ c", FOURTEEN), ("inv(exp(x))", "exp(c * x)", FOURTEEN),
    ("inv(x / (c + x))", "(c + x) / x", FOURTEEN), ("log(inv(x))", "c * log(x)", FOURTEEN),
    ("sqrt(inv(x))", "inv(sqrt(x))", FOURTEEN), ("square(inv(x))", "inv(square(x))", FOURTEEN),
    ("cube(inv(x))", "inv(cube(x))", FOURTEEN), ("abs(inv(x))", "inv(abs(x))", FOURTEEN),
    ("c * inv(x)", "c / x", FOURTEEN), ("inv(x) / (c + x)", "inv((c + x) * x)", FOURTEEN),
    ("x / inv(c + x)", "(c + x) * x", FOURTEEN), ("inv(c + x) * inv(x)", "inv((c + x) * x)", WITHOUT_DIVISION),
    ("cos(c + x)", "sin(c + x)", FOURTEEN),
]


@pytest.mark.parametrize("removed, kept, ops", [(r, k, TEN) for r, k in RULES] + MORE_RULES)
def test_each_rule_of_the_enumeration_keeps_an_equal_form(removed, kept, ops):
    """The removed form is not enumerated, the kept one is, at equal or lower complexity, and the
    kept form fitted to the removed one's values at random constants reproduces them (RMS below
    1e-9 of their scale: an exact fit; data in x > 0, where both are defined)."""
    removed_tree, kept_tree = grammar.parse(removed), grammar.parse(kept)
    size = grammar.complexity(removed_tree)
    forms = set(grammar.enumerate_forms(size, ops))
    assert removed_tree not in forms and kept_tree in forms
    assert grammar.complexity(kept_tree) <= size
    x = np.linspace(0.2, 2.0, 40)
    rng = np.random.default_rng(sum(map(ord, removed)))
    c = rng.uniform(0.5, 1.5, (3, grammar.constants(removed_tree)))
    y = np.stack([grammar.evaluate_numpy(removed_tree, row, x) for row in c])
    # (three draws in one batch, compiled for every operation in blocks of 32 rows: the rules share
    # one program, and 24 fits run faster there than in the search's 256-row blocks)
    fits = search.fit_forms([kept_tree], np.broadcast_to(x, y.shape), y, codes=ALL_CODES, block_rows=32)
    for (_, rms, _), values, row in zip((f[0] for f in fits), y, c):
        assert rms < 1e-9 * np.max(np.abs(values)), (removed, kept, row, rms)


def test_a_form_that_leaves_its_domain_never_enters_the_front():
    """On x in [-1, 1] (through 0), log x, sqrt x and x ^ c are undefined at some points: such a
    form's loss is infinite (log(x) and sqrt(x) given alone), and every front member is finite at
    every data point."""
    x = np.linspace(-1.0, 1.0, 41)
    y = np.exp(0.7 * x) + 0.1 * x
    bad = [grammar.parse(t) for t in ("c * log(x)", "c * sqrt(x) + c", "x ^ c", "c + inv(x)")]
    fits = search.fit_forms(bad, x, y)
    assert all(not np.isfinite(rms) or not ok for _, rms, ok in fits)
    found, front = law_front(x, y, 6, TEN)
    assert len(front) >= 3
    for tree, c, rms, _ in front:
        assert np.all(np.isfinite(grammar.evaluate_numpy(tree, c, x))) and np.isfinite(rms), grammar.show(tree)


def test_the_minimax_loss_reaches_chebyshev_s_best_line():
    """The best uniform line to e^x on [0, 1] has slope m = e - 1 and error E = 1 - b with
    b = (1 + m - m ln m)/2 (equioscillation at 0, ln m and 1): E = 0.105933. The minimax fit on 1001
    points reaches it within 1e-6 (the grid misses the interior extremum by at most m (h/2)^2 / 2),
    the least-squares fit does not (its largest error is 0.1547, at x = 1)."""
    x = np.linspace(0.0, 1.0, 1001)
    m = np.e - 1
    E = 1 - (1 + m - m * np.log(m)) / 2
    line = [grammar.parse("c * x + c")]
    # (one form's starts on 1001 points: blocks of 8 rows, not the search's 64 and 256, all but one idle)
    (c, largest, ok), = search.fit_forms(line, x, np.exp(x), loss="max", block_rows=8)
    assert ok and largest == pytest.approx(E, abs=1e-6) and c[0] == pytest.approx(m, rel=1e-4)
    (c2, _, _), = search.fit_forms(line, x, np.exp(x), block_rows=8)
    assert np.max(np.abs(grammar.evaluate_numpy(line[0], c2, x) - np.exp(x))) > 1.2 * E


def test_the_relative_loss_weights_each_point_by_its_size():
    """y = x^2 + 1e-3 x^-1 on [0.01, 10], fitted by c x^c: least squares follows the large values,
    the relative loss the small ones; each fit is the better under its own measure (each is that
    measure's optimum), and the loss returned is the RMS of the relative error."""
    x = np.geomspace(0.01, 10.0, 50)
    y = x ** 2 + 1e-3 / x
    form = [grammar.parse("c * (x ^ c)")]
    (c_rms, _, _), = search.fit_forms(form, x, y)
    (c_rel, rel, _), = search.fit_forms(form, x, y, loss="relative")
    relative = lambda c: np.sqrt(np.mean(((grammar.evaluate_numpy(form[0], c, x) - y) / y) ** 2))
    absolute = lambda c: np.sqrt(np.mean((grammar.evaluate_numpy(form[0], c, x) - y) ** 2))
    assert rel == pytest.approx(relative(c_rel), rel=1e-12)
    assert relative(c_rel) < 0.99 * relative(c_rms) and absolute(c_rms) < 0.99 * absolute(c_rel)
    with pytest.raises(ValueError, match="y is 0 at 1 point"):
        search.fit_forms(form, x, np.where(x == x[3], 0.0, y), loss="relative")


def test_a_cost_table_ranks_the_front(tmp_path):
    """With exp costing 20, the exponential law's exact member (c + c exp(c x), 9 by the default count)
    costs more than the rational members, and the front ranks by the table's cost; a table that
    leaves out an operation of --ops, or names an unknown one, is refused by name."""
    x = np.linspace(0.0, 3.0, 40)
    data = tmp_path / "d.csv"
    data.write_text("x,y\n" + "".join(f"{float(a)!r},{float(b)!r}\n" for a, b in zip(x, 0.3 + 1.7 * np.exp(-1.3 * x))))
    table = tmp_path / "cost.toml"
    table.write_text('[cost]\n"+" = 1\n"*" = 1\n"/" = 2\nexp = 20\n')
    front = regress(data, "x", "y", tmp_path / "out", max_complexity=9, ops="+,*,/,exp", engine="exhaustive",
                    cost=table, log=lambda s: None)
    assert [m["complexity"] for m in front] == sorted(m["complexity"] for m in front)
    exact = [m for m in front if m["rms"] < 1e-10]
    assert exact and exact[0]["complexity"] == grammar.complexity(grammar.parse(exact[0]["form"]),
                                                                  grammar.read_cost_table(table, ("+", "*", "/", "exp")))
    assert exact[0]["complexity"] == 27 and exact[0]["structure"] == 9
    table.write_text('[cost]\n"+" = 1\n"*" = 1\nexp = 20\n')
    with pytest.raises(RegressError, match="no cost for /"):
        regress(data, "x", "y", tmp_path / "o2", max_complexity=5, ops="+,*,/,exp", cost=table, log=lambda s: None)
    table.write_text('[cost]\n"+" = 1\n"*" = 1\n"/" = 2\nexp = 20\ntan = 3\n')
    with pytest.raises(RegressError, match="unknown key 'tan'"):
        regress(data, "x", "y", tmp_path / "o3", max_complexity=5, ops="+,*,/,exp", cost=table, log=lambda s: None)


def test_the_description_length_counts_the_operation_set():
    """Bartlett et al.'s form term: structure x ln(symbols), the symbols being the operations, the
    variable and the constant. The same two members with four operations (6 symbols) and with ten
    (12): the larger set adds structure x ln 2 nats to each. The data term favours the larger
    member by 17.5 nats, its constants cost 4.6 more; its form costs 6 ln 6 = 10.75 more with four
    operations (it is chosen) and 6 ln 12 = 14.91 more with ten (the simpler member is chosen)."""
    front = [dict(complexity=3, structure=3, rms=0.02, constants=1),
             dict(complexity=9, structure=9, rms=np.sqrt(4e-4 - 17.5 * 2e-4 / 100), constants=3)]
    four = [dict(m) for m in front]
    ten = [dict(m) for m in front]
    assert select(four, 100, 0.01, 4 + 1 + 1) == 1
    assert select(ten, 100, 0.01, 10 + 1 + 1) == 0
    for a, b in zip(four, ten):
        assert b["description_length"] - a["description_length"] == pytest.approx(a["structure"] * np.log(2))
