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
    assert parse_operations("+, -, *, /") == ("+", "-", "*", "/") and parse_operations("*/") == ("*", "/")
    assert parse_operations("pow,exp, +") == ("+", "exp", "pow") and parse_operations("^") == ("pow",)
    with pytest.raises(RegressError, match=r"--ops '\+,tan': unknown operation 'tan'"):
        parse_operations("+,tan")
    with pytest.raises(RegressError, match="operation 'exp' given twice"):
        parse_operations("exp,+,exp")


def test_regress_writes_the_front(tmp_path):
    """2t/(t + 4) is of complexity 8: found exactly, written as a front file and a figure."""
    data = tmp_path / "data.csv"
    t = np.arange(1.0, 51.0)
    data.write_text("t,v\n" + "".join(f"{a},{float(b)!r}\n" for a, b in zip(t, 2.0 * t / (t + 4.0))))
    out = tmp_path / "front"
    front = regress(data, "t", "v", out, max_complexity=8, log=lambda s: None, ops="+-*/")
    assert front[-1]["complexity"] == 8 and front[-1]["rms"] < 1e-12
    with open(out / "front.csv") as f:
        rows = list(csv.DictReader(f))
    assert [int(r["complexity"]) for r in rows] == [m["complexity"] for m in front]
    assert "t" in rows[-1]["canonical"] and float(rows[-1]["rms"]) < 1e-12
    assert (out / "front.png").stat().st_size > 10_000


def test_regress_command_rejects_too_few_points(tmp_path):
    """Fewer points than the constants of the search: exit 2, a message, nothing written. (Up to
    complexity 7, where the ten operations' forms have 3 constants: the default 10 would enumerate
    400,000 forms, seconds, before the same message.)"""
    few = tmp_path / "few.csv"
    few.write_text("t,v\n1,2\n2,3\n3,5\n")
    out = tmp_path / "bad"
    run = subprocess.run([sys.executable, "-m", "pipeline", "regress", str(few), "--x", "t", "--y", "v",
                          "--out", str(out), "--max-complexity", "7"], capture_output=True, text=True,
                         env=cli_env(tmp_path))
    assert run.returncode == 2 and "3 data points" in run.stderr and "up to 3 constants" in run.stderr
    assert not out.exists()
    run = subprocess.run([sys.executable, "-m", "pipeline", "regress", str(few), "--x", "t", "--y", "w"],
                         capture_output=True, text=True, env=cli_env(tmp_path))
    assert run.returncode == 2 and "no column 'w' (--y)" in run.stderr


@pytest.mark.parametrize("rows, message", [
    ([(1.0, v) for v in np.linspace(1, 2, 12)], "column 't' (--x) has the one value 1 on every row: there is nothing"),
    ([(t, 3.0) for t in range(12)], "column 'v' (--y) has the one value 3 on every row: the fit is that constant"),
    ([(t, 1e300 if t == 5 else t) for t in range(12)], "holds 1e+300 (data row 6): values beyond 1e+150 overflow"),
])
def test_regress_refuses_columns_no_search_can_fit(tmp_path, rows, message):
    """Exit 2 with one line naming the column and what is wrong; nothing written, no lock file."""
    data = tmp_path / "bad.csv"
    data.write_text("t,v\n" + "".join(f"{float(a)!r},{float(b)!r}\n" for a, b in rows))
    out = tmp_path / "out" / "bad"
    run = subprocess.run([sys.executable, "-m", "pipeline", "regress", str(data), "--x", "t", "--y", "v", "--out",
                          str(out), "--max-complexity", "5"], capture_output=True, text=True, env=cli_env(tmp_path))
    assert run.returncode == 2, run.stderr
    assert len(run.stderr.strip().splitlines()) == 1 and message in run.stderr, run.stderr
    assert not out.exists() and (not (tmp_path / "out").exists() or not list((tmp_path / "out").iterdir()))


def test_model_selection_marks_the_true_family(tmp_path):
    """On 3 t / (t + 2) with Gaussian noise (sigma 0.01, given) the member of least description length is the true form's
    family (the larger members fit the noise). After a successful run no lock file is left beside
    the output folder."""
    rng = np.random.default_rng(4)
    t = np.linspace(0.5, 20.0, 60)
    v = 3 * t / (t + 2) + rng.normal(0, 0.01, t.size)
    data = tmp_path / "noisy.csv"
    data.write_text("t,v\n" + "".join(f"{float(a)!r},{float(b)!r}\n" for a, b in zip(t, v)))
    out, said = tmp_path / "out" / "noisy", []
    front = regress(data, "t", "v", out, max_complexity=10, log=said.append, noise=0.01, ops="+-*/")
    chosen = [m for m in front if m["selected"]]
    assert len(chosen) == 1 and chosen[0]["complexity"] == 8, [(m["complexity"], m["description_length"]) for m in front]
    assert not any(m["selected"] for m in front if m["complexity"] > 8)
    with open(out / "front.csv") as f:
        rows = list(csv.DictReader(f))
    assert [r["selected"] for r in rows].count("True") == 1
    assert sorted(p.name for p in out.parent.iterdir()) == ["noisy"]
    assert not any(line.startswith("warning") for line in said)


def test_an_outlier_that_dominates_the_fit_is_named(tmp_path):
    """The same data with one y set to 40 (the curve is below 3): a warning names that row (its
    number in the file and its values), since it holds more than half the squared error of most
    front members; the front is still written."""
    rng = np.random.default_rng(4)
    t = np.linspace(0.5, 20.0, 60)
    v = 3 * t / (t + 2) + rng.normal(0, 0.01, t.size)
    v[17] = 40.0
    data = tmp_path / "outlier.csv"
    data.write_text("t,v\n" + "".join(f"{float(a)!r},{float(b)!r}\n" for a, b in zip(t, v)))
    said = []
    regress(data, "t", "v", tmp_path / "out", max_complexity=8, log=said.append, ops="+-*/")
    warnings = [line for line in said if line.startswith("warning")]
    assert len(warnings) == 1 and "data row 18 (" in warnings[0] and "v=40" in warnings[0], said
    assert (tmp_path / "out" / "front.csv").exists()


