"""Proven bounds of a form's largest error as a shader computes it, over a box of its variables:
branch and bound with interval arithmetic (python-flint's arb, whose every ball provably encloses
the value it stands for).

The form is taken as its shader computes it: the operations of its optimized SPIR-V
(`execution.emulation_program`, what `lowering.evaluate` emulates), its constants the format's
values. On a box B (one interval per input; the inputs exact values of the format):

- its real error, the exact value of those operations minus the target, by the mean-value form:
  e - f over B lies in (e - f)(c) + sum_i d_i(e - f)(B) [-r_i, r_i] (c the box's centre, r_i its
  half-widths; the derivatives carried forward through the operations, and through the target's
  sympy tree, as arb enclosures over B). Where an operation is not differentiable over B (a
  selection whose condition B does not decide, a square root reaching 0) the plain enclosure
  e(B) - f(B) stands instead;
- its rounding error, carried forward through the operations: each computed value differs from its
  exact value over B by at most d, propagated (|a| d_b + |b| d_a + d_a d_b for a product, and so
  on), plus what the operation itself may err at its result (`Rounding`: half a unit in the last
  place for + - * / and sqrt correctly rounded, as lavapipe computes them; Vulkan's minimum
  allowances; a vendor's documented figures), a unit in the last place being at most `UNIT` |v|
  plus the subnormals' spacing. A contracted multiply-add rounds once instead of twice, within the
  same bound.

A relative error divides by the least of max(|f|, floor) over B. `certify` splits the boxes on the
side that adds most to the bound, the largest bound first; the largest error found bounds from below:
with `LAVAPIPE`'s rounding each box's centre's and corners' error as executed (the emulation), with an
allowance (Vulkan's, a vendor's) the bound at each box's centre alone (the most a driver may err
there). It stops when the largest bound left is within `RATIO` of the largest found (proven) or after
`WORK` boxes (budget, with the bound reached): the same plan on every machine.
"""

from __future__ import annotations

import dataclasses
import heapq
import math

import numpy as np

from .rounding import (LAVAPIPE, SMALLEST, UNIT, Certified, NotBounded, Rounding, Unsupported, numpy_target,  # noqa: F401
                       vendor, vulkan)

RATIO = 1.25            # proven: the largest bound left within RATIO of the largest error found
RATIO_ONE = 1.01        # the same in one variable, where boxes are cheap
WORK = 4_000            # boxes bounded per form at most
DEBUG = False


# --- arb helpers ---------------------------------------------------------------------------------

def _arb(value):
    from flint import arb

    return arb(value)


def lo(a) -> float:
    """A float at most every value of the ball `a`."""
    return math.nextafter(float(a.mid()) - float(a.rad()), -math.inf)


def hi(a) -> float:
    """A float at least every value of the ball `a`."""
    return math.nextafter(float(a.mid()) + float(a.rad()), math.inf)


def magnitude(a) -> float:
    """A float at least every |value| of `a`."""
    return max(abs(lo(a)), abs(hi(a)))


def least_magnitude(a) -> float:
    """A float at most every |value| of `a` (0 where it straddles 0)."""
    low, high = lo(a), hi(a)
    return 0.0 if low <= 0.0 <= high else max(0.0, math.nextafter(min(abs(low), abs(high)), 0.0))


def hull(low: float, high: float):
    return _arb(low).union(_arb(high))


def finite(a) -> bool:
    return a.is_finite() and math.isfinite(lo(a)) and math.isfinite(hi(a))


# --- the forward pass over the shader's operations -------------------------------------------------

@dataclasses.dataclass
class Value:
    """An operation's exact value over the box (`v`), its partial derivatives over it (`g`, one ball
    per input; None where not differentiable there) and the bound of its rounding error (`d`)."""

    v: object
    g: list | None
    d: float
    least: float | None = None      # a float at most the exact value wherever known without a ball's slack
                                    # (an input's box end; a difference Sterbenz's lemma makes exact)
    most: float | None = None       # the same from above


def _ulp(v, precision: str, ulps: float) -> float:
    """`ulps` units in the last place at every value of `v`, bounded."""
    return ulps * (UNIT[precision] * magnitude(v) + SMALLEST[precision])


