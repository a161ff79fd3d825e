"""Cost in GPU machine code (beyond the paper): every lobe of the registry (at the paper's power 2),
the family (k (t - 1) + 1)^m at each power of `front.powers` and at the run's `lobe.power`, and each
registry lobe times each of its normalizations with n per pixel, compiled for every architecture of
`pipeline.isa.architectures` by its vendor's back end (Mesa's RADV for AMD, ptxas for NVIDIA,
ocloc for Intel, Mesa's freedreno and panfrost for Adreno and Mali: `pipeline.isa.machine_code`): instructions by the vendor's classes and cycles by its cost model,
net of the shader's fixed wrapper.

The shaders are compiled with the paper's constants as stand-ins (`CONSTANTS`): each constant is
one literal in the code, so the machine code does not depend on its value, and a refit that moves
Q or the line keeps this stage. The registry's shaders and the family at each power are memoized
apart (what is missing is compiled at once, then stored apart), so a run with other powers
compiles only the powers not compiled before. Where the
compiler cannot run (no Vulkan loader, no RADV,
no `vulkan` package; no ptxas; no ocloc; no qemu-user or arm64 Mesa), the stage says why per vendor and returns the other vendors' rows.
"""

from ..engine import toolchains
from ..isa import architectures, machine_code
from ..optics import registry

CONSTANTS = registry.PAPER


def compiled(powers, registry_shaders: bool) -> dict:
    """The machine-code rows of the registry (with `registry_shaders`) and of the family at `powers`,
    or why there are none."""
    try:
        found = machine_code.costs(CONSTANTS, [int(m) for m in powers], registry_shaders=registry_shaders)
    except machine_code.CompilerMissing as e:
        return dict(available=False, reason=str(e), devices={}, rows=[], missing={})
    return dict(available=True, reason="", **found)


@toolchains.uses(*toolchains.MACHINE_CODE)
def registry_rows() -> dict:
    return compiled((), registry_shaders=True)


@toolchains.uses(*toolchains.MACHINE_CODE)
def family_rows(power: int) -> dict:
    return compiled((power,), registry_shaders=False)


def _family_of(row, power: int) -> bool:
    return row["lobe"] == registry.family_name(power) and row["what"] in ("family lobe", "NDF")


def _parts(found: dict, powers) -> tuple[dict, dict[int, dict]]:
    """One compilation of the registry and the family at `powers`, split into what `registry_rows`
    and each `family_rows(power)` return (each with the wrappers)."""
    wrappers = [r for r in found["rows"] if r["what"].startswith("wrapper")]
    base = dict(found, rows=[r for r in found["rows"] if not any(_family_of(r, m) for m in powers)])
    return base, {m: dict(found, rows=[r for r in found["rows"] if _family_of(r, m)] + wrappers) for m in powers}


def merged(base: dict, families: list[dict]) -> dict:
    """The rows of `base` (the registry's) and of each family part, per architecture in the order of
    one compilation of them all: the lobes, the family at each power, the NDFs, the wrappers."""
    if not base["available"]:
        return base
    rows = []
    # The registry's order (a stored dict comes back with its keys sorted).
    for architecture in (a for a in machine_code.ARCHITECTURES if a in base["devices"]):
        own = [r for r in base["rows"] if r["architecture"] == architecture]
        rows += [r for r in own if r["what"].startswith("lobe")]
        rows += [r for part in families for r in part["rows"]
                 if r["architecture"] == architecture and not r["what"].startswith("wrapper")]
        rows += [r for r in own if not r["what"].startswith("lobe")]
    return dict(base, rows=rows)


def run(config, inputs, memo):
    power = config["lobe.power"]
    powers = sorted(int(m) for m in set(config["front.powers"]) | {power})
    base = memo.cached("machine_code_registry", registry_rows)
    parts = {m: memo.cached("machine_code_family", family_rows, power=m) for m in powers}
    missing = [m for m in powers if parts[m] is None]
    if base is None or missing:
        # What is missing, compiled at once (each RADV run starts a Vulkan device), stored apart.
        found = compiled(missing, registry_shaders=base is None)
        new_base, new_parts = _parts(found, missing)
        if base is None:
            base = memo.store("machine_code_registry", registry_rows, new_base)
        for m in missing:
            parts[m] = memo.store("machine_code_family", family_rows, new_parts[m], power=m)
    found = merged(base, [parts[m] for m in powers])
    if memo.log is not None:
        measured = [a for a in machine_code.ARCHITECTURES if a in found["devices"]]
        memo.log(f"compiled for {architectures.label(measured) or 'no architecture'}"
                 + "".join(f"; {machine_code.VENDORS[v]} not measured: {why}" for v, why in found.get("missing", {}).items()))
    rows = found["rows"]
    family = [r for r in rows if r["what"] == "family lobe"]
    pow_rows = [r for r in rows if r["what"] == "lobe" and r["lobe"] == registry.REFERENCE]
    return dict(found, power=power,
                pow_transcendental=min(r["special"] for r in pow_rows) if pow_rows else -1,
                family_transcendental_max=max(r["special"] for r in family) if family else -1)
