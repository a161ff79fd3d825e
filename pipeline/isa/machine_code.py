"""What each shader costs in the machine code of each GPU architecture (`architectures`): the
shaders of `shaders`, compiled by each architecture's back end (`radv` for AMD, `nvidia` for
NVIDIA, `intel` for Intel, `adreno` for Qualcomm, `mali` for Arm; the back ends run side by side),
counted by its own instruction classes and costed by its own model, every count net of the
shader's wrapper. Each back end module gives `compile_shaders`, `net`, its `COST_MODEL`, `MODEL`
and `UNIT` in words, `describe(row)`, `cell(row)` and `method(devices)` for the report, and
`SECONDS_PER_SHADER` for the time a compilation is announced with.

Every row, whatever its vendor, has `architecture` (the registry's name), `vendor`, `family` (the
chip its compiler was told), `instructions` (math instructions, net), `special` (special-function
or transcendental instructions, net), `cycles` (net, by `cost_model`) and the listing; beside them
the back end's own counts (`net_vector_alu` ... for AMD, `net_fma` ... for NVIDIA, `net_fpu` ... for
Intel, `net_alu`, `net_sfu` ... for Adreno, `net_arith`, `net_sfu` ... for Mali). A back end
that cannot run here is skipped and its reason kept (`missing`); where none can, CompilerMissing.
"""

from __future__ import annotations

import functools
import hashlib
import json
import os
import threading
from pathlib import Path

from ..engine import paths, toolchains
from . import adreno, intel, mali, nvidia, radv
from .architectures import (ARCHITECTURES, BY_CHIP, VENDORS, Architecture, CompilerMissing, named,  # noqa: F401
                            vendor_groups)
from .shaders import (FORM_PUSH, NDF_BODIES, NDF_PER_PIXEL, PER_PIXEL, UNIFORM, WRAPPER_PER_PIXEL,  # noqa: F401
                      WRAPPER_UNIFORM, form_shader, glsl_expression, shader_sources)

BACKENDS = {"radv": radv, "nvidia": nvidia, "intel": intel, "adreno": adreno, "mali": mali}
ALL = tuple(ARCHITECTURES)
TOOLS = toolchains.MACHINE_CODE         # the tools the back ends run


def backend(architecture: str):
    """The back end module of an architecture (its counts, its cost model, its words)."""
    return BACKENDS[ARCHITECTURES[architecture].backend]


def vendor_backend(vendor: str):
    """The back end module of a vendor's architectures."""
    return next(BACKENDS[a.backend] for a in ARCHITECTURES.values() if a.vendor == vendor)


START_SECONDS = 4.0         # the compilers' processes started, the shaders lowered


def estimate_seconds(count: int, architectures=ALL) -> float:
    """About how long compiling `count` shaders for each of `architectures` takes on this machine:
    each back end's measured CPU seconds per shader and architecture, the back ends side by side on
    the machine's cores."""
    cpu = sum(backend(a).SECONDS_PER_SHADER for a in architectures) * count
    return START_SECONDS + cpu / max(1, min(len(BACKENDS), os.cpu_count() or 1))


def models_text(architectures) -> str:
    """The cost model of each vendor among `architectures`, in words: "ACO's cycles per wave on AMD,
    a throughput model's cycles per warp on NVIDIA"."""
    return ", ".join(f"{vendor_backend(vendor).MODEL} on {VENDORS[vendor]}"
                     for vendor, _ in vendor_groups([a for a in architectures if a in ARCHITECTURES]))


# The modules that write, compile and read a shader (execution on lavapipe and the special functions'
# documented accuracies are not among them: a change there compiles nothing again).
COMPILING = ("machine_code", "architectures", "shaders", "lowering", "radv", "vulkan_pipeline", "nvidia", "intel",
             "gles", "gles_driver", "adreno", "mali", "compiler_process")


@functools.cache
def _code_version() -> str:
    """The code that compiles and reads a shader: this wing's `COMPILING` modules and the SPIR-V front end."""
    here = Path(__file__).parent
    files = [here / f"{name}.py" for name in COMPILING] + [here.parent / "optics" / "spirv.py"]
    return hashlib.sha256(b"".join(f.read_bytes() for f in files)).hexdigest()


def _kept_file(backend: str, chip: str, source: str) -> Path:
    module = BACKENDS[backend]
    key = json.dumps([_code_version(), toolchains.fingerprint([module.TOOL, "shader_tools"]), backend, chip, source])
    return paths.MACHINE_CODE_CACHE / backend / f"{hashlib.sha256(key.encode()).hexdigest()[:32]}.json"


