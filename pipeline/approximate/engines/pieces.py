"""A shader function's branch taken apart: the sub-domain where each piece is taken
(`sub_domains`), and the branch put back together with each piece's replacement (`assembled`).

A branch the reader writes as a piecewise expression (`Piecewise((a, c <= 0.04045), (b, True))`: a
ternary, an if/else, an early return) whose conditions compare one argument with numbers splits that
argument's range into intervals, one per piece: where its condition holds and no earlier one does.
Each piece is then a function of its own on its interval, derived there (`engines.shader_file`), and
the branch of the pieces' replacements competes, costed whole, with the branch-free forms over the
whole domain. A branch on more than one argument, or a piece taken on two intervals, is derived
whole only (the reason says why).
"""

from __future__ import annotations

import dataclasses

import sympy as sp

PIECES = "derived pieces"       # the anchor that is the branch of the pieces' replacements


@dataclasses.dataclass
class Piece:
    """One piece of a branch: where it is taken (its `condition` as read; the interval `domain` of its
    `argument` where it holds and no earlier one does, None where that is empty or one point), the
    expression `shipped` there, and once derived its replacement (`chosen`, the member's name;
    `form`, its expression in the function's arguments, the piece as shipped where none was chosen,
    with the `reason`) and the derivation's `results`."""

    index: int
    condition: object
    argument: str
    domain: tuple[float, float] | None
    shipped: object
    form: object = None
    chosen: str | None = None
    reason: str = ""
    results: dict | None = None

    @property
    def where(self) -> str:
        return "otherwise" if self.condition is sp.true else str(self.condition)


def sub_domains(expression, ranges: dict) -> tuple[list[Piece], str]:
    """(every piece of `expression`, "") where it is a branch whose conditions compare one argument
    of `ranges` ({argument: (lo, hi)}) with numbers and two pieces or more are taken on an interval of
    positive width, else ([], why not)."""
    if not isinstance(expression, sp.Piecewise):
        return [], "it has no branch"
    compared = set().union(*(c.free_symbols for _, c in expression.args))
    if len(compared) != 1:
        return [], (f"its branch compares {len(compared)} arguments" if compared else "its branch compares no argument")
    (symbol,) = compared
    if symbol.name not in ranges:
        return [], f"its branch compares {symbol.name}, which has no range"
    lo, hi = ranges[symbol.name]
    left = sp.Interval(lo, hi)
    pieces = []
    for expr, condition in expression.args:
        try:
            where = sp.S.Reals if condition is sp.true else condition.as_set()
        except (NotImplementedError, TypeError, ValueError):
            return [], f"its condition {condition} is not an interval of {symbol.name}"
        taken = left.intersect(where)
        left = left - taken
        if taken is not sp.S.EmptySet and taken.measure > 0 and not isinstance(taken, sp.Interval):
            return [], f"a piece is taken on more than one interval of {symbol.name} ({taken})"
        domain = (float(taken.start), float(taken.end)) if isinstance(taken, sp.Interval) and taken.measure > 0 else None
        pieces.append(Piece(len(pieces) + 1, condition, symbol.name, domain, expr, form=expr))
    if sum(p.domain is not None for p in pieces) < 2:
        return [], "one piece is taken on the whole domain"
    return pieces, ""


def assembled(pieces: list[Piece]):
    """The branch with each piece's form in its place, its conditions as read, every constant as the
    float64 it is (a form's constants are float64 values held at a finer precision, which the
    anchors' text would not read back)."""
    branch = sp.Piecewise(*((p.form, p.condition) for p in pieces))
    return branch.xreplace({f: sp.Float(float(f), precision=53) for f in branch.atoms(sp.Float)})