def _up(x: float) -> float:
    return math.nextafter(x, math.inf)


def form_pass(ops, result: str, box, inputs: list[str], precision: str, rounding: Rounding,
              derivatives: bool = True, least: list[float] | None = None, most: list[float] | None = None) -> Value:
    """The form's operations over `box` (one arb per name of `inputs`; `least` and `most` each
    input's least and largest value, where known exactly): its exact value, derivatives and rounding
    bound (module docstring). Raises NotBounded for an operation `rounding` does not bound."""
    count = len(inputs)
    zero = [_arb(0)] * count
    values: dict[str, Value] = {}

    def grad(*parts):
        return None if any(p is None for p in parts) else parts

    for op in ops:
        a = [values[x] for x in op.args]
        if op.kind == "input":
            i = inputs.index(op.op)
            values[op.name] = Value(box[i], [_arb(1) if j == i else _arb(0) for j in range(count)] if derivatives
                                    else None, 0.0, least[i] if least is not None else None,
                                    most[i] if most is not None else None)
        elif op.kind == "constant":          # (the format's value, as the shader holds it)
            exact = float(np.float16(op.value) if precision == "fp16" or op.width == 16 else np.float32(op.value))
            values[op.name] = Value(_arb(exact), list(zero) if derivatives else None, 0.0, exact, exact)
        elif op.kind == "convert":
            values[op.name] = a[0]
        elif op.kind == "arithmetic":
            values[op.name] = _arithmetic(op.op, a, precision, rounding, derivatives)
        elif op.kind == "function":
            values[op.name] = _function(op.op, a, precision, rounding, derivatives)
        elif op.kind == "compare":
            values[op.name] = Value(_decided(op.op, a[0], a[1]), None, 0.0)
        elif op.kind == "select":
            condition, x, y = a
            if condition.v is True:
                values[op.name] = x
            elif condition.v is False:
                values[op.name] = y
            else:       # (not decided over the box, or a computed value may fall on either side)
                values[op.name] = Value(x.v.union(y.v), None, max(x.d, y.d) + _spread(x.v, y.v))
        else:
            raise Unsupported(f"{op.kind} {op.op} is not bounded")
        if derivatives and values[op.name].g is not None and grad(*values[op.name].g) is None:
            values[op.name].g = None
    return values[result]


def _spread(x, y) -> float:
    """What picking the other branch may add: the largest gap between the two values' enclosures."""
    return max(0.0, _up(hi(x) - lo(y)), _up(hi(y) - lo(x)))


def _decided(kind: str, a: Value, b: Value):
    """True or False where the comparison holds or fails at every value within the rounding error of
    a and b, else None."""
    low_a, high_a = lo(a.v) - a.d, hi(a.v) + a.d
    low_b, high_b = lo(b.v) - b.d, hi(b.v) + b.d
    if kind in ("gt", "ge"):
        if low_a > high_b:
            return True
        if high_a < low_b:
            return False
    if kind in ("lt", "le"):
        if high_a < low_b:
            return True
        if low_a > high_b:
            return False
    return None


def _arithmetic(kind: str, a: list[Value], precision: str, rounding: Rounding, derivatives: bool) -> Value:
    if kind == "FNegate":
        x = a[0]
        return Value(-x.v, [-g for g in x.g] if x.g is not None else None, x.d)
    x, y = a
    if kind in ("FAdd", "FSub"):
        sign = 1 if kind == "FAdd" else -1
        v = x.v + y.v if sign > 0 else x.v - y.v
        g = [p + sign * q for p, q in zip(x.g, y.g)] if x.g is not None and y.g is not None else None
        if kind == "FSub" and _sterbenz(x, y):      # (exact: either rounding returns it)
            low, high = _difference(x.least, y.most, -math.inf), _difference(x.most, y.least, math.inf)
            return Value(v, g, 0.0, low, high)
        d = _up(x.d + y.d)
        return Value(v, g, _up(d + _ulp(v + hull(-d, d), precision, rounding.basic)))
    if kind == "FMul":
        v = x.v * y.v
        g = [x.v * q + y.v * p for p, q in zip(x.g, y.g)] if x.g is not None and y.g is not None else None
        d = _up(magnitude(x.v) * y.d + magnitude(y.v) * x.d + x.d * y.d)
        return Value(v, g, _up(d + _ulp(v + hull(-d, d), precision, rounding.basic)))
    if kind == "FDiv":
        least = least_magnitude(y.v) - y.d
        if least <= 0:
            raise NotBounded("a division whose divisor's enclosure reaches 0 on the box")
        v = x.v / y.v
        g = [(p * y.v - x.v * q) / (y.v * y.v) for p, q in zip(x.g, y.g)] if x.g is not None and y.g is not None \
            else None
        d = _up((x.d + magnitude(v) * y.d) / math.nextafter(least, 0.0))
        return Value(v, g, _up(d + _ulp(v + hull(-d, d), precision, rounding.division)))
    raise Unsupported(f"{kind} is not bounded")


