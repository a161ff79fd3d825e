"""The target's sympy expression walked forward with its partial derivatives, in whatever arithmetic
the caller's leaves carry (arb balls in `certified_box`, float64 intervals in `certified_arrays`):
sums and products here, the leaves, powers and functions by the caller."""

from __future__ import annotations


def forward(expression, variable, number, power, function):
    """(value, [partial derivatives]) of `expression`: `variable(symbol)` and `number(e)` give a
    leaf's (value, derivatives); `power(b, gb, exponent, walk)` a power's from its base's; and
    `function(e, v, g)` a function's from its argument's (each raises to refuse)."""

    def walk(e):
        if e.is_Symbol:
            return variable(e)
        if e.is_Number or e.is_NumberSymbol:
            return number(e)
        if e.is_Add or e.is_Mul:
            value, g = walk(e.args[0])
            for t in e.args[1:]:
                v, h = walk(t)
                if e.is_Add:
                    value, g = value + v, [p + q for p, q in zip(g, h)]
                else:           # (the product rule with the old value)
                    value, g = value * v, [p * v + value * q for p, q in zip(g, h)]
            return value, g
        if e.is_Pow:
            b, gb = walk(e.args[0])
            return power(b, gb, e.args[1], walk)
        v, g = walk(e.args[0]) if e.args else (None, None)
        return function(e, v, g)

    return walk(expression)
