"""The error of a target of several variables (`engines.several_variables`) as its forms' shaders execute:
each form's GLSL (the text that is costed) run by lavapipe (`isa.execution`) in float32 or float16,
one invocation per point, reading the variables and the parameter as inputs, against the target in
float64 at the same points (the inputs rounded to the format first, as a shader receives them).

The points are the caller's (`engines.several_variables.execution_points`: the box's measuring grid and where each
form's float64 error peaks). A material member's constants c0, c1, ... are what the CPU computes
once per material: its formulas (as `derive_twin.py` prints them) in float64 at each point's
parameter, rounded to the format (float32 push constants, converted to float16 where the form
computes in float16). Where lavapipe cannot run, the per-operation
emulation in float32 (`execution.emulate`) measures instead.
"""

from __future__ import annotations

import math

import numpy as np


def measure(bodies: dict, names, columns, exact, floor: float = 0.0, precision: str = "fp32") -> dict:
    """Every form of `bodies` ({name: (its GLSL expression in `names` and c0, c1, ..., the constants'
    formulas as text in the last name (the parameter), or None)}) executed in `precision` (float32, or
    float16: its inputs and constants float16 too) at the points
    `columns` (one array per name), against `exact` (a numpy function of those arrays, float64):
    dict(errors={name: {max_abs_error, max_rel_error, x_abs, x_rel} or None}, not_executed={name:
    why}, how, inputs); the relative error's divisor max(|f|, floor)."""
    import sympy as sp

    from ...isa import execution
    from ..targets import parse

    names = list(names)
    dtype = np.float16 if precision == "fp16" else np.float32
    columns = [np.asarray(c, dtype=dtype) for c in columns]
    wide = [c.astype(np.float64) for c in columns]
    with np.errstate(all="ignore"):
        truth = np.broadcast_to(np.asarray(exact(*wide), dtype=np.float64), wide[0].shape)
    shared = dict(zip(names, columns))
    sets, pixel = [], {}
    for name, (body, constants) in bodies.items():
        if not constants:
            pixel[name] = body
            continue
        inputs = dict(shared)
        with np.errstate(all="ignore"):
            for i, text in enumerate(constants):
                f = sp.lambdify([sp.Symbol(names[-1], real=True)], parse(text, (names[-1],)), "numpy")
                inputs[f"c{i}"] = np.broadcast_to(np.asarray(f(wide[-1]), dtype=np.float64), wide[0].shape)
        sets.append(({name: body}, inputs, truth, floor))
    if pixel:
        sets.insert(0, (pixel, shared, truth, floor))
    why = execution.available()
    how = ("lavapipe (Mesa's Vulkan driver on the CPU: llvmpipe)" if why is None else
           f"the per-operation emulation in {precision} (lavapipe is not available: {why})")
    errors, not_executed = {}, {}
    for (forms, inputs, _, _), results in zip(sets, execution.execute_sets(sets, precision) if sets else []):
        for name, outcome in results.items():
            if isinstance(outcome, dict):
                errors[name] = outcome
                continue
            try:
                emulated = execution.emulate(forms[name], inputs, precision)
            except Exception as e:      # (a function the emulation does not know)
                errors[name] = None
                not_executed[name] = f"{outcome}; not emulated: {str(e).splitlines()[0][:160]}"
                continue
            errors[name] = execution.errors(emulated, wide[0], truth, floor)
            if why is None:
                not_executed[name] = f"{outcome}; measured by the per-operation emulation"
    return dict(errors=errors, not_executed=not_executed, how=how, inputs=int(wide[0].size))


def nan_errors() -> dict:
    return dict(max_abs_error=math.nan, max_rel_error=math.nan, x_abs=math.nan, x_rel=math.nan)
