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
from .spirv_reader import lanes, Refused, read_both

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


SCALARS = ("float", "half", "min16float")
VECTORS = {f"{base}{n}": n for n in (2, 3, 4) for base in ("vec", "float", "half", "min16float")}


def width(type_name: str) -> int:
    """1 for a scalar float type, N for a vector of N floats (vecN, floatN, halfN), 0 otherwise."""
    return 1 if type_name in SCALARS else VECTORS.get(type_name, 0)


def harness(text: str, definition: Definition, language: str, path: Path | None = None, lane: bool = False) -> str:
    """The harness of one function around the file's preprocessed `text` (module docstring), its
    lines numbered as the file's (`path`) in the compiler's messages: each argument an input of its
    own type and the result the output; with `lane` (a function of vectors), every argument a scalar
    input broadcast to its vector type and the result's first lane the output (`call`)."""
    types = [p.type if not lane else "float" for p in definition.parameters]
    result = definition.return_type if not lane else "float"
    call = function_call(definition, language, lane)
    body = "\n".join("" if line.startswith(("#version", "#extension")) else line for line in text.splitlines())
    if language == "hlsl":
        inputs = ", ".join(f"{_hlsl(t)} a{i} : A{i}" for i, t in enumerate(types))
        return (f"#define main {RENAMED_MAIN}\n#line 0 \"{path}\"\n{body}\n#undef main\n"
                f"{_hlsl(result)} main({inputs}) : SV_Target {{ return {call}; }}\n")
    extensions = "\n".join(sorted({line for line in text.splitlines() if line.startswith("#extension")} - {INCLUDE}))
    inputs = "".join(f"layout(location = {i}) in {_glsl(t)} a{i};\n" for i, t in enumerate(types))
    return (f"#version 450\n{LINES}\n{extensions}\n#define main {RENAMED_MAIN}\n#line 0 \"{path}\"\n{body}\n#undef main\n"
            f"#line 1 \"the harness\"\n{inputs}layout(location = 0) out {_glsl(result)} result_of_the_function;\n"
            f"void main() {{ result_of_the_function = {call}; }}\n")


def _glsl(type_name: str) -> str:
    n = width(type_name)
    return "float" if n == 1 else f"vec{n}"


def _hlsl(type_name: str) -> str:
    n = width(type_name)
    return "float" if n == 1 else f"float{n}"


def function_call(definition: Definition, language: str, lane: bool = False) -> str:
    """The call of the function on a0, a1, ...; with `lane`, each vector argument its scalar input
    broadcast (vec3(a0), or HLSL's (float3)a0) and the result's first lane taken (.x)."""
    arguments = []
    for i, p in enumerate(definition.parameters):
        n = width(p.type)
        if lane and n > 1:
            arguments.append(f"({_hlsl(p.type)})a{i}" if language == "hlsl" else f"{_glsl(p.type)}(a{i})")
        else:
            arguments.append(f"a{i}")
    call = f"{definition.name}({', '.join(arguments)})"
    return f"{call}.x" if lane and width(definition.return_type) > 1 else call


def refusal(definition: Definition) -> str | None:
    """Why a function is refused before it is compiled (its signature), or None."""
    written = [p for p in definition.parameters if {"out", "inout"} & set(p.qualifiers)]
    if written:
        return f"an out or inout parameter ({written[0].name})"
    if definition.return_type in ("void", ""):
        return "no result (void)"
    n = width(definition.return_type)
    if not n:
        return f"a result of type {definition.return_type} (a float or a vector of floats is read)"
    others = [p for p in definition.parameters if width(p.type) not in (1, n) or p.array]
    if others:
        return (f"an argument of type {others[0].type}{'[]' if others[0].array else ''} ({others[0].name})"
                + (f": a float or a vector of {n}, as its result" if n > 1 else ""))
    if len(definition.parameters) > MAX_ARGUMENTS:
        return f"{len(definition.parameters)} arguments; at most {MAX_ARGUMENTS} free scalars are derived"
    return None


def disassembly(text: str, definition: Definition, options: Options, path: Path, lane: bool = False) -> str:
    """The optimized SPIR-V's text of the function's harness (`lane`: its vector arguments broadcast,
    its result's first lane). Raises ShaderError naming the function where it does not compile."""
    source = harness(text, definition, options.language, path, lane)
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
    lanes: int = 1              # a vector result's lanes, each the expression of its own lane


def reading(text: str, definition: Definition, options: Options, path: Path) -> tuple:
    """(the function's expression, its transliteration, its result's lanes): as the compiler means it
    (module docstring); a function of vectors read twice, as it is (its lanes one scalar function of
    their own lane, `spirv_reader.lanes`) and on broadcast scalars (its first lane, the expression and
    the transliteration), the two the same function (at 64 points, 1e-12 relative). Raises Refused."""
    import numpy as np
    import sympy as sp

    names = [p.name for p in definition.parameters]
    n = width(definition.return_type)
    expression, transliteration = read_both(disassembly(text, definition, options, path, lane=n > 1), names)
    if n > 1:
        one = lanes(disassembly(text, definition, options, path), names,
                    [p.name for p in definition.parameters if width(p.type) > 1])
        symbols = [sp.Symbol(a, real=True) for a in names]
        points = np.random.default_rng(0).uniform(0.0, 1.0, (len(names), 64))
        with np.errstate(all="ignore"):
            a, b = (np.broadcast_to(np.asarray(sp.lambdify(symbols, e, "numpy")(*points), dtype=float), (64,))
                    for e in (one, expression))
        if not np.allclose(a, b, rtol=1e-12, atol=0, equal_nan=True):
            raise Refused("its first lane on broadcast arguments is not the function of every lane")
    return expression, transliteration, n


def read_function(text: str, definition: Definition, options: Options, path: Path) -> Reading:
    """The function's expression as the compiler means it (module docstring), or its refusal."""
    why = refusal(definition)
    if why is not None:
        return Reading(definition, refused=why)
    try:
        expression, _, n = reading(text, definition, options, path)
        return Reading(definition, expression, lanes=n)
    except Refused as e:
        return Reading(definition, refused=str(e))
