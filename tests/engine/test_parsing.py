"""The lock around building syntax trees (`pipeline.engine.parsing`): every `ast.parse` in a
process that imported the pipeline's cache holds it, whoever calls it (`ast.literal_eval`, numpy's
header reader, `traceback`'s carets), so that two stage threads never build ASTs at once (CPython 3.11's race)."""
import ast
import io
import threading
import traceback

import numpy as np

import pipeline.engine.cache  # noqa: F401  (what the runner imports)
from pipeline.engine.parsing import PARSING


def _waits_for_the_lock(work) -> bool:
    """Whether `work` run in another thread waits while this thread holds PARSING, and finishes
    once it is released."""
    finished = threading.Event()
    thread = threading.Thread(target=lambda: (work(), finished.set()))
    with PARSING:
        thread.start()
        waited = not finished.wait(0.5)
    thread.join(10)
    return waited and finished.is_set()


def test_ast_parse_and_what_calls_it_wait_for_the_lock():
    array = io.BytesIO()
    np.save(array, np.arange(3.0))

    def read_array():
        array.seek(0)
        assert np.load(array).tolist() == [0.0, 1.0, 2.0]        # its header: ast.literal_eval

    def format_a_traceback():
        try:
            {}["key"] + 1
        except KeyError as e:                                    # the carets: ast.parse of the line
            assert "KeyError" in "".join(traceback.format_exception(e))

    assert _waits_for_the_lock(lambda: ast.parse("a * (b + c)"))
    assert _waits_for_the_lock(lambda: ast.literal_eval("[1, 2]"))
    assert _waits_for_the_lock(read_array)
    assert _waits_for_the_lock(format_a_traceback)


def test_a_holder_of_the_lock_may_parse():
    with PARSING:
        assert ast.literal_eval("(1, 2)") == (1, 2)
    assert not hasattr(ast.parse.unlocked, "unlocked")          # wrapped once
