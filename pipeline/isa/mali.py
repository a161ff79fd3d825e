"""Mali machine code of a fragment shader's arithmetic, by Mesa's panfrost compiler (Bifrost and
Valhall back ends).

The shader's operations are printed as a GL ES 3.1 fragment shader (`pipeline.isa.gles`) and
compiled by Mesa's panfrost GL ES driver on its drm-shim null device (`PAN_GPU_ID` 0x6221 for
Mali-G72, Bifrost; 0xa867 for Mali-G610, Valhall), in an arm64 Debian user space under qemu-user;
`BIFROST_MESA_DEBUG=shaders,shaderdb` prints each listing and the compiler's statistics. This is
Mesa's compiler, not Arm's driver.

Counted from the final listing: `arith` (floating-point arithmetic: FMA, FADD, min, max, compare,
select ...), `sfu` (the transcendental unit's operations: FEXP, FLOGD, FRCP, FRSQ, FSIN, FCOS and
their table steps), `cvt` (conversions between float and integer, as pow and exp2 need), and
`inst` (the compiler's instruction count); the harness (the varying's load, the blend, the alpha
test, moves of constants, address arithmetic, branches, nops) is left out, and every count is net
of the same shader returning t.

The cost model (`cycles`, "mali-mesa"), per 64 threads (the width of an AMD wave), in the units of
the compiler's own per-thread estimate (Arm Mobile Studio's heuristic, which Mesa's authors say
they match), net of the wrapper's:
- Valhall: the busiest of the FMA (/64), CVT (/64) and SFU (/16) units as the compiler prints them
  (x 64: one FMA or conversion is 1 cycle, a transcendental 4).
- Bifrost: an execution engine issues one tuple a cycle, an FMA-unit and an ADD-unit operation
  (transcendentals on the ADD unit), at the compiler's 24 tuples per cycle; the tuples a shader
  needs are bounded below by the larger of its FMA-slot and ADD-slot operations, and that bound is
  the cost (x 64 / 24: 2.67 cycles a tuple). The compiler's own tuple count (`arith_cycles`, kept)
  is not: a tiny shader's few operations fill the wrapper's empty slots, so that a cube came out
  cheaper than a square.
Varying, texture and load-store cycles are the harness's and left out. The cycles rank one
architecture's shaders, not two architectures.
"""

from __future__ import annotations

import re

from . import gles

COST_MODEL = "mali-mesa"
THREADS = 64                # cycles per 64 threads: the compiler's per-thread estimate x 64
BIFROST_TUPLES_PER_CYCLE = 24       # Mesa's normalization of Bifrost's arithmetic (bi_print_stats)
CLASSES = ("arith", "sfu", "cvt", "inst", "fma_slot", "add_slot")
UNITS = ("arith_cycles", "fma_cycles", "cvt_cycles", "sfu_cycles")
ENVIRONMENT = {"BIFROST_MESA_DEBUG": "shaders,shaderdb"}
SHIM = "libpanfrost_noop_drm_shim.so"
STATS = re.compile(r"SHADER-DB: MESA_SHADER_FRAGMENT shader: (.*)$")
SFU = re.compile(r"^(FEXP|FLOGD|FLOG_TABLE|FRCP|FRSQ|FSQRT|FSIN|FCOS|FPOW|FATAN|FEXP_TABLE|FRCP_APPROX|FRSQ_APPROX)")
CVT = re.compile(r"^([SUF](8|16|32|64)_TO_[SUF](8|16|32|64)|FREXP|FROUND|V2F32_TO_V2F16|F16_TO_F32|F32_TO_F16)")
HARNESS = re.compile(r"^(NOP|MOV|LD_|LEA_|ST_|ATEST|BLEND|BRANCH|IADD_IMM|LOAD|STORE|ZS_EMIT|DISCARD|VAR_TEX)")


def opcode(line: str) -> str:
    """A listing line's opcode: "*FMA.f32 r0:t0, ..." and "FMA.f32 r0, ..." are FMA."""
    text = line.strip().lstrip("*+")
    text = re.sub(r"^r\d+\s*=\s*", "", text)
    return text.split()[0].split(".")[0] if text else ""


def final_listing(text: list[str]) -> list[str]:
    """The instructions of the final disassembly: Bifrost's clauses from the last `clause_0:`, or
    Valhall's lines after the IR's last closing brace."""
    end = next(i for i, line in enumerate(text) if STATS.search(line))
    clause = [i for i in range(end) if text[i].strip() == "clause_0:"]
    start = clause[-1] if clause else max(i for i in range(end) if text[i].strip() == "}")
    out = []
    for line in text[start + 1:end]:
        s = line.strip()
        if not s or s.endswith(":") or s in ("{", "}") or s.startswith(("ds(", "slot ")):
            continue
        out.append(s)
    return out


