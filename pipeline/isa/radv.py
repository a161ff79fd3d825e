"""AMD machine code, by Mesa's RADV driver and its ACO back end, on RADV's null device: no GPU is
needed. glslang's SPIR-V (unoptimized: the driver's own optimizer sees the shader as written) is
compiled into a graphics pipeline per fragment shader (`pipeline.isa.vulkan_pipeline`), once per
chip family (`RADV_FORCE_FAMILY`: gfx1100 RDNA3, navi21 RDNA2, navi10 RDNA1, vega10 GCN5, polaris10
GCN4; Mesa 22.3 takes family names, not gfx numbers).

From each fragment shader's final listing (`RADV_DEBUG=shaders`) the instructions are counted by
kind: vector ALU (v_*, interpolation excluded), transcendental (v_log, v_exp, v_rcp, v_rsq,
v_sqrt, v_sin, v_cos: the quarter-rate unit), scalar (s_*); and ACO's own estimates
(`ACO_DEBUG=perfinfo`): the latency of one wave in cycles and the throughput, as cycles per wave
(1 / wave64_per_cycle). Every count is also given net of the shader's wrapper, measured on the
same chip and subtracted. The cost model (`cycles`, "aco-perfinfo") is ACO's cycles per wave, net
of the wrapper's; `instructions` counts the vector ALU and transcendental instructions, net.
"""

from __future__ import annotations

import os
import re
import sys
import tempfile
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

from ..engine import toolchains
from ..optics import spirv
from . import compiler_process
from .architectures import CompilerMissing

TRANSCENDENTAL = re.compile(r"^v_(exp|log|rcp|rsq|sqrt|sin|cos)_(f16|f32|legacy_f32)")
TIMEOUT_S = 120
PROGRAM = Path(__file__).with_name("vulkan_pipeline.py")    # the Vulkan program the driver compiles in
COST_MODEL = "aco-perfinfo"

VERTEX = """#version 450
layout(location = 0) out float t_out;
layout(location = 1) out float n_out;
layout(location = 2) out float third_out;
layout(location = 3) out float fourth_out;
void main()
{
    vec2 p = vec2(gl_VertexIndex & 1, gl_VertexIndex >> 1);
    t_out = p.x;
    n_out = 1.0 + 999.0 * p.y;
    third_out = 0.5 + 0.25 * p.x;
    fourth_out = 0.25 + 0.5 * p.y;
    gl_Position = vec4(2.0 * p - 1.0, 0.0, 1.0);
}
"""


def radv_icd() -> str:
    """Path of Mesa's radeon ICD json (as `toolchains` finds it), or CompilerMissing saying what is missing."""
    found = toolchains.locate("radv")
    if not found.found:
        raise CompilerMissing(found.missing)
    return found.path


def check_available() -> str:
    """The RADV ICD json path if the compiler can run here; else raises CompilerMissing."""
    try:
        import vulkan  # noqa: F401
    except (ImportError, OSError) as e:
        raise CompilerMissing(f"the Python package vulkan cannot be loaded: {e}") from None
    spirv.tool("glslangValidator")
    return radv_icd()


def spirv_binary(source: str, folder: Path, name: str, stage: str = "frag") -> Path:
    """GLSL `source` compiled to SPIR-V (`spirv.compile_glsl`), as folder/name."""
    return spirv.compile_glsl(source, stage, folder / name, f"shader {name}")


def compile_family(family: str, folder: Path, icd: str) -> str:
    """The driver's stderr for every pipeline of `folder`, compiled for one chip family by this
    process's `vulkan_pipeline.py` for it (`compiler_process`: its device, created once; on RDNA2
    and RDNA3 that compiles 38 of RADV's own compute shaders, 0.2 s)."""
    def env():
        return dict(os.environ, VK_ICD_FILENAMES=icd, RADV_FORCE_FAMILY=family, RADV_DEBUG="shaders,nocache",
                    ACO_DEBUG="perfinfo", MESA_SHADER_CACHE_DISABLE="true",
                    XDG_RUNTIME_DIR=os.environ.get("XDG_RUNTIME_DIR") or tempfile.gettempdir())

    # run as a script (-P: its folder not on sys.path), without importing the pipeline package
    running = compiler_process.running([sys.executable, "-P", str(PROGRAM)], (icd, family), env)
    try:
        printed = running.batch(str(folder), "@@@ END", TIMEOUT_S)
    except TimeoutError:
        raise CompilerMissing(f"RADV could not compile for {family} in {TIMEOUT_S} s") from None
    except compiler_process.Ended as e:
        tail = "\n".join(e.printed.splitlines()[-5:])
        raise CompilerMissing(f"RADV could not compile for {family} (exit {e.returncode}): {tail}") from None
    return printed + "\n@@@ END\n"


def split_shaders(stderr: str) -> dict[str, str]:
    """The driver's output per shader, by the markers `vulkan_pipeline` writes."""
    parts = re.split(r"\n@@@ (SHADER \S+|END)\n", stderr)
    return {parts[i][len("SHADER "):]: parts[i + 1] for i in range(1, len(parts) - 1, 2)
            if parts[i].startswith("SHADER ")}


