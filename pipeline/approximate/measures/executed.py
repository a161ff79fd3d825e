"""The error of a one-variable target's forms as their shaders execute: each form's GLSL (the body
that is costed and exported) run by lavapipe (`isa.execution`) in the run's format, float32 or
float16, at inputs representable in it, against the target in float64 at the same inputs.

Where it is executed (`inputs`): in float16 every representable value of the domain (at most
65,536); in float32 `SPREAD` values evenly spaced among the domain's representable values (which
crowd toward 0; the domain's ends included) and `SPREAD` / 4 evenly spaced in value, plus, around
every extremum the real-valued measure found (`measure.max_error`'s x_abs and x_rel of each form),
the `NEIGHBOURS` nearest float32 values.

The truth is the target's float64 values (its numpy form) at those inputs: float64's rounding is
2^29 times below float32's. Where the target itself loses digits in float64 (a cancelling target),
`TRUTH_CHECK` inputs are compared with mpmath at 30 digits; if float64 errs there by more than
`TRUTH_TOLERANCE` of the format's unit, the truth is numpy's long double where it passes the same
check, else mpmath's at every input (`truth`).

Where lavapipe cannot run, each form is computed by the per-operation emulation in the format
(`execution.emulate`: + - * / sqrt correctly rounded, the special functions numpy's, not a
driver's); a form whose special function the emulation does not know (acos) is not executed, and
its row says so. `how` says which measured.
"""

from __future__ import annotations

import math

import numpy as np

from ..targets import numpy_function, PRECISIONS
# The format's unit: its spacing at 1 (an error below it of the target's range, or relative, is rounding).
UNIT = {"fp32": 2.0 ** -23, "fp16": 2.0 ** -10}
DTYPES = {"fp32": np.float32, "fp16": np.float16}
BITS = {"fp32": (np.int32, 0x7FFFFFFF), "fp16": (np.int16, 0x7FFF)}
SPREAD = 1 << 22
NEIGHBOURS = 512
TRUTH_CHECK = 4096
TRUTH_TOLERANCE = 1e-3


class ExecutedError(ValueError):
    """A precision that is not one of PRECISIONS (one line)."""


def check_precision(precision: str) -> str:
    if precision not in PRECISIONS:
        raise ExecutedError(f"--precision {precision!r}: give one of {', '.join(PRECISIONS)}")
    return precision


def ordinals(values, precision: str) -> np.ndarray:
    """Each value of the format as its place in the ordered representable values (0 for 0 and -0;
    negative below), so that consecutive values differ by 1."""
    signed, magnitude = BITS[precision]
    bits = np.asarray(values, dtype=DTYPES[precision]).view(signed).astype(np.int64)
    return np.where(bits < 0, -(bits & magnitude), bits)


def from_ordinals(places, precision: str) -> np.ndarray:
    """The values of the format at places (`ordinals`' inverse; 0 gives +0)."""
    signed, magnitude = BITS[precision]
    places = np.asarray(places, dtype=np.int64)
    bits = np.where(places < 0, (-places) | (magnitude + 1), places)
    return bits.astype(np.uint32 if precision == "fp32" else np.uint16).view(DTYPES[precision])


def _inside(lo: float, hi: float, precision: str) -> tuple[int, int]:
    """The places of the smallest and largest values of the format in [lo, hi]."""
    dtype = DTYPES[precision]
    a, b = dtype(lo), dtype(hi)
    first, last = int(ordinals(a, precision)), int(ordinals(b, precision))
    if float(a) < lo:
        first += 1
    if float(b) > hi:
        last -= 1
    return first, last