def _sterbenz(x: Value, y: Value) -> bool:
    """Whether x - y is exact for every pair of the format's values in x and y (Sterbenz's lemma:
    y / 2 <= x <= 2 y), both computed exactly and their ranges known."""
    if x.d or y.d or None in (x.least, x.most, y.least, y.most):
        return False
    return y.least > 0 and y.most / 2 <= x.least and x.most <= 2 * y.least


def _difference(a: float, b: float, toward: float) -> float:
    """a - b rounded toward `toward` (-inf: a float at most it; inf: at least)."""
    from fractions import Fraction

    near = a - b
    exact = Fraction(a) - Fraction(b)
    if (toward < 0 and Fraction(near) > exact) or (toward > 0 and Fraction(near) < exact):
        near = math.nextafter(near, toward)
    return near


def _function(kind: str, a: list[Value], precision: str, rounding: Rounding, derivatives: bool) -> Value:
    if kind == "Sqrt":
        x = a[0]
        low = lo(x.v)
        if low < 0 and hi(x.v) < 0:
            raise NotBounded("sqrt of a negative enclosure")
        inside = x.v if low >= 0 else x.v.nonnegative_part()     # (a ball may reach below 0 where its value cannot)
        v = inside.sqrt()
        g = None
        if x.g is not None and low > 0:
            g = [p / (2 * v) for p in x.g]
        root = math.sqrt(max(low, 0.0))
        below = math.sqrt(max(low - x.d, 0.0))
        d = _up(min(x.d / (root + below), math.sqrt(x.d)) if root + below > 0 else math.sqrt(x.d))
        return Value(v, g, _up(d + _ulp(v + hull(-d, d), precision, rounding.sqrt)))
    if kind == "FAbs":
        x = a[0]
        if lo(x.v) > 0:
            return x
        if hi(x.v) < 0:
            return Value(-x.v, [-p for p in x.g] if x.g is not None else None, x.d)
        return Value(hull(0.0, magnitude(x.v)), None, x.d)
    if kind in ("FMax", "NMax", "FMin", "NMin"):
        x, y = a
        bigger = kind.endswith("Max")
        if lo(x.v) - x.d > hi(y.v) + y.d:
            return x if bigger else y
        if lo(y.v) - y.d > hi(x.v) + x.d:
            return y if bigger else x
        v = x.v.max(y.v) if bigger else x.v.min(y.v)
        g = [p.union(q) for p, q in zip(x.g, y.g)] if x.g is not None and y.g is not None else None
        return Value(v, g, max(x.d, y.d))
    if kind in ("FClamp", "NClamp"):
        x, low_, high_ = a
        return _function("FMin", [_function("FMax", [x, low_], precision, rounding, derivatives), high_], precision,
                         rounding, derivatives)
    name = {"Exp2": "exp2", "Log2": "log2", "InverseSqrt": "inversesqrt", "Sin": "sin", "Cos": "cos",
            "Exp": "exp", "Log": "log", "Acos": "acos", "Asin": "asin", "Atan": "atan", "Pow": "pow"}.get(kind)
    if name == "pow" and {"exp2", "log2"} <= set(rounding.functions):
        return _power(a[0], a[1], precision, rounding)
    if name is None or name not in rounding.functions or name == "pow":
        raise Unsupported(f"uses {kind}, which {rounding.name} does not bound")
    return _special(name, a[0], precision, rounding.functions[name])


