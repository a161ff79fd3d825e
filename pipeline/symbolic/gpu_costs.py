"""Cycles per operation on each GPU architecture the `gpu_isa` stage compiles for
(`pipeline.isa.architectures`: AMD through RADV, NVIDIA through ptxas, Intel through ocloc,
Qualcomm and Arm through Mesa's freedreno and panfrost): the cost tables of
`pipeline regress --cost` for a search ranked by machine code.

A form's cost is what its architecture's compiler makes of it: a fragment shader returning the form
in t (the interpolated input; its constants written as numbers, as a shader specialized to one
material has them), its cycles by the back end's cost model (ACO's cycles per wave on AMD, the
throughput model per warp on NVIDIA, and so on: `isa.machine_code.models_text`), net of the shader returning t
(`isa.machine_code.form_cycles`, the one costing of every form). The table gives each operation a cost such that a form's
cost is about the sum of its operations' costs: fitted by non-negative least squares to the
compiled cycles of `CALIBRATION` forms drawn from every form of the grammar's ten operations
(`OPERATIONS`: what a lobe is made of) up to complexity 7 (random constants, a fixed seed), a
quarter of them held out, on which the prediction's error is measured and returned. Constants and
the variable cost 0. sin, cos, abs and inv are not in the tables: a search with them ranked by
cycles takes the user's table (`regress --cost`), and `regress --gpu` compiles its members anyway.

A sum of per-operation costs cannot see what the compiler does with a whole form (a multiply and
an add fused into one fma, independent operations issued while a transcendental is in flight), so
the tables predict and the compiled cycles of a form remain the measure.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from ..isa.machine_code import ALL, ARCHITECTURES, form_cycles, form_sources
from . import grammar

CALIBRATION = 400           # forms compiled to fit the tables (a quarter held out)
OPERATIONS = grammar.TEN    # the operations the tables cost
CALIBRATION_COMPLEXITY = 7
SEED = 0


MAX_CONSTANTS = 8


def _bodies(expressions: dict[str, str]) -> dict:
    """`form_cycles`' bodies of GLSL expressions in t (a per-material constant c[i] read as the push
    constant c<i>)."""
    return {name: ("return " + re.sub(r"\bc\[(\d+)\]", r"c\1", text) + ";", ["t"]) for name, text in expressions.items()}


def not_kept(expressions: dict[str, str], architectures=ALL) -> float:
    """The share of the shaders `expression_cycles` would compile that no run has kept (0 to 1), over
    the architectures (for the time a command announces)."""
    from ..isa.machine_code import _kept_file

    sources = form_sources(_bodies(expressions), ["t"])[0].values()
    chosen = [ARCHITECTURES[a] for a in architectures]
    missing = sum(not _kept_file(a.backend, a.chip, source).is_file() for a in chosen for source in sources)
    return missing / max(1, len(chosen) * len(sources))


def calibration_expressions(count: int = CALIBRATION, uniforms: bool = False) -> tuple[list, dict[str, str]]:
    """The forms `operation_costs` compiles (a fixed seed) and their GLSL."""
    forms = grammar.enumerate_forms(CALIBRATION_COMPLEXITY, OPERATIONS)
    rng = np.random.default_rng(SEED)
    chosen = [forms[i] for i in rng.choice(len(forms), min(count, len(forms)), replace=False)]
    glsl = {f"form{i:03d}": grammar.glsl(e, rng.uniform(0.5, 1.5, grammar.constants(e)), uniforms="c" if uniforms else "")
            for i, e in enumerate(chosen)}
    return chosen, glsl


def expression_cycles(expressions: dict[str, str], architectures=ALL) -> dict[str, dict[str, float]]:
    """{architecture: {name: cycles}} of each GLSL expression in t (its per-material constants c[i],
    if any, push constants), by the one costing of every form (`isa.machine_code.form_cycles`: a
    fragment shader returning it, net of the shader returning t), on each architecture whose
    compiler runs here. Raises CompilerMissing where none runs, and the error of a form a back end
    cannot lower (a table is fitted to every form or to none)."""
    cycles, missing, _ = form_cycles(_bodies(expressions), ["t"], architectures)
    failed = [name for name in expressions if name in missing]
    if failed:
        raise RuntimeError(f"{failed[0]}: {missing[failed[0]]}")
    return {a: by for a, by in cycles.items() if by}


def operation_counts(e) -> list[int]:
    """How many times e uses each operation of `OPERATIONS`, in that order (KeyError for another)."""
    counts = dict.fromkeys(OPERATIONS, 0)

    def walk(node):
        if len(node) > 1:
            counts[node[0]] += 1
            for a in node[1:]:
                walk(a)

    walk(e)
    return list(counts.values())


def operation_costs(count: int = CALIBRATION, architectures=ALL, uniforms: bool = False) -> dict:
    """{"tables": {architecture (rdna3, ..., sm_120): {operation: cycles}},
    "held_out": {architecture: {"forms", "mean_cycles", "mean_abs_error", "max_abs_error",
    "mean_abs_error_flat"}}}, the last being the error of one cost for every operation fitted
    alike (what the table must beat). With `uniforms` the forms' constants are per-material uniforms
    (a lobe whose parameters depend on n) instead of numbers. Raises CompilerMissing where no
    back end runs."""
    from scipy.optimize import nnls

    chosen, glsl = calibration_expressions(count, uniforms)
    measured = expression_cycles(glsl, architectures)
    A = np.array([operation_counts(e) for e in chosen], dtype=float)
    fit = slice(0, 3 * len(chosen) // 4)
    held = slice(3 * len(chosen) // 4, len(chosen))
    tables, held_out = {}, {}
    for architecture, cycles in measured.items():
        y = np.array([cycles[name] for name in glsl])
        weights, _ = nnls(A[fit], y[fit])
        flat = float(np.sum(A[fit].sum(axis=1) * y[fit]) / np.sum(A[fit].sum(axis=1) ** 2))
        error = A[held] @ weights - y[held]
        tables[architecture] = {op: round(float(w), 2) for op, w in zip(OPERATIONS, weights)}
        held_out[architecture] = dict(forms=int(y[held].size), mean_cycles=float(np.mean(y[held])),
                                      mean_abs_error=float(np.mean(np.abs(error))),
                                      max_abs_error=float(np.max(np.abs(error))),
                                      mean_abs_error_flat=float(np.mean(np.abs(A[held].sum(axis=1) * flat - y[held]))))
    return dict(tables=tables, held_out=held_out)


def write_tables(tables: dict[str, dict[str, float]], folder: Path) -> list[Path]:
    """One TOML file per architecture, `cost_<architecture>.toml`, in the form
    `grammar.read_cost_table` reads; returns their paths."""
    folder.mkdir(parents=True, exist_ok=True)
    paths = []
    for architecture, table in tables.items():
        lines = [f"# Cycles of each operation on {architecture} ({ARCHITECTURES[architecture].title}), fitted to the "
                 f"machine code of {CALIBRATION} forms", "# (pipeline.symbolic.gpu_costs)", "[cost]", "constant = 0",
                 "variable = 0"]
        lines += [f'"{op}" = {cycles:g}' for op, cycles in table.items()]
        path = folder / f"cost_{architecture}.toml"
        path.write_text("\n".join(lines) + "\n")
        paths.append(path)
    return paths
