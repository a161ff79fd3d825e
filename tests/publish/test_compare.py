"""`pipeline compare`: the table is the runs' results.json, side by side; bad folders exit 2."""

import csv
import json
import subprocess
import sys

import pytest

from pipeline.engine import paths
from pipeline.publish import compare

from ..helpers import cli_env


def write_run(folder, Q, metric, d):
    """A run folder as the pipeline writes it (the parts compare reads: config and headline)."""
    folder.mkdir(parents=True)
    doc = dict(name=folder.name, config={"run.name": folder.name, "derivation.Q": Q, "derivation.metric": metric,
                                         "scan.curve_points": 161},
               headline={"accuracy.d_f_Q2": d, "lobe_comparison.d_max": {"f_2": 0.079, "f_Q2": d},
                         "render.flip_f_Q2_max": 0.3}, stages={})
    (folder / "results.json").write_text(json.dumps(doc))
    return doc


@pytest.fixture()
def sweep(tmp_path):
    docs = {}
    for Q in (0.5, 0.7):
        for metric in ("relative_epicenter", "absolute"):
            name = f"Q={Q}_metric={metric}"
            docs[name] = write_run(tmp_path / "sweep" / name, Q, metric, 0.01 * Q + (0.002 if metric == "absolute" else 0))
    return tmp_path / "sweep", docs


def test_the_table_is_the_runs_results_side_by_side(sweep, tmp_path):
    folder, docs = sweep
    runs = compare.find_runs([folder])
    assert [name for name, _ in runs] == sorted(docs)
    columns, rows = compare.table(runs)
    assert columns[:3] == ["run", "derivation.Q", "derivation.metric"]      # only the keys that differ
    assert "scan.curve_points" not in columns and "run.name" not in columns
    for row in rows:
        doc = docs[row[0]]
        cells = dict(zip(columns, row))
        assert cells["derivation.Q"] == doc["config"]["derivation.Q"]
        assert cells["derivation.metric"] == doc["config"]["derivation.metric"]
        assert cells["accuracy.d_f_Q2"] == doc["headline"]["accuracy.d_f_Q2"]
        assert cells["lobe_comparison.d_max.f_Q2"] == doc["headline"]["lobe_comparison.d_max"]["f_Q2"]
    text = compare.markdown(columns, rows)
    assert "accuracy.d_f_Q2" in text and "render.flip_f_Q2_max" not in text     # the same in every run
    compare.write_csv(tmp_path / "compare.csv", columns, rows)
    with open(tmp_path / "compare.csv") as f:
        written = list(csv.reader(f))
    assert written[0] == columns and len(written) == 5
    assert float(written[1][columns.index("accuracy.d_f_Q2")]) == docs[written[1][0]]["headline"]["accuracy.d_f_Q2"]


def test_the_cli_writes_the_table_and_a_plot_into_the_sweep_folder(sweep, tmp_path):
    folder, _ = sweep
    done = subprocess.run([sys.executable, "-m", "pipeline", "compare", str(folder), "--plot",
                           "derivation.Q:accuracy.d_f_Q2"], capture_output=True, text=True, env=cli_env(tmp_path),
                          cwd=paths.ROOT)
    assert done.returncode == 0, done.stderr
    assert (folder / "compare.csv").is_file() and (folder / "compare.png").stat().st_size > 10_000
    assert "4 runs; config keys that differ: derivation.Q, derivation.metric" in done.stdout
    assert not list(folder.glob(".*tmp*"))


@pytest.mark.parametrize("args, message", [
    (["missing"], "missing: no such folder"),
    (["empty"], "empty: holds no results.json"),
    (["sweep", "--plot", "derivation.Q"], "expected KEY:FIELD"),
    (["sweep", "--plot", "derivation.Q:accuracy.nothing"], "'accuracy.nothing' is not a headline metric"),
])
def test_bad_input_exits_2_with_one_line(sweep, tmp_path, args, message):
    (tmp_path / "empty").mkdir()
    done = subprocess.run([sys.executable, "-m", "pipeline", "compare", *args], capture_output=True, text=True,
                          env=cli_env(tmp_path), cwd=tmp_path)
    assert done.returncode == 2 and done.stderr.count("\n") == 1 and message in done.stderr, done.stderr
    assert not (tmp_path / "sweep" / "compare.csv").exists()
