"""`certified_box`'s branch and bound on arrays of boxes at once: interval arithmetic in float64 with
outward rounding (each correctly rounded + - * / and sqrt moved one float outward), for forms and
targets whose every operation is one of + - * /, sqrt, min, max, clamp, abs, a comparison or a
selection (the target: sums, products, integer and half powers of its variables and rational
constants). Inf-sup intervals keep a product's sign and size where arb's midpoint-radius balls lose
them, and a batch of boxes costs about what one box costs in arb, so a form's boxes can number in
the hundreds of thousands.

Per box B, as `certified_box` states it: the form's exact value, its partial derivatives (forward,
as intervals; the whole line where an operation is not differentiable over B) and its rounding bound
d; the target's value and derivatives; the error enclosed twice, plainly (e - f, or e / f - 1) and
by the mean-value form around B's centre, and the two intersected; the bound max |error| plus d (or
d / least |f|). Each round splits the `BATCH` boxes of largest bound on the side that adds most,
bounds the children and executes the form at their centres and corners (the largest error found);
a box whose bound is within `RATIO` of the largest found is closed. Proven when none is open;
at `certified_box.WORK`-like budget (`WORK` boxes) the largest open bound is the one reached.
"""

from __future__ import annotations

import itertools
import math

import numpy as np

from .rounding import LAVAPIPE, SMALLEST, UNIT, Certified, NotBounded, Rounding, Unsupported, numpy_target

WORK = 400_000      # boxes bounded per form at most (the same plan on every machine)
BATCH = 2_048       # boxes split per round
LARGEST = {"fp32": float(np.finfo(np.float32).max), "fp16": float(np.finfo(np.float16).max)}
SAFETY = 1.0 + 2.0 ** -40       # a rounding bound's own float64 rounding errors, covered
ALGEBRAIC = ("Sqrt", "FAbs", "FMax", "FMin", "NMax", "NMin", "FClamp", "NClamp")

INF = math.inf


def down(x):
    return np.nextafter(x, -INF)


def up(x):
    return np.nextafter(x, INF)


class Interval:
    """[lo, hi] per box (float64 arrays); a NaN end stands for the whole line."""

    __slots__ = ("lo", "hi")

    def __init__(self, lo, hi):
        lo, hi = np.asarray(lo, np.float64), np.asarray(hi, np.float64)
        bad = np.isnan(lo) | np.isnan(hi)
        self.lo = np.where(bad, -INF, lo)
        self.hi = np.where(bad, INF, hi)

    @staticmethod
    def point(x):
        return Interval(x, x)

    def __add__(self, o):
        o = _as(o)
        return Interval(down(self.lo + o.lo), up(self.hi + o.hi))

    def __sub__(self, o):
        o = _as(o)
        return Interval(down(self.lo - o.hi), up(self.hi - o.lo))

    def __neg__(self):
        return Interval(-self.hi, -self.lo)

    def __mul__(self, o):
        o = _as(o)
        with np.errstate(invalid="ignore"):
            p = np.stack([self.lo * o.lo, self.lo * o.hi, self.hi * o.lo, self.hi * o.hi])
        bad = np.isnan(p).any(axis=0)
        return Interval(np.where(bad, np.nan, down(np.min(p, axis=0))), np.where(bad, np.nan, up(np.max(p, axis=0))))

    def square(self):
        low, high = np.abs(self.lo), np.abs(self.hi)
        straddles = (self.lo <= 0) & (self.hi >= 0)
        least = np.where(straddles, 0.0, np.minimum(low, high))
        return Interval(down(least * least).clip(0.0), up(np.maximum(low, high) ** 2))

    def __truediv__(self, o):
        o = _as(o)
        zero = (o.lo <= 0) & (o.hi >= 0)
        with np.errstate(all="ignore"):
            p = np.stack([self.lo / o.lo, self.lo / o.hi, self.hi / o.lo, self.hi / o.hi])
        bad = zero | np.isnan(p).any(axis=0)
        return Interval(np.where(bad, np.nan, down(np.min(p, axis=0))), np.where(bad, np.nan, up(np.max(p, axis=0))))

    def sqrt(self):
        with np.errstate(invalid="ignore"):
            return Interval(np.where(self.hi < 0, np.nan, down(np.sqrt(np.maximum(self.lo, 0.0))).clip(0.0)),
                            np.where(self.hi < 0, np.nan, up(np.sqrt(self.hi))))

    def magnitude(self):
        return np.maximum(np.abs(self.lo), np.abs(self.hi))

    def least_magnitude(self):
        straddles = (self.lo <= 0) & (self.hi >= 0)
        return np.where(straddles, 0.0, np.minimum(np.abs(self.lo), np.abs(self.hi)))

    def union(self, o):
        return Interval(np.minimum(self.lo, o.lo), np.maximum(self.hi, o.hi))

    def widened(self, d):
        return Interval(down(self.lo - d), up(self.hi + d))

    def finite(self):
        return np.isfinite(self.lo) & np.isfinite(self.hi)


