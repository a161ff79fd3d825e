"""What each lobe costs in a GPU's own machine code: the lobe in a fragment shader, compiled by
glslang to SPIR-V (unoptimized: the driver's own optimizer sees the shader as written), then by
Mesa's RADV driver and its ACO back end to AMD machine code, for RDNA3 (gfx1100), RDNA2 (navi21) and GCN5
(vega10), on RADV's null device: no GPU is needed (`pipeline.optics.vulkan_pipeline` creates the
pipelines).

From each fragment shader's final listing (`RADV_DEBUG=shaders`) the instructions are counted by
kind: vector ALU (v_*, interpolation excluded), transcendental (v_log, v_exp, v_rcp, v_rsq,
v_sqrt, v_sin, v_cos: the quarter-rate unit), scalar (s_*); and ACO's own estimates
(`ACO_DEBUG=perfinfo`): the latency of one wave in cycles and the throughput, as cycles per wave
(1 / wave64_per_cycle). Every count is also given net of the shader's fixed wrapper (the same
shader whose lobe returns t: interpolation, export), which is measured on the same chip and
subtracted.

Two shaders per lobe: the lobe alone with n, k and the rate as push constants (per material, so
nothing folds at compile time, and what depends on n alone is computed once per material on the
CPU), and the lobe times each normalization of its registry entry with n per pixel (a varying, so
k(n) and coef(n) are computed per pixel too).
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
import tempfile
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import sympy as sp

from ..engine import toolchains
from . import registry, spirv

FAMILIES = {"gfx1100": "RDNA3", "navi21": "RDNA2", "vega10": "GCN5"}
TRANSCENDENTAL = re.compile(r"^v_(exp|log|rcp|rsq|sqrt|sin|cos)_(f16|f32|legacy_f32)")
TIMEOUT_S = 120

VERTEX = """#version 450
layout(location = 0) out float t_out;
layout(location = 1) out float n_out;
void main()
{
    vec2 p = vec2(gl_VertexIndex & 1, gl_VertexIndex >> 1);
    t_out = p.x;
    n_out = 1.0 + 999.0 * p.y;
    gl_Position = vec4(2.0 * p - 1.0, 0.0, 1.0);
}
"""
# The lobe alone: n, k and the rate per material (push constants).
UNIFORM = """#version 450
layout(location = 0) in float t_in;
layout(location = 0) out vec4 color;
layout(push_constant) uniform Material {{ float n; float k; float rate; }};
float lobe(float t)
{{
    {body}
}}
void main() {{ color = vec4(lobe(t_in)); }}
"""
# The lobe and its normalization with n per pixel (a varying): its parameter and coef per pixel.
PER_PIXEL = """#version 450
layout(location = 0) in float t_in;
layout(location = 1) in float n_in;
layout(location = 0) out vec4 color;
float lobe(float t, float n, float k, float rate)
{{
    {body}
}}
void main()
{{
    float n = n_in;
    float p = {parameter};
    color = vec4(({coef}) * lobe(t_in, n, p, p));
}}
"""
WRAPPER_UNIFORM = UNIFORM.format(body="return t;")
# Normal distributions D(t = N.H) as an engine writes them, the per-material values as push
# constants (rate: alpha^2 for Beckmann and GGX, the normalization coef for the lobes).
NDF_BODIES = {
    "Beckmann": "float t2 = t * t;\n    return exp((t2 - 1.0) / (rate * t2)) / (3.14159265 * rate * t2 * t2);",
    "GGX": "float d = t * t * (rate - 1.0) + 1.0;\n    return rate / (3.14159265 * d * d);",
    "f_b": "return rate * pow(t, n);",
}
# The distributions whose roughness a shader computes from n per pixel (the rate alpha^2 = 2 / (n + 2));
# the lobes' NDFs with n per pixel are their "lobe and coef, n per pixel" shaders with the Phong-form coef.
NDF_PER_PIXEL = {"Beckmann": "2.0 / (n + 2.0)", "GGX": "2.0 / (n + 2.0)"}
WRAPPER_PER_PIXEL = """#version 450
layout(location = 0) in float t_in;
layout(location = 1) in float n_in;
layout(location = 0) out vec4 color;
void main() { color = vec4(t_in, n_in, 0.0, 0.0); }
"""


class CompilerMissing(RuntimeError):
    """The Vulkan loader, Mesa's RADV driver or the `vulkan` package is not installed."""


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


