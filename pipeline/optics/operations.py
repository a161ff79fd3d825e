"""What a lobe or a normalization costs to evaluate: operations counted on its sympy form, per pixel
and per material (`count_operations`), as a compiler that folds constants and hoists what does not
depend on the pixel would see them.
"""

from __future__ import annotations

import sympy as sp

from .registry import symbols

t, n_sym = symbols()

OPERATIONS = ("pow", "exp/log", "div", "sqrt", "madd")


def _is_constant(expr) -> bool:
    return not expr.free_symbols


def _node_operations(expr) -> dict[str, int]:
    """The operations of expr's top node alone (constant subexpressions are folded: free)."""
    ops = dict.fromkeys(OPERATIONS, 0)
    if _is_constant(expr):
        return ops
    if isinstance(expr, sp.Add | sp.Max | sp.Min | sp.Piecewise):
        terms = [a for a in expr.args if not _is_constant(a)]
        ops["madd"] += len(terms) - (0 if len(terms) < len(expr.args) else 1)
    elif isinstance(expr, sp.Mul):
        variable = [a for a in expr.args if not _is_constant(a)]
        constant = [a for a in expr.args if _is_constant(a) and a not in (1, -1)]  # negation is free
        divisions = [a for a in variable if a.is_Pow and a.exp == -1]
        ops["div"] += len(divisions)
        ops["madd"] += max(len(variable) + min(len(constant), 1) - 1 - len(divisions), 0)
    elif isinstance(expr, sp.Pow):
        e = expr.exp
        if e == -1:
            ops["div"] += 1
        elif e in (sp.Rational(1, 2), sp.Rational(-1, 2)):
            ops["sqrt"] += 1
        elif e.is_Integer and e > 1:     # by repeated squaring
            ops["madd"] += int(e).bit_length() - 1 + bin(int(e)).count("1") - 1
        elif expr.base.is_Number:
            ops["exp/log"] += 1          # c^x is an exp2 / exp
        else:
            ops["pow"] += 1
    elif isinstance(expr, sp.exp | sp.log):
        ops["exp/log"] += 1
    return ops


def _children(expr):
    if isinstance(expr, sp.Mul):   # a / b: the division is the Mul's; go on into b itself
        return [a.base if (a.is_Pow and a.exp == -1) else a for a in expr.args if a != -1]
    return expr.args


def _add(counts, ops):
    for key, v in ops.items():
        counts[key] += v


def _count(expr, counts, seen):
    if expr.is_Atom or expr in seen:     # a repeated subexpression is computed once
        return
    seen.add(expr)
    _add(counts, _node_operations(expr))
    for a in _children(expr):
        _count(a, counts, seen)


def count_operations(expr, variable=t):
    """(per_pixel, per_material): operation counts of expr, hoisting what does not depend on `variable`.

    Subexpressions free of the variable (functions of n only) are computed once per material, the
    rest once per pixel. A square counts as one multiply; x^-1 and a / b as one division; c^x as
    one exp; a general x^y as one pow; additions, multiplications and max as multiply-adds. Constant
    subexpressions are folded and a repeated subexpression is counted once, as a compiler would.
    The counts are those of the expressions as written here (after sympy's canonical form).
    """
    pixel = dict.fromkeys(OPERATIONS, 0)
    material = dict.fromkeys(OPERATIONS, 0)
    seen = set()

    def walk(e):
        if not e.has(variable):
            _count(e, material, seen)
        elif not e.is_Atom and e not in seen:
            seen.add(e)
            _add(pixel, _node_operations(e))
            for a in _children(e):
                walk(a)

    walk(expr)
    return pixel, material