def parse_fragment(text: str) -> dict:
    """Counts and ACO's estimates of the fragment shader in one pipeline's output."""
    stage = [m.start() for m in re.finditer(r"ACO shader stage: fragment_fs", text)]
    disasm = re.search(r"Pixel Shader\ndisasm:\n(.*?)(?:\n\s*\n|\s*\Z)", text, re.S)
    if not stage or disasm is None:
        raise ValueError("no fragment shader listing in RADV's output (RADV_DEBUG=shaders, ACO_DEBUG=perfinfo)")
    perf = text[stage[-1]:disasm.start()]
    latency = re.search(r"\nlatency: ([\d.]+)", perf)
    per_cycle = re.search(r"\nwave64_per_cycle: ([\d.]+)", perf)
    if latency is None or per_cycle is None:
        raise ValueError("no ACO cycle estimate in RADV's output (ACO_DEBUG=perfinfo)")
    listing = []
    for line in disasm.group(1).splitlines():
        line = line.strip().split(";")[0].strip()
        repeated = re.fullmatch(r"\(then repeated (\d+) times\)", line)
        if repeated:            # the disassembler folds repeats of the instruction above
            listing += [listing[-1]] * int(repeated.group(1))
        elif line and not line.endswith(":"):
            listing.append(line)
    counts = dict(vector_alu=0, transcendental=0, scalar=0, other=0)
    for line in listing:
        op = line.split()[0]
        if TRANSCENDENTAL.match(op):
            counts["transcendental"] += 1
        elif op.startswith("v_") and not op.startswith("v_interp"):
            counts["vector_alu"] += 1
        elif op.startswith("s_"):
            counts["scalar"] += 1
        else:
            counts["other"] += 1
    # ACO prints wave64_per_cycle to 6 decimals: its inverse is good to ~0.01 cycle; kept to 0.1.
    return dict(counts, listing_length=len(listing), latency_cycles=float(latency.group(1)),
                cycles_per_wave=round(1.0 / float(per_cycle.group(1)), 1), listing=listing)


NET_FIELDS = ("vector_alu", "transcendental", "scalar", "other", "listing_length", "latency_cycles", "cycles_per_wave")


def net(parsed: dict, wrapper: dict, chip: str) -> dict:
    """A shader's counts net of its wrapper's (`net_*`), and the fields every back end gives:
    `instructions` (vector ALU and transcendental, net), `special` (transcendental, net) and
    `cycles` (ACO's cycles per wave, net)."""
    out = {f"net_{field}": round(parsed[field] - wrapper[field], 1) if isinstance(parsed[field], float)
           else parsed[field] - wrapper[field] for field in NET_FIELDS}
    return dict(out, instructions=out["net_vector_alu"] + out["net_transcendental"], special=out["net_transcendental"],
                cycles=out["net_cycles_per_wave"], cost_model=COST_MODEL)


def compile_shaders(sources: dict[str, str], chips) -> tuple[dict, dict]:
    """Every fragment shader of `sources` (name -> GLSL) compiled by RADV for each chip family:
    ({chip: {name: `parse_fragment` of it}}, {chip: the driver's device name}). Raises
    CompilerMissing where the compiler cannot run."""
    icd = check_available()
    chips = tuple(chips)
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        with ThreadPoolExecutor(os.cpu_count() or 2) as pool:
            jobs = [pool.submit(spirv_binary, VERTEX, folder, "vert.spv", "vert")]
            jobs += [pool.submit(spirv_binary, source, folder, f"{name}.frag.spv") for name, source in sources.items()]
            for job in jobs:
                job.result()
            outputs = dict(zip(chips, pool.map(lambda f: compile_family(f, folder, icd), chips)))
    compiled, devices = {}, {}
    for family, stderr in outputs.items():
        device = re.search(r"@@@ DEVICE (.*)\n", stderr)
        devices[family] = device.group(1).strip() if device else family
        compiled[family] = {name: parse_fragment(text) for name, text in split_shaders(stderr).items()}
        missing = set(sources) - set(compiled[family])
        if missing:
            raise ValueError(f"RADV ({family}) printed no listing for shaders {sorted(missing)}")
    return compiled, devices


SECONDS_PER_SHADER = 0.008  # CPU seconds per shader and architecture, measured on a 2-core x86-64 machine
MODEL = "ACO's cycles per wave"  # the cost model in a few words
UNIT = "cycles per wave (RADV, ACO's estimate)"


def describe(row) -> str:
    """One shader's net machine code in words."""
    parts = [f"{row['net_vector_alu']} vector ALU"]
    if row["net_transcendental"]:
        parts.append(f"{row['net_transcendental']} transcendental")
    if row["net_scalar"]:
        parts.append(f"{row['net_scalar']} scalar")
    return ", ".join(parts) + f" instructions, {row['cycles']:g} cycles per wave"


def cell(row) -> str:
    """A table cell: vector ALU + transcendental instructions, cycles."""
    return f"{row['net_vector_alu']} + {row['net_transcendental']} T, {row['cycles']:g} cyc"


def method(devices: list[str]) -> str:
    """How the numbers were obtained, for the report."""
    return ("Mesa's RADV driver and its ACO back end on RADV's null device (" + ", ".join(devices) + "). Cycles per "
            "wave: ACO's own throughput estimate (1 / wave64_per_cycle, `aco-perfinfo`), net of the wrapper's. Cells: "
            "vector ALU + transcendental (v_log, v_exp, v_rcp, v_rsq, v_sqrt: the quarter-rate unit) instructions, cycles.")


TOOL = "radv"        # what `pipeline.engine.toolchains` finds for this back end


def check() -> None:
    """CompilerMissing, saying what is missing, where this back end cannot compile here."""
    check_available()