def _power(x: Value, y: Value, precision: str, rounding: Rounding) -> Value:
    """pow(x, y) as Vulkan states its precision, inherited from exp2(y log2 x): log2, a product and
    exp2, each within its allowance; not bounded where the computed base may fall below 0 (undefined
    there). Where x may reach 0 (y > 0 over the box): both the exact and the
    computed value lie in [0, top], top the largest exp2 may return for the largest y log2 x it may
    be given, v (exp2's allowance 2^v (a + b|v|) ulp grows toward v_top while 2^v |v| does where
    v < -1 / ln 2), so their difference is at most top; a box where v_top is not below that is not
    bounded (split further)."""
    if lo(x.v) - x.d > 0:
        logarithm = _special("log2", x, precision, rounding.functions["log2"])
        product = _arithmetic("FMul", [y, logarithm], precision, rounding, x.g is not None)
        return _special("exp2", product, precision, rounding.functions["exp2"])
    if (x.least if x.least is not None else lo(x.v) - x.d) < 0:
        raise NotBounded("pow's base may be computed below 0 on the box (its result undefined there)")
    least_y = lo(y.v) - y.d
    largest_x = hi(x.v) + x.d
    if least_y <= 0 or largest_x <= 0:
        raise NotBounded("pow of a base reaching 0 with an exponent not above 0 on the box")
    at_top = _special("log2", Value(_arb(largest_x), None, 0.0), precision, rounding.functions["log2"])
    largest_log = hi(at_top.v) + at_top.d
    if largest_log >= 0:
        raise NotBounded("pow's base reaches 0 and 1 on the box")
    v_top = least_y * largest_log
    v_top = v_top + abs(v_top) * rounding.basic * UNIT[precision] + SMALLEST[precision]
    if v_top >= -1.0 / math.log(2.0):
        raise NotBounded("pow's base reaches 0 on a box too wide")
    exp2 = rounding.functions["exp2"]
    top = _up(2.0 ** v_top * (1 + (exp2.ulps + exp2.ulps_per_x * abs(v_top)) * UNIT[precision])
              + exp2.absolute + SMALLEST[precision])
    return Value(hull(0.0, top), None, top)


def _special(name: str, x: Value, precision: str, accuracy) -> Value:
    """A driver's own function of one argument: its exact value and derivative over the argument's
    enclosure widened by the argument's rounding error, plus its allowance (`accuracy`)."""
    from flint import arb

    wide = x.v + hull(-x.d, x.d)
    exact = {"exp2": lambda t: (t * arb(2).log()).exp(), "log2": lambda t: t.log() / arb(2).log(),
             "inversesqrt": lambda t: 1 / t.sqrt(), "sin": lambda t: t.sin(), "cos": lambda t: t.cos(),
             "acos": lambda t: t.acos(), "asin": lambda t: t.asin(), "atan": lambda t: t.atan()}[name]
    slope = {"exp2": lambda t: (t * arb(2).log()).exp() * arb(2).log(), "log2": lambda t: 1 / (t * arb(2).log()),
             "inversesqrt": lambda t: -1 / (2 * t * t.sqrt()), "sin": lambda t: t.cos(), "cos": lambda t: -t.sin(),
             "acos": lambda t: -1 / (1 - t * t).sqrt(), "asin": lambda t: 1 / (1 - t * t).sqrt(),
             "atan": lambda t: 1 / (1 + t * t)}[name]
    if name in ("acos", "asin"):     # (monotone on [-1, 1]: from the argument's ends, a ball's slack past 1 kept out)
        low = max(lo(x.v), x.least) if x.least is not None else lo(x.v)
        high = min(hi(x.v), x.most) if x.most is not None else hi(x.v)
        if low - x.d < -1 or high + x.d > 1:
            raise NotBounded(f"{name}'s argument may leave [-1, 1] on the box")
        ends = [exact(arb(low)), exact(arb(high))]
        v = hull(min(lo(e) for e in ends), max(hi(e) for e in ends))
        ends = [exact(arb(low - x.d)), exact(arb(high + x.d))]
        value = hull(min(lo(e) for e in ends), max(hi(e) for e in ends))
        wide = hull(low - x.d, high + x.d)
    else:
        v, value = exact(x.v), exact(wide)
    if not (finite(v) and finite(value)):
        raise NotBounded(f"{name} is not bounded on the box (its argument reaches where it is not finite)")
    propagated = 0.0
    if x.d:         # (an argument computed with an error: its slope over the widened argument carries it)
        steepest = slope(wide)
        if not finite(steepest):
            raise NotBounded(f"{name} is not bounded on the box (its slope is not finite where its argument may be)")
        propagated = _up(magnitude(steepest) * x.d)
    inner = slope(x.v)
    g = [p * inner for p in x.g] if x.g is not None and finite(inner) else None
    argument = magnitude(wide)
    allowed = 0.0
    if accuracy.absolute and lo(wide) <= accuracy.hi and hi(wide) >= accuracy.lo:
        allowed = accuracy.absolute
    if not accuracy.absolute or lo(wide) < accuracy.lo or hi(wide) > accuracy.hi:
        allowed = max(allowed, _ulp(value, precision, accuracy.ulps + accuracy.ulps_per_x * argument))
    return Value(v, g, _up(propagated + allowed))


