"""Outside text (a target's or anchor's name, an expression, a source, a CSV column) made to stay text
in each format the pipeline writes: Markdown prose and table cells, Markdown code spans, matplotlib
labels (mathtext's `$`), comments of GLSL and HLSL, Python string literals, HTML and a script's JSON,
identifiers of shader and Python functions, and a folder's name."""

from __future__ import annotations

import html as _html
import json
import keyword
import re

# characters Markdown would read as markup (code, emphasis, a table's cell, a link, math, HTML, an
# escape): written as numeric character references, which every Markdown renderer shows as the
# character and none reads as markup (a backslash escape is not read alike by GFM and Python-Markdown)
# (_ only at a word's edge: inside a word, as in cos_n20, no renderer reads it as emphasis)
_MARKDOWN = re.compile(r"[\\`*|\[\]$<>&]|(?<![A-Za-z0-9])_|_(?![A-Za-z0-9])")
_LINE_BREAKS = re.compile(r"[\r\n\t\f\v\u2028\u2029\x85]")
_CONTROL = re.compile(r"[\x00-\x1f\x7f]")


def one_line(text) -> str:
    """The text on one line: line breaks and tabs as spaces, other control characters dropped."""
    return _CONTROL.sub("", _LINE_BREAKS.sub(" ", str(text)))


def markdown(text) -> str:
    """Markdown prose or a table cell showing `text` as it is, on one line: \\ ` * | [ ] $ < > & (and _
    at a word's edge) as numeric character references (no markup of the text is ever rendered, no cell split)."""
    return _MARKDOWN.sub(lambda m: f"&#{ord(m.group(0))};", one_line(text))


def code(text) -> str:
    """Markdown showing `text` as code, as it is, on one line, also inside a table: a code span fenced
    by more backticks than its longest run of them; where it holds a |, which a table splits at even
    inside a code span, an HTML <code> element of its characters as references."""
    text = one_line(text)
    if "|" in text:
        return f"<code>{markdown(text)}</code>"
    longest = max((len(run) for run in re.findall(r"`+", text)), default=0)
    fence = "`" * (longest + 1)
    pad = " " if text.startswith("`") or text.endswith("`") or not text.strip() else ""
    return f"{fence}{pad}{text}{pad}{fence}"


def mathtext(text) -> str:
    """A matplotlib label showing `text` as it is (a `$` would start mathtext), on one line."""
    return one_line(text).replace("$", r"\$")


def comment(text) -> str:
    """The text of a `//` comment line of GLSL or HLSL: one line, never ending in a backslash (which
    would join the next line to the comment)."""
    text = one_line(text)
    return text + " " if text.endswith("\\") else text


def python_string(text) -> str:
    """A Python string literal of `text`: triple-quoted where it holds no quote, backslash or line
    break (a docstring as one writes it), otherwise repr's (each of them escaped)."""
    text = str(text)
    if not any(c in text for c in '"\\') and one_line(text) == text:
        return f'"""{text}"""'
    return repr(text)


def identifier(text) -> str:
    """An identifier of GLSL, HLSL and Python from `text`: ASCII letters, digits and single
    underscores (GLSL reserves __ and gl_), never starting with a digit, never a keyword."""
    name = re.sub(r"_+", "_", re.sub(r"[^A-Za-z0-9_]", "_", str(text))).strip("_") or "f"
    if name[0].isdigit() or name.lower().startswith("gl_") or keyword.iskeyword(name) or name in _SHADER_WORDS:
        name = "f_" + name
    return name


# GLSL's and HLSL's words a function may not be named (the common ones; every name written is prefixed
# by the target's, so this guards a bare one)
_SHADER_WORDS = {"main", "float", "int", "uint", "bool", "void", "vec2", "vec3", "vec4", "float2", "float3", "float4",
                 "if", "else", "for", "while", "do", "return", "break", "continue", "discard", "struct", "const",
                 "in", "out", "inout", "uniform", "layout", "true", "false", "half", "double", "precision", "switch",
                 "case", "default", "sampler", "texture", "static", "inline", "register", "packoffset"}


def folder_name(text) -> str:
    """A folder's name from `text`: letters, digits, -, _ and . only, not starting with a dot (never
    a path that leaves its parent)."""
    name = re.sub(r"[^A-Za-z0-9._-]", "_", str(text)).lstrip(".")
    return name or "target"


def html(text) -> str:
    """HTML text or an attribute's value showing `text` as it is (&, <, >, " and ' as entities)."""
    return _html.escape(str(text), quote=True)


def script_json(value) -> str:
    """JSON of `value` safe inside an HTML <script> element: <, >, & and the line separators escaped as
    \\u sequences (no text can close the element or open a comment)."""
    text = json.dumps(value, ensure_ascii=False, allow_nan=False)
    return (text.replace("<", "\\u003c").replace(">", "\\u003e").replace("&", "\\u0026")
            .replace("\u2028", "\\u2028").replace("\u2029", "\\u2029"))
