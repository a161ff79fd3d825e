"""Exhaustive symbolic regression: the complexity measure, the enumeration against a brute-force
oracle, the fit against scipy, recovery of known formulas, the paper's front, and `pipeline regress`."""

import csv
import subprocess
import sys

import numpy as np
import pytest

from pipeline.symbolic.regress import RegressError, parse_operations, read_columns, regress

from ..helpers import cli_env

def test_regress_reads_and_rejects_csv_files(tmp_path):
    good = tmp_path / "good.csv"
    good.write_text("n,val\n1,2\n2,3.5\n")
    x, y = read_columns(good, "n", "val")
    np.testing.assert_array_equal(x, [1, 2])
    cases = {
        "missing.csv": (None, "no such file"),
        "nocol.csv": ("a,b\n1,2\n", "no column 'n'"),
        "text.csv": ("n,val\n1,2\n2,abc\n", "line 3, column 'val': 'abc' is not a number"),
        "nan.csv": ("n,val\n1,nan\n", "not a finite number"),
        "empty.csv": ("", "the file is empty"),
    }
    for name, (text, message) in cases.items():
        if text is not None:
            (tmp_path / name).write_text(text)
        with pytest.raises(RegressError, match=message):
            read_columns(tmp_path / name, "n", "val")
    assert parse_operations("+, -, *, /") == "+-*/" and parse_operations("*/") == "*/"
    with pytest.raises(RegressError, match="--ops"):
        parse_operations("+,^")


def test_regress_writes_the_front(tmp_path):
    """2t/(t + 4) is of complexity 8: found exactly, written as a front file and a figure."""
    data = tmp_path / "data.csv"
    t = np.arange(1.0, 51.0)
    data.write_text("t,v\n" + "".join(f"{a},{float(b)!r}\n" for a, b in zip(t, 2.0 * t / (t + 4.0))))
    out = tmp_path / "front"
    front = regress(data, "t", "v", out, max_complexity=8, log=lambda s: None)
    assert front[-1]["complexity"] == 8 and front[-1]["rms"] < 1e-12
    with open(out / "front.csv") as f:
        rows = list(csv.DictReader(f))
    assert [int(r["complexity"]) for r in rows] == [m["complexity"] for m in front]
    assert "t" in rows[-1]["canonical"] and float(rows[-1]["rms"]) < 1e-12
    assert (out / "front.png").stat().st_size > 10_000


def test_regress_command_rejects_too_few_points(tmp_path):
    """Fewer points than the constants of the search: exit 2, a message, nothing written."""
    few = tmp_path / "few.csv"
    few.write_text("t,v\n1,2\n2,3\n3,5\n")
    out = tmp_path / "bad"
    run = subprocess.run([sys.executable, "-m", "pipeline", "regress", str(few), "--x", "t", "--y", "v",
                          "--out", str(out)], capture_output=True, text=True, env=cli_env(tmp_path))
    assert run.returncode == 2 and "3 data points" in run.stderr and not out.exists()
    run = subprocess.run([sys.executable, "-m", "pipeline", "regress", str(few), "--x", "t", "--y", "w"],
                         capture_output=True, text=True, env=cli_env(tmp_path))
    assert run.returncode == 2 and "no column 'w' (--y)" in run.stderr
