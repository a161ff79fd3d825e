"""The answer written back: a shader file with the bodies of some of its functions replaced (each
function's signature, qualifiers, comments and every other byte as they were), as a unified diff of
the file that `git apply` and `patch -p1` take. A replaced function may keep its original beside it,
renamed `NAME_reference`."""

from __future__ import annotations

import difflib
import re

from .definitions import Definition

REFERENCE = "_reference"


def body(expression: str, indent: str = "    ") -> str:
    """A function body that returns the GLSL or HLSL `expression` (its own language's text)."""
    return "{\n" + indent + "return " + expression + ";\n}"


def _indent_of(source: bytes, definition: Definition) -> str:
    """The indentation of the function's first statement (four spaces where its body is on one line)."""
    inside = source[definition.body_start + 1:definition.body_end - 1].decode(errors="replace")
    match = re.search(r"\n([ \t]+)\S", inside)
    return match.group(1) if match else "    "


def replaced(source: bytes, bodies: dict, keep_reference: bool = False) -> bytes:
    """`source` with each Definition of `bodies` ({Definition: its new body's expression}) returning
    that expression instead; with `keep_reference`, the original function after it, renamed
    NAME_reference (its name's first occurrence in its signature)."""
    out, at = [], 0
    for definition in sorted(bodies, key=lambda d: d.start):
        indent = _indent_of(source, definition)
        out.append(source[at:definition.body_start])
        out.append(body(bodies[definition], indent).encode())
        if keep_reference:          # (after the function: a `// derive:` line above it stays its own)
            original = source[definition.start:definition.end].decode()
            signature = definition.signature
            renamed = re.sub(rf"\b{re.escape(definition.name)}\b", definition.name + REFERENCE, signature, count=1)
            out.append(("\n\n" + renamed + original[len(signature):]).encode())
        at = definition.body_end
    out.append(source[at:])
    return b"".join(out)


def unified_diff(path: str, before: bytes, after: bytes) -> str:
    """The unified diff of one file (`path` as the repository names it: a/PATH and b/PATH), which
    `git apply` and `patch -p1` take; empty where nothing changed."""
    a, b = before.decode().splitlines(keepends=True), after.decode().splitlines(keepends=True)
    lines = list(difflib.unified_diff(a, b, f"a/{path}", f"b/{path}"))
    out = []
    for line in lines:          # (a last line without its newline: the marker patch and git read)
        out.append(line if line.endswith("\n") else line + "\n\\ No newline at end of file\n")
    return "".join(out)
