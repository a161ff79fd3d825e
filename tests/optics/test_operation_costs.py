"""Cycles per operation from RADV's machine code: the cost tables of `pipeline regress --cost`."""

import pytest

from pipeline.optics import machine_code, operation_costs
from pipeline.symbolic import grammar


@pytest.fixture(scope="module")
def costs():
    try:
        return operation_costs.operation_costs()
    except (machine_code.CompilerMissing, machine_code.spirv.ToolMissing) as e:
        pytest.skip(f"machine-code cost not measured here: {e}")


def test_every_operation_has_a_cost_on_every_architecture_and_the_tables_read_back(costs, tmp_path):
    """One table per architecture, every operation of the grammar in it, written as TOML that
    `grammar.read_cost_table` reads back to the same numbers."""
    assert set(costs) == {"rdna3", "rdna2", "gcn5"}
    for path in operation_costs.write_tables(costs, tmp_path):
        table = grammar.read_cost_table(path, grammar.OPERATIONS)
        architecture = path.stem.removeprefix("cost_")
        assert {op: table[op] for op in grammar.OPERATIONS} == costs[architecture]
        assert table["constant"] == table["variable"] == 0


def test_the_costs_follow_the_hardware(costs):
    """What AMD's ISA documents say independently of ACO's estimates: +, - and * issue at full rate
    and cost alike (square is one multiply; cube two dependent ones, 2x an add plus at most one
    cycle of stall per step in ACO's estimate of the chain); exp, log and sqrt run on the
    quarter-rate transcendental unit, at least 3x an add; a division is a reciprocal (transcendental)
    and a multiply; pow is log, multiply and exp, so more than either; GCN5 (wave64 on 16-lane
    SIMDs) costs more per wave than RDNA for every operation."""
    for architecture, table in costs.items():
        add = table["+"]
        assert add > 0 and table["-"] == table["*"] == table["square"] == add, architecture
        assert 2 * add <= table["cube"] <= 2 * add + 1, architecture
        for op in ("exp", "log", "sqrt", "/"):
            assert table[op] >= 3 * add, (architecture, op)
        assert table["pow"] > max(table["exp"], table["log"]), architecture
    for op in grammar.OPERATIONS:
        assert costs["gcn5"][op] > costs["rdna3"][op], op


def test_the_costs_command_prints_and_writes_the_tables(costs, tmp_path):
    """`pipeline costs --out DIR`: the table printed, one TOML per architecture written, the
    numbers those of `operation_costs` (the compiler is deterministic)."""
    import subprocess
    import sys

    from ..helpers import cli_env

    run = subprocess.run([sys.executable, "-m", "pipeline", "costs", "--out", str(tmp_path / "c")], capture_output=True,
                         text=True, env=cli_env(tmp_path))
    assert run.returncode == 0, run.stderr
    assert sorted(p.name for p in (tmp_path / "c").iterdir()) == ["cost_gcn5.toml", "cost_rdna2.toml", "cost_rdna3.toml"]
    assert grammar.read_cost_table(tmp_path / "c" / "cost_gcn5.toml", grammar.OPERATIONS)["exp"] == costs["gcn5"]["exp"]
    assert run.stdout.splitlines()[1].split()[0] == "rdna3"