def inputs(lo: float, hi: float, precision: str, extrema=()) -> np.ndarray:
    """The inputs of the module docstring, sorted, without repeats, in the format."""
    first, last = _inside(lo, hi, precision)
    if last < first:
        raise ExecutedError(f"no {precision} value lies in [{lo:g}, {hi:g}]")
    count = last - first + 1
    if precision == "fp16" or count <= SPREAD:
        return from_ordinals(np.arange(first, last + 1), precision)
    dtype = DTYPES[precision]
    by_value = np.clip(np.linspace(lo, hi, SPREAD // 4).astype(dtype), dtype(lo), dtype(hi))
    places = [np.round(np.linspace(first, last, SPREAD)).astype(np.int64), ordinals(by_value, precision)]
    for x in extrema:
        if x is not None and math.isfinite(x) and lo <= x <= hi:
            centre = int(ordinals(dtype(x), precision))
            places.append(np.arange(centre - NEIGHBOURS // 2, centre + NEIGHBOURS // 2))
    places = np.sort(np.clip(np.concatenate(places), first, last))
    # without repeats (np.unique hashes, which takes seconds on these millions of regular integers)
    return from_ordinals(places[np.r_[True, places[1:] != places[:-1]]], precision)


def truth(target, x: np.ndarray, unit: float, log=print) -> tuple[np.ndarray, dict]:
    """(the target's values at the inputs x, how they were computed and checked): `truth_function`
    checked on `TRUTH_CHECK` of the inputs, then applied to them all."""
    function, checked = truth_function(target, x, unit, log)
    return function(np.asarray(x, dtype=np.float64)), checked


def truth_function(target, x: np.ndarray, unit: float, log=print):
    """(a function of float64 inputs giving the target's values, how it computes them and how it was
    checked), chosen on `TRUTH_CHECK` of the inputs x spread evenly: float64, or where float64
    differs from mpmath (30 digits) there by more than `TRUTH_TOLERANCE` of the format's unit
    (relative, or of the target's range), numpy's long double (80-bit on x86) if it does not, else
    mpmath at every input. `float64_difference` (and `difference`, the chosen one's) is the largest
    difference found, in units of the range (abs) or relative: the truth's margin."""
    import mpmath
    import sympy as sp

    exact = np.asarray(x, dtype=np.float64)
    sample = exact[np.unique(np.linspace(0, exact.size - 1, min(TRUTH_CHECK, exact.size)).astype(int))]
    precise = sp.lambdify(target.symbol(), target.sympy(), "mpmath")
    long = sp.lambdify(target.symbol(), target.sympy(), "numpy")

    def by_mpmath(points):
        with mpmath.workdps(30):
            return np.array([float(precise(mpmath.mpf(float(p)))) for p in points])

    def by_long_double(points):
        with np.errstate(all="ignore"):
            values = np.asarray(long(np.asarray(points, dtype=np.longdouble)))
        return np.broadcast_to(values, np.shape(points)).astype(np.float64)

    reference = by_mpmath(sample)
    if target.metric == "rel":
        scale = np.maximum(np.abs(reference), target.floor)
    else:
        scale = np.full_like(reference, max(float(np.max(np.abs(reference))), 1e-300))

    def difference(values):
        with np.errstate(all="ignore"):
            d = np.abs(values - reference) / np.where(scale > 0, scale, 1.0)
        return float(np.max(np.where(np.isfinite(d), d, np.inf))) if d.size else 0.0

    float64 = difference(target.numpy()(sample))
    checked = dict(float64_difference=float64, computed_by="float64", checked=int(sample.size))
    if float64 <= TRUTH_TOLERANCE * unit:
        return target.numpy(), checked
    try:
        wider = difference(by_long_double(sample)) if np.finfo(np.longdouble).nmant > 52 else np.inf
    except Exception:               # (a function numpy does not compute in long double)
        wider = np.inf
    if wider <= TRUTH_TOLERANCE * unit:
        log(f"float64 computes {target.expression} with a relative error {float64:.3g} on the domain: the truth by "
            f"numpy's long double (its difference from mpmath {wider:.3g})")
        return by_long_double, checked | dict(computed_by="long double", difference=wider)
    log(f"float64 computes {target.expression} with a relative error {float64:.3g} on the domain: the truth at all "
        f"{exact.size} inputs by mpmath (30 digits)")
    return by_mpmath, checked | dict(computed_by="mpmath (30 digits)", difference=0.0)


def measure(bodies: dict[str, str], target, precision: str, extrema=(), log=print) -> dict:
    """Every form of `bodies` ({name: its GLSL expression in the target's variable}) executed (module
    docstring): dict(errors={name: {max_abs_error, max_rel_error, x_abs, x_rel} or None where it was
    not executed}, not_executed={name: why}, how=lavapipe's or the emulation's name, inputs=how many,
    truth=how it was checked)."""
    from ...isa import execution

    lo, hi = target.domain
    x = inputs(lo, hi, precision, extrema)
    floor = target.floor if target.metric == "rel" else 0.0
    values, checked = truth(target, x, UNIT[precision], log)
    why = execution.available()
    errors, not_executed = {}, {}
    if why is None:
        how = "lavapipe (Mesa's Vulkan driver on the CPU: llvmpipe)"
        done = execution.execute_forms(bodies, x, precision, target.variable, truth=values, floor=floor)
    else:
        how = f"the per-operation emulation in {precision} (lavapipe is not available: {why})"
        done = {name: execution.ExecutionError(f"{name}: not executed") for name in bodies}
        log(f"forms not executed on a driver: {why}; computed by the per-operation emulation in {precision}")
    for name, outcome in done.items():
        if isinstance(outcome, dict):
            errors[name] = outcome
            continue
        try:            # a form lavapipe did not execute (or no lavapipe): the emulation's numbers
            emulated = execution.emulate(bodies[name], x, precision, target.variable)
        except Exception as e:          # (a function the emulation does not know: acos)
            errors[name] = None
            not_executed[name] = f"{outcome}; not emulated: {str(e).splitlines()[0][:160]}"
            continue
        errors[name] = execution.errors(emulated, x, values, floor)
        if why is None:
            not_executed[name] = f"{outcome}; measured by the per-operation emulation"
    return dict(errors=errors, not_executed=not_executed, how=how, inputs=int(x.size), truth=checked,
                precision=precision)


GAP = 2.0           # an executed error above GAP times the float64 one (and the rounding floor) is a gap
SPECIAL = ("acos", "asin", "atan", "pow", "exp2", "log2", "exp", "log", "sin", "cos", "inversesqrt")


def gap_cause(expression, body: str, target, precision: str, executed_error: float, key: str) -> dict:
    """Why a form's executed error exceeds its float64 one, by a rule on numbers (`cause`):
    `constants` where its constants rounded to the format, computed in float64 (`constants_error`),
    already err more than executed_error / GAP; else `function` where it calls a special function
    (`SPECIAL`) and the per-operation emulation with numpy's functions in the format
    (`emulated_error`) errs less than executed_error / GAP, or cannot be computed (the driver's own
    lowering is the difference); else `arithmetic` (the format's rounding of each operation, a
    cancellation)."""
    import re

    from ...isa import execution
    from ..forms import in_format
    from .measure import max_error

    lo, hi = target.domain
    floor = target.floor if target.metric == "rel" else 0.0
    constants = max_error(numpy_function(in_format(expression, precision), target.symbol()), target.numpy(), lo, hi,
                          floor)[key]
    out = dict(constants_error=constants, emulated_error=None, functions=[])
    if constants > executed_error / GAP:
        return out | dict(cause="constants")
    functions = [f for f in SPECIAL if re.search(rf"\b{f}\(", body)]
    if functions:
        x = inputs(lo, hi, precision)
        try:
            emulated = execution.emulate(body, x, precision, target.variable)
        except Exception:           # (a function the emulation does not know: acos)
            return out | dict(cause="function", functions=functions)
        values, _ = truth(target, x, UNIT[precision], log=lambda s: None)
        error = execution.errors(emulated, x, values, floor)[key]
        out |= dict(emulated_error=error, functions=functions)
        if error < executed_error / GAP:
            return out | dict(cause="function")
    return out | dict(cause="arithmetic")