# --- the target's sympy tree ----------------------------------------------------------------------

def target_pass(expression, symbols, box, derivatives: bool = True):
    """(the target's value over `box` as an arb, its partial derivatives or None): the sympy
    `expression` in `symbols` walked with arb balls."""
    import sympy as sp
    from flint import arb

    from .target_tree import forward

    count = len(symbols)

    def variable(e):
        i = symbols.index(e)
        return box[i], [arb(1) if j == i else arb(0) for j in range(count)]

    def number(e):
        if e is sp.pi:
            value = arb.pi()
        elif e is sp.E:
            value = arb(1).exp()
        elif e.is_Rational:
            value = arb(int(e.p)) / arb(int(e.q))
        elif e.is_Number:
            value = arb(float(e))
        else:
            raise Unsupported(f"the target's {e} is not bounded")
        return value, [arb(0)] * count

    def power(b, gb, exponent, walk):
        if exponent.is_Integer:
            n = int(exponent)
            value = b ** n if n >= 0 else 1 / (b ** (-n))
            return value, [n * (b ** (n - 1) if n >= 1 else 1 / b ** (1 - n)) * p for p in gb]
        if exponent in (sp.Rational(1, 2), sp.Rational(-1, 2)):
            root = (b if lo(b) >= 0 else b.nonnegative_part()).sqrt()
            if exponent > 0:
                return root, [p / (2 * root) for p in gb]
            return 1 / root, [-p / (2 * b * root) for p in gb]
        q, gq = walk(exponent)
        value = (q * b.log()).exp()
        return value, [value * (hq * b.log() + q * hb / b) for hb, hq in zip(gb, gq)]

    functions = {sp.exp: (lambda t: t.exp(), lambda t: t.exp()), sp.log: (lambda t: t.log(), lambda t: 1 / t),
                 sp.sin: (lambda t: t.sin(), lambda t: t.cos()), sp.cos: (lambda t: t.cos(), lambda t: -t.sin()),
                 sp.acos: (lambda t: t.acos(), lambda t: -1 / (1 - t * t).sqrt()),
                 sp.asin: (lambda t: t.asin(), lambda t: 1 / (1 - t * t).sqrt()),
                 sp.atan: (lambda t: t.atan(), lambda t: 1 / (1 + t * t)),
                 sp.tan: (lambda t: t.tan(), lambda t: 1 / (t.cos() * t.cos()))}

    def function(e, v, g):
        if e.func not in functions or len(e.args) != 1:
            raise Unsupported(f"the target's {e.func.__name__} is not bounded")
        value_of, slope_of = functions[e.func]
        return value_of(v), [slope_of(v) * p for p in g]

    value, g = forward(expression, variable, number, power, function)
    return value, (g if derivatives else None)


# --- one box, and the branch and bound --------------------------------------------------------------

def box_bound(ops, result, inputs, target_expression, symbols, box, precision: str, rounding: Rounding,
              metric: str = "abs", floor: float = 0.0) -> float:
    """A proven upper bound of the form's error as computed (`rounding`) against the target over
    `box` (a list of (lo, hi) per input; module docstring); inf where it cannot be bounded there."""
    return bound_and_sides(ops, result, inputs, target_expression, symbols, box, precision, rounding, metric,
                           floor)[0]


