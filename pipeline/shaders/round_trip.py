"""A reading checked against the function as it executes: on lavapipe, in float32, at `INPUTS` or
more inputs of the domain (a grid of each argument's range), both shaders optimized by `spirv-opt -O`
as the reading was (which turns c / 12.92 into c * (1 / 12.92), a different float32), the user's
function (the file's preprocessed text included unchanged, its `main` renamed) and the reading's
transliteration
(`spirv_reader.read_both`: the optimized shader's operations, one statement each) must agree to the
last bit; the reading's sympy expression, evaluated in float64 at the same float32 inputs, must then
agree with them to float32's rounding (`RTOL` of the value, `ATOL` of the largest |value|). A
mismatch is one line naming the function and the first input where it differs. An HLSL function
runs in an HLSL compute harness (glslang's HLSL front end), its transliteration in GLSL's.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from .definitions import Definition

INPUTS = 1 << 16            # at least this many inputs per function
RTOL = 1e-5                 # float64 against float32: the float32 rounding of a few operations
ATOL = 1e-6                 # ... of the largest |value| (a value near 0 after cancellation)
RENAMED_MAIN = "main_of_the_shader_file"


@dataclasses.dataclass(frozen=True)
class RoundTrip:
    """The check's outcome: `how` it ran (lavapipe, or why it did not), the inputs, the bits the
    transliteration differs by at most (`ulps`), the sympy reading's largest scaled difference
    (`drift`: 1 at the tolerance), and `mismatch`, the one line of a failure (None where it held)."""

    how: str
    inputs: int
    ulps: int | None = None
    drift: float | None = None
    mismatch: str | None = None

    @property
    def checked(self) -> bool:
        return self.how == "lavapipe"


def grid(ranges: list[tuple[float, float]], count: int = INPUTS) -> list[np.ndarray]:
    """float32 inputs of the box: per argument ceil(count^(1/d)) evenly spaced values of its range
    (both ends among them), every combination."""
    per = math.ceil(count ** (1 / len(ranges)) - 1e-9)
    while per ** len(ranges) < count:
        per += 1
    axes = [np.linspace(lo, hi, per).astype(np.float32) for lo, hi in ranges]
    return [g.ravel() for g in np.meshgrid(*axes, indexing="ij")]


def prelude(text: str, language: str = "glsl") -> str:
    """The file's preprocessed text as the execution harness's declarations: its `#extension` lines
    first (GLSL), its `#version` and `#line` lines left out, its `main` renamed."""
    lines = text.splitlines()
    extensions = [line for line in lines if line.startswith("#extension") and "include_directive" not in line
                  and language == "glsl"]
    body = [line for line in lines if not line.startswith(("#version", "#extension", "#line"))]
    return "\n".join(extensions + [f"#define main {RENAMED_MAIN}"] + body + ["#undef main"])


def round_trip(text: str, definition: Definition, expression, transliteration: str,
               ranges: list[tuple[float, float]], language: str = "glsl") -> RoundTrip:
    """The module docstring's check of one function read from the file's preprocessed `text` (a
    function of vectors on broadcast arguments, its first lane: `harness.function_call`)."""
    from .harness import function_call, width

    import sympy as sp

    from ..isa import execution

    points = grid(ranges)
    count = points[0].size
    why = execution.available()
    if why is not None:
        return RoundTrip(f"not executed: {why}", count)
    names = [f"a{i}" for i in range(len(points))]
    arguments = ", ".join(f"float {n}" for n in names)
    reading = f"float the_reading({arguments})\n{{\n{transliteration}\n}}\n"
    inputs = dict(zip(names, points))
    call = ", ".join(names)
    lane = width(definition.return_type) > 1
    function = ((prelude(text) + "\n" + reading, function_call(definition, "glsl", lane)) if language == "glsl" else
                (prelude(text, "hlsl"), function_call(definition, "hlsl", lane), "hlsl"))
    outcome = execution.execute_forms({"function": function, "reading": (reading, f"the_reading({call})")}, inputs,
                                      optimized=True)
    for name, values in outcome.items():
        if isinstance(values, Exception):
            return RoundTrip(f"not executed: {values}", count, mismatch=f"{definition.name}: {values}")
    function, reading = (np.asarray(outcome[k], dtype=np.float32) for k in ("function", "reading"))
    same = (function.view(np.uint32) == reading.view(np.uint32)) | (np.isnan(function) & np.isnan(reading))
    ulps = int(np.max(np.abs(function.view(np.int32).astype(np.int64) - reading.view(np.int32).astype(np.int64))
                      * ~same)) if not same.all() else 0
    if not same.all():
        i = int(np.flatnonzero(~same)[0])
        at = ", ".join(f"{p.name} = {float(x[i]):.9g}" for p, x in zip(definition.parameters, points))
        return RoundTrip("lavapipe", count, ulps, mismatch=(
            f"{definition.name}: its reading computes {float(reading[i]):.9g} where the function computes "
            f"{float(function[i]):.9g} ({at}): the reader misread it"))
    symbols = [sp.Symbol(p.name, real=True) for p in definition.parameters]
    with np.errstate(all="ignore"):
        exact = np.broadcast_to(np.asarray(sp.lambdify(symbols, expression, "numpy")(
            *(x.astype(np.float64) for x in points)), dtype=np.float64), function.shape)
    finite = np.isfinite(function)
    scale = float(np.max(np.abs(function[finite]))) if finite.any() else 1.0
    allowed = RTOL * np.abs(function.astype(np.float64)) + ATOL * scale
    with np.errstate(all="ignore"):
        drift_all = np.where(finite, np.abs(exact - function) / allowed, 0.0)
    drift_all = np.where(finite & ~np.isfinite(exact), np.inf, drift_all)
    drift = float(np.max(drift_all))
    if drift > 1:
        i = int(np.argmax(drift_all))
        at = ", ".join(f"{p.name} = {float(x[i]):.9g}" for p, x in zip(definition.parameters, points))
        return RoundTrip("lavapipe", count, 0, drift, mismatch=(
            f"{definition.name}: its expression gives {float(exact[i]):.9g} where the function computes "
            f"{float(function[i]):.9g} ({at}): the expression misreads it"))
    return RoundTrip("lavapipe", count, 0, drift)
