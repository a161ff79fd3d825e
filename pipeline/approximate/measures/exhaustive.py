"""Every input of a one-variable domain (`derive --certify`): each form executed at every value of the
run's format (float32 or float16) in the domain, so that its largest error as executed is the true
maximum over the domain, not a sample's ([0, 1] holds 1,065,353,217 float32 values, 15,361 float16).

How each form is executed:
- a form whose operations numpy rounds as lavapipe does (+ - * /, sqrt, min, max, clamp, abs,
  comparisons and selections: `execution.EXACT_FUNCTIONS`) by the per-operation emulation
  (`execution.emulation_program`, `lowering.evaluate`), bit for bit what lavapipe computes;
- a form that calls a driver's own function (acos, pow, exp2, inversesqrt, a fused multiply-add) on
  lavapipe itself (`execution.execute_sets`); where lavapipe is not available it is not certified,
  and its entry says why.

The inputs go in tasks of `TASK` consecutive values (each task's arrays in `PIECE`s, so memory stays
flat), spread over one process per core. The truth at each input is the target in float64, or in
long double or mpmath where float64 loses digits on the domain (`executed.truth_function`, chosen
once for the whole domain on an even sample); `truth` records how, and the largest difference from
mpmath (30 digits) found on that sample: the margin within which each maximum is the true one.
"""

from __future__ import annotations

import concurrent.futures
import multiprocessing
import os

import numpy as np

from . import executed

TASK = 1 << 24          # inputs per task (a process's unit of work; one lavapipe run)
PIECE = 1 << 22         # inputs per array of the emulation within a task


def count(lo: float, hi: float, precision: str) -> int:
    """How many values of the format lie in [lo, hi]."""
    first, last = executed._inside(lo, hi, precision)
    return max(0, last - first + 1)


def _merge(a: dict | None, b: dict) -> dict:
    """The larger of two tasks' errors per kind (`execution.errors`' keys), the earlier input on a tie
    (tasks are merged in input order)."""
    if a is None:
        return dict(b)
    out = dict(a)
    for key, where in (("max_abs_error", "x_abs"), ("max_rel_error", "x_rel")):
        if b[key] > a[key]:
            out[key], out[where] = b[key], b[where]
    return out


def _task(target, programs: dict, lavapipe: dict, first: int, last: int, precision: str, floor: float,
          truth_by: str) -> dict:
    """{name: `execution.errors`} of every form over the format's values at places first..last: the
    emulated ones (`programs`, {name: (ops, result)}) piece by piece, the others (`lavapipe`, {name:
    GLSL body}) in one lavapipe run; a form lavapipe did not execute, its ExecutionError's text."""
    from ...isa import execution, lowering

    dtype = executed.DTYPES[precision]
    function = _truth(target, truth_by)
    out: dict = {}
    for start in range(first, last + 1, PIECE):
        x = _values(start, min(start + PIECE, last + 1), precision)
        f = function(x.astype(np.float64))
        denominator = np.maximum(np.abs(f), floor)
        for name, (ops, result) in programs.items():
            values = np.asarray(lowering.evaluate(ops, result, {target.variable: x}, {}, dtype), dtype=dtype)
            values = np.broadcast_to(values, x.shape)
            out[name] = _merge(out.get(name), execution.errors(values, x, f, floor, denominator))
    if lavapipe:
        x = _values(first, last + 1, precision)
        (done,) = execution.execute_sets([(lavapipe, x, function(x.astype(np.float64)), floor)], precision,
                                         target.variable)
        for name, outcome in done.items():
            out[name] = outcome if isinstance(outcome, dict) else str(outcome)
    return out


def _values(start: int, stop: int, precision: str) -> np.ndarray:
    """The format's values at places start..stop-1 (`executed.from_ordinals`; where none is negative,
    each value's bits are its place: a view of the integers)."""
    if start >= 0:
        integers = np.arange(start, stop, dtype=np.uint32 if precision == "fp32" else np.uint16)
        return integers.view(executed.DTYPES[precision])
    return executed.from_ordinals(np.arange(start, stop), precision)


