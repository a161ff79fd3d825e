"""The parametric search's parts computed in worker processes (`parametric_search.searched`): the
same records as in this process, each part's lines logged by its search in order, every part kept;
a worker that dies leaves the rest to this process, with one line."""

import os
import time
from pathlib import Path

import pytest
import sympy as sp

from pipeline.approximate import targets
from pipeline.approximate.search import box_search as parametric_search
from pipeline.approximate.search.box_search import Search
from pipeline.symbolic.budgets import Budget

TARGET = targets.several_variable_targets()["smith_ggx_visibility"]


class PlantedSearch(Search):
    """Each part one planted record (a form in the target's symbols, numbered by the part), the
    process that computed it in its coverage; the part named `dies` ends its process."""

    dies: str = ""
    fails: str = ""
    sleeps: str = ""

    def compute(self, part, f, log):
        if part == self.dies and os.environ.get("PLANTED_PARENT") != str(os.getpid()):
            os._exit(3)
        if part == self.sleeps:
            Path(os.environ["PLANTED_SLEEPER"]).write_text(str(os.getpid()))
            time.sleep(120)
        if part == self.fails:
            while not Path(os.environ["PLANTED_SLEEPER"]).exists():
                time.sleep(0.05)
            raise RuntimeError("planted failure")
        nov, nol, alpha = TARGET.symbols()
        number = list(parametric_search.PARTS).index(part) + 1
        log(f"{part}: computed")
        log(f"{part}: done")
        record = dict(name=f"{part}_1", family="planted", expression=sp.Float(0.25) * number * nov * nol / alpha,
                      source="planted", per="pixel", errors=dict(max_abs_error=0.1 * number, max_rel_error=0.2))
        return [record], dict(process=os.getpid(), **{f"{part}_seconds": 0.0})


def _run(searches, monkeypatch, tmp_path, workers):
    from pipeline.engine import paths

    monkeypatch.setattr(paths, "DERIVE_CACHE", tmp_path / "derive")
    monkeypatch.setattr(parametric_search, "worker_count", lambda parts: min(parts, workers))
    lines, top = [[] for _ in searches], []
    out = parametric_search.searched(searches, [None] * len(searches), [x.append for x in lines], top.append)
    return out, lines, top


def test_the_parts_computed_in_workers_are_those_computed_here_and_kept(monkeypatch, tmp_path):
    """Two searches (a pair's parts), their five parts in two worker processes: the same records
    and coverage as computed here (but the process), each search's lines in the parts' order,
    each part kept (a second run reads all five and starts no process)."""
    monkeypatch.setenv("PLANTED_PARENT", str(os.getpid()))
    searches = [PlantedSearch(TARGET, Budget(10.0), 4), PlantedSearch(TARGET, Budget(20.0), 4)]
    here, here_lines, _ = _run(searches, monkeypatch, tmp_path / "here", 0)
    there, there_lines, top = _run(searches, monkeypatch, tmp_path / "there", 2)
    assert top == ["searching: 6 parts (anchors' refits, families' fits, grammar's search) in 2 processes"]
    assert there_lines == here_lines
    assert here_lines[0] == [f"{p}: {w}" for p in parametric_search.PARTS for w in ("computed", "done")]
    for (found_here, coverage_here), (found_there, coverage_there) in zip(here, there):
        assert [r["expression"] for r in found_there] == [r["expression"] for r in found_here]
        assert [r["name"] for r in found_there] == ["families_1", "grammar_1", "anchors_1"]
        processes = {coverage_there[p]["process"] for p in parametric_search.PARTS}
        assert os.getpid() not in processes
        assert ({k: v for k, v in coverage_there.items() if k not in (*parametric_search.PARTS, "process")}
                == {k: v for k, v in coverage_here.items() if k not in (*parametric_search.PARTS, "process")})
        assert coverage_there["kept"] is False
    again, again_lines, top = _run(searches, monkeypatch, tmp_path / "there", 2)
    assert top == [] and all(coverage["kept"] for _, coverage in again)
    assert all(len(x) == 3 and all("of an earlier run" in line for line in x) for x in again_lines)
    assert [[r["expression"] for r in found] for found, _ in again] == [[r["expression"] for r in found]
                                                                         for found, _ in there]


def test_a_worker_that_dies_leaves_its_parts_to_this_process(monkeypatch, tmp_path):
    """The grammar's part ends its worker process: one line says so, and every part not computed
    by then is computed here; the records are all there."""
    monkeypatch.setenv("PLANTED_PARENT", str(os.getpid()))
    search = PlantedSearch(TARGET, Budget(10.0), 4)
    object.__setattr__(search, "dies", "grammar")
    ((found, coverage),), _, top = _run([search], monkeypatch, tmp_path, 2)
    assert top[-1] == "a search process died (killed, or out of memory): the rest is computed in this process"
    assert [r["name"] for r in found] == ["families_1", "grammar_1", "anchors_1"]
    assert coverage["grammar"]["process"] == os.getpid()


def test_a_part_s_error_ends_the_other_workers_at_once(monkeypatch, tmp_path):
    """A part's error in its worker reaches the run as it is, and the worker computing another part
    (planted: for two minutes) is ended with it, not waited for."""
    monkeypatch.setenv("PLANTED_PARENT", str(os.getpid()))
    monkeypatch.setenv("PLANTED_SLEEPER", str(tmp_path / "sleeper.pid"))
    search = PlantedSearch(TARGET, Budget(10.0), 4)
    object.__setattr__(search, "fails", "families")
    object.__setattr__(search, "sleeps", "grammar")
    started = time.monotonic()
    with pytest.raises(RuntimeError, match="planted failure"):
        _run([search], monkeypatch, tmp_path, 2)
    assert time.monotonic() - started < 60
    sleeper = int((tmp_path / "sleeper.pid").read_text())
    with pytest.raises(ProcessLookupError):
        os.kill(sleeper, 0)


@pytest.mark.parametrize("cores, daemon, expected", [(2, False, 2), (8, False, 3), (1, False, 0), (2, True, 0)])
def test_one_worker_per_core_and_part_none_where_one_would_do(monkeypatch, cores, daemon, expected):
    from pipeline.engine import workers

    monkeypatch.setattr(workers, "cores", lambda: cores)
    monkeypatch.setattr(workers, "may_start_processes", lambda: not daemon)
    assert parametric_search.worker_count(3) == expected