def bound_and_sides(ops, result, inputs, target_expression, symbols, box, precision: str, rounding: Rounding,
                    metric: str = "abs", floor: float = 0.0, same: bool = False) -> tuple[float, list[float] | None]:
    """(`box_bound`, what each side adds to it where the mean-value form bounded it: the slope's
    magnitude times the side's width, the side to split; None where the plain enclosure did). `same`:
    the form computes the target's own expression (the exact row), its real error 0, its rounding
    error alone bounded."""
    from flint import arb

    if same:
        balls = [hull(a, b) for a, b in box]
        try:
            whole = form_pass(ops, result, balls, inputs, precision, rounding, derivatives=False,
                              least=[a for a, _ in box], most=[b for _, b in box])
            f, _ = target_pass(target_expression, symbols, balls, derivatives=False)
        except (NotBounded, ZeroDivisionError, ValueError):
            return math.inf, None
        least = max(least_magnitude(f), floor) if metric == "rel" else 1.0
        if least <= 0 or not math.isfinite(whole.d):
            return math.inf, None
        return _up(whole.d / math.nextafter(least, 0.0)) if metric == "rel" else whole.d, \
            [b - a for a, b in box]

    balls = [hull(a, b) for a, b in box]
    try:
        whole = form_pass(ops, result, balls, inputs, precision, rounding, least=[a for a, _ in box],
                          most=[b for _, b in box])
        f, gf = target_pass(target_expression, symbols, balls)
    except (NotBounded, ZeroDivisionError, ValueError):
        return math.inf, None
    relative = metric == "rel"
    sides = None
    least = max(least_magnitude(f), floor) if relative else 1.0
    if relative and least <= 0:
        return math.inf, None
    # the plain enclosure, and the mean-value form of e - f (abs) or of e / f (rel, where |f| >= floor)
    error = (whole.v - f) / f if relative and least_magnitude(f) >= floor else whole.v - f
    if not relative or least_magnitude(f) < floor:
        error = (whole.v - f) * (1 / _arb(least) if relative else 1)
    if whole.g is not None and gf is not None and (not relative or least_magnitude(f) >= floor):
        middle = [0.5 * a + 0.5 * b for a, b in box]
        centre = [arb(c) for c in middle]
        try:
            at = form_pass(ops, result, centre, inputs, precision, rounding, derivatives=False, least=middle,
                           most=middle)
            fc, _ = target_pass(target_expression, symbols, centre, derivatives=False)
        except (NotBounded, ZeroDivisionError, ValueError):
            at = None
        if at is not None:
            if relative:          # d(e / f) = (f de - e df) / f^2
                spread = at.v / fc - 1
                slopes = [(f * p - whole.v * q) / (f * f) for p, q in zip(whole.g, gf)]
            else:
                spread = at.v - fc
                slopes = [p - q for p, q in zip(whole.g, gf)]
            for (a, b), c, slope in zip(box, middle, slopes):
                spread = spread + slope * (arb(a) - arb(c)).union(arb(b) - arb(c))
            if finite(spread) and magnitude(spread) < magnitude(error):
                error = spread
            if all(finite(slope) for slope in slopes):
                sides = [magnitude(slope) * (b - a) for (a, b), slope in zip(box, slopes)]
    if not (finite(error) and finite(whole.v)):
        return math.inf, None
    rounding_part = whole.d / math.nextafter(least, 0.0) if relative else whole.d
    return _up(magnitude(error) + _up(rounding_part)), sides


