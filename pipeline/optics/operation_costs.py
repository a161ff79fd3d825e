"""Cycles per operation on each GPU architecture the `gpu_isa` stage compiles for (RDNA3, RDNA2,
GCN5): the cost tables of `pipeline regress --cost` for a search ranked by machine code.

Each operation of the symbolic grammar is compiled by RADV (`machine_code.compile_shaders`) in a
fragment shader that applies it REPEATS times in a chain, each step reading the last (a = a + k,
a = k / a, a = exp(a), a = pow(a, k), ...), to the interpolated t, with k a per-material push
constant (so nothing folds and a uniform operand stays uniform, as a lobe's parameters do); its
cost is ACO's throughput estimate (cycles per wave) net of the same shader with no step, divided by
REPEATS. Constants and the variable cost 0 (push constants and an interpolated input, both
already paid by the wrapper).

The tables are predictions: the compiler fuses a multiply and an add into one fma, shares
subexpressions and schedules around latency, so a form's compiled cycles differ from the sum of
its operations' costs (a chain of one operation is its throughput, not its latency).
"""

from __future__ import annotations

from pathlib import Path

from .machine_code import FAMILIES, UNIFORM, compile_shaders

REPEATS = 8
# One step of each operation's chain (a: the running value; k: a per-material constant). A chain
# of pow alone would fold (pow(pow(a, k), k) is exp2(k k log2 a): NIR removes log2(exp2(x))), so
# each pow step adds k, whose cost ("+") is subtracted.
STEPS = {"+": "a = a + k;", "-": "a = k - a;", "*": "a = a * k;", "/": "a = k / a;", "exp": "a = exp(a);",
         "log": "a = log(a);", "sqrt": "a = sqrt(a);", "square": "a = a * a;", "cube": "a = a * a * a;",
         "pow": "a = pow(a, k) + k;"}
SUBTRACT = {"pow": "+"}


def chain_shader(step: str, repeats: int) -> str:
    """The fragment shader applying `step` `repeats` times to t."""
    return UNIFORM.format(body="float a = t;\n    " + "\n    ".join([step] * repeats) + "\n    return a;")


def operation_costs(families=tuple(FAMILIES)) -> dict[str, dict[str, float]]:
    """{architecture ("rdna3", "rdna2", "gcn5"): {operation: cycles per wave}}, from RADV's machine
    code (module docstring). Raises machine_code.CompilerMissing where RADV cannot run here."""
    sources = {"chain_none": chain_shader("", 0)}
    sources.update({f"chain_{i:02d}": chain_shader(step, REPEATS) for i, step in enumerate(STEPS.values())})
    compiled, _ = compile_shaders(sources, families)
    out = {}
    for family, shaders in compiled.items():
        base = shaders["chain_none"]["cycles_per_wave"]
        table = {op: (shaders[f"chain_{i:02d}"]["cycles_per_wave"] - base) / REPEATS for i, op in enumerate(STEPS)}
        out[FAMILIES[family].lower()] = {op: round(cycles - (table[SUBTRACT[op]] if op in SUBTRACT else 0.0), 2)
                                         for op, cycles in table.items()}
    return out


def write_tables(costs: dict[str, dict[str, float]], folder: Path) -> list[Path]:
    """One TOML file per architecture, `cost_<architecture>.toml`, in the form
    `grammar.read_cost_table` reads; returns their paths."""
    folder.mkdir(parents=True, exist_ok=True)
    paths = []
    for architecture, table in costs.items():
        lines = [f"# Cycles per wave of each operation on {architecture.upper()}, from RADV's machine code",
                 f"# (ACO's throughput estimate of a chain of {REPEATS}, net of the empty shader; pipeline.optics.operation_costs)",
                 "[cost]", "constant = 0", "variable = 0"]
        lines += [f'"{op}" = {cycles:g}' for op, cycles in table.items()]
        path = folder / f"cost_{architecture}.toml"
        path.write_text("\n".join(lines) + "\n")
        paths.append(path)
    return paths
