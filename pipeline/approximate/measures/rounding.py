"""What each operation of a shader may err, as the certification bounds it (`Rounding`: lavapipe's
round to nearest, Vulkan's minimum allowances, a vendor's documented figures), and the record of a
certified bound (`Certified`), shared by the two branch and bounds (`certified_box` in arb balls,
`certified_arrays` in float64 intervals)."""

from __future__ import annotations

import dataclasses

UNIT = {"fp32": 2.0 ** -23, "fp16": 2.0 ** -10}          # the format's spacing at 1 (an ulp at v: <= UNIT |v|)
SMALLEST = {"fp32": 2.0 ** -149, "fp16": 2.0 ** -24}     # the subnormals' spacing


class NotBounded(ValueError):
    """An operation not bounded on a box (a divisor reaching 0 there), one line."""


class Unsupported(NotBounded):
    """A form with an operation its `Rounding` does not bound anywhere (one line naming it)."""


@dataclasses.dataclass(frozen=True)
class Rounding:
    """What each operation's computed result may err at its exact value, in units in the last place
    of the result: `basic` for + - * (0.5: correctly rounded; 1: either neighbour), `division`,
    `sqrt`; a driver's own functions by `functions` ({exp2, log2, inversesqrt, ...: an
    `isa.special_functions.Accuracy`}; a function not there is not bounded). `source` says whose."""

    name: str
    basic: float
    division: float
    sqrt: float
    functions: dict = dataclasses.field(default_factory=dict)
    source: str = ""


LAVAPIPE = Rounding("lavapipe", 0.5, 0.5, 0.5, {}, "IEEE 754 round to nearest (lavapipe: every + - * / and sqrt "
                                                   "correctly rounded)")


def vulkan(precision: str) -> Rounding:
    """Vulkan's minimum for a conforming driver: + - * to either neighbour (no RoundingModeRTE), division
    2.5 ulp, sqrt 4.5 (inherited from 1 / inversesqrt), the functions `special_functions.MINIMUM`'s."""
    from ...isa import special_functions

    table = special_functions.MINIMUM[precision]
    return Rounding("Vulkan", 1.0, table["division"].ulps, table["sqrt"].ulps, dict(table), special_functions.VULKAN)


def vendor(name: str, precision: str) -> Rounding:
    """A vendor's documented figures (`special_functions.VENDOR`: AMD's and NVIDIA's), Vulkan's minimum
    for a function it does not document; + - * correctly rounded (their ISA guides: round to nearest
    even, the instructions' default mode)."""
    from ...isa import special_functions

    spec = vulkan(precision)
    own = special_functions.VENDOR.get((name, precision), {})
    functions = dict(spec.functions) | {k: v for k, v in own.items() if k not in ("division", "sqrt")}
    return Rounding(name, 0.5, own["division"].ulps if "division" in own else spec.division,
                    own["sqrt"].ulps if "sqrt" in own else spec.sqrt, functions,
                    "; ".join(sorted({a.source for a in own.values()}) + ["+ - *: round to nearest even, the ISA's "
                                                                          "default mode"]) if own else spec.source)


@dataclasses.dataclass
class Certified:
    """A form's certified error: `bound` (proven over the box where `status` is "proven" or
    "budget"), the largest error found (`found`, where: `at`), the boxes bounded (`boxes`),
    `status`: proven (bound <= RATIO found), budget (the work's boxes bounded first), or not bounded (why
    in `reason`); `method`: arb (`certified_box`'s balls) or intervals (`certified_arrays`)."""

    bound: float
    found: float
    at: tuple
    boxes: int
    status: str
    reason: str = ""
    method: str = "arb"


def numpy_target(expression, symbols):
    """The target's sympy expression as a numpy function of its symbols (float64)."""
    import sympy as sp

    return sp.lambdify(symbols, expression, "numpy")
