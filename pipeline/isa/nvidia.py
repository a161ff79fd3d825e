"""NVIDIA machine code (SASS) of a fragment shader's arithmetic, by NVIDIA's own offline compiler.

The shader's operations (`pipeline.isa.lowering`, from glslang's optimized SPIR-V) are printed as a
PTX kernel (a shader computing in float16: `_half`) with the instructions an NVIDIA GLSL driver lowers them to under graphics precision:
pow x^y as lg2.approx, mul, ex2.approx; exp as a multiply by log2(e) and ex2.approx; log2 and sqrt,
1/sqrt, sin and cos as their .approx instructions; a division as div.approx (MUFU.RCP and a
multiply); max, min and abs; every float instruction with .ftz (without it ptxas adds range
fix-ups around each MUFU, which a graphics driver does not), and add and mul without a rounding
mode, so that ptxas may contract them into FFMA as drivers do. The varyings (t, n) are loaded from
global memory, the per-material uniforms are kernel parameters (constant-bank operands, as a
graphics uniform is) and the result is stored, so nothing folds at compile time. `ptxas` (pip `nvidia-cuda-nvcc-cu12`) compiles the kernel for each architecture and
`cuobjdump -sass` (pip `nvidia-cuda-cuobjdump`, which runs `nvidia-cuda-nvdisasm`; 13.x reads
sm_75 and newer) prints the SASS.

Counted by the pipe that runs them: `fma` (FADD, FMUL, FFMA, and their FTZ forms; HADD2, HMUL2,
HFMA2 in float16), `alu` (FMNMX,
FSEL, FSETP: compare, minimum and maximum), `mufu` (the special-function unit: MUFU.EX2, .LG2,
.RCP, .RSQ, .SQRT, .SIN, .COS), `other` (moves, conversions); the harness's own instructions (the
loads, the store, the thread index and its address) are left out, and every count is net of the
same kernel returning t. All shaders of a run are entries of one PTX module per architecture: one
ptxas and one cuobjdump each.

The cost model (`cycles`, "nvidia-throughput"): cycles per warp on one SM sub-partition (an SM has
four), bound by throughput: the largest of the issue slots (one instruction per cycle) and each
pipe's busy cycles, count x 32 / (the pipe's results per clock per SM / 4). The results per clock
per SM are the CUDA C++ Programming Guide's table "Throughput of Native Arithmetic Instructions"
(32-bit floating-point add, multiply, multiply-add: 64 on compute capability 7.5, 128 on 8.6, 8.9,
9.0 and 12.0; compare, minimum, maximum: 64; reciprocal, reciprocal square root, base-2 logarithm
and exponential, sine, cosine: 16). Latency, register pressure and occupancy are not modelled.
"""

from __future__ import annotations

import re
import subprocess
import tempfile
from pathlib import Path

from ..engine import toolchains
from .architectures import CompilerMissing
from .lowering import LoweringError, Op

# Results per clock per SM (CUDA C++ Programming Guide, "Throughput of Native Arithmetic Instructions").
THROUGHPUT = {
    "sm_75": {"fma": 64, "alu": 64, "mufu": 16},
    "sm_86": {"fma": 128, "alu": 64, "mufu": 16},
    "sm_89": {"fma": 128, "alu": 64, "mufu": 16},
    "sm_90": {"fma": 128, "alu": 64, "mufu": 16},
    "sm_120": {"fma": 128, "alu": 64, "mufu": 16},
}
COST_MODEL = "nvidia-throughput"
WARP = 32
SUB_PARTITIONS = 4
PTX_VERSION = "8.7"                 # sm_120 needs PTX ISA 8.7 (CUDA 12.8)
LOG2_E = 1.4426950408889634
LN_2 = 0.6931471805599453
INV_2PI = 0.15915494309189535
TIMEOUT_S = 60
PIPES = {"fma": re.compile(r"^(FADD|FMUL|FFMA|HADD2|HMUL2|HFMA2)\b"), "alu": re.compile(r"^(FMNMX|FSEL|FSETP)\b"),
         "mufu": re.compile(r"^MUFU\.")}
# The harness, not the shader's arithmetic: memory, the thread index, the address, the end.
HARNESS = re.compile(r"^(LDG|STG|LDC|ULDC|LDCU|S2R|S2UR|EXIT|BRA|NOP|IMAD\.WIDE)\b")
CLASSES = ("fma", "alu", "mufu", "other")


def _hex(value: float) -> str:
    import struct
    return "0f%08X" % struct.unpack("<I", struct.pack("<f", value))[0]


