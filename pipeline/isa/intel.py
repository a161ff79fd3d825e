"""Intel machine code (Gen EU assembly) of a fragment shader's arithmetic, by Intel's own offline
compiler.

The shader's operations (`pipeline.isa.lowering`) are printed as an OpenCL C kernel with the
functions an Intel GLSL driver lowers them to under graphics precision (`native_powr`,
`native_exp`, `native_exp2`, `native_log`, `native_log2`, `native_sqrt`, `native_rsqrt`,
`native_sin`, `native_cos`, `native_divide`; `fmax`, `fmin`, `fabs`, `fma`), compiled with
`-cl-fast-relaxed-math` and SIMD16 pinned (`intel_reqd_sub_group_size(16)`, a fragment shader's
width) by `ocloc` (Debian's intel-opencl-icd) for Gen9 (skl), Xe-LP (tgllp) and Xe-HPG (acm-g10),
and disassembled by `ocloc disasm` through IGA (Debian's libigc-tools ships `libiga64.so.1`; ocloc
opens `libiga64.so`, so a link to it is made in a temporary folder on LD_LIBRARY_PATH). The
varyings (t, n) are loaded from a buffer, the per-material uniforms are kernel arguments (push
constants, as a graphics uniform is) and the result is stored, so nothing folds at compile time.
All shaders of a run are kernels of one program per architecture: one ocloc compile and one
disassembly each.

Counted by the unit that runs them: `fpu` (float add, mul, mad, sel, cmp, mov, min and max),
`math` (the extended-math unit: math.exp, .log, .inv, .sqrt, .rsqt, .sin, .cos, .fdiv), `pow`
(math.pow, one instruction on Gen9; Xe lowers pow to log, multiply, exp), `other`; integer
arithmetic (addresses), memory messages (send), synchronization and nops are the harness's and
left out; every count is net of the same kernel returning t.

The cost model (`cycles`, "intel-mesa"): cycles per SIMD16 thread, bound by throughput, from Mesa's
own performance model of Intel's EU (`src/intel/compiler/brw_ir_performance.cpp`, Gfx9 to Xe-HPG):
an FPU instruction occupies the FPU 2 cycles per GRF of its execution size, an extended-math one the
math unit 4 cycles per GRF and pow 8, and the EU front end 2 cycles per GRF of the destination
(math: 4 per GRF, less 2); a SIMD16 float instruction is 2 GRFs of 32 bytes. The cycles are the
largest of the front end's, the FPU's and the math unit's busy cycles. Latency and the co-issue of
FPU0 and FPU1 (Gen8 to Gen11) are not modelled.
"""

from __future__ import annotations

import math
import os
import re
import subprocess
import tempfile
from pathlib import Path

from ..engine import toolchains
from .architectures import CompilerMissing
from .lowering import LoweringError, Op, c_statements

COST_MODEL = "intel-mesa"
CLASSES = ("fpu", "math", "pow", "other")
GRF_BYTES = 32
TIMEOUT_S = 120
FLOAT_OPS = {"add", "mul", "mad", "sel", "cmp", "mov", "max", "min", "csel", "add3"}
HARNESS = re.compile(r"^(send|sends|sendc|sendsc|sync|nop|jmpi|halt|wait|illegal)")
# Back-end and front-end occupancy per GRF of execution / destination size (Mesa's model).
FPU_PER_GRF, MATH_PER_GRF, POW_PER_GRF, FRONT_PER_GRF, MATH_FRONT_OFFSET = 2, 4, 8, 2, -2
CONSTANT_FORMAT = "{:.9g}f"


def _c(value: float) -> str:
    if math.isinf(value):
        return "INFINITY" if value > 0 else "-INFINITY"
    text = CONSTANT_FORMAT.format(value)
    return text if any(c in text for c in ".e") else text.replace("f", ".0f")


def kernel(name: str, ops: list[Op], result: str) -> str:
    """One OpenCL C kernel computing the operations: each varying (t, n) from in[i] (n 1024 floats
    after t), each uniform an argument, the result to out[i]."""
    uniforms = sorted({op.op for op in ops if op.kind == "uniform"})
    inputs = sorted({op.op for op in ops if op.kind == "input"})
    body, names = c_statements(ops, input_expr=lambda name: f"in[i + {1024 * inputs.index(name)}]",
                               uniform_expr=lambda k: f"u{k}", constant=_c, function=_function,
                               divide=lambda x, y: f"native_divide({x}, {y})", float_type="float", bool_type="int",
                               half_type="half")
    params = ", ".join(["__global const float *in", "__global float *out"] + [f"float u{i}" for i in range(len(uniforms))])
    return ("__attribute__((intel_reqd_sub_group_size(16)))\n"
            f"__kernel void {name}({params})\n{{\n  int i = get_global_id(0);\n" + "\n".join(body)
            + f"\n  out[i] = {names[result]};\n}}\n")