def parse(lines: list[str]) -> dict:
    """The compiler's statistics and the final listing's counts (`CLASSES`, `UNITS`, `listing`)."""
    text = [line.removeprefix("MESA: info: ") for line in lines]
    stats = next((STATS.search(line) for line in text if STATS.search(line)), None)
    if stats is None:
        raise ValueError("panfrost printed no statistics for the fragment shader")
    values = {name: float(value) for value, name in re.findall(r"([\d.]+) ([a-z]+)", stats.group(1))}
    listing = final_listing(text)
    counts = dict(arith=0, sfu=0, cvt=0, inst=int(values["inst"]), fma_slot=0, add_slot=0)
    for line in listing:
        op = opcode(line)
        if not op or HARNESS.match(op):
            continue
        counts["sfu" if SFU.match(op) else "cvt" if CVT.match(op) else "arith"] += 1
        if line.lstrip().startswith("*"):           # Bifrost: the tuple's FMA slot
            counts["fma_slot"] += 1
        elif line.lstrip().startswith("+"):         # and its ADD slot (transcendentals run there)
            counts["add_slot"] += 1
    units = dict(arith_cycles=values.get("arith", 0.0), fma_cycles=values.get("fma", 0.0),
                 cvt_cycles=values.get("cvt", 0.0), sfu_cycles=values.get("sfu", 0.0))
    return dict(counts, **units, listing=listing)


def compile_shaders(sources: dict[str, str], chips) -> tuple[dict, dict]:
    """Every fragment shader of `sources` (name -> GLSL) as GL ES, compiled by panfrost for each
    chip (PAN_GPU_ID): ({chip: {name: counts and the listing}}, {chip: what compiled it})."""
    gles.tools()
    lowered = gles.lower(sources)
    done = gles.compile_chips(lowered, chips, lambda chip: dict(ENVIRONMENT, PAN_GPU_ID=chip), SHIM)
    compiled = {chip: {name: parse(printed[name]) for name in sources} for chip, (printed, _) in done.items()}
    return compiled, {chip: f"{device}, panfrost PAN_GPU_ID={chip}" for chip, (_, device) in done.items()}


def valhall(chip: str) -> bool:
    """Valhall (Mali-G57 and newer, product ids from 0x9000) or Bifrost."""
    return int(chip, 16) >= 0x9000


def cycles(net: dict, chip: str) -> float:
    """Cycles per 64 threads from counts net of the wrapper's: Valhall's per-thread unit cycles as
    the compiler prints them; Bifrost's tuples as its issue bound, the larger of the FMA-slot and
    ADD-slot operations, at the compiler's 24 tuples per cycle."""
    if valhall(chip):
        return THREADS * float(max(net["fma_cycles"], net["cvt_cycles"], net["sfu_cycles"], 0.0))
    return THREADS * float(max(net["fma_slot"], net["add_slot"], 0)) / BIFROST_TUPLES_PER_CYCLE


def net(parsed: dict, wrapper: dict, chip: str) -> dict:
    """Counts net of the wrapper's (`net_*`), and `instructions` (arithmetic, SFU and conversions,
    net), `special` (SFU, net) and `cycles` (the compiler's estimate, net)."""
    out = {f"net_{c}": parsed[c] - wrapper[c] for c in CLASSES}
    diff = {u: parsed[u] - wrapper[u] for u in UNITS + ("fma_slot", "add_slot")}
    return dict(out, instructions=out["net_arith"] + out["net_sfu"] + out["net_cvt"], special=out["net_sfu"],
                cycles=round(cycles(diff, chip), 3), cost_model=COST_MODEL)


SECONDS_PER_SHADER = 0.037  # CPU seconds per shader and architecture, measured on a 2-core x86-64 machine
MODEL = "panfrost's estimate per 64 threads (Mesa's compiler)"  # the cost model in a few words
UNIT = "cycles per 64 threads (Mesa's panfrost estimate)"


def describe(row) -> str:
    """One shader's net machine code in words."""
    parts = [f"{row['net_arith']} arithmetic"]
    if row["net_sfu"]:
        parts.append(f"{row['net_sfu']} SFU")
    if row["net_cvt"]:
        parts.append(f"{row['net_cvt']} conversion")
    return ", ".join(parts) + f" instructions, {row['cycles']:g} cycles per 64 threads (Mesa's panfrost estimate)"


def cell(row) -> str:
    """A table cell: arithmetic and conversion + SFU instructions, cycles."""
    return f"{row['net_arith'] + row['net_cvt']} + {row['net_sfu']} SFU, {row['cycles']:g} cyc"


def method(devices: list[str]) -> str:
    """How the numbers were obtained, for the report."""
    return ("Mesa's panfrost GL ES driver and its Bifrost (Mali-G72) and Valhall (Mali-G610) compilers on the "
            "drm-shim null device, in an arm64 user space under qemu-user (" + devices[0] + " ...): Mesa's compiler, "
            "not Arm's driver. The shader printed as a GL ES fragment shader, as for Adreno. Cycles per 64 threads in "
            "the units of the compiler's per-thread estimate (Arm Mobile Studio's, `mali-mesa`), net of the wrapper's: "
            "on Valhall the busiest of the FMA (/64), CVT (/64) and SFU (/16) units as the compiler prints them; on "
            "Bifrost the tuples the shader needs at least (the larger of its FMA-unit and ADD-unit operations: a "
            "tuple holds one of each) at the compiler's 24 tuples per cycle, as its own tuple count lets a tiny "
            "shader's operations fill the wrapper's empty slots. Cells: arithmetic and conversion + SFU (FEXP, "
            "FLOGD, FRCP, FRSQ) instructions, cycles.")


TOOL = "mesa_mobile"        # what `pipeline.engine.toolchains` finds for this back end


def check() -> None:
    """CompilerMissing, saying what is missing, where this back end cannot compile here."""
    gles.tools()