def glsl_expression(expr) -> str:
    """A sympy expression in n as GLSL, integer powers written as products (as a shader author
    writes them) and pi as a number."""
    from .coef_forms import glsl
    return glsl(sp.sympify(expr).subs(sp.pi, sp.Float(float(sp.pi), 17)))


def spirv_binary(source: str, folder: Path, name: str, stage: str = "frag") -> Path:
    """GLSL `source` compiled to SPIR-V (`spirv.compile_glsl`), as folder/name."""
    return spirv.compile_glsl(source, stage, folder / name, f"shader {name}")


def compile_family(family: str, folder: Path, icd: str) -> str:
    """The driver's stderr for every pipeline of `folder`, compiled for one chip family."""
    env = dict(os.environ, VK_ICD_FILENAMES=icd, RADV_FORCE_FAMILY=family, RADV_DEBUG="shaders,nocache",
               ACO_DEBUG="perfinfo", MESA_SHADER_CACHE_DISABLE="true",
               XDG_RUNTIME_DIR=os.environ.get("XDG_RUNTIME_DIR") or tempfile.gettempdir())
    done = subprocess.run([sys.executable, "-m", "pipeline.optics.vulkan_pipeline", str(folder)], env=env,
                          capture_output=True, text=True, timeout=TIMEOUT_S)
    if done.returncode != 0 or "@@@ END" not in done.stderr:
        tail = "\n".join(done.stderr.strip().splitlines()[-5:])
        raise CompilerMissing(f"RADV could not compile for {family} (exit {done.returncode}): {tail}")
    return done.stderr


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
    return dict(counts, instructions=len(listing), latency_cycles=float(latency.group(1)),
                cycles_per_wave=round(1.0 / float(per_cycle.group(1)), 1), listing=listing)


NET_FIELDS = ("vector_alu", "transcendental", "scalar", "other", "instructions", "latency_cycles", "cycles_per_wave")


def _net(row: dict, wrapper: dict) -> dict:
    return {f"net_{field}": round(row[field] - wrapper[field], 1) if isinstance(row[field], float)
            else row[field] - wrapper[field] for field in NET_FIELDS}


def shader_sources(p: registry.Parameters, powers, registry_shaders: bool = True) -> dict[str, tuple[str, str, str, str]]:
    """name -> (GLSL, lobe, what, normalization) of every shader to compile: each registry lobe
    alone ("lobe", by its key) and with each of its normalizations ("lobe and coef, n per pixel"),
    the family at each power of `powers` alone ("family lobe", by its name f_Q2, f_Q3, ...), the
    normal distributions D of a microfacet BRDF ("NDF": Beckmann, GGX, cos^n and the family, each
    with its per-material constants; "NDF, n per pixel": Beckmann and GGX with alpha from n per pixel),
    and the two wrappers. Without `registry_shaders`: the
    family's shaders at `powers` and the wrappers only."""
    from .normalizations import normalizations
    _, n = registry.symbols()
    norms = normalizations(p)
    out = {"wrapper_uniform": (WRAPPER_UNIFORM, "", "wrapper", ""),
           "wrapper_per_pixel": (WRAPPER_PER_PIXEL, "", "wrapper", "")}
    for index, lobe in enumerate(registry.LOBES.values() if registry_shaders else ()):
        body = lobe.glsl_of(p)
        out[f"lobe{index:02d}"] = (UNIFORM.format(body=body), lobe.key, "lobe", "")
        parameter = glsl_expression(lobe.parameter(registry.SYMPY, n, p))
        for j, (form, key) in enumerate(lobe.energy):
            source = PER_PIXEL.format(body=body, parameter=parameter, coef=glsl_expression(norms[key].expr))
            out[f"lobe{index:02d}_norm{j:02d}"] = (source, lobe.key, "lobe and coef, n per pixel", f"{form} {key}")
    for power in powers:
        body = registry.linear_power_glsl(power)
        out[f"family{power:02d}"] = (UNIFORM.format(body=body), registry.family_name(power), "family lobe", "")
        steps, result = registry.power_steps("b", power)
        ndf = "\n    ".join(["float b = max(k * t + (1.0 - k), 0.0);"] + [f"float {a} = {e};" for a, e in steps]
                             + [f"return rate * {result};"])
        out[f"ndf_family{power:02d}"] = (UNIFORM.format(body=ndf), registry.family_name(power), "NDF", "")
    for index, (name, body) in enumerate(NDF_BODIES.items() if registry_shaders else ()):
        out[f"ndf{index:02d}"] = (UNIFORM.format(body=body), name, "NDF", "")
        if name in NDF_PER_PIXEL:
            # Beckmann and GGX with n per pixel: alpha^2 = 2 / (n + 2) computed in the shader.
            out[f"ndf{index:02d}_pixel"] = (PER_PIXEL.format(body=body, parameter=NDF_PER_PIXEL[name], coef="1.0"),
                                            name, "NDF, n per pixel", "")
    return out