def kernel(name: str, ops: list[Op], result: str) -> str:
    """One PTX entry computing the operations: each varying (t, n) from in[thread] (n 1024 floats
    after t), each uniform a kernel parameter (read from the constant bank, as a graphics uniform
    is), the result to out[thread]."""
    inputs = sorted({op.op for op in ops if op.kind == "input"})
    uniforms = sorted({op.op for op in ops if op.kind == "uniform"})
    reg: dict[str, str] = {}
    body: list[str] = []
    count = [0]

    def new(kind="f") -> str:
        count[0] += 1
        return f"%{kind}{count[0]}"

    for op in ops:
        a = [reg[x] for x in op.args]
        if op.width == 16:
            r = new("p" if op.kind == "compare" else "h")
            body += _half(op, r, a, reg, new)
            reg[op.name] = r
            continue
        r = new("p" if op.kind == "compare" else "f")
        if op.kind == "input":
            body.append(f"ld.global.f32 {r}, [%rin+{4096 * inputs.index(op.op)}];")
        elif op.kind == "uniform":
            body.append(f"ld.param.f32 {r}, [u{uniforms.index(op.op)}];")
        elif op.kind == "constant":
            body.append(f"mov.f32 {r}, {_hex(op.value)};")
        elif op.kind == "convert":
            body.append(f"cvt.f32.f16 {r}, {a[0]};")
        elif op.kind == "arithmetic":
            if op.op == "FNegate":
                body.append(f"neg.ftz.f32 {r}, {a[0]};")
            else:
                instruction = {"FAdd": "add.ftz", "FSub": "sub.ftz", "FMul": "mul.ftz", "FDiv": "div.approx.ftz"}[op.op]
                body.append(f"{instruction}.f32 {r}, {a[0]}, {a[1]};")
        elif op.kind == "function":
            body += _function(op.op, r, a, new)
        elif op.kind == "compare":
            body.append(f"setp.{op.op}.ftz.f32 {r}, {a[0]}, {a[1]};")
        elif op.kind == "select":
            body.append(f"selp.f32 {r}, {a[1]}, {a[2]}, {a[0]};")
        reg[op.name] = r
    size = count[0] + 1
    params = [".param .u64 p_in", ".param .u64 p_out"] + [f".param .f32 u{i}" for i in range(len(uniforms))]
    lines = [f".visible .entry {name}(" + ", ".join(params) + ")", "{",
             "  .reg .b64 %rd<8>;", "  .reg .b64 %rin, %rbase;", "  .reg .b32 %r1;",
             f"  .reg .f32 %f<{size}>;", f"  .reg .b16 %h<{size}>;", f"  .reg .pred %p<{size}>;",
             "  ld.param.u64 %rd1, [p_in];", "  ld.param.u64 %rd2, [p_out];",
             "  cvta.to.global.u64 %rbase, %rd1;", "  cvta.to.global.u64 %rd4, %rd2;",
             "  mov.u32 %r1, %tid.x;", "  mul.wide.u32 %rd5, %r1, 4;", "  add.s64 %rin, %rbase, %rd5;"]
    lines += ["  " + line for line in body]
    lines += ["  add.s64 %rd7, %rd4, %rd5;", f"  st.global.f32 [%rd7], {reg[result]};", "  ret;", "}", ""]
    return "\n".join(lines)


def module(kernels: dict[str, tuple[list[Op], str]], architecture: str) -> str:
    """A PTX module of one entry per shader (name -> its operations and result) for `architecture`."""
    header = [f".version {PTX_VERSION}", f".target {architecture}", ".address_size 64", ""]
    return "\n".join(header) + "\n".join(kernel(name, *k) for name, k in kernels.items())


def _half_hex(value: float) -> str:
    import numpy as np
    return "0x%04X" % int(np.float16(value).view(np.uint16))


def _half(op: Op, r: str, a: list[str], reg: dict, new) -> list[str]:
    """PTX of one float16 operation (a shader with explicit 16-bit types): + - * and fma, negation,
    compare and select in half precision (HADD, HMUL, HFMA2 on sm_53 and newer), exp2 as
    ex2.approx.f16 (sm_75 and newer); a division and every other function in float32 between
    conversions (the MUFU computes in float32), as NVIDIA's compiler lowers them for half."""
    if op.kind == "constant":
        return [f"mov.b16 {r}, {_half_hex(op.value)};"]
    if op.kind == "convert":
        return [f"cvt.rn.f16.f32 {r}, {a[0]};"]
    if op.kind == "arithmetic" and op.op != "FDiv":
        if op.op == "FNegate":
            return [f"neg.f16 {r}, {a[0]};"]
        return [f"{ {'FAdd': 'add', 'FSub': 'sub', 'FMul': 'mul'}[op.op]}.f16 {r}, {a[0]}, {a[1]};"]
    if op.kind == "function" and op.op == "Exp2":
        return [f"ex2.approx.f16 {r}, {a[0]};"]
    if op.kind == "function" and op.op == "Fma":
        return [f"fma.rn.f16 {r}, {a[0]}, {a[1]}, {a[2]};"]
    if op.kind == "compare":
        return [f"setp.{op.op}.f16 {r}, {a[0]}, {a[1]};"]
    if op.kind == "select":
        return [f"selp.b16 {r}, {a[1]}, {a[2]}, {a[0]};"]
    if op.kind in ("arithmetic", "function"):
        wide = [new() for _ in a]
        lines = [f"cvt.f32.f16 {w}, {x};" for w, x in zip(wide, a)]
        result = new()
        if op.kind == "arithmetic":
            lines.append(f"div.approx.ftz.f32 {result}, {wide[0]}, {wide[1]};")
        else:
            lines += _function(op.op, result, wide, new)
        return lines + [f"cvt.rn.f16.f32 {r}, {result};"]
    raise LoweringError(f"no PTX lowering for a float16 {op.kind}")