def _function(name: str, a: list[str]) -> str:
    """OpenCL C of one GLSL.std.450 function, as an Intel driver lowers it."""
    native = {"Pow": "native_powr", "Exp": "native_exp", "Exp2": "native_exp2", "Log": "native_log",
              "Log2": "native_log2", "Sqrt": "native_sqrt", "InverseSqrt": "native_rsqrt", "Sin": "native_sin",
              "Cos": "native_cos", "FAbs": "fabs", "FMax": "fmax", "NMax": "fmax", "FMin": "fmin", "NMin": "fmin",
              "Fma": "fma"}
    if name in ("FClamp", "NClamp"):
        return f"fmin(fmax({a[0]}, {a[1]}), {a[2]})"
    if name not in native:
        raise LoweringError(f"no OpenCL C lowering for the GLSL.std.450 function {name}")
    return f"{native[name]}({', '.join(a)})"


def program(kernels: dict[str, tuple[list[Op], str]]) -> str:
    """The kernels as one OpenCL C program; cl_khr_fp16 enabled where one computes in float16 (its
    16-bit values `half`; the native functions, which OpenCL defines on float, take and give float
    between conversions)."""
    half = any(op.width == 16 for ops, _ in kernels.values() for op in ops)
    head = "#pragma OPENCL EXTENSION cl_khr_fp16 : enable\n" if half else ""
    return head + "\n".join(kernel(name, *k) for name, k in kernels.items())


def tools() -> str:
    """ocloc as `toolchains` finds it, or CompilerMissing saying what is missing."""
    found = toolchains.locate("intel")
    if not found.found:
        raise CompilerMissing(found.missing)
    return found.path


def assembly(source: str, device: str) -> dict[str, list[str]]:
    """{kernel: its instructions (IGA's text, comments and dependency annotations dropped)} of an
    OpenCL C program compiled by ocloc for `device`."""
    ocloc = tools()
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        (folder / "lobes.cl").write_text(source)
        os.symlink(toolchains.intel_iga(), folder / "libiga64.so")
        env = dict(os.environ, LD_LIBRARY_PATH=os.pathsep.join(filter(None, [tmp, os.environ.get("LD_LIBRARY_PATH")])))
        done = subprocess.run([ocloc, "compile", "-file", "lobes.cl", "-device", device, "-options",
                               "-cl-fast-relaxed-math", "-output", "lobes", "-output_no_suffix", "-q"],
                              capture_output=True, text=True, timeout=TIMEOUT_S, cwd=tmp, env=env)
        if done.returncode != 0 or not (folder / "lobes").is_file():
            raise RuntimeError(f"ocloc ({device}) failed: {(done.stdout + done.stderr).strip()[:2000]}")
        dis = subprocess.run([ocloc, "disasm", "-file", "lobes", "-device", device, "-dump", "dis"],
                             capture_output=True, text=True, timeout=TIMEOUT_S, cwd=tmp, env=env)
        files = sorted((folder / "dis").glob("*_KernelHeap.asm"))
        if dis.returncode != 0 or not files:
            raise CompilerMissing(f"ocloc disasm ({device}) printed no assembly (IGA, libiga64.so from Debian's "
                                  f"libigc-tools): {(dis.stdout + dis.stderr).strip()[-500:]}")
        out = {}
        for path in files:
            lines = []
            for line in path.read_text().splitlines():
                text = re.sub(r"\{[^}]*\}", "", line.split("//")[0]).strip()
                if text and not text.endswith(":"):
                    lines.append(text)
            out[path.name.removesuffix("_KernelHeap.asm")] = lines
    return out


def _instruction(line: str) -> tuple[str, int, str]:
    """(opcode, execution size, destination type) of one IGA line."""
    text = re.sub(r"^\((W|[+\-!~]*f\d\.\d[^)]*)\)\s*", "", line)
    text = re.sub(r"^\((W)\)\s*", "", text)
    words = text.split()
    opcode = words[0] if words else ""
    size = re.search(r"\((\d+)\|M\d+\)", text)
    dtype = re.search(r"<\d+>:(\w+)", text)
    return opcode, int(size.group(1)) if size else 1, dtype.group(1) if dtype else ""


