"""A shader function's branch taken apart (`engines.pieces`): each piece's interval where it is taken,
the cases derived whole only with their reasons, and the branch put back with each piece's form,
equal to the branch as read wherever the forms are the pieces."""

import numpy as np
import sympy as sp

from pipeline.approximate.engines.pieces import assembled, sub_domains

x, y = sp.symbols("x y", real=True)


def test_each_piece_is_taken_on_its_own_interval():
    pieces, why = sub_domains(sp.Piecewise((x / 12.92, x <= 0.04045), (x ** 2, True)), {"x": (0.0, 1.0)})
    assert why == "" and [p.domain for p in pieces] == [(0.0, 0.04045), (0.04045, 1.0)]
    assert [p.where for p in pieces] == ["x <= 0.04045", "otherwise"] and pieces[0].argument == "x"
    # a cascade: each piece where its condition holds and no earlier one does
    cascade = sp.Piecewise((x, x < 0.25), (2 * x, x < 0.5), (3 * x, True))
    assert [p.domain for p in sub_domains(cascade, {"x": (0.0, 1.0)})[0]] == [(0.0, 0.25), (0.25, 0.5), (0.5, 1.0)]
    # a piece never taken on the domain keeps its place, with no interval
    never = sp.Piecewise((x, x < -1), (2 * x, x < 0.5), (3 * x, True))
    assert [p.domain for p in sub_domains(never, {"x": (0.0, 1.0)})[0]] == [None, (0.0, 0.5), (0.5, 1.0)]
    # the argument compared is the one split; the others keep their ranges
    assert sub_domains(sp.Piecewise((x * y, y > 0.5), (x, True)), {"x": (0, 1), "y": (0, 2)})[0][1].domain == (0.0, 0.5)


def test_a_branch_that_is_not_pieces_on_intervals_says_why():
    assert sub_domains(x ** 2, {"x": (0, 1)}) == ([], "it has no branch")
    assert sub_domains(sp.Piecewise((x, x < 2), (x ** 2, True)), {"x": (0, 1)}) == \
        ([], "one piece is taken on the whole domain")
    assert sub_domains(sp.Piecewise((x, x < y), (y, True)), {"x": (0, 1), "y": (0, 1)}) == \
        ([], "its branch compares 2 arguments")
    pieces, why = sub_domains(sp.Piecewise((x, (x < 0.2) | (x > 0.8)), (x ** 2, True)), {"x": (0, 1)})
    assert pieces == [] and why.startswith("a piece is taken on more than one interval of x")


def test_the_branch_put_back_is_the_branch_read_where_the_forms_are_the_pieces():
    read = sp.Piecewise((x / 12.92, x < 0.0031308), (sp.Float(1.055) * x ** sp.Float(0.41666) - 0.055, True))
    pieces, _ = sub_domains(read, {"x": (0.0, 1.0)})
    again = assembled(pieces)
    points = np.r_[np.linspace(0, 1, 101), 0.0031308, np.nextafter(0.0031308, 0)]
    f, g = sp.lambdify(x, read), sp.lambdify(x, again)
    assert all(f(v) == g(v) for v in points)            # (the threshold itself on the side it was read on)
    # a form's constants at a finer precision: the branch holds them as the float64 they are
    pieces[0].form = sp.Float("0.077399380505084999", 60) * x
    assert {f._prec for f in assembled(pieces).atoms(sp.Float)} == {53}
    assert float(assembled(pieces).args[0].expr.coeff(x)) == 0.077399380505084999