def _function(name: str, r: str, a: list[str], new) -> list[str]:
    """PTX of one GLSL.std.450 function, as a driver lowers it."""
    if name == "Pow":
        lg, m = new(), new()
        return [f"lg2.approx.ftz.f32 {lg}, {a[0]};", f"mul.ftz.f32 {m}, {lg}, {a[1]};", f"ex2.approx.ftz.f32 {r}, {m};"]
    if name == "Exp":
        m = new()
        return [f"mul.ftz.f32 {m}, {a[0]}, {_hex(LOG2_E)};", f"ex2.approx.ftz.f32 {r}, {m};"]
    if name == "Log":
        lg = new()
        return [f"lg2.approx.ftz.f32 {lg}, {a[0]};", f"mul.ftz.f32 {r}, {lg}, {_hex(LN_2)};"]
    single = {"Exp2": "ex2.approx.ftz", "Log2": "lg2.approx.ftz", "Sqrt": "sqrt.approx.ftz",
              "InverseSqrt": "rsqrt.approx.ftz", "Sin": "sin.approx.ftz", "Cos": "cos.approx.ftz", "FAbs": "abs.ftz"}
    if name in single:
        return [f"{single[name]}.f32 {r}, {a[0]};"]
    if name in ("FMax", "NMax"):
        return [f"max.ftz.f32 {r}, {a[0]}, {a[1]};"]
    if name in ("FMin", "NMin"):
        return [f"min.ftz.f32 {r}, {a[0]}, {a[1]};"]
    if name in ("FClamp", "NClamp"):
        m = new()
        return [f"max.ftz.f32 {m}, {a[0]}, {a[1]};", f"min.ftz.f32 {r}, {m}, {a[2]};"]
    if name == "Fma":
        return [f"fma.rn.ftz.f32 {r}, {a[0]}, {a[1]}, {a[2]};"]
    raise LoweringError(f"no PTX lowering for the GLSL.std.450 function {name}")


def tools() -> tuple[str, str]:
    """(ptxas, cuobjdump) as `toolchains` finds them, or CompilerMissing saying what is missing."""
    found = toolchains.locate("nvidia")
    if not found.found:
        raise CompilerMissing(found.missing)
    return found.path, toolchains.nvidia_tools()["cuobjdump"]


def sass(source: str, architecture: str) -> dict[str, list[str]]:
    """{entry: its SASS instructions (opcode and operands; addresses, encodings and predicate guards
    dropped)} of a PTX module compiled by ptxas for `architecture`."""
    ptxas, cuobjdump = tools()
    with tempfile.TemporaryDirectory() as tmp:
        src, cubin = Path(tmp) / "lobes.ptx", Path(tmp) / "lobes.cubin"
        src.write_text(source)
        done = subprocess.run([ptxas, f"-arch={architecture}", str(src), "-o", str(cubin)], capture_output=True,
                              text=True, timeout=TIMEOUT_S)
        if done.returncode != 0:
            raise RuntimeError(f"ptxas ({architecture}) failed: {done.stderr.strip()[:2000]}")
        listing = subprocess.run([cuobjdump, "-sass", str(cubin)], capture_output=True, text=True,
                                 timeout=TIMEOUT_S, env=toolchains.nvidia_env())
    if listing.returncode != 0:
        raise RuntimeError(f"cuobjdump ({architecture}) failed: {listing.stderr.strip()}")
    out: dict[str, list[str]] = {}
    current = None
    for line in listing.stdout.splitlines():
        function = re.match(r"\s+Function : (\S+)", line)
        if function:
            current = out.setdefault(function.group(1), [])
            continue
        m = re.match(r"\s+/\*[0-9a-f]{4}\*/\s+(.*?);", line)
        if m and current is not None and not (current and current[-1].startswith("EXIT")):
            current.append(re.sub(r"^@!?U?P\w+\s+", "", m.group(1).strip()))
    return out


