"""One lock for building Python syntax trees, held by every `ast.parse` in the process.

CPython 3.11 can fail with "SystemError: AST constructor recursion depth mismatch" when two threads
turn source into AST objects at once: its AST builder keeps its depth in per-interpreter state
(python/cpython#106905; later versions keep it per call). The runner computes stages in threads, and
source is parsed there by much that the pipeline calls: numpy reads each array header with
`ast.literal_eval`, the expression reader parses formulas, `traceback` parses a line to place its
carets (equinox formats the stack whenever optimistix's root find is traced), `inspect` parses
builtins' signatures when numpy.ma is imported, and Dr.Jit parses and compiles Mitsuba's
integrators. So importing this module (`engine.cache` does) makes `ast.parse`, through which
`ast.literal_eval`, `traceback` and `inspect` go, hold `PARSING`.

`ast.parse` takes no other lock while it holds this one, so it cannot deadlock with an import in
another thread. The places that hold it around more are the registrations of Mitsuba's plugins
(`mitsuba.bsdf`, `mitsuba.microfacet`), since Dr.Jit also compiles the AST objects it builds there.
"""
from __future__ import annotations

import ast
import functools
import threading

PARSING = threading.RLock()


def _holding_the_lock(parse):
    @functools.wraps(parse)
    def parse_holding_the_lock(*args, **kwargs):
        with PARSING:
            return parse(*args, **kwargs)
    parse_holding_the_lock.unlocked = parse
    return parse_holding_the_lock


if not hasattr(ast.parse, "unlocked"):          # (once, however often this module is reloaded)
    ast.parse = _holding_the_lock(ast.parse)