def _compile_kept(backend: str, sources: dict[str, str], chips) -> tuple[dict, dict]:
    """A back end's `compile_shaders`, each shader's result kept on disk by its text, the chip, the
    compiler found and this wing's code (`paths.MACHINE_CODE_CACHE`): only what no run compiled
    before is compiled, once for all chips that lack it. An entry that cannot be read is compiled
    again."""
    module = BACKENDS[backend]
    module.check()
    compiled: dict = {chip: {} for chip in chips}
    devices: dict = {}
    todo: set[str] = set()
    for chip in chips:
        for name, source in sources.items():
            try:
                entry = json.loads(_kept_file(backend, chip, source).read_text())
                compiled[chip][name], devices[chip] = entry["parsed"], entry["device"]
            except (OSError, ValueError, KeyError, TypeError):
                todo.add(name)
    if todo:
        wanted = [chip for chip in chips if any(name not in compiled[chip] for name in todo)]
        fresh, names = module.compile_shaders({name: sources[name] for name in sources if name in todo}, wanted)
        for chip in wanted:
            devices[chip] = names[chip]
            for name, parsed in fresh[chip].items():
                compiled[chip][name] = parsed
                kept = _kept_file(backend, chip, sources[name])
                kept.parent.mkdir(parents=True, exist_ok=True)
                partial = kept.with_suffix(f".{os.getpid()}.{threading.get_ident()}.tmp")
                partial.write_text(json.dumps(dict(parsed=parsed, device=names[chip])))
                os.replace(partial, kept)
    return compiled, devices


def compile_shaders(sources: dict[str, str], wrappers: dict[str, str], architectures=ALL) -> dict:
    """Every fragment shader of `sources` (name -> GLSL) for each architecture of `architectures`
    (names), each net of its wrapper (`wrappers`: name -> the name of its wrapper in `sources`; a
    wrapper's own row is net of itself). Returns dict(rows={architecture: {name: row}},
    devices={architecture: what compiled it}, missing={vendor: why its back end did not run}).
    Raises CompilerMissing where no back end can run."""
    from concurrent.futures import ThreadPoolExecutor

    chosen = named(architectures)
    rows, devices, missing = {}, {}, {}
    mine = {backend: [a for a in chosen if a.backend == backend] for backend in BACKENDS}
    # The back ends side by side: each spends its time in its compiler's processes.
    with ThreadPoolExecutor(len(BACKENDS)) as pool:
        futures = {backend: pool.submit(_compile_kept, backend, sources, [a.chip for a in archs])
                   for backend, archs in mine.items() if archs}
    for backend, future in futures.items():
        module = BACKENDS[backend]
        try:
            compiled, names = future.result()
        except CompilerMissing as e:
            missing[mine[backend][0].vendor] = str(e)
            continue
        for a in mine[backend]:
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


def form_sources(bodies: dict, names, precision: str = "fp32") -> tuple[dict, dict, dict]:
    """(sources, wrappers, {source key: form name}) of `form_cycles`'s shaders."""
    sources, wrappers, keys = {}, {}, {}
    for i, (name, (body, used, *netted)) in enumerate(bodies.items()):
        netted = list(netted[0]) if netted else used
        wrapper = ("wrapper16_" if precision == "fp16" else "wrapper_") + "_".join(netted)
        sources.setdefault(wrapper, form_shader(names, netted, None, precision=precision))
        key = f"form_{i:03d}"
        sources[key], wrappers[key], keys[key] = form_shader(names, used, body, precision=precision), wrapper, name
    return sources, wrappers, keys


def form_cycles(bodies: dict, names, architectures=ALL, precision: str = "fp32") -> tuple[dict, dict, dict]:
    """({architecture: {name: cycles}}, {what: why not}, {architecture: what compiled it}) of `bodies`
    ({name: (GLSL statements returning a form, the inputs of `names` it reads[, the inputs it is
    netted of])}), each in `shaders.form_shader` (push constants c0 ... c15 and F0), net of the
    wrapper of the inputs it reads (or of those given: a pixel form of `pipeline derive` pays the
    read of its parameter), clipped at 0. A form a back end cannot lower is left out (named in the second dict, as is a
    vendor whose back end does not run); raises CompilerMissing where none runs. The one costing of
    every form: `pipeline derive`'s, the lobe search's families and the cost tables' forms. precision
    "fp16": each form computed in float16 with explicit 16-bit types (`shaders.form_shader`), net of
    the wrapper converting its inputs alike."""
    sources, wrappers, keys = form_sources(bodies, names, precision)
    cycles: dict = {a: {} for a in architectures}
    missing: dict = {}
    devices: dict = {}

    def add(chosen):
        wanted = chosen + sorted({wrappers[k] for k in chosen})
        compiled = compile_shaders({k: sources[k] for k in wanted}, wrappers, architectures)
        missing.update(compiled["missing"])
        devices.update(compiled["devices"])
        for a, shaders in compiled["rows"].items():
            cycles[a].update({keys[k]: max(round(row["cycles"], 2), 0.0) for k, row in shaders.items() if k in keys})

    def attempt(chosen):
        """`add(chosen)`; where a form a back end cannot lower fails it, each half again, down to
        that form alone, which is left out with its reason (the others compiled in halves, not one
        by one: a run of 200 forms with one such form compiles a few dozen batches, not 200)."""
        try:
            add(chosen)
        except CompilerMissing:
            raise
        except Exception as e:
            if len(chosen) == 1:
                missing[keys[chosen[0]]] = str(e).splitlines()[0][:200]
                return
            attempt(chosen[:len(chosen) // 2])
            attempt(chosen[len(chosen) // 2:])

    attempt(list(keys))
    return cycles, missing, devices


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
