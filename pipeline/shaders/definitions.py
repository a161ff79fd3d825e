"""The functions a GLSL or HLSL file defines, found by tree-sitter's grammar of the language
(`tree-sitter-glsl`, `tree-sitter-hlsl`: the file parsed, nothing of it run): each one's name,
return type, parameters (type, name, qualifiers), the byte spans of the whole definition and of its
body, its line, and the `// derive:` annotation on the line directly above it, where there is one."""

from __future__ import annotations

import dataclasses
import re
from pathlib import Path

LANGUAGES = ("glsl", "hlsl")
HLSL_SUFFIXES = (".hlsl", ".fx", ".hlsli", ".fxh")
ANNOTATION = re.compile(r"^\s*//\s*derive:(.*)$")
QUALIFIERS = {"in", "out", "inout", "const", "highp", "mediump", "lowp", "precise", "uniform", "noperspective",
              "nointerpolation", "linear", "centroid", "sample"}


class ShaderError(ValueError):
    """Bad shader input (one line naming the file and what is wrong)."""


@dataclasses.dataclass(frozen=True)
class Parameter:
    name: str
    type: str
    qualifiers: tuple[str, ...] = ()
    array: bool = False


@dataclasses.dataclass(frozen=True)
class Definition:
    """One function of a file: `signature` is its text up to the body's brace, `start`/`end` the
    definition's byte span, `body_start`/`body_end` its body's (the braces included), `line` its
    first line (1-based), `annotation` the text after `// derive:` on the line above (or None)."""

    name: str
    return_type: str
    parameters: tuple[Parameter, ...]
    signature: str
    start: int
    end: int
    body_start: int
    body_end: int
    line: int
    annotation: str | None = None

    @property
    def types(self) -> tuple[str, ...]:
        return tuple(p.type for p in self.parameters)

    def text(self) -> str:
        """The function as a list of its file names it: `float name(float x, float y)`."""
        return f"{self.return_type} {self.name}({', '.join(f'{p.type} {p.name}' for p in self.parameters)})"


def language_of(path: Path, lang: str | None = None) -> str:
    """The file's language: `lang` where given, HLSL by its suffix (`HLSL_SUFFIXES`), else GLSL."""
    if lang is not None:
        if lang not in LANGUAGES:
            raise ShaderError(f"--lang {lang!r}: give one of {', '.join(LANGUAGES)}")
        return lang
    return "hlsl" if Path(path).suffix.lower() in HLSL_SUFFIXES else "glsl"


def _parser(language: str):
    import warnings

    from tree_sitter import Language, Parser

    if language == "hlsl":
        import tree_sitter_hlsl as grammar
    else:
        import tree_sitter_glsl as grammar
    with warnings.catch_warnings():         # (these grammars' wheels hand tree-sitter an int, which it deprecates)
        warnings.simplefilter("ignore", DeprecationWarning)
        return Parser(Language(grammar.language()))


def _parameter(text: str) -> Parameter:
    """A parameter's declaration text (`in float x`, `const vec3 c`, `float x : TEXCOORD0`)."""
    text = text.split(":", 1)[0].split("=", 1)[0].strip()
    array = "[" in text
    words = re.sub(r"\[[^\]]*\]", " ", text).split()
    qualifiers = tuple(w for w in words if w in QUALIFIERS)
    rest = [w for w in words if w not in QUALIFIERS]
    if len(rest) < 2:
        return Parameter(rest[-1] if rest else "", rest[0] if rest else "", qualifiers, array)
    return Parameter(rest[-1], " ".join(rest[:-1]), qualifiers, array)


def _top_level(node):
    """The function definitions at the file's top level, inside preprocessor conditionals too (an
    include guard's #ifndef), in order."""
    for child in node.children:
        if child.type == "function_definition":
            yield child
        elif child.type.startswith("preproc_"):
            yield from _top_level(child)


def definitions(source: bytes, language: str) -> list[Definition]:
    """Every function definition of `source` (the file's bytes), in order."""
    tree = _parser(language).parse(source)
    lines = source.split(b"\n")
    out = []
    for node in _top_level(tree.root_node):
        declarator, body = node.child_by_field_name("declarator"), node.child_by_field_name("body")
        while declarator is not None and declarator.type != "function_declarator":
            declarator = declarator.child_by_field_name("declarator")
        if declarator is None or body is None:
            continue
        name_node = declarator.child_by_field_name("declarator")
        parameters = declarator.child_by_field_name("parameters")
        type_node = node.child_by_field_name("type")
        return_type = source[type_node.start_byte:type_node.end_byte].decode() if type_node is not None else ""
        listed = [source[p.start_byte:p.end_byte].decode() for p in parameters.named_children
                  if p.type.endswith("parameter_declaration")] if parameters is not None else []
        row = node.start_point[0]
        above = lines[row - 1].decode(errors="replace") if row > 0 else ""
        annotation = ANNOTATION.match(above)
        out.append(Definition(
            name=source[name_node.start_byte:name_node.end_byte].decode(), return_type=return_type,
            parameters=tuple(_parameter(p) for p in listed if p.strip() not in ("void", "")),
            signature=source[node.start_byte:body.start_byte].decode().rstrip(), start=node.start_byte,
            end=node.end_byte, body_start=body.start_byte, body_end=body.end_byte, line=row + 1,
            annotation=annotation.group(1).strip() if annotation else None))
    return out


def read(path: Path, lang: str | None = None) -> tuple[str, list[Definition]]:
    """(the file's language, its functions). Raises ShaderError naming a missing or unreadable file."""
    path = Path(path)
    if not path.is_file():
        raise ShaderError(f"{path}: no such file")
    language = language_of(path, lang)
    return language, definitions(path.read_bytes(), language)