def count(listing: list[str]) -> dict:
    """A SASS listing's instructions by pipe (`CLASSES`), the harness's left out."""
    counts = dict.fromkeys(CLASSES, 0)
    for line in listing:
        if HARNESS.match(line):
            continue
        pipe = next((p for p, pattern in PIPES.items() if pattern.match(line)), "other")
        counts[pipe] += 1
    return counts


def cycles(net: dict[str, int], architecture: str) -> float:
    """Cycles per warp on one SM sub-partition by the throughput model, from instruction counts
    net of the wrapper: the largest of the issue slots and each pipe's busy cycles."""
    rates = THROUGHPUT[architecture]
    busy = [net[pipe] * WARP / (rates[pipe] / SUB_PARTITIONS) for pipe in rates]
    issued = sum(net[c] for c in CLASSES)
    return float(max([issued] + busy))


def compile_shaders(sources: dict[str, str], chips) -> tuple[dict, dict]:
    """Every fragment shader of `sources` (name -> GLSL) lowered to PTX and compiled by ptxas for
    each architecture, one module per architecture: ({chip: {name: counts by pipe and the
    listing}}, {chip: what compiled it}). Raises CompilerMissing where ptxas or cuobjdump is not
    installed, LoweringError naming an operation no lowering knows."""
    from ..optics import spirv
    from .lowering import operations

    tools()
    lowered = {name: operations(spirv.optimized_disassembly(source)) for name, source in sources.items()}
    compiled, devices = {}, {}
    for chip in chips:
        listings = sass(module(lowered, chip), chip)
        missing = set(sources) - set(listings)
        if missing:
            raise ValueError(f"cuobjdump ({chip}) printed no SASS for {sorted(missing)}")
        compiled[chip] = {name: dict(count(listings[name]), listing=listings[name]) for name in sources}
        devices[chip] = f"ptxas {toolchains.locate('nvidia').version.split(',')[0].split()[-1]} -arch={chip}"
    return compiled, devices


def net(parsed: dict, wrapper: dict, chip: str) -> dict:
    """A shader's counts by pipe net of its wrapper's (`net_*`), and the fields every back end
    gives: `instructions` (FP32, compare and special-function instructions, net), `special` (MUFU,
    net) and `cycles` (the throughput model on the net counts)."""
    out = {f"net_{c}": parsed[c] - wrapper[c] for c in CLASSES}
    counts = {c: out[f"net_{c}"] for c in CLASSES}
    return dict(out, instructions=counts["fma"] + counts["alu"] + counts["mufu"], special=counts["mufu"],
                cycles=cycles(counts, chip), cost_model=COST_MODEL)


SECONDS_PER_SHADER = 0.0055  # CPU seconds per shader and architecture, measured on a 2-core x86-64 machine
MODEL = "a throughput model's cycles per warp"  # the cost model in a few words
UNIT = "cycles per warp (ptxas, throughput model)"


def describe(row) -> str:
    """One shader's net machine code in words."""
    parts = [f"{row['net_fma']} FP32"]
    if row["net_alu"]:
        parts.append(f"{row['net_alu']} compare/min/max")
    if row["net_mufu"]:
        parts.append(f"{row['net_mufu']} MUFU")
    if row["net_other"]:
        parts.append(f"{row['net_other']} other")
    return ", ".join(parts) + f" instructions, {row['cycles']:g} cycles per warp (throughput model)"


def cell(row) -> str:
    """A table cell: FP32 and compare + MUFU instructions, cycles."""
    return f"{row['net_fma'] + row['net_alu']} + {row['net_mufu']} MUFU, {row['cycles']:g} cyc"


def method(devices: list[str]) -> str:
    """How the numbers were obtained, for the report."""
    return ("the shader's SPIR-V lowered to PTX as a graphics driver lowers it (lg2/ex2.approx, .ftz), compiled by "
            "NVIDIA's ptxas and read back as SASS by cuobjdump (" + devices[0] + " ...). Cycles per warp on one SM "
            "sub-partition by a throughput model (`nvidia-throughput`): the largest of the issue slots and each pipe's "
            "busy cycles at the CUDA C++ Programming Guide's results per clock per SM (FP32 64 on sm_75, 128 after; "
            "compare/min/max 64; MUFU 16). Cells: FP32 + MUFU instructions, cycles.")


TOOL = "nvidia"        # what `pipeline.engine.toolchains` finds for this back end


def check() -> None:
    """CompilerMissing, saying what is missing, where this back end cannot compile here."""
    tools()
