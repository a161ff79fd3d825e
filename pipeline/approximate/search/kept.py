"""The entries `pipeline derive` keeps in `paths.DERIVE_CACHE` (a search, a template's fits): JSON
written whole (a temporary file, then one rename) beside the SHA-256 of its body, read back only
where the hash still matches, every expression in it read by the one parser
(`engine.expressions.parse`, float64 constants: `engine.expressions.text` wrote it). An entry whose
hash or expressions fail is recomputed, with one line saying why; nothing in it is evaluated."""

from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path

from ...engine import expressions


class Unusable(Exception):
    """A kept entry that cannot be used (the message says why)."""


def _digest(body: str) -> str:
    return hashlib.sha256(body.encode("utf-8")).hexdigest()


def write(path: Path, body: dict) -> None:
    """Keep `body` (JSON values) at `path`, with its hash, in one rename."""
    text = json.dumps(body, sort_keys=True)
    path.parent.mkdir(parents=True, exist_ok=True)
    partial = path.with_suffix(f".{os.getpid()}.tmp")
    partial.write_text(json.dumps(dict(sha256=_digest(text), body=text)))
    os.replace(partial, path)


def read(path: Path, log) -> dict | None:
    """The body kept at `path`; None where there is none, or (after one line to `log` saying why)
    where it cannot be used: not JSON, or its body changed after it was written."""
    try:
        entry = json.loads(path.read_text())
    except FileNotFoundError:
        return None
    except (OSError, UnicodeDecodeError, ValueError) as e:
        log(f"the kept entry {path.name} is not readable ({type(e).__name__}): computed again")
        return None
    if not (isinstance(entry, dict) and set(entry) == {"sha256", "body"}):
        log(f"the kept entry {path.name} is of another format: computed again")
        return None
    if not (isinstance(entry["body"], str) and entry["sha256"] == _digest(entry["body"])):
        log(f"the kept entry {path.name} was changed after it was written (its hash): computed again")
        return None
    try:
        return json.loads(entry["body"])
    except ValueError:
        log(f"the kept entry {path.name} is not readable (ValueError): computed again")
        return None


def expression(text, symbols):
    """A kept expression read back (`expressions.parse`, float64 constants). Raises Unusable."""
    try:
        return expressions.parse(text, symbols, what="a kept expression", float64=True)
    except expressions.ExpressionError as e:
        raise Unusable(str(e)) from None


def text(expr, symbols) -> str:
    """An expression as it is kept (`expressions.text`), checked to read back to the same tree in
    `symbols` ({name: Symbol}). Raises Unusable where it does not."""
    try:
        return expressions.text(expr, symbols)
    except expressions.ExpressionError as e:
        raise Unusable(str(e)) from None