def compile_shaders(sources: dict[str, str], families=tuple(FAMILIES)) -> tuple[dict, dict]:
    """Every fragment shader of `sources` (name -> GLSL) compiled by RADV for each chip family:
    ({family: {name: `parse_fragment` of it}}, {family: the driver's device name}). Raises
    CompilerMissing where the compiler cannot run."""
    icd = check_available()
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        with ThreadPoolExecutor(os.cpu_count() or 2) as pool:
            jobs = [pool.submit(spirv_binary, VERTEX, folder, "vert.spv", "vert")]
            jobs += [pool.submit(spirv_binary, source, folder, f"{name}.frag.spv") for name, source in sources.items()]
            for job in jobs:
                job.result()
            outputs = dict(zip(families, pool.map(lambda f: compile_family(f, folder, icd), families)))
    compiled, devices = {}, {}
    for family, stderr in outputs.items():
        device = re.search(r"@@@ DEVICE (.*)\n", stderr)
        devices[family] = device.group(1).strip() if device else family
        compiled[family] = {name: parse_fragment(text) for name, text in split_shaders(stderr).items()}
        missing = set(sources) - set(compiled[family])
        if missing:
            raise ValueError(f"RADV ({family}) printed no listing for shaders {sorted(missing)}")
    return compiled, devices


def costs(p: registry.Parameters, powers=(2,), families=tuple(FAMILIES), registry_shaders: bool = True) -> dict:
    """Machine-code costs of every shader of `shader_sources` on each chip family: a dict with the
    rows (lobe, what, normalization, family, architecture, counts, estimates and their net values)
    and the driver's name per family. Raises CompilerMissing where the compiler cannot run."""
    sources = shader_sources(p, powers, registry_shaders)
    compiled, devices = compile_shaders({name: source for name, (source, *_) in sources.items()}, families)
    rows = []
    for family, shaders in compiled.items():
        for name, (source, lobe, what, norm) in sources.items():
            if what == "wrapper":
                continue
            parsed = shaders[name]
            wrapper = shaders["wrapper_per_pixel" if "per pixel" in what else "wrapper_uniform"]
            rows.append(dict(lobe=lobe, what=what, normalization=norm, family=family, architecture=FAMILIES[family],
                             **{k: v for k, v in parsed.items() if k != "listing"}, **_net(parsed, wrapper),
                             listing=parsed["listing"]))
        for name in ("wrapper_uniform", "wrapper_per_pixel"):
            parsed = shaders[name]
            rows.append(dict(lobe="", what=name.replace("_", " "), normalization="", family=family,
                             architecture=FAMILIES[family], **{k: v for k, v in parsed.items() if k != "listing"},
                             **{f"net_{f}": 0 for f in NET_FIELDS}, listing=parsed["listing"]))
    return dict(rows=rows, devices=devices)