def test_rounded_data_takes_its_rounding_floor_as_noise():
    from pipeline.symbolic.regress import rounding_noise
    assert rounding_noise(np.array([0.634, 0.833, 1.04])) == pytest.approx(0.001 / np.sqrt(12))
    assert rounding_noise(np.array([1.0, 2.0, 7.0])) == pytest.approx(1 / np.sqrt(12))
    assert rounding_noise(np.array([np.pi, np.e])) is None


def test_regress_takes_complexity_up_to_16_and_says_how_long_first(tmp_path):
    data = tmp_path / "d.csv"
    t = np.arange(1.0, 21.0)
    data.write_text("t,v\n" + "".join(f"{float(a)!r},{float(b)!r}\n" for a, b in zip(t, 1.5 * t)))
    with pytest.raises(RegressError, match=r"give an integer in \[1, 16\]"):
        regress(data, "t", "v", tmp_path / "out", max_complexity=17, log=lambda s: None)
    said = []
    regress(data, "t", "v", tmp_path / "out", max_complexity=5, log=said.append)
    assert "searching expressions up to complexity 5" in said[0] and "s here" in said[0]


def test_the_same_command_gives_the_same_front_on_a_busy_machine_and_from_its_plan(tmp_path):
    """`pipeline regress` with a budget that the ladder shares between rungs, twice: the second time
    with both cores busy with other processes and this machine's kept rates replaced by those of a
    machine 1000 times slower: front.csv and plan.json byte-identical. The first run's plan.json
    given back (`--plan`, in Python): the same front.csv. `--timeout` shorter than the run: exit 124,
    one line, nothing written. `--plan` beside `--seconds`: exit 2."""
    import json

    from ..helpers import PLANTED_SLOW_RATES, busy_cores

    t = np.linspace(0.5, 3.0, 60)
    data = tmp_path / "d.csv"
    data.write_text("t,v\n" + "".join(f"{float(a)!r},{float(b)!r}\n" for a, b in zip(t, 0.3 + 1.0 / (t + 0.5)
                                                                                       + 0.1 * np.exp(-t))))
    (tmp_path / "slow.json").write_text(json.dumps(PLANTED_SLOW_RATES))
    command = [sys.executable, "-m", "pipeline", "regress", str(data), "--x", "t", "--y", "v", "--seconds", "10",
               "--max-complexity", "8", "--out"]
    env = cli_env(tmp_path, PIPELINE_RATES=str(tmp_path / "rates.json"))
    first = subprocess.run(command + [str(tmp_path / "first")], capture_output=True, text=True, env=env, timeout=600)
    assert first.returncode == 0, first.stderr
    with busy_cores(2):
        second = subprocess.run(command + [str(tmp_path / "second")], capture_output=True, text=True, timeout=600,
                                env=env | dict(PIPELINE_RATES=str(tmp_path / "slow.json")))
    assert second.returncode == 0, second.stderr
    plan = json.loads((tmp_path / "first" / "plan.json").read_text())["plan"]
    assert [r["name"] for r in plan["searches"]["regress"]["rungs"]][:2] == ["arithmetic", "wide"]
    for name in ("front.csv", "plan.json"):
        assert (tmp_path / "first" / name).read_bytes() == (tmp_path / "second" / name).read_bytes(), name
    regress(data, "t", "v", tmp_path / "third", max_complexity=8, log=lambda s: None,
            plan=tmp_path / "first" / "plan.json")
    assert (tmp_path / "first" / "front.csv").read_bytes() == (tmp_path / "third" / "front.csv").read_bytes()
    late = subprocess.run(command + [str(tmp_path / "late"), "--timeout", "0.5"], capture_output=True, text=True,
                          env=env, timeout=600)
    assert late.returncode == 124 and late.stderr.strip().splitlines() == [
        "error: stopped at the --timeout of 0.5 s; nothing written"], late.stderr
    assert not (tmp_path / "late").exists()
    both = subprocess.run(command[:-5] + ["--plan", str(tmp_path / "first" / "plan.json"), "--seconds", "20"],
                          capture_output=True, text=True, env=env, timeout=600)
    assert both.returncode == 2 and "--plan fixes the work; --seconds would change it" in both.stderr


TIMEOUT_LOST_ONCE = """
import sys, time
from pipeline.engine import faults

class Slow:
    def __del__(self):
        time.sleep(0.3)         # the timeout's signal arrives here, where its exception is lost

faults.stop_after(0.1)
started = time.perf_counter()
try:
    slow = Slow()
    del slow
    time.sleep(3.0)
except faults.TimedOut:
    print(f"raised again after {time.perf_counter() - started:.2f} s")
"""


def test_a_timeout_that_lands_where_exceptions_are_ignored_is_raised_again():
    """`--timeout`'s signal landing in a callback whose exceptions Python ignores (a planted __del__,
    as JAX's garbage-collection hook is one): raised again within RAISE_AGAIN_SECONDS of the callback's
    end, and no traceback of the lost one on stderr."""
    done = subprocess.run([sys.executable, "-c", TIMEOUT_LOST_ONCE], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0 and done.stderr == "", done.stderr
    assert done.stdout.startswith("raised again after ") and float(done.stdout.split()[-2]) < 1.0, done.stdout