def _as(x) -> Interval:
    return x if isinstance(x, Interval) else Interval.point(x)


def _whole(shape) -> Interval:
    return Interval(np.full(shape, -INF), np.full(shape, INF))


class Value:
    """An operation's exact value over each box (`v`), its partial derivatives (`g`, one Interval per
    input) and its rounding bound (`d`, an array)."""

    __slots__ = ("v", "g", "d")

    def __init__(self, v, g, d):
        self.v, self.g, self.d = v, g, d


def supported(ops, expression) -> bool:
    """Whether the form's operations and the target's sympy tree are all this module's (module docstring)."""
    if any(op.kind == "uniform" or (op.kind == "function" and op.op not in ALGEBRAIC)
           or (op.kind == "arithmetic" and op.op not in ("FNegate", "FAdd", "FSub", "FMul", "FDiv")) for op in ops):
        return False
    import sympy as sp

    def algebraic(e):
        if e.is_Symbol or e.is_Rational or e.is_Float:
            return True
        if e.is_Add or e.is_Mul:
            return all(algebraic(a) for a in e.args)
        if e.is_Pow:
            power = e.args[1]
            return algebraic(e.args[0]) and (power.is_Integer or power in (sp.Rational(1, 2), sp.Rational(-1, 2)))
        return False

    return algebraic(expression)


def _ulp(v: Interval, precision: str, ulps: float):
    return ulps * (UNIT[precision] * v.magnitude() + SMALLEST[precision])


def _rounded(v: Interval, d, precision: str, ulps: float):
    """d plus what the operation may err at its result (within d of v)."""
    return (d + _ulp(v.widened(d), precision, ulps)) * SAFETY


def form_pass(ops, result: str, box: list[Interval], inputs: list[str], precision: str, rounding: Rounding,
              derivatives: bool = True) -> Value:
    """`certified_box.form_pass` on every box at once (the module docstring's arithmetic)."""
    count, shape = len(inputs), box[0].lo.shape
    zero = np.zeros(shape)
    values: dict[str, Value] = {}
    for op in ops:
        a = [values[x] for x in op.args]
        if op.kind == "input":
            i = inputs.index(op.op)
            values[op.name] = Value(box[i], [Interval.point(zero + (j == i)) for j in range(count)]
                                    if derivatives else None, zero)
        elif op.kind == "constant":
            exact = float(np.float16(op.value) if precision == "fp16" or op.width == 16 else np.float32(op.value))
            values[op.name] = Value(Interval.point(zero + exact), [Interval.point(zero)] * count if derivatives
                                    else None, zero)
        elif op.kind == "convert":
            x = a[0]
            own = "fp16" if op.width == 16 else precision
            values[op.name] = Value(x.v, x.g, _rounded(x.v, x.d, own, rounding.basic) if own != precision else x.d)
        elif op.kind == "arithmetic":
            values[op.name] = _arithmetic(op, a, precision, rounding, derivatives)
        elif op.kind == "function":
            values[op.name] = _function(op.op, a, precision, rounding, derivatives)
        elif op.kind == "compare":
            values[op.name] = Value(_decided(op.op, a[0], a[1]), None, zero)
        elif op.kind == "select":
            condition, x, y = a
            yes, no = condition.v == 1, condition.v == 0
            both = ~(yes | no)
            v = Interval(np.where(yes, x.v.lo, np.where(no, y.v.lo, np.minimum(x.v.lo, y.v.lo))),
                         np.where(yes, x.v.hi, np.where(no, y.v.hi, np.maximum(x.v.hi, y.v.hi))))
            spread = np.maximum(0.0, np.maximum(up(x.v.hi - y.v.lo), up(y.v.hi - x.v.lo)))
            d = np.where(yes, x.d, np.where(no, y.d, (np.maximum(x.d, y.d) + spread) * SAFETY))
            g = None
            if derivatives:
                g = [Interval(np.where(both, np.nan, np.where(yes, p.lo, q.lo)),
                              np.where(both, np.nan, np.where(yes, p.hi, q.hi))) for p, q in zip(x.g, y.g)]
            values[op.name] = Value(v, g, d)
        else:
            raise Unsupported(f"{op.kind} {op.op} is not bounded")
    out = values[result]
    too_large = out.v.magnitude() + out.d > LARGEST[precision]
    out.d = np.where(too_large | ~np.isfinite(out.d), INF, out.d)
    return out


