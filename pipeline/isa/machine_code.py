"""What each shader costs in the machine code of each GPU architecture (`architectures`): the
shaders of `shaders`, compiled by each architecture's back end (`radv` for AMD, `nvidia` for
NVIDIA, `intel` for Intel), counted by its own instruction classes and costed by its own model, every count net of
the shader's wrapper.

Every row, whatever its vendor, has `architecture` (the registry's name), `vendor`, `family` (the
chip its compiler was told), `instructions` (math instructions, net), `special` (special-function
or transcendental instructions, net), `cycles` (net, by `cost_model`) and the listing; beside them
the back end's own counts (`net_vector_alu` ... for AMD, `net_fma` ... for NVIDIA, `net_fpu` ... for
Intel). A back end
that cannot run here is skipped and its reason kept (`missing`); where none can, CompilerMissing.
"""

from __future__ import annotations

from . import intel, nvidia, radv
from .architectures import ARCHITECTURES, BY_CHIP, VENDORS, Architecture, CompilerMissing, named  # noqa: F401
from .shaders import (NDF_BODIES, NDF_PER_PIXEL, PER_PIXEL, UNIFORM, WRAPPER_PER_PIXEL,  # noqa: F401
                      WRAPPER_UNIFORM, glsl_expression, shader_sources)

BACKENDS = {"radv": radv, "nvidia": nvidia, "intel": intel}
ALL = tuple(ARCHITECTURES)


def compile_shaders(sources: dict[str, str], wrappers: dict[str, str], architectures=ALL) -> dict:
    """Every fragment shader of `sources` (name -> GLSL) for each architecture of `architectures`
    (names), each net of its wrapper (`wrappers`: name -> the name of its wrapper in `sources`; a
    wrapper's own row is net of itself). Returns dict(rows={architecture: {name: row}},
    devices={architecture: what compiled it}, missing={vendor: why its back end did not run}).
    Raises CompilerMissing where no back end can run."""
    chosen = named(architectures)
    rows, devices, missing = {}, {}, {}
    for backend, module in BACKENDS.items():
        mine = [a for a in chosen if a.backend == backend]
        if not mine:
            continue
        try:
            compiled, names = module.compile_shaders(sources, [a.chip for a in mine])
        except CompilerMissing as e:
            missing[mine[0].vendor] = str(e)
            continue
        for a in mine:
            shaders = compiled[a.chip]
            devices[a.name] = names[a.chip]
            rows[a.name] = {name: dict(architecture=a.name, vendor=a.vendor, family=a.chip,
                                       **{k: v for k, v in shaders[name].items() if k != "listing"},
                                       **module.net(shaders[name], shaders[wrappers.get(name, name)], a.chip),
                                       listing=shaders[name]["listing"])
                            for name in sources}
    if not rows:
        raise CompilerMissing("; ".join(f"{VENDORS[v]}: {why}" for v, why in missing.items()))
    return dict(rows=rows, devices=devices, missing=missing)


def costs(p, powers=(2,), architectures=ALL, registry_shaders: bool = True) -> dict:
    """Machine-code costs of every shader of `shader_sources` on each architecture: a dict with the
    rows (lobe, what, normalization, n_per, the row fields of `compile_shaders`), the compiler per
    architecture and the vendors whose back end did not run. Raises CompilerMissing where none runs."""
    sources = shader_sources(p, powers, registry_shaders)
    wrappers = {name: "wrapper_per_pixel" if "per pixel" in what else "wrapper_uniform"
                for name, (_, _, what, _) in sources.items() if what != "wrapper"}
    found = compile_shaders({name: source for name, (source, *_) in sources.items()}, wrappers, architectures)
    rows = []
    for architecture, shaders in found["rows"].items():
        for name, (_, lobe, what, norm) in sources.items():
            if what == "wrapper":
                continue
            rows.append(dict(lobe=lobe, what=what, normalization=norm, n_per="pixel" if "per pixel" in what
                             else "material", **shaders[name]))
        for name in ("wrapper_uniform", "wrapper_per_pixel"):
            rows.append(dict(lobe="", what=name.replace("_", " "), normalization="",
                             n_per="pixel" if "pixel" in name else "material", **shaders[name]))
    return dict(rows=rows, devices=found["devices"], missing=found["missing"])
