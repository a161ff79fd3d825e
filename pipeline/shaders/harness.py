"""A function of a shader file compiled as the compiler means it: the file preprocessed by glslang
(its `#include`s resolved, its `#define`s applied, with the run's `-I` and `-D`), then a small
fragment-shader harness holding that text unchanged (its `main` renamed out of the way, its
`#version` and `#extension` lines hoisted above it) whose own `main` loads the function's arguments
from inputs (argument i at location i) and stores its result; compiled to SPIR-V (glslang; HLSL
through its HLSL front end), optimized by `spirv-opt -O` and read back (`spirv_reader`).
"""

from __future__ import annotations

import dataclasses
import tempfile
from pathlib import Path

from ..optics import spirv as tools
from .definitions import Definition, ShaderError
from .spirv_reader import Refused, read

INCLUDE = "#extension GL_GOOGLE_include_directive : require"
LINES = "#extension GL_GOOGLE_cpp_style_line_directive : require"
RENAMED_MAIN = "main_of_the_shader_file"
MAX_ARGUMENTS = 3           # a shader's inputs a derived form reads (`approximate.targets.MAX_AXES`)


@dataclasses.dataclass(frozen=True)
class Options:
    """How the file compiles: its language, include folders (`-I`) and macros (`-D NAME[=VALUE]`)."""

    language: str = "glsl"
    include: tuple[str, ...] = ()
    define: tuple[str, ...] = ()

    def arguments(self, path: Path) -> list[str]:
        return ([f"-I{path.parent}"] + [f"-I{d}" for d in self.include] + [f"-D{d}" for d in self.define]
                + (["-D"] if self.language == "hlsl" else []))


def preprocessed(path: Path, options: Options) -> str:
    """The file's text after glslang's preprocessor. Raises ShaderError with glslang's message (the
    file and its line) where it does not preprocess."""
    path = Path(path).resolve()
    done = tools.run_tool([tools.tool("glslangValidator"), "-E", "-S", "frag", *options.arguments(path),
                           "--P", INCLUDE, str(path)], cwd=path.parent)
    if done.returncode != 0:
        raise ShaderError(f"{path} does not compile: {_first_error(done.stdout + done.stderr)}")
    return done.stdout


def _first_error(log: str) -> str:
    return next((line.strip() for line in log.splitlines() if "ERROR" in line), log.strip().splitlines()[0]
                if log.strip() else "glslang failed")


def harness(text: str, definition: Definition, language: str, path: Path | None = None) -> str:
    """The harness of one function around the file's preprocessed `text` (module docstring), its
    lines numbered as the file's (`path`) in the compiler's messages."""
    count = len(definition.parameters)
    arguments = ", ".join(f"a{i}" for i in range(count))
    body = "\n".join("" if line.startswith(("#version", "#extension")) else line for line in text.splitlines())
    if language == "hlsl":
        inputs = ", ".join(f"float a{i} : A{i}" for i in range(count))
        return (f"#define main {RENAMED_MAIN}\n#line 0 \"{path}\"\n{body}\n#undef main\n"
                f"float main({inputs}) : SV_Target {{ return {definition.name}({arguments}); }}\n")
    extensions = "\n".join(sorted({line for line in text.splitlines() if line.startswith("#extension")} - {INCLUDE}))
    inputs = "".join(f"layout(location = {i}) in float a{i};\n" for i in range(count))
    return (f"#version 450\n{LINES}\n{extensions}\n#define main {RENAMED_MAIN}\n#line 0 \"{path}\"\n{body}\n#undef main\n"
            f"#line 1 \"the harness\"\n{inputs}layout(location = 0) out float result_of_the_function;\n"
            f"void main() {{ result_of_the_function = {definition.name}({arguments}); }}\n")


def refusal(definition: Definition) -> str | None:
    """Why a function is refused before it is compiled (its signature), or None."""
    written = [p for p in definition.parameters if {"out", "inout"} & set(p.qualifiers)]
    if written:
        return f"an out or inout parameter ({written[0].name})"
    if definition.return_type in ("void", ""):
        return "no result (void)"
    if definition.return_type not in ("float", "half", "min16float"):
        return f"a result of type {definition.return_type} (a scalar float is read)"
    others = [p for p in definition.parameters if p.type not in ("float", "half", "min16float") or p.array]
    if others:
        return f"an argument of type {others[0].type}{'[]' if others[0].array else ''} ({others[0].name})"
    if len(definition.parameters) > MAX_ARGUMENTS:
        return f"{len(definition.parameters)} arguments; at most {MAX_ARGUMENTS} free scalars are derived"
    return None


def disassembly(text: str, definition: Definition, options: Options, path: Path) -> str:
    """The optimized SPIR-V's text of the function's harness. Raises ShaderError naming the function
    where it does not compile."""
    source = harness(text, definition, options.language, path)
    with tempfile.TemporaryDirectory(prefix="shader_") as folder:
        folder = Path(folder)
        stem = folder / ("harness.hlsl" if options.language == "hlsl" else "harness.frag")
        stem.write_text(source)
        spv, opt = folder / "harness.spv", folder / "optimized.spv"
        command = [tools.tool("glslangValidator"), "-V", "-S", "frag", str(stem), "-o", str(spv)]
        if options.language == "hlsl":
            command[1:1] = ["-D", "-e", "main"]
        done = tools.run_tool(command)
        if done.returncode != 0:
            raise ShaderError(f"{path}: {definition.name} does not compile: {_first_error(done.stdout + done.stderr)}")
        done = tools.run_tool([tools.tool("spirv-opt"), "-O", str(spv), "-o", str(opt)])
        if done.returncode != 0:
            raise ShaderError(f"{path}: spirv-opt failed on {definition.name}: {_first_error(done.stderr)}")
        return tools.run_tool([tools.tool("spirv-dis"), str(opt)], check=True).stdout


@dataclasses.dataclass(frozen=True)
class Reading:
    """One function read: its expression in its parameters' names, or why it was refused."""

    definition: Definition
    expression: object = None
    refused: str | None = None


def read_function(text: str, definition: Definition, options: Options, path: Path) -> Reading:
    """The function's expression as the compiler means it (module docstring), or its refusal."""
    why = refusal(definition)
    if why is not None:
        return Reading(definition, refused=why)
    names = [p.name for p in definition.parameters]
    try:
        return Reading(definition, read(disassembly(text, definition, options, path), names))
    except Refused as e:
        return Reading(definition, refused=str(e))