def _decided(kind: str, a: Value, b: Value):
    """1 where the comparison holds at every value within the rounding error of a and b, 0 where it
    fails at every one, -1 where the box does not decide it."""
    low_a, high_a = a.v.lo - a.d, a.v.hi + a.d
    low_b, high_b = b.v.lo - b.d, b.v.hi + b.d
    out = np.full(low_a.shape, -1)
    if kind in ("gt", "ge"):
        out = np.where(low_a > high_b, 1, np.where(high_a < low_b, 0, -1))
    elif kind in ("lt", "le"):
        out = np.where(high_a < low_b, 1, np.where(low_a > high_b, 0, -1))
    return out


def _arithmetic(op, a: list[Value], precision: str, rounding: Rounding, derivatives: bool) -> Value:
    kind = op.op
    if kind == "FNegate":
        x = a[0]
        return Value(-x.v, [-g for g in x.g] if derivatives else None, x.d)
    x, y = a
    if kind in ("FAdd", "FSub"):
        v = x.v + y.v if kind == "FAdd" else x.v - y.v
        g = ([p + q for p, q in zip(x.g, y.g)] if kind == "FAdd" else [p - q for p, q in zip(x.g, y.g)]) \
            if derivatives else None
        return Value(v, g, _rounded(v, x.d + y.d, precision, rounding.basic))
    if kind == "FMul":
        same = op.args[0] == op.args[1]
        v = x.v.square() if same else x.v * y.v
        g = [x.v * q + y.v * p for p, q in zip(x.g, y.g)] if derivatives else None
        d = x.v.magnitude() * y.d + y.v.magnitude() * x.d + x.d * y.d
        return Value(v, g, _rounded(v, d, precision, rounding.basic))
    if kind == "FDiv":
        least = y.v.least_magnitude() - y.d
        v = x.v / y.v
        g = [(p - v * q) / y.v for p, q in zip(x.g, y.g)] if derivatives else None
        with np.errstate(all="ignore"):
            d = np.where(least > 0, (x.d + v.magnitude() * y.d) / down(np.maximum(least, 0.0)), INF)
        return Value(v, g, _rounded(v, d, precision, rounding.division))
    raise Unsupported(f"{kind} is not bounded")


