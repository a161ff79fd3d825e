"""Adreno machine code of a fragment shader's arithmetic, by Mesa's freedreno compiler (ir3).

The shader's operations are printed as a GL ES 3.1 fragment shader (`pipeline.isa.gles`) and
compiled by Mesa's freedreno GL ES driver on its drm-shim null device (`FD_GPU_ID` 630 or 740),
in an arm64 Debian user space under qemu-user; `IR3_SHADER_DEBUG=disasm` prints each listing with
ir3's statistics. This is Mesa's compiler, not Qualcomm's driver.

Counted by ir3's own instruction categories (its statistics line): `alu` (cat2: add, mul, min,
max, compare, the varying's bary.f), `mad` (cat3: multiply-add, select), `sfu` (cat4, the
special-function unit: exp2, log2, rcp, rsq, sqrt, sin, cos), `mov` (cat1: moves and
conversions), `nop` (the nops ir3 inserts to wait for a result: Adreno does not interlock ALU
results, the compiler pads them), and `issue` (ir3's instruction count: every instruction with its
repeats and nops, one issue slot each); every count net of the same shader returning t.

The cost model (`cycles`, "ir3-issue"): cycles per wave as ir3's statistics give them: the issue
slots of the wave's instruction stream (`issue`) plus ir3's estimate of the cycles the wave waits
on the special-function unit at its (ss) syncs (`sstall`) and on memory at its (sy) syncs
(`systall`). Other waves issuing into those slots and the ALU's width per architecture are not
modelled: the cycles rank one architecture's shaders, not two architectures.
"""

from __future__ import annotations

import re

from . import gles

COST_MODEL = "ir3-issue"
CLASSES = ("alu", "mad", "sfu", "mov", "nop", "issue", "sstall", "systall")
PREFIX = "MESA: info: "
STATS = re.compile(r"; FRAG prog \d+/\d+: (.*)$")
FIELDS = {"instr": "issue", "nops": "nop", "cat1": "mov", "cat2": "alu", "cat3": "mad", "cat4": "sfu",
          "sstall": "sstall", "systall": "systall"}
ENVIRONMENT = {"FD_MESA_DEBUG": "serialc", "IR3_SHADER_DEBUG": "disasm"}
SHIM = "libfreedreno_noop_drm_shim.so"


def parse(lines: list[str]) -> dict:
    """ir3's statistics and listing of the (first) fragment shader among the lines Mesa printed
    compiling it: the counts of `CLASSES` and `listing` (the instructions, no comments)."""
    text = [line.removeprefix(PREFIX) for line in lines]
    start = next((i for i, line in enumerate(text) if re.match(r"Native code for .* FRAG shader", line)), None)
    if start is None:
        raise ValueError("ir3 printed no fragment shader listing")
    counts = dict.fromkeys(CLASSES, 0)
    listing, seen = [], set()
    for line in text[start + 1:]:
        m = STATS.match(line)
        if m:
            for value, name in re.findall(r"(\d+) ([\w()-]+)", m.group(1)):
                if name in FIELDS and FIELDS[name] not in seen:
                    counts[FIELDS[name]] = int(value)
                    seen.add(FIELDS[name])
            continue
        if seen and not line.startswith(";"):
            break
        stripped = line.strip()
        if stripped and not stripped.startswith((";", "@", "SIMD")) and not stripped.endswith(":"):
            listing.append(stripped)
    if not {"issue", "alu", "sfu"} <= seen:
        raise ValueError("ir3 printed no statistics for the fragment shader")
    return dict(counts, listing=listing)


def opcode(line: str) -> str:
    """An ir3 line's opcode, without its flags ((ss), (rpt2), (nop3), (ei) ...)."""
    return re.sub(r"^(\([^)]*\))*", "", line).split()[0] if line.strip() else ""


def compile_shaders(sources: dict[str, str], chips) -> tuple[dict, dict]:
    """Every fragment shader of `sources` (name -> GLSL) as GL ES, compiled by freedreno for each
    chip (FD_GPU_ID): ({chip: {name: counts and the listing}}, {chip: what compiled it})."""
    gles.tools()
    lowered = gles.lower(sources)
    done = gles.compile_chips(lowered, chips, lambda chip: dict(ENVIRONMENT, FD_GPU_ID=chip), SHIM)
    compiled = {chip: {name: parse(printed[name]) for name in sources} for chip, (printed, _) in done.items()}
    return compiled, {chip: f"{device}, freedreno FD_GPU_ID={chip}" for chip, (_, device) in done.items()}


def cycles(net: dict) -> float:
    return float(net["issue"] + net["sstall"] + net["systall"])


def net(parsed: dict, wrapper: dict, chip: str) -> dict:
    """Counts net of the wrapper's (`net_*`), and `instructions` (ALU, multiply-add and SFU, net),
    `special` (SFU, net) and `cycles` (ir3's issue slots and stalls, net)."""
    out = {f"net_{c}": parsed[c] - wrapper[c] for c in CLASSES}
    diff = {c: parsed[c] - wrapper[c] for c in CLASSES}
    return dict(out, instructions=out["net_alu"] + out["net_mad"] + out["net_sfu"], special=out["net_sfu"],
                cycles=cycles(diff), cost_model=COST_MODEL)


SECONDS_PER_SHADER = 0.047  # CPU seconds per shader and architecture, measured on a 2-core x86-64 machine
MODEL = "ir3's issue slots and SFU stalls per wave (Mesa's compiler)"  # the cost model in a few words
UNIT = "cycles per wave (Mesa's ir3: issue slots and SFU stalls)"


def describe(row) -> str:
    """One shader's net machine code in words."""
    parts = [f"{row['net_alu'] + row['net_mad']} ALU"]
    if row["net_sfu"]:
        parts.append(f"{row['net_sfu']} SFU")
    return (", ".join(parts) + f" instructions, {row['cycles']:g} cycles per wave (Mesa's ir3 statistics: issue slots "
            "with nops, and SFU stalls)")


def cell(row) -> str:
    """A table cell: ALU and multiply-add + SFU instructions, cycles."""
    return f"{row['net_alu'] + row['net_mad']} + {row['net_sfu']} SFU, {row['cycles']:g} cyc"


def method(devices: list[str]) -> str:
    """How the numbers were obtained, for the report."""
    return ("Mesa's freedreno GL ES driver and its ir3 compiler on the drm-shim null device, in an arm64 user space "
            "under qemu-user (" + devices[0] + " ...): Mesa's compiler, not Qualcomm's driver. The shader's SPIR-V "
            "printed as a GL ES fragment shader (a separable program, its uniforms in the default block). Cycles per "
            "wave from ir3's own statistics (`ir3-issue`): the issue slots of the wave's instructions, the nops ir3 "
            "inserts for latency included, plus its estimate of the cycles stalled on the special-function unit. "
            "Cells: ALU + SFU (exp2, log2, rcp, rsq, sqrt) instructions, cycles.")


TOOL = "mesa_mobile"        # what `pipeline.engine.toolchains` finds for this back end


def check() -> None:
    """CompilerMissing, saying what is missing, where this back end cannot compile here."""
    gles.tools()
