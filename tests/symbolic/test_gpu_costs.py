"""Cycles per operation fitted to each architecture's machine code (AMD by RADV, NVIDIA by ptxas): the
cost tables of `pipeline regress --cost`."""

import subprocess
import sys

import numpy as np
import pytest

from pipeline.isa import machine_code
from pipeline.optics.spirv import ToolMissing
from pipeline.symbolic import gpu_costs, grammar

from ..helpers import cli_env

FORMS = 120     # (the command's 400 take 25 s; the properties below hold on fewer)


@pytest.fixture(scope="module")
def costs():
    try:
        return gpu_costs.operation_costs(FORMS)
    except (machine_code.CompilerMissing, ToolMissing) as e:
        pytest.skip(f"machine-code cost not measured here: {e}")


def test_the_tables_predict_forms_they_were_not_fitted_to(costs):
    """On the held-out quarter of the forms (compiled, never fitted), the table's prediction (the
    sum of its operations' costs) misses by less than a quarter of the mean cycles on average, and
    by less than a table with one cost for every operation (fitted alike): the operations do differ."""
    for architecture, held in costs["held_out"].items():
        assert held["forms"] == FORMS // 4
        assert held["mean_abs_error"] < 0.25 * held["mean_cycles"], (architecture, held)
        assert held["mean_abs_error"] < 0.8 * held["mean_abs_error_flat"], (architecture, held)


def test_the_costs_follow_the_hardware(costs):
    """What AMD's ISA guides say independently of the fit, and holds on every vendor: exp and log run
    on a slower transcendental unit, so each costs at least twice a multiply; pow is a log, a
    multiply and an exp, so more than either (but on Bifrost, where a natural log is a log2 and a
    multiply by ln 2 on the FMA unit and pow's multiply folds into the exp's FMA_RSCALE: both need
    four tuples, `tests/isa/test_mali.py` reads the listings); a transcendental costs more per
    wave on GCN5 (wave64 on 16-lane SIMDs) than on RDNA."""
    for architecture, table in costs["tables"].items():
        for op in ("exp", "log"):
            assert table[op] >= 2 * table["*"], (architecture, op)
        if architecture != "g72":
            assert table["pow"] > max(table["exp"], table["log"]), architecture
    for op in ("exp", "log", "pow", "/"):
        assert costs["tables"]["gcn5"][op] > costs["tables"]["rdna3"][op], op


def test_the_costs_command_writes_tables_regress_reads(costs, tmp_path):
    """`pipeline costs --forms 20 --out DIR`: one TOML per architecture, read back by
    `grammar.read_cost_table` with every operation; --forms out of range exits 2."""
    out = tmp_path / "c"
    run = subprocess.run([sys.executable, "-m", "pipeline", "costs", "--forms", "20", "--out", str(out)],
                         capture_output=True, text=True, env=cli_env(tmp_path))
    assert run.returncode == 0, run.stderr
    assert sorted(p.name for p in out.iterdir()) == sorted(f"cost_{a}.toml" for a in costs["tables"])
    for path in out.iterdir():
        table = grammar.read_cost_table(path, gpu_costs.OPERATIONS)
        assert all(np.isfinite(table[op]) and table[op] >= 0 for op in gpu_costs.OPERATIONS)
    bad = subprocess.run([sys.executable, "-m", "pipeline", "costs", "--forms", "5"], capture_output=True, text=True,
                         env=cli_env(tmp_path))
    assert bad.returncode == 2 and "--forms 5: give an integer in [20, 2000]" in bad.stderr
    unknown = subprocess.run([sys.executable, "-m", "pipeline", "costs", "--gpu", "rdna3,navi31"], capture_output=True,
                             text=True, env=cli_env(tmp_path))
    assert unknown.returncode == 2 and "unknown GPU architecture 'navi31'" in unknown.stderr


def test_regress_compiles_every_front_member_for_the_gpu_asked(costs, tmp_path):
    """`regress --gpu rdna3`: every front member's compiled cycles in front.csv, equal to compiling
    its expression alone (`expression_cycles`, the compiler being deterministic), the constant
    member 0. An unknown GPU, or two variables, are refused by name."""
    import csv

    from pipeline.symbolic.regress import RegressError, regress

    x = np.linspace(0.0, 3.0, 40)
    data = tmp_path / "d.csv"
    data.write_text("x,y\n" + "".join(f"{float(a)!r},{float(b)!r}\n" for a, b in zip(x, 0.3 + 1.7 * np.exp(-1.3 * x))))
    front = regress(data, "x", "y", tmp_path / "out", max_complexity=6, ops="+-*/", engine="exhaustive", gpu="rdna3",
                    log=lambda s: None)
    with open(tmp_path / "out" / "front.csv") as f:
        rows = list(csv.DictReader(f))
    assert [float(r["cycles"]) for r in rows] == [m["cycles"] for m in front]
    def glsl(text):         # (the printed constants, 6 digits: the code compiled is the same)
        values = []
        tree = grammar.parse(text, "x", values)
        return grammar.glsl(tree, values)

    alone = gpu_costs.expression_cycles({m["form"]: glsl(m["expression"]) for m in front}, ("rdna3",))["rdna3"]
    assert [m["cycles"] for m in front] == [alone[m["form"]] for m in front]
    assert front[0]["form"] == "c" and front[0]["cycles"] == 0
    with pytest.raises(RegressError, match="--gpu 'navi31': give one of rdna3, rdna2, rdna1, gcn5, gcn4, sm_120, sm_90"):
        regress(data, "x", "y", tmp_path / "o2", max_complexity=3, gpu="navi31", log=lambda s: None)
    with pytest.raises(RegressError, match="--gpu compiles forms of one variable"):
        regress(data, "x,z", "y", tmp_path / "o3", max_complexity=3, gpu="gcn5", log=lambda s: None)
