"""The shaders whose machine code the pipeline measures, written once in GLSL for every vendor:
each lobe alone with n, k and the rate as per-material uniforms (push constants: nothing folds at
compile time, and what depends on n alone is computed once per material on the CPU), the lobe
times each normalization of its registry entry with n per pixel (a varying, so k(n) and coef(n)
are computed per pixel too), the family at each power, the normal distributions of a microfacet
BRDF, and the two wrappers (the same shaders returning t) whose cost every count is net of.
glslang compiles them to SPIR-V; each back end of `pipeline.isa` takes it from there."""

from __future__ import annotations

import re

import numpy as np
import sympy as sp

from ..optics import registry

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


FORM_CONSTANTS = 16         # a form's push constants c0 ... c15 (a pair's two forms of up to 8 each) ...
FORM_PUSH = " ".join(f"float c{i};" for i in range(FORM_CONSTANTS)) + " float F0;"   # ... and F0


FLOAT16 = ("#extension GL_EXT_shader_explicit_arithmetic_types_float16 : require\n")
# a numeric literal, not part of a name (x2, vec3, c0)
LITERAL = re.compile(r"(?<![\w.])(\d+\.\d*(?:[eE][+-]?\d+)?|\.\d+(?:[eE][+-]?\d+)?|\d+[eE][+-]?\d+|\d+)(?![\w.])")


def half_literals(body: str) -> str:
    """GLSL with every numeric literal written float16_t(the exact value of its nearest float16):
    glslang truncates a literal converted to half (float16_t(0.3) is 0.2998, not the nearest
    0.30005), and a bare float literal would promote float16 arithmetic to float32."""
    return LITERAL.sub(lambda m: f"float16_t({float(np.float16(float(m.group(1))))!r})", body)


CONTRACT = ("allowed", "never")       # may a driver fuse a multiply and an add (`precise_body`)


def precise_body(body: str, precision: str = "fp32") -> str:
    """A form's GLSL statements with the value it returns declared `precise` (every operation it is
    computed from decorated NoContraction in SPIR-V: no fused multiply-add, no reordering), as
    `--contract never` costs and writes it."""
    kind = "float16_t" if precision == "fp16" else "float"
    head, _, tail = body.rpartition("return ")
    return f"{head}precise {kind} value_ = {tail.rstrip().removesuffix(';')};\n    return value_;"


def form_shader(names, used, body: str | None, push: str = FORM_PUSH, precision: str = "fp32") -> str:
    """A fragment shader with one input per name of `names` (location i; those a form does not read are
    never interpolated), the push constants `push` (a block's members, as "float c0; float c1;"), and a
    function of the inputs `used` whose GLSL statements are `body`. body None: the wrapper, which
    computes nothing and writes the inputs `used`. A form's cycles are net of the wrapper of the same
    inputs, and both write alike, so that neither the inputs' interpolation nor the export counts,
    the form's arithmetic does: with one input, the value to all four components (as the lobes'
    shaders `UNIFORM` and `WRAPPER_UNIFORM` write theirs); with several, the form in the first input's
    place and the other inputs beside it (written as the wrapper writes them, so that the export is
    the same four values but one; a broadcast form against a wrapper of distinct values would net
    the export's difference out of the form). The one shader of every derived form and every lobe
    family's fit.

    precision "fp16": the function computes in float16 with explicit 16-bit types (what a phone's
    mediump computes), its literals the nearest float16 (`half_literals`), its inputs converted to
    float16 and its value back to float32; the wrapper converts its inputs to float16 and back, so that
    the conversions are netted out and the arithmetic counts. The push constants stay float32."""
    half = precision == "fp16"
    inputs = "\n".join(f"layout(location = {i}) in float {n}_in;" for i, n in enumerate(names))
    head = f"#version 450\n{FLOAT16 if half else ''}{inputs}\nlayout(location = 0) out vec4 color;\n"

    def read(n):
        return f"float16_t({n}_in)" if half else f"{n}_in"

    def written(n):
        return f"float(float16_t({n}_in))" if half else f"{n}_in"

    if body is None:
        values = written(used[0]) if len(used) == 1 else ", ".join([written(n) for n in used] + ["0.0"] * (4 - len(used)))
        return head + f"void main() {{ color = vec4({values}); }}\n"
    block = f"layout(push_constant) uniform Material {{ {push} }};\n" if push else ""
    kind = "float16_t" if half else "float"
    arguments = ", ".join(f"{kind} {n}" for n in used)
    value = f"form({', '.join(read(n) for n in used)})"
    value = f"float({value})" if half else value
    values = value if len(used) == 1 else ", ".join([value] + [written(n) for n in used[1:]] + ["0.0"] * (4 - len(used)))
    return (head + block + f"{kind} form({arguments})\n{{\n    {half_literals(body) if half else body}\n}}\n"
            f"void main() {{ color = vec4({values}); }}\n")


def glsl_expression(expr) -> str:
    """A sympy expression in n as GLSL, integer powers written as products (as a shader author
    writes them) and pi as a number."""
    from ..optics.coef_forms import glsl
    expr = expr if isinstance(expr, sp.Basic) else sp.Float(expr) if isinstance(expr, float) else sp.Integer(expr)
    return glsl(expr.subs(sp.pi, sp.Float(float(sp.pi), 17)))


def shader_sources(p: registry.Parameters, powers, registry_shaders: bool = True) -> dict[str, tuple[str, str, str, str]]:
    """name -> (GLSL, lobe, what, normalization) of every shader to compile: each registry lobe
    alone ("lobe", by its key) and with each of its normalizations ("lobe and coef, n per pixel"),
    the family at each power of `powers` alone ("family lobe", by its name f_Q2, f_Q3, ...), the
    normal distributions D of a microfacet BRDF ("NDF": Beckmann, GGX, cos^n and the family, each
    with its per-material constants; "NDF, n per pixel": Beckmann and GGX with alpha from n per pixel),
    and the two wrappers. Without `registry_shaders`: the
    family's shaders at `powers` and the wrappers only."""
    from ..optics.normalizations import normalizations
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
