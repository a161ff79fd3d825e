"""Publishing an output folder whole (`pipeline.engine.publishing`): one rename, a stamp that skips
an unchanged write, a failed write that leaves the previous folder as it was, leftovers swept."""

import pytest

from pipeline.engine.publishing import publish


def writer(text, calls):
    def write(tmp):
        calls.append(tmp)
        (tmp / "a.txt").write_text(text)
        return "1 file"
    return write


def test_a_folder_is_written_whole_and_an_unchanged_one_is_not_rewritten(tmp_path):
    out, log, calls = tmp_path / "run", [], []
    publish(out, "key1", log.append, writer("first", calls))
    assert (out / "a.txt").read_text() == "first" and (out / ".stamp").read_text() == "key1"
    publish(out, "key1", log.append, writer("second", calls))
    assert len(calls) == 1 and (out / "a.txt").read_text() == "first" and "up to date" in log[-1]
    publish(out, "key2", log.append, writer("second", calls))
    assert (out / "a.txt").read_text() == "second" and (out / ".stamp").read_text() == "key2"
    # Only the folder is left beside it: no temporary or old copy, no lock file.
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run"]


def test_a_failed_write_leaves_the_previous_folder_as_it_was(tmp_path):
    out = tmp_path / "run"
    publish(out, "key1", lambda s: None, writer("first", []))

    def broken(tmp):
        (tmp / "a.txt").write_text("half")
        raise OSError("disk full")

    with pytest.raises(OSError, match="disk full"):
        publish(out, "key2", lambda s: None, broken)
    assert (out / "a.txt").read_text() == "first" and (out / ".stamp").read_text() == "key1"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run"]


def test_what_a_killed_write_left_is_swept_by_the_next(tmp_path):
    out = tmp_path / "run"
    (tmp_path / ".run.tmp.abc").mkdir()         # a killed writer's temporary folder
    (tmp_path / ".run.old").mkdir()             # ... or the previous folder it had moved aside
    (tmp_path / ".other.tmp.x").mkdir()         # another run's: not touched
    publish(out, "key", lambda s: None, writer("x", []))
    assert sorted(p.name for p in tmp_path.iterdir()) == [".other.tmp.x", "run"]


def test_a_waiting_writer_locks_afresh_when_the_holder_removes_the_lock_file(tmp_path):
    """Two writers of one folder at once: the second waits, says so, and writes after the first; the
    lock file is gone after both."""
    import threading
    import time

    from pipeline.engine.publishing import output_lock

    out, order, said = tmp_path / "run", [], []
    first_in = threading.Event()

    def first():
        with output_lock(out, said.append):
            first_in.set()
            time.sleep(0.5)
            order.append("first")

    thread = threading.Thread(target=first)
    thread.start()
    first_in.wait()
    with output_lock(out, said.append):
        order.append("second")
    thread.join()
    assert order == ["first", "second"]
    assert any("is being written by another run" in s for s in said)
    assert not (tmp_path / ".run.lock").exists()