def _function(kind: str, a: list[Value], precision: str, rounding: Rounding, derivatives: bool) -> Value:
    if kind == "Sqrt":
        x = a[0]
        v = x.v.sqrt()
        g = [p / (v + v) for p in x.g] if derivatives else None
        root = np.sqrt(np.maximum(x.v.lo, 0.0))
        below = np.sqrt(np.maximum(x.v.lo - x.d, 0.0))
        with np.errstate(all="ignore"):
            d = np.where(root + below > 0, np.minimum(x.d / down(root + below), up(np.sqrt(x.d))), up(np.sqrt(x.d)))
        d = np.where(x.v.hi < 0, INF, d)
        return Value(v, g, _rounded(v, d, precision, rounding.sqrt))
    if kind == "FAbs":
        x = a[0]
        positive, negative = x.v.lo > 0, x.v.hi < 0
        v = Interval(np.where(positive, x.v.lo, np.where(negative, -x.v.hi, 0.0)),
                     np.where(negative, -x.v.lo, x.v.magnitude()))
        g = None
        if derivatives:
            g = [Interval(np.where(positive, p.lo, np.where(negative, -p.hi, np.nan)),
                          np.where(positive, p.hi, np.where(negative, -p.lo, np.nan))) for p in x.g]
        return Value(v, g, x.d)
    if kind in ("FMax", "NMax", "FMin", "NMin"):
        x, y = a
        bigger = kind.endswith("Max")
        x_above = x.v.lo - x.d > y.v.hi + y.d
        y_above = y.v.lo - y.d > x.v.hi + x.d
        first = x_above if bigger else y_above          # where x is the result
        second = y_above if bigger else x_above         # where y is
        if bigger:
            v = Interval(np.maximum(x.v.lo, y.v.lo), np.maximum(x.v.hi, y.v.hi))
        else:
            v = Interval(np.minimum(x.v.lo, y.v.lo), np.minimum(x.v.hi, y.v.hi))
        g = None
        if derivatives:
            g = [Interval(np.where(first, p.lo, np.where(second, q.lo, np.minimum(p.lo, q.lo))),
                          np.where(first, p.hi, np.where(second, q.hi, np.maximum(p.hi, q.hi)))) for p, q in zip(x.g, y.g)]
        return Value(v, g, np.where(first, x.d, np.where(second, y.d, np.maximum(x.d, y.d))))
    if kind in ("FClamp", "NClamp"):
        x, low, high = a
        return _function("FMin", [_function("FMax", [x, low], precision, rounding, derivatives), high], precision,
                         rounding, derivatives)
    raise Unsupported(f"uses {kind}, which {rounding.name} does not bound")


def target_pass(expression, symbols, box: list[Interval], derivatives: bool = True):
    """(the target's value over each box, its partial derivatives), the sympy tree walked in intervals
    (`target_tree.forward`)."""
    import sympy as sp

    from .target_tree import forward

    count, shape = len(symbols), box[0].lo.shape
    zero = np.zeros(shape)

    def constant(value: float, exact: bool):
        c = Interval.point(zero + value)
        return c if exact else Interval(down(c.lo), up(c.hi))

    def variable(e):
        i = symbols.index(e)
        return box[i], [Interval.point(zero + (j == i)) for j in range(count)]

    def number(e):
        if e.is_Rational:
            p, q = int(e.p), int(e.q)
            value = constant(p / q, q & (q - 1) == 0 and abs(p) < 2 ** 53)
        elif e.is_Float:
            value = constant(float(e), True)
        else:
            raise Unsupported(f"the target's {e} is not bounded by {__name__}")
        return value, [Interval.point(zero)] * count

    def power(b, gb, exponent, walk):
        if exponent.is_Integer:
            n = int(exponent)
            value = _power(b, abs(n))
            slope = _power(b, abs(n) - 1) * float(abs(n))
            if n < 0:
                value = Interval.point(zero + 1.0) / value
                slope = -(slope * value * value)
            return value, [slope * p for p in gb]
        root = b.sqrt()
        if exponent == sp.Rational(1, 2):
            return root, [p / (root + root) for p in gb]
        if exponent == sp.Rational(-1, 2):
            inverse = Interval.point(zero + 1.0) / root
            return inverse, [-(p * inverse / (b + b)) for p in gb]
        raise Unsupported(f"the target's power {exponent} is not bounded by {__name__}")

    def function(e, v, g):
        raise Unsupported(f"the target's {e.func.__name__} is not bounded by {__name__}")

    value, g = forward(expression, variable, number, power, function)
    return value, (g if derivatives else None)


def _power(b: Interval, n: int) -> Interval:
    out = Interval.point(np.ones_like(b.lo))
    base = b
    while n:
        if n & 1:
            out = out * base
        n >>= 1
        if n:
            base = base.square()
    return out


