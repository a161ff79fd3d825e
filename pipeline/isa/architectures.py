"""The GPU architectures the pipeline compiles for, one registry: each is named as its vendor names
it (the name the CLI and every table use), with its vendor, the chip its compiler is told, and the
back end module of `pipeline.isa` that compiles for it (which states its cost model). Each vendor's
newest first: tables and figures show its first architecture as the vendor's."""

from __future__ import annotations

import dataclasses


class CompilerMissing(RuntimeError):
    """A back end's compiler is not installed here; the message says what is missing and how to
    install it."""


@dataclasses.dataclass(frozen=True)
class Architecture:
    """`name` as the CLI takes it (rdna3, sm_86), `vendor` (amd, nvidia), `chip` what its
    compiler is told (RADV_FORCE_FAMILY's family name, ptxas's -arch, ocloc's -device, freedreno's
    FD_GPU_ID, panfrost's PAN_GPU_ID), `title` its vendor's name
    for it, `backend` the module of `pipeline.isa` that compiles for it."""

    name: str
    vendor: str
    chip: str
    title: str
    backend: str


ARCHITECTURES = {a.name: a for a in (
    Architecture("rdna3", "amd", "gfx1100", "RDNA3", "radv"),
    Architecture("rdna2", "amd", "navi21", "RDNA2", "radv"),
    Architecture("rdna1", "amd", "navi10", "RDNA1", "radv"),
    Architecture("gcn5", "amd", "vega10", "GCN5", "radv"),
    Architecture("gcn4", "amd", "polaris10", "GCN4", "radv"),
    Architecture("sm_120", "nvidia", "sm_120", "Blackwell", "nvidia"),
    Architecture("sm_90", "nvidia", "sm_90", "Hopper", "nvidia"),
    Architecture("sm_89", "nvidia", "sm_89", "Ada", "nvidia"),
    Architecture("sm_86", "nvidia", "sm_86", "Ampere", "nvidia"),
    Architecture("sm_75", "nvidia", "sm_75", "Turing", "nvidia"),
    Architecture("xe_hpg", "intel", "acm-g10", "Xe-HPG", "intel"),
    Architecture("xe_lp", "intel", "tgllp", "Xe-LP", "intel"),
    Architecture("gen9", "intel", "skl", "Gen9", "intel"),
    Architecture("a740", "qualcomm", "740", "Adreno 740", "adreno"),
    Architecture("a630", "qualcomm", "630", "Adreno 630", "adreno"),
    Architecture("g610", "arm", "0xa867", "Mali-G610", "mali"),
    Architecture("g72", "arm", "0x6221", "Mali-G72", "mali"),
)}
VENDORS = {"amd": "AMD", "nvidia": "NVIDIA", "intel": "Intel", "qualcomm": "Qualcomm", "arm": "Arm"}
BY_CHIP = {a.chip: a for a in ARCHITECTURES.values()}


def named(names) -> tuple[Architecture, ...]:
    """The architectures of `names` (in the registry's order), or ValueError naming an unknown one."""
    unknown = [n for n in names if n not in ARCHITECTURES]
    if unknown:
        raise ValueError(f"unknown GPU architecture {unknown[0]!r}; the architectures are {', '.join(ARCHITECTURES)}")
    return tuple(a for a in ARCHITECTURES.values() if a.name in names)


def label(names) -> str:
    """Architectures in words, grouped by vendor: "AMD rdna3, rdna2; NVIDIA sm_75"."""
    out = []
    for vendor, title in VENDORS.items():
        mine = [n for n in names if ARCHITECTURES[n].vendor == vendor]
        if mine:
            out.append(f"{title} {', '.join(mine)}")
    return "; ".join(out)


def vendor_groups(names) -> list[tuple[str, list[str]]]:
    """The architectures of `names` grouped by vendor, vendors and architectures in the registry's
    order: [("amd", ["rdna3", "gcn5"]), ("nvidia", ["sm_86"])]; names not in the registry are their
    own group."""
    order = list(ARCHITECTURES)
    out: dict[str, list[str]] = {}
    for a in sorted(names, key=lambda a: order.index(a) if a in order else len(order)):
        out.setdefault(ARCHITECTURES[a].vendor if a in ARCHITECTURES else a, []).append(a)
    return list(out.items())
