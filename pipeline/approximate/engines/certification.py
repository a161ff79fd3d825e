"""`derive --certify`: the fronts read off errors proven over the whole domain. A form's sampled error
is at most its true one, so a form that certified members dominate at its sampled error is dominated
at its true one too: `until_certified` certifies the fronts' members, the anchors and the exact
target, reads the fronts off again, and certifies the members that joined them, until none is left.
How a form is certified is the engine's: every input in one variable (`measures.exhaustive`), interval
branch and bound in several (`box_certified`, `measures.certified_box`), each box bound spread over
one process per core.
"""

from __future__ import annotations

import concurrent.futures
import math
import multiprocessing
import os


def until_certified(needed, errors: dict, error_key: str, certify_names, log=print) -> dict:
    """`certify_names(names)` ({name: (its errors, or None and why not)}) for the names `needed(errors)`
    gives that are not yet certified or refused, each certified form's errors replacing its sampled
    ones in `errors`, until none is left. Returns dict(certified=[names], not_certified={name: why},
    passes)."""
    out = dict(certified=[], not_certified={}, passes=0)
    while True:
        names = sorted(n for n in needed(errors) if n not in out["certified"] and n not in out["not_certified"])
        if not names:
            return out
        for name in [n for n in names if not math.isfinite(errors[n][error_key])]:
            out["not_certified"][name] = "not executed (its sampled error is not finite)"
        names = [n for n in names if n not in out["not_certified"]]
        if not names:
            continue
        done = certify_names(names)
        for name in names:
            found, why = done[name]
            if found is None:
                out["not_certified"][name] = why
            else:
                errors[name] = dict(errors[name]) | found
                out["certified"].append(name)
        out["passes"] += 1
        log(f"certified {sum(done[n][0] is not None for n in names)} of {len(names)} forms (pass {out['passes']})")


def _one(arguments: tuple):
    from ..measures import certified_box

    name, rounding, body, inputs, expression, symbols, domain, precision, metric, floor, found, ratio, same = arguments
    chosen = certified_box.LAVAPIPE if rounding == "lavapipe" else certified_box.vulkan(precision) \
        if rounding == "vulkan" else certified_box.vendor(rounding, precision)
    return name, rounding, certified_box.certify(body, inputs, expression, symbols, domain, precision, chosen, metric,
                                                 floor, found=found, ratio=ratio, same=same)


def box_bounds(jobs: list[tuple], processes: int | None = None) -> dict:
    """{(name, rounding): Certified} of every job (name, rounding: lavapipe, vulkan or a vendor, the
    form's GLSL body, its inputs, the target's sympy expression and symbols, the domain, precision,
    metric, floor, the largest error sampled, the ratio that proves, whether the form is the target's
    own expression) on one process per core."""
    processes = min(processes or os.cpu_count() or 1, len(jobs))
    if processes <= 1:
        return {(n, r): c for n, r, c in map(_one, jobs)}
    context = multiprocessing.get_context("spawn")      # (the parent holds XLA's threads)
    with concurrent.futures.ProcessPoolExecutor(processes, mp_context=context) as pool:
        return {(n, r): c for n, r, c in pool.map(_one, jobs)}