def _truth(target, truth_by: str):
    """The truth function `executed.truth_function` chose (its `computed_by`), rebuilt in a worker."""
    if truth_by == "float64":
        return target.numpy()
    import mpmath
    import sympy as sp

    if truth_by == "long double":
        long = sp.lambdify(target.symbol(), target.sympy(), "numpy")

        def by_long_double(points):
            with np.errstate(all="ignore"):
                values = np.asarray(long(np.asarray(points, dtype=np.longdouble)))
            return np.broadcast_to(values, np.shape(points)).astype(np.float64)
        return by_long_double
    precise = sp.lambdify(target.symbol(), target.sympy(), "mpmath")

    def by_mpmath(points):
        with mpmath.workdps(30):
            return np.array([float(precise(mpmath.mpf(float(p)))) for p in points])
    return by_mpmath


def certify(bodies: dict[str, str], target, precision: str, log=print, processes: int | None = None) -> dict:
    """Every form of `bodies` ({name: its GLSL expression in the target's variable}) executed at every
    value of the format in the target's domain (module docstring): dict(errors={name: {max_abs_error,
    max_rel_error, x_abs, x_rel} over them all}, not_certified={name: why}, how={name: "emulation" or
    "lavapipe"}, inputs=how many, truth=how it was computed and checked, seconds)."""
    import time

    from ...isa import execution

    started = time.perf_counter()
    lo, hi = target.domain
    first, last = executed._inside(lo, hi, precision)
    inputs = last - first + 1
    floor = target.floor if target.metric == "rel" else 0.0
    sample = executed.inputs(lo, hi, precision) if inputs > executed.TRUTH_CHECK else \
        executed.from_ordinals(np.arange(first, last + 1), precision)
    _, checked = executed.truth_function(target, sample, executed.UNIT[precision], log)
    programs, lavapipe, how, not_certified = {}, {}, {}, {}
    why_not = execution.available()
    for name, body in bodies.items():
        try:
            ops, result = execution.emulation_program(body, precision, [target.variable])
        except Exception as e:          # (an operation the lowering does not know: lavapipe's alone)
            blocking = f"not emulated ({str(e).splitlines()[0][:120]})"
        else:
            blocking = execution.not_exactly_emulated(ops)
            blocking = blocking and f"uses {blocking}, which only a driver computes"
        if blocking is None:
            programs[name], how[name] = (ops, result), "emulation"
        elif why_not is None:
            lavapipe[name], how[name] = body, "lavapipe"
        else:
            not_certified[name] = f"{blocking}, and lavapipe is not available: {why_not}"
    tasks = [(a, min(a + TASK - 1, last)) for a in range(first, last + 1, TASK)]
    processes = min(processes or os.cpu_count() or 1, len(tasks))
    log(f"certifying {len(programs) + len(lavapipe)} forms at every one of {inputs:,} {precision} inputs "
        f"({len(programs)} by the emulation, {len(lavapipe)} on lavapipe) in {len(tasks)} tasks on {processes} "
        "processes")
    errors: dict = {}
    arguments = (target, programs, lavapipe)
    if processes == 1:
        results = (_task(*arguments, a, b, precision, floor, checked["computed_by"]) for a, b in tasks)
        for found in results:
            errors = _fold(errors, found)
    else:
        # (spawned: the parent holds XLA's threads, which a fork would copy half-made)
        context = multiprocessing.get_context("spawn")
        with concurrent.futures.ProcessPoolExecutor(processes, mp_context=context) as pool:
            futures = [pool.submit(_task, *arguments, a, b, precision, floor, checked["computed_by"]) for a, b in tasks]
            for done, future in enumerate(futures, 1):
                errors = _fold(errors, future.result())
                if done % max(1, len(tasks) // 8) == 0 or done == len(tasks):
                    log(f"  certified {done}/{len(tasks)} tasks ({time.perf_counter() - started:.0f} s)")
    out = {}
    for name in bodies:
        found = errors.get(name)
        if isinstance(found, str):
            not_certified[name] = found
        elif found is not None:
            out[name] = found
    return dict(errors=out, not_certified=not_certified, how={n: h for n, h in how.items() if n in out},
                inputs=int(inputs), truth=checked, precision=precision,
                seconds=round(time.perf_counter() - started, 1))


def _fold(errors: dict, found: dict) -> dict:
    """Each form's errors so far merged with a task's (`_merge`); a task's failure (text) stays."""
    for name, e in found.items():
        if isinstance(errors.get(name), str):
            continue
        errors[name] = e if isinstance(e, str) else _merge(errors.get(name), e)
    return errors