def certify(body: str, inputs: list[str], target_expression, symbols, domain, precision: str = "fp32",
            rounding: Rounding = LAVAPIPE, metric: str = "abs", floor: float = 0.0, found: float = 0.0,
            at: tuple = (), excluded=(), work: int | None = None, ratio: float = RATIO,
            same: bool = False, method: str | None = None) -> Certified:
    """The branch and bound of the module docstring for the form `body` (GLSL in `inputs`) against
    the target (a sympy expression in `symbols`, in the inputs' order) over `domain` ((lo, hi) per
    input), the largest error sampled so far `found` (at `at`) its starting lower bound. `excluded`:
    boxes of the domain left out (a singular corner the target excludes), each ((lo, hi), ...). `same`:
    the form is the target's own expression (`bound_and_sides`). A form and target of + - * /, sqrt,
    min, max, clamp, abs and selections alone go to `certified_arrays` (the same proof on arrays of
    boxes, `certified_arrays.WORK` of them at most) unless `method` is "arb"; `work` (boxes) defaults to
    the method's."""
    from ...isa import execution
    from . import certified_arrays

    try:
        ops, result = execution.emulation_program(body, precision, list(inputs), driver=True)
    except Exception as e:          # (an operation the lowering does not know)
        return Certified(math.inf, found, at, 0, "not bounded", str(e).splitlines()[0][:160])
    try:
        whole = [hull(*map(float, d)) for d in domain]
        form_pass(ops, result, whole, list(inputs), precision, rounding, derivatives=False)
        target_pass(target_expression, symbols, whole, derivatives=False)
    except Unsupported as e:
        return Certified(math.inf, found, at, 0, "not bounded", str(e))
    except (NotBounded, ZeroDivisionError, ValueError):
        pass
    if method in (None, "intervals") and certified_arrays.supported(ops, target_expression):
        return certified_arrays.certify(ops, result, list(inputs), target_expression, symbols, domain, precision,
                                        rounding, metric, floor, found, at, excluded,
                                        certified_arrays.WORK if work is None else work, ratio, same)
    work = WORK if work is None else work
    exact = numpy_target(target_expression, symbols)
    dtype = np.float32 if precision == "fp32" else np.float16
    heap: list = []
    boxes = 0
    best, where = found, tuple(at)

    def push(box):
        nonlocal boxes, best, where
        if any(all(a >= e_lo and b <= e_hi for (a, b), (e_lo, e_hi) in zip(box, ex)) for ex in excluded):
            return
        boxes += 1
        if rounding == LAVAPIPE:
            seen, point = _executed_error(ops, result, inputs, _points(box, dtype), exact, dtype, metric, floor)
        else:           # (what the allowance permits at the centre: the most a conforming driver may err there)
            point = tuple(_points(box, dtype)[0])
            seen = bound_and_sides(ops, result, inputs, target_expression, symbols, tuple((c, c) for c in point),
                                   precision, rounding, metric, floor, same)[0]
            seen = seen if math.isfinite(seen) else 0.0
        if seen > best:
            best, where = seen, point
        bound, sides = bound_and_sides(ops, result, inputs, target_expression, symbols, box, precision, rounding,
                                       metric, floor, same)
        heapq.heappush(heap, (-bound, boxes, box, sides))

    def _corners_bound(box) -> float:
        """The largest error at the box's corners: executed (lavapipe's rounding), or each corner's
        own bound (an allowance), inf where one is not bounded."""
        if rounding == LAVAPIPE:
            return _executed_error(ops, result, inputs, _points(box, dtype), exact, dtype, metric, floor)[0]
        return max(bound_and_sides(ops, result, inputs, target_expression, symbols, tuple((c, c) for c in corner),
                                   precision, rounding, metric, floor, same)[0] for corner in _points(box, dtype)[1:])

    push(tuple(tuple(map(float, d)) for d in domain))
    while heap:
        top = -heap[0][0]
        if top <= ratio * best and math.isfinite(top):
            return Certified(max(top, best), best, where, boxes, "proven")
        if boxes >= work:
            if DEBUG:
                for item in heapq.nsmallest(8, heap):
                    print(-item[0], item[2], item[3])
            if not math.isfinite(top):        # (a box no split bounded: say why)
                return Certified(math.inf, best, where, boxes, "not bounded", _why_not(
                    ops, result, inputs, heap[0][2], precision, rounding))
            return Certified(top, best, where, boxes, "budget")
        _, _, box, sides = heapq.heappop(heap)
        # the widest side, measured relative to its distance from 0 where it does not reach it (a side
        # from 0.01 to 1 is split at 0.1: a function of 1 / x varies alike on each half)
        # the side that adds most to the bound, or where the plain enclosure bounded it the widest
        # (relative to its distance from 0 where it does not reach it: from 0.01 to 1 split at 0.1)
        widths = sides or [(b - a) * (1.0 if not (a > 0 and b > 4 * a) else math.log(b / a) / (b - a) * b)
                           for a, b in box]
        i = int(np.argmax(widths))
        a, b = box[i]
        middle = float(dtype(math.sqrt(a * b) if a > 0 and b > 4 * a else 0.5 * (a + b)))
        if not (a < middle < b):
            middle = 0.5 * (a + b)
            if not (a < middle < b):    # (two neighbouring floats wide: its inputs are its corners, found)
                own = _corners_bound(box)
                if not math.isfinite(own):
                    return Certified(math.inf, best, where, boxes, "not bounded", _why_not(
                        ops, result, inputs, box, precision, rounding))
                if own > best:
                    best, where = own, tuple(_points(box, dtype)[1])
                heapq.heappush(heap, (-own, boxes, box, None))
                continue
        push(box[:i] + ((a, middle),) + box[i + 1:])
        push(box[:i] + ((middle, b),) + box[i + 1:])
    return Certified(best, best, where, boxes, "proven")


