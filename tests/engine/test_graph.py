"""The command line: the graph, dry runs, fast errors, exit codes, and recovery from kills."""

import subprocess
import sys


from pipeline.engine import graph
from pipeline.engine import paths

from ..helpers import cli_env

def run_cli(args, tmp_path, **kwargs):
    return subprocess.run([sys.executable, "-m", "pipeline", *args], capture_output=True, text=True,
                          env=cli_env(tmp_path), cwd=paths.ROOT, **kwargs)


def test_graph_lists_every_stage_with_its_reads_and_outputs(tmp_path):
    done = run_cli(["graph"], tmp_path)
    assert done.returncode == 0
    for stage in graph.STAGES:
        assert f"] {stage.name}  (" in done.stdout
        for field in stage.outputs:
            assert f"      {field} " in done.stdout
    assert "    reads:  q_choice.Q_used" in done.stdout     # linear_coefficient reads one field


def test_the_graph_is_a_dag_of_declared_fields():
    graph.validate()
    names = [s.name for s in graph.STAGES]
    assert len(set(names)) == len(names)
    for s in graph.STAGES:
        assert all(names.index(u) < names.index(s.name) for u in s.upstream)


def test_config_dependencies_follow_the_graph():
    from pipeline.engine.config import KEYS
    # The scan's best Q depends on the zone (through zone.level) but not on Q or the line.
    deps = graph.config_dependencies("q_scan.Q_scan_best", KEYS)
    assert "zone.calibration_target" in deps and "scan.fine_step" in deps
    assert "derivation.Q" not in deps and "derivation.fit" not in deps
    assert "derivation.Q" in graph.config_dependencies("hemispherical.hemi_max_abs_dev", KEYS)
    assert graph.config_dependencies("sample.sample_size", KEYS) == {
        "derivation.n_min", "derivation.n_max", "sample.consecutive_to", "sample.spread_from", "sample.spread_count"}