def count(listing: list[str]) -> dict:
    """A listing's instructions by unit (`CLASSES`), the harness's left out, and their occupancy
    in cycles (`busy_front`, `busy_fpu`, `busy_math`) by Mesa's model."""
    counts = dict.fromkeys(CLASSES, 0)
    busy = dict(busy_front=0, busy_fpu=0, busy_math=0)
    for line in listing:
        opcode, size, dtype = _instruction(line)
        base = opcode.split(".")[0]
        if HARNESS.match(opcode) or not opcode:
            continue
        grfs = max(1, math.ceil(size * 4 / GRF_BYTES))
        if base == "math":
            kind = "pow" if opcode == "math.pow" else "math"
            counts[kind] += 1
            busy["busy_math"] += (POW_PER_GRF if kind == "pow" else MATH_PER_GRF) * grfs
            busy["busy_front"] += max(MATH_PER_GRF * grfs + MATH_FRONT_OFFSET, 0)
        elif base in FLOAT_OPS and dtype in ("f", "hf"):
            counts["fpu"] += 1
            busy["busy_fpu"] += FPU_PER_GRF * grfs
            busy["busy_front"] += FRONT_PER_GRF * grfs
        elif dtype in ("f", "hf"):
            counts["other"] += 1
            busy["busy_fpu"] += FPU_PER_GRF * grfs
            busy["busy_front"] += FRONT_PER_GRF * grfs
    return dict(counts, **busy)


def compile_shaders(sources: dict[str, str], chips) -> tuple[dict, dict]:
    """Every fragment shader of `sources` (name -> GLSL) printed as OpenCL C and compiled by ocloc
    for each device, one program per device: ({chip: {name: counts and the listing}}, {chip: what
    compiled it}). Raises CompilerMissing where ocloc or IGA is not installed."""
    from ..optics import spirv
    from .lowering import operations

    tools()
    lowered = {name: operations(spirv.optimized_disassembly(source)) for name, source in sources.items()}
    source = program(lowered)
    compiled, devices = {}, {}
    for chip in chips:
        listings = assembly(source, chip)
        missing = set(sources) - set(listings)
        if missing:
            raise ValueError(f"ocloc ({chip}) printed no assembly for {sorted(missing)}")
        compiled[chip] = {name: dict(count(listings[name]), listing=listings[name]) for name in sources}
        devices[chip] = f"ocloc {toolchains.locate('intel').version} -device {chip}"
    return compiled, devices


def cycles(net: dict) -> float:
    """Cycles per SIMD16 thread by the throughput model, from occupancies net of the wrapper."""
    return float(max(net["busy_front"], net["busy_fpu"], net["busy_math"], 0))


def net(parsed: dict, wrapper: dict, chip: str) -> dict:
    """A shader's counts by unit net of its wrapper's (`net_*`), and the fields every back end
    gives: `instructions` (FPU, math and pow instructions, net), `special` (math and pow, net) and
    `cycles` (the throughput model on the net occupancies)."""
    out = {f"net_{c}": parsed[c] - wrapper[c] for c in CLASSES}
    busy = {k: parsed[k] - wrapper[k] for k in ("busy_front", "busy_fpu", "busy_math")}
    return dict(out, instructions=out["net_fpu"] + out["net_math"] + out["net_pow"],
                special=out["net_math"] + out["net_pow"], cycles=cycles(busy), cost_model=COST_MODEL)


SECONDS_PER_SHADER = 0.011  # CPU seconds per shader and architecture, measured on a 2-core x86-64 machine
MODEL = "Mesa's EU model's cycles per SIMD16 thread"  # the cost model in a few words
UNIT = "cycles per SIMD16 thread (ocloc, Mesa's model)"


def describe(row) -> str:
    """One shader's net machine code in words."""
    parts = [f"{row['net_fpu']} FPU"]
    if row["net_math"] or row["net_pow"]:
        parts.append(f"{row['net_math'] + row['net_pow']} extended math")
    return ", ".join(parts) + f" instructions, {row['cycles']:g} cycles per SIMD16 thread (Mesa's model)"


def cell(row) -> str:
    """A table cell: FPU + extended-math instructions, cycles."""
    return f"{row['net_fpu']} + {row['net_math'] + row['net_pow']} EM, {row['cycles']:g} cyc"


def method(devices: list[str]) -> str:
    """How the numbers were obtained, for the report."""
    return ("the shader's SPIR-V printed as OpenCL C with the native_* functions a graphics driver uses, SIMD16, "
            "compiled by Intel's ocloc and disassembled through IGA (" + devices[0] + " ...). Cycles per SIMD16 thread "
            "by Mesa's model of the EU (`intel-mesa`, brw_ir_performance.cpp): the largest of the front end's, the "
            "FPU's (2 cycles per GRF) and the extended-math unit's (4 per GRF, pow 8) busy cycles. Cells: FPU + "
            "extended-math instructions, cycles.")


TOOL = "intel"        # what `pipeline.engine.toolchains` finds for this back end


def check() -> None:
    """CompilerMissing, saying what is missing, where this back end cannot compile here."""
    tools()
