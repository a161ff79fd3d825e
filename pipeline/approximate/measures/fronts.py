"""The front and the verdict, shared by `pipeline derive`'s engines (`engines`: one variable, several,
a pair) and the lobe search: the best constant's error (what a form must beat), the format's
rounding (errors below it are equal), the forms no cheaper form beats, and an anchor's place.
"""

from __future__ import annotations

import math

import numpy as np

from . import measure

MATCH = 0.01                    # an error within 1 % of an anchor's matches it
TIE = 1e-6                      # errors within this (relative) are equal on a front


def constant_error(target, f) -> float:
    """The error of the best constant (minimax, on the measuring grid): a form worth a cycle beats it.
    abs: (max f - min f) / 2; rel (f of one sign): (max |f| - min |f|) / (max |f| + min |f|), the
    floor raising min |f|."""
    return measure.best_constant_error(f(measure.grid(*target.domain)), target.metric, target.floor)


def rounding_floor(target, constant: float, precision: str = "fp32") -> float:
    """The error below which two forms are equal in a shader (the format's rounding): its unit
    (`executed.UNIT`: float32 2^-23, float16 2^-10) of the target's range (abs; the range is twice the
    best constant's error), or the unit itself (rel)."""
    from .executed import UNIT

    return UNIT[precision] * (2 * constant if target.metric == "abs" else 1.0)


def front(rows: list[dict], error: str, floor: float = 0.0) -> list[dict]:
    """The rows no other beats at equal or fewer cycles: sorted by cycles, each with an error below
    every cheaper row's by more than TIE (relative); errors below `floor` count as `floor` (float32
    rounding: a form exact to 1e-15 and the exact one are equal). Rows of equal cycles and errors
    equal to 6 significant digits are a tie, kept by the row listed first (the same function written
    twice differs in its last bits). The fronts of `pipeline derive` and of the lobe search."""
    ordered = sorted((r for r in rows if np.isfinite(r[error]) and r["cycles"] is not None),
                     key=lambda r: (r["cycles"], float(f"{max(r[error], floor):.6g}")))
    out, best = [], math.inf
    for r in ordered:
        if max(r[error], floor) < best * (1.0 - TIE):
            out.append(r)
            best = max(r[error], floor)
    return out


def verdict(anchor_cycles: float, anchor_error: float, found: list[dict], error: str, floor: float = 0.0) -> dict:
    """How the found front places an anchor: the most accurate found form at no more cycles, and
    `beaten` (its error below the anchor's by more than MATCH), `matched` (within MATCH) or
    `missed` (none as accurate at no more cycles; `ratio` says by how much), `by` that form and
    `by_cycles` its cycles; errors below `floor` count as `floor`."""
    cheaper = [r for r in found if r["cycles"] <= anchor_cycles and np.isfinite(r[error])]
    if not cheaper:
        return dict(verdict="missed", ratio=math.inf, by=None, by_cycles=None)
    best = min(cheaper, key=lambda r: r[error])
    ratio = max(best[error], floor) / max(anchor_error, floor) if max(anchor_error, floor) > 0 else 1.0
    word = "beaten" if ratio < 1 - MATCH else "matched" if ratio <= 1 + MATCH else "missed"
    return dict(verdict=word, ratio=float(ratio), by=best["name"], by_cycles=best["cycles"])