def _why_not(ops, result, inputs, box, precision: str, rounding: Rounding) -> str:
    """Why the form is not bounded on `box`, one line."""
    try:
        form_pass(ops, result, [hull(a, b) for a, b in box], list(inputs), precision, rounding, derivatives=False,
                  least=[a for a, _ in box], most=[b for _, b in box])
    except NotBounded as e:
        return f"{e} (at {', '.join(f'[{a:.4g}, {b:.4g}]' for a, b in box)})"
    return f"its error is not finite at {', '.join(f'[{a:.4g}, {b:.4g}]' for a, b in box)}"


def _points(box, dtype) -> np.ndarray:
    """The box's centre and corners in the format (where the error is sought from below), one row each."""
    import itertools

    centre = [float(dtype(0.5 * a + 0.5 * b)) for a, b in box]
    corners = list(itertools.product(*[(float(dtype(a)), float(dtype(b))) for a, b in box]))
    return np.asarray([centre] + [list(c) for c in corners], dtype=np.float64)


def _executed_error(ops, result, inputs, points: np.ndarray, exact, dtype, metric: str, floor: float) -> tuple:
    """(the largest error as the emulation executes the form at `points` of the format, where)."""
    from ...isa import lowering

    with np.errstate(all="ignore"):
        values = {name: points[:, i].astype(dtype) for i, name in enumerate(inputs)}
        computed = np.asarray(lowering.evaluate(ops, result, values, {}, dtype), dtype=np.float64)
        computed = np.broadcast_to(computed, (len(points),))
        f = np.broadcast_to(np.asarray(exact(*[points[:, i] for i in range(points.shape[1])]), dtype=np.float64),
                            (len(points),))
        error = np.abs(computed - f)
        if metric == "rel":
            error = error / np.maximum(np.abs(f), floor)
    error = np.where(np.isfinite(error), error, 0.0)
    k = int(np.argmax(error))
    return float(error[k]), tuple(float(v) for v in points[k])


def spec_bounds(body: str, inputs: list[str], expression, symbols, domain, precision: str, vendors=(),
                metric: str = "abs", floor: float = 0.0, work: int | None = None, ratio: float = RATIO,
                same: bool = False) -> dict:
    """{"vulkan": the `certify` of `body` with Vulkan's minimum allowances (`vulkan`), and per vendor
    of `vendors` that documents its own figures (`special_functions.VENDOR`: AMD, NVIDIA) with them
    (`vendor`), each a Certified}:
    the worst a conforming driver may give, the operations in the order written (a contracted
    multiply-add is within the same bound)."""
    out = {"vulkan": certify(body, inputs, expression, symbols, domain, precision, vulkan(precision), metric, floor,
                             work=work, ratio=ratio, same=same)}
    from ...isa import special_functions

    for name in sorted({v for v in vendors if (v, precision) in special_functions.VENDOR}):
        out[name] = certify(body, inputs, expression, symbols, domain, precision, vendor(name, precision), metric,
                            floor, work=work, ratio=ratio, same=same)
    return out