def bounds(ops, result, inputs, expression, symbols, lo: np.ndarray, hi: np.ndarray, precision: str,
           rounding: Rounding, metric: str, floor: float, same: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """(each box's proven bound, what each side adds to it (boxes x sides; the widths where the
    mean-value form did not bound it)) of the boxes lo[i] .. hi[i] (module docstring)."""
    k = lo.shape[1]
    box = [Interval(lo[:, j], hi[:, j]) for j in range(k)]
    relative = metric == "rel"
    with np.errstate(all="ignore"):
        whole = form_pass(ops, result, box, inputs, precision, rounding, derivatives=not same)
        f, gf = target_pass(expression, symbols, box, derivatives=not same)
        least_f = f.least_magnitude()
        least = np.maximum(least_f, floor) if relative else np.ones(len(lo))
        rounding_part = np.where(least > 0, up(whole.d / np.where(least > 0, down(least), 1.0)), INF) * SAFETY
        widths = hi - lo
        if same:
            out = np.where(whole.v.finite(), rounding_part, INF)
            return np.where(np.isnan(out), INF, out), widths
        quotient = relative & (least_f >= floor) if relative else np.zeros(len(lo), bool)
        if relative:
            plain_q = whole.v / f - 1.0
            plain_f = (whole.v - f) * Interval.point(up(1.0 / np.where(least > 0, down(least), np.nan)))
            plain = Interval(np.where(quotient, plain_q.lo, plain_f.lo), np.where(quotient, plain_q.hi, plain_f.hi))
        else:
            plain = whole.v - f
        centre = 0.5 * lo + 0.5 * hi
        at_box = [Interval.point(centre[:, j]) for j in range(k)]
        at = form_pass(ops, result, at_box, inputs, precision, rounding, derivatives=False)
        fc, _ = target_pass(expression, symbols, at_box, derivatives=False)
        if relative:
            q = whole.v / f
            middle = at.v / fc - 1.0
            slopes = [(p - q * r) / f for p, r in zip(whole.g, gf)]
        else:
            middle = at.v - fc
            slopes = [p - r for p, r in zip(whole.g, gf)]
        spread = middle
        for j, slope in enumerate(slopes):
            spread = spread + slope * Interval(down(lo[:, j] - centre[:, j]), up(hi[:, j] - centre[:, j]))
        use_spread = spread.finite() & (quotient if relative else True)
        error = Interval(np.where(use_spread, np.maximum(plain.lo, spread.lo), plain.lo),
                         np.where(use_spread, np.minimum(plain.hi, spread.hi), plain.hi))
        bound = up(error.magnitude() + rounding_part)
        bound = np.where(whole.v.finite() & f.finite() & ~np.isnan(bound), bound, INF)
        sides = np.stack([slope.magnitude() * widths[:, j] for j, slope in enumerate(slopes)], axis=1)
        finite = np.isfinite(sides).all(axis=1) & use_spread
        sides = np.where(finite[:, None], sides, _log_widths(lo, hi))
    return bound, sides


def _log_widths(lo, hi):
    """A side's width, measured relative to its distance from 0 where it spans a factor over 4."""
    with np.errstate(all="ignore"):
        geometric = (lo > 0) & (hi > 4 * lo)
        return np.where(geometric, np.log(hi / np.where(lo > 0, lo, 1.0)) * hi, hi - lo)


def certify(ops, result, inputs: list[str], expression, symbols, domain, precision: str = "fp32",
            rounding: Rounding = LAVAPIPE, metric: str = "abs", floor: float = 0.0, found: float = 0.0,
            at: tuple = (), excluded=(), work: int = WORK, ratio: float = 1.25, same: bool = False) -> Certified:
    """`certified_box.certify` for a form and target `supported` here (module docstring)."""
    dtype = np.float32 if precision == "fp32" else np.float16
    exact = numpy_target(expression, symbols)
    best, where = float(found), tuple(at)
    closed = 0.0
    count = 0

    def evaluate(lo, hi):
        nonlocal best, where, count
        keep = np.ones(len(lo), bool)
        for box in excluded:
            inside = np.ones(len(lo), bool)
            for j, (e_lo, e_hi) in enumerate(box):
                inside &= (lo[:, j] >= e_lo) & (hi[:, j] <= e_hi)
            keep &= ~inside
        lo, hi = lo[keep], hi[keep]
        count += len(lo)
        seen, point = _found(ops, result, inputs, expression, symbols, lo, hi, dtype, exact, precision, rounding,
                             metric, floor, same)
        if seen > best:
            best, where = seen, point
        b, sides = bounds(ops, result, inputs, expression, symbols, lo, hi, precision, rounding, metric, floor, same)
        return lo, hi, b, sides

    lo, hi, b, sides = evaluate(np.asarray([[float(a) for a, _ in domain]]), np.asarray([[float(c) for _, c in domain]]))
    while True:
        done = b <= ratio * best
        if done.any():
            closed = max(closed, float(b[done].max()))
            lo, hi, b, sides = lo[~done], hi[~done], b[~done], sides[~done]
        if len(b) == 0:
            return Certified(max(closed, best), best, where, count, "proven", method="intervals")
        if count >= work:
            return Certified(max(closed, float(b.max())), best, where, count, "budget", method="intervals")
        if len(b) > BATCH:
            split = np.argpartition(-b, BATCH - 1)[:BATCH]
        else:
            split = np.arange(len(b))
        rest = np.ones(len(b), bool)
        rest[split] = False
        s_lo, s_hi, s_sides = lo[split], hi[split], sides[split]
        j = np.argmax(s_sides, axis=1)
        rows = np.arange(len(split))
        a, c = s_lo[rows, j], s_hi[rows, j]
        geometric = (a > 0) & (c > 4 * a)
        middle = np.where(geometric, np.sqrt(a * np.where(geometric, c, 1.0)), 0.5 * a + 0.5 * c)
        middle = middle.astype(dtype).astype(np.float64)
        middle = np.where((a < middle) & (middle < c), middle, 0.5 * a + 0.5 * c)
        splittable = (a < middle) & (middle < c)
        if not splittable.all():        # (one value of the format wide: the centre's error is the box's)
            closed = max(closed, float(b[split][~splittable].max()))
            keep_rows = splittable
            s_lo, s_hi, j, middle, rows = s_lo[keep_rows], s_hi[keep_rows], j[keep_rows], middle[keep_rows], \
                np.arange(int(keep_rows.sum()))
            if not len(rows):
                lo, hi, b, sides = lo[rest], hi[rest], b[rest], sides[rest]
                continue
        left_hi = s_hi.copy()
        left_hi[rows, j] = middle
        right_lo = s_lo.copy()
        right_lo[rows, j] = middle
        n_lo, n_hi, n_b, n_sides = evaluate(np.concatenate([s_lo, right_lo]), np.concatenate([left_hi, s_hi]))
        lo = np.concatenate([lo[rest], n_lo])
        hi = np.concatenate([hi[rest], n_hi])
        b = np.concatenate([b[rest], n_b])
        sides = np.concatenate([sides[rest], n_sides])


def _found(ops, result, inputs, expression, symbols, lo, hi, dtype, exact, precision, rounding, metric, floor, same):
    """(the largest error found in the boxes, where): with lavapipe's rounding the form executed (the
    emulation) at each box's centre and corners in the format; with an allowance the bound at each
    centre (the most a driver may err there)."""
    from ...isa import lowering

    if not len(lo):
        return 0.0, ()
    k = lo.shape[1]
    centre = _inside(0.5 * lo + 0.5 * hi, lo, hi, dtype)
    if rounding != LAVAPIPE:
        b, _ = bounds(ops, result, inputs, expression, symbols, centre, centre, precision, rounding, metric, floor,
                      same)
        b = np.where(np.isfinite(b), b, 0.0)
        i = int(np.argmax(b))
        return float(b[i]), tuple(float(v) for v in centre[i])
    corners = [np.stack([(hi if c else lo)[:, j] for j, c in enumerate(pick)], axis=1)
               for pick in itertools.product((0, 1), repeat=k)]
    points = np.concatenate([centre] + [_inside(c, lo, hi, dtype) for c in corners])
    with np.errstate(all="ignore"):
        values = {name: points[:, j].astype(dtype) for j, name in enumerate(inputs)}
        computed = np.broadcast_to(np.asarray(lowering.evaluate(ops, result, values, {}, dtype), np.float64),
                                   (len(points),))
        f = np.broadcast_to(np.asarray(exact(*[points[:, j] for j in range(k)]), np.float64), (len(points),))
        error = np.abs(computed - f)
        if metric == "rel":
            error = error / np.maximum(np.abs(f), floor)
    error = np.where(np.isfinite(error), error, 0.0)
    i = int(np.argmax(error))
    return float(error[i]), tuple(float(v) for v in points[i])


def _inside(x, lo, hi, dtype):
    """x rounded to the format, moved inward to the box's nearest value of the format where rounding left it."""
    p = x.astype(dtype)
    p = np.where(p.astype(np.float64) < lo, np.nextafter(p, dtype(np.inf)), p)
    p = np.where(p.astype(np.float64) > hi, np.nextafter(p, dtype(-np.inf)), p)
    return p.astype(np.float64)


__all__ = ["certify", "bounds", "supported", "Interval", "NotBounded"]
