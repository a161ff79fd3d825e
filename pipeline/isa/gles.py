"""The shared part of the mobile back ends (`adreno`, `mali`): a shader's operations
(`pipeline.isa.lowering`) printed as a GL ES 3.1 fragment shader, and Mesa's own GL ES drivers
compiling a run's shaders on their drm-shim null devices, in an arm64 Debian user space run by
qemu-user (`toolchains.find_mesa_mobile`).

The shader reads the varyings (t, n) as highp inputs (mediump, and writes mediump, where it
computes in float16: explicit 16-bit types print as mediump, which Mesa's ir3 and panfrost compute
in 16 bits) and the per-material uniforms as highp uniforms of the default block (constant registers, as Vulkan's push constants are), and writes
vec4(result, every input it read): the wrapper reads the same inputs, so interpolation and output
cancel in the net count. Each shader is its own separable program (`glCreateShaderProgramv`), so
no vertex shader is linked with it and no arithmetic moves across the stage boundary. These are
Mesa's compilers (freedreno's ir3, panfrost's Bifrost and Valhall back ends), not Qualcomm's or
Arm's drivers.

`compile_all(sources, environment)` sends the shaders to `gles_driver.py`, run under the arm64
Python and kept running for the process's later batches with the same chip and variables
(`compiler_process`: its start, about 1 CPU-s under qemu where a batch of 30 shaders takes 0.1 s
more, paid once); each shader lies between two marker lines on standard error where Mesa prints
its listing; compiles are serial (freedreno's `serialc`), so each listing lies between its
shader's markers.
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path

from ..engine import toolchains
from . import compiler_process
from .architectures import CompilerMissing
from .lowering import LoweringError, Op, c_statements

DRIVER = Path(__file__).with_name("gles_driver.py")
MARK = "@@pipeline-shader"
LIBRARIES = "usr/lib/aarch64-linux-gnu"
TIMEOUT_S = 600
CONSTANT_FORMAT = "{:.9g}"


def _c(value: float) -> str:
    if math.isinf(value):
        return "(1.0 / 0.0)" if value > 0 else "(-1.0 / 0.0)"
    text = CONSTANT_FORMAT.format(value)
    return text if any(c in text for c in ".e") else text + ".0"


FUNCTIONS = {"Pow": "pow", "Exp": "exp", "Exp2": "exp2", "Log": "log", "Log2": "log2", "Sqrt": "sqrt",
             "InverseSqrt": "inversesqrt", "Sin": "sin", "Cos": "cos", "FAbs": "abs", "FMax": "max", "NMax": "max",
             "FMin": "min", "NMin": "min", "FClamp": "clamp", "NClamp": "clamp"}


def _function(name: str, a: list[str]) -> str:
    """GL ES of one GLSL.std.450 function (fma as a multiply-add: GL ES 3.1 has no fma)."""
    if name == "Fma":
        return f"{a[0]} * {a[1]} + {a[2]}"
    if name not in FUNCTIONS:
        raise LoweringError(f"no GL ES lowering for the GLSL.std.450 function {name}")
    return f"{FUNCTIONS[name]}({', '.join(a)})"


def fragment_shader(ops: list[Op], result: str) -> str:
    """The GL ES 3.1 fragment shader of the operations (see the module's text)."""
    uniforms = sorted({op.op for op in ops if op.kind == "uniform"})
    inputs = sorted({op.op for op in ops if op.kind == "input"})
    body, names = c_statements(ops, input_expr=lambda name: f"in_{name}", uniform_expr=lambda k: f"u{k}",
                               constant=_c, function=_function, divide=lambda x, y: f"{x} / {y}",
                               float_type="highp float", bool_type="bool", half_type="mediump float")
    outputs = [names[result]] + [f"in_{i}" for i in inputs]
    outputs += ["0.0"] * (4 - len(outputs))
    # a shader computing in float16 reads and writes mediump, as a phone's mediump shader does
    io = "mediump" if any(op.width == 16 for op in ops) else "highp"
    head = ["#version 310 es", "precision highp float;"]
    head += [f"in {io} float in_{i};" for i in inputs]
    head += [f"uniform highp float u{i};" for i in range(len(uniforms))]
    head += [f"layout(location = 0) out {io} vec4 color;", "void main()", "{"]
    return "\n".join(head + body + [f"  color = vec4({', '.join(outputs[:4])});", "}"]) + "\n"


def tools() -> toolchains.Found:
    """Mesa's arm64 user space as `toolchains` finds it, or CompilerMissing saying what is missing."""
    found = toolchains.locate("mesa_mobile")
    if not found.found:
        raise CompilerMissing(found.missing)
    return found


def split(output: str) -> dict[str, list[str]]:
    """{shader: the lines Mesa printed while compiling it} from the driver's standard error; a
    shader that failed to compile raises ValueError with the compiler's log."""
    out: dict[str, list[str]] = {}
    current = None
    for line in output.splitlines():
        if line.startswith(MARK):
            words = line[len(MARK):].split(maxsplit=2)
            if words[0] == "begin":
                current = words[1]
                out[current] = []
            elif words[0] == "failed":
                raise ValueError(f"Mesa refused the shader {words[1]}: {words[2] if len(words) > 2 else ''}")
            elif words[0] == "end":
                current = None
        elif current is not None:
            out[current].append(line)
    return out


def compile_all(sources: dict[str, str], chip: str, environment: dict[str, str], shim: str) -> tuple[dict[str, list[str]], str]:
    """({name: the lines Mesa printed compiling its GL ES source}, what compiled them) for one chip:
    `environment` the driver's variables (FD_GPU_ID, PAN_GPU_ID, the debug flags), `shim` the
    drm-shim library's file name."""
    found = tools()
    root = Path(found.path)

    def env():
        out = dict(os.environ, **environment, MESA_SHADER_CACHE_DISABLE="true", MESA_LOG="stderr",
                   LIBGL_DRIVERS_PATH=str(root / LIBRARIES / "dri"), EGL_PLATFORM="surfaceless")
        out.pop("LD_PRELOAD", None)
        return out

    command = [toolchains.qemu(), "-L", str(root), "-E", f"LD_PRELOAD={root / LIBRARIES / shim}",
               str(root / "usr/bin/python3.11"), str(DRIVER)]
    running = compiler_process.running(command, tuple(sorted(environment.items())), env)
    batch = json.dumps({f"s{i}": text for i, text in enumerate(sources.values())})
    try:
        printed = split(running.batch(batch, f"{MARK} batch-end", TIMEOUT_S))
    except TimeoutError:
        raise RuntimeError(f"Mesa's compiler ({chip}) under qemu did not finish {len(sources)} shaders in "
                           f"{TIMEOUT_S} s") from None
    except compiler_process.Ended as e:
        raise RuntimeError(f"Mesa's compiler ({chip}) under qemu failed (exit {e.returncode}): "
                           f"{e.printed}") from None
    if len(printed) != len(sources):
        raise RuntimeError(f"Mesa's compiler ({chip}) under qemu printed {len(printed)} of {len(sources)} "
                           "shaders")
    listings = {name: printed[f"s{i}"] for i, name in enumerate(sources)}
    return listings, f"Mesa {found.version} ({Path(found.path).name}, qemu-user)"


def compile_chips(sources: dict[str, str], chips, environment, shim: str) -> dict:
    """`compile_all` for each chip (`environment(chip)` its variables), the chips' processes side
    by side: {chip: (listings, what compiled them)}."""
    from concurrent.futures import ThreadPoolExecutor

    with ThreadPoolExecutor(max(1, len(chips))) as pool:
        futures = {chip: pool.submit(compile_all, sources, chip, environment(chip), shim) for chip in chips}
        return {chip: f.result() for chip, f in futures.items()}


def lower(sources: dict[str, str]) -> dict[str, str]:
    """Every GLSL fragment shader of `sources` as its GL ES twin, through one expression tree."""
    from ..optics import spirv
    from .lowering import operations

    return {name: fragment_shader(*operations(spirv.optimized_disassembly(source))) for name, source in sources.items()}
