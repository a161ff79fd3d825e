"""Shader export: the run's lobe and normalizations as ready-to-paste GLSL and HLSL functions, and a
Python twin printed from the same sympy expressions, so that a test can check the exported code
against the pipeline's own lobe.

Every function body is one sympy expression with the run's constants filled in (`functions`);
each language only prints it (sympy's GLSL, C and Python printers). t is cos x: dot(N, H) for the
Blinn form, dot(R, V) for the Phong form, clamped to [0, 1] by the caller.
"""

from __future__ import annotations

import importlib.metadata
from pathlib import Path

import numpy as np
import sympy as sp

from ..optics import coef_forms, integrals, registry
from ..engine.cache import digest

t, n = sp.symbols("t n", real=True)
PREFIX = "cosquad_"


def functions(slope: float, intercept: float, coef_scale: float, coef_offset: float,
              power: int = 2) -> dict[str, tuple]:
    """name -> (arguments, sympy expression) with the constants filled in, evaluated to floats."""
    k = sp.Float(slope) * n + sp.Float(intercept)

    def exact_coef(which):
        # In r = 1 / k: no pow, nothing that overflows float16 (optics.coef_forms).
        return coef_forms.exact_coef_of_n(which, power, k)
    def asymptotic(which):
        c1, c0 = integrals.asymptote(which, power)
        return sp.Float(c1) * k + sp.Float(c0)
    exprs = {
        "k": ((n,), k),
        "coef": ((n,), sp.Float(coef_scale) * (sp.Float(coef_offset) + n)),
        "coef_exact": ((n,), exact_coef("phong")),
        "coef_blinn": ((n,), exact_coef("blinn")),
        "coef_asymptotic": ((n,), asymptotic("phong")),
        "coef_blinn_asymptotic": ((n,), asymptotic("blinn")),
    }
    def numeric(expr):
        expr = sp.N(expr, 17)
        # sp.N leaves the sides of a Piecewise condition symbolic (e.g. sqrt(2) + 2): evaluate them too.
        return expr.replace(lambda e: e.is_Relational, lambda e: e.func(sp.N(e.lhs, 17), sp.N(e.rhs, 17)))
    return {name: (args, numeric(expr)) for name, (args, expr) in exprs.items()}


DOCS = {
    "k": "k(n) = slope n + intercept, the lobe's coefficient",
    "lobe": "the lobe ((k (t - 1) + 1)^{power}, 0 past its zero crossing, by squarings and multiplies: no pow); "
            "t = cos x",
    "lobe_u": "the same lobe of u = 1 - cos x (u from cosquad_u), for half precision: k t + 1 - k cancels "
              "in float16 at large n, 1 - k u does not",
    "u": "u = 1 - dot(N, H) without cancellation, |N x H|^2 / (1 + N.H); 1 (the lobe's edge) for a back-facing H",
    "coef": "the run's normalization scale (offset + n) (the paper's 0.214 (0.807 + n))",
    "coef_exact": "exact Phong-form normalization 1 / (2 pi Int(n)): albedo 1 at normal incidence; written in "
                  "r = 1 / k: no pow, and no power of k that overflows half precision",
    "coef_blinn": "exact Blinn-form normalization (t = dot(N, H)), at normal view; written in r = 1 / k: no pow, "
                  "and no power of k that overflows half precision",
    "coef_asymptotic": "the exact Phong-form coef's two-term large-k form c1 k + c0: multiply-adds only (no division, "
                       "no transcendental instruction), safe in half precision; {asymptotic_phong}",
    "coef_blinn_asymptotic": "the exact Blinn-form coef's two-term large-k form c1 k + c0: multiply-adds only (no "
                             "division, no transcendental instruction), safe in half precision; {asymptotic_blinn}",
    "ndf": "the lobe as a microfacet normal distribution D(h), t = dot(N, H): normalized so that "
           "int D (N.H) dw_h = 1 (the Phong-form exact coef, not the Blinn-form one); use in "
           "f = D G F / (4 N.L N.V)",
}


def _glsl(expr) -> str:
    return coef_forms.glsl(expr)


def _hlsl(expr) -> str:
    return coef_forms.hlsl(expr)


def _python(expr) -> str:
    return sp.pycode(expr, fully_qualified_modules=True)


def _relative(source: str) -> str:
    from ..engine.paths import ROOT
    path = Path(source).resolve()
    return str(path.relative_to(ROOT)) if path.is_relative_to(ROOT) else str(path)


def power_lines(base: str, power: int, declare: str) -> tuple[list[str], str]:
    """(statements, result) computing base^power by `registry.power_steps`, each statement
    `declare name = expression;` (declare "float " for GLSL/HLSL, "" and no ';' for Python)."""
    steps, result = registry.power_steps(base, power)
    end = ";" if declare else ""
    return [f"{declare}{name} = {expression}{end}" for name, expression in steps], result


def header(comment: str, config, version_tag: str, coef_note: str) -> list[str]:
    c, p = comment, PREFIX
    power = config["lobe.power"]
    title = ("Modified cosine-quadratic specular lobe" if power == 2 else
             f"The cosine-linear lobe to the power {power} ({registry.family_name(power)})")
    return [f"{c} {title}, exported by cosquad-pipeline {version_tag}",
            f"{c} from run '{config.name}' (config {_relative(config.source)}).",
            f"{c} Usage, with the exact normalizations (albedo 1 at normal incidence):",
            f"{c}   Blinn form: spec = {p}coef_blinn(n) * {p}lobe(max(dot(N, H), 0.0), n) * max(dot(N, L), 0.0) * light",
            f"{c}   Phong form: spec = {p}coef_exact(n) * {p}lobe(max(dot(R, V), 0.0), n) * max(dot(N, L), 0.0) * light",
            f"{c} (The run's {coef_note}.)",
            f"{c} n is a material's: compute {p}k(n) and the coef once per material (on the CPU, or in a uniform),",
            f"{c} not per pixel. {p}sample can return directions below the surface (Phong form, grazing light):",
            f"{c} give those weight 0 (reject dot(N, L) <= 0). Half precision (mediump, mobile): t = dot(N, H) near 1",
            f"{c} loses the lobe at large n; use {p}lobe_u({p}u(N, H), n) there.", ""]


# Importance sampling, as `pipeline.optics.sampling` does it: the lobe's cosine to its axis from one uniform
# number, the direction around the axis, and the solid-angle pdf. {v2}, {v3}: the vector types.
SAMPLER = """// Importance sampling of the lobe around `axis` (R for the Phong form; N for the half vector of the
// Blinn form, then reflect the view about it), from xi uniform in [0, 1)^2. The solid-angle pdf of
// the direction is {p}pdf(dot(axis, dir), n) (Blinn form: divided by 4 dot(wo, h) for wo).
{v3} {p}sample({v2} xi, {v3} axis, float n)
{{
    float k = {p}k(n);
    float w0 = pow(max(1.0 - 2.0 * k, 0.0), {m1}.0);
    float w = pow(w0 + xi.x * (1.0 - w0), 1.0 / {m1}.0);   // k (c - 1) + 1, with density proportional to w^{m}
    float c = 1.0 + (w - 1.0) / k;
    float s = sqrt(max(1.0 - c * c, 0.0));
    float phi = 6.283185307179586 * xi.y;
    float sgn = axis.z >= 0.0 ? 1.0 : -1.0;              // an orthonormal frame (Duff et al. 2017)
    float a = -1.0 / (sgn + axis.z);
    float b = axis.x * axis.y * a;
    {v3} t = {v3}(1.0 + sgn * axis.x * axis.x * a, sgn * b, -sgn * axis.x);
    {v3} u = {v3}(b, sgn + axis.y * axis.y * a, -axis.y);
    return c * axis + s * cos(phi) * t + s * sin(phi) * u;
}}

// Solid-angle pdf of {p}sample at cosine c to its axis.
float {p}pdf(float c, float n)
{{
    float k = {p}k(n);
    float b = max(k * (c - 1.0) + 1.0, 0.0);
    float z = 6.283185307179586 * (1.0 - pow(max(1.0 - 2.0 * k, 0.0), {m1}.0)) / ({m1}.0 * k);
    {steps}
    return {result} / z;
}}
"""

SAMPLER_PY = """
def {p}sample(xi, axis, n):
    \"\"\"Importance sampling of the lobe around axis (a unit 3-tuple) from xi in [0, 1)^2.\"\"\"
    k = {p}k(n)
    w0 = max(1.0 - 2.0 * k, 0.0) ** {m1}
    w = (w0 + xi[0] * (1.0 - w0)) ** (1.0 / {m1})
    c = 1.0 + (w - 1.0) / k
    s = math.sqrt(max(1.0 - c * c, 0.0))
    phi = 6.283185307179586 * xi[1]
    x, y, z = axis
    sgn = 1.0 if z >= 0.0 else -1.0
    a = -1.0 / (sgn + z)
    b = x * y * a
    t = (1.0 + sgn * x * x * a, sgn * b, -sgn * x)
    u = (b, sgn + y * y * a, -y)
    return tuple(c * axis[i] + s * math.cos(phi) * t[i] + s * math.sin(phi) * u[i] for i in range(3))


def {p}pdf(c, n):
    \"\"\"Solid-angle pdf of {p}sample at cosine c to its axis.\"\"\"
    k = {p}k(n)
    b = max(k * (c - 1.0) + 1.0, 0.0)
    z = 6.283185307179586 * (1.0 - max(1.0 - 2.0 * k, 0.0) ** {m1}) / ({m1} * k)
    {steps}
    return {result} / z
"""


def render_sources(config, slope, intercept, coef_scale, coef_offset, version_tag: str,
                   coef_note: str, asymptotic_notes: dict | None = None) -> dict[str, str]:
    """The three files: GLSL, HLSL and the Python twin, as text. `coef_note` says, in a few words,
    how far the run's coef(n) is from the exact one; `asymptotic_notes` ("asymptotic_phong",
    "asymptotic_blinn"), how far the large-k forms are."""
    power = config["lobe.power"]
    fns = functions(slope, intercept, coef_scale, coef_offset, power)
    c_steps, result = power_lines("b", power, "float ")
    py_steps, _ = power_lines("b", power, "")
    notes = asymptotic_notes or {"asymptotic_phong": "its error: see the report", "asymptotic_blinn": "its error: see the report"}
    docs = {name: text.format(power=power, **notes) for name, text in DOCS.items()}
    glsl, hlsl = header("//", config, version_tag, coef_note), header("//", config, version_tag, coef_note)
    py = (['"""' + header("", config, version_tag, coef_note)[0].strip() + '"""', ""]
          + header("#", config, version_tag, coef_note))
    py += ["import math", "", ""]
    for name, (args, expr) in fns.items():
        c_args = ", ".join(f"float {a}" for a in args)
        glsl += [f"// {docs[name]}", f"float {PREFIX}{name}({c_args})", "{", f"    return {_glsl(expr)};", "}", ""]
        hlsl += [f"// {docs[name]}", f"float {PREFIX}{name}({c_args})", "{", f"    return {_hlsl(expr)};", "}", ""]
        py += [f"def {PREFIX}{name}({', '.join(str(a) for a in args)}):", f'    """{docs[name]}"""',
               f"    return {_python(expr)}", "", ""]
        if name == "k":
            # The lobe: the registry's GLSL body of f_Q2 at the run's power, as a shader author
            # writes it (no pow).
            lobe_glsl = registry.LOBES["f_Q2"].glsl_of(registry.Parameters(power=power))
            body = ["{", f"    float k = {PREFIX}k(n);", f"    {lobe_glsl}", "}", ""]
            for lines in (glsl, hlsl):
                lines += [f"// {docs['lobe']}", f"float {PREFIX}lobe(float t, float n)"] + body
            py += [f"def {PREFIX}lobe(t, n):", f'    """{docs["lobe"]}"""', f"    k = {PREFIX}k(n)",
                   "    b = max(k * t + (1.0 - k), 0.0)", *(f"    {line}" for line in py_steps),
                   f"    return {result}", "", ""]
            body_u = (["{", f"    float k = {PREFIX}k(n);", "    float b = max(1.0 - k * u, 0.0);"]
                      + [f"    {line}" for line in c_steps] + [f"    return {result};", "}", ""])
            for lines in (glsl, hlsl):
                lines += [f"// {docs['lobe_u']}", f"float {PREFIX}lobe_u(float u, float n)"] + body_u
            py += [f"def {PREFIX}lobe_u(u, n):", f'    """{docs["lobe_u"]}"""', f"    k = {PREFIX}k(n)",
                   "    b = max(1.0 - k * u, 0.0)", *(f"    {line}" for line in py_steps),
                   f"    return {result}", "", ""]
            for lines, v3 in ((glsl, "vec3"), (hlsl, "float3")):
                lines += [f"// {DOCS['u']}", f"float {PREFIX}u({v3} N, {v3} H)", "{", "    float t = dot(N, H);",
                          "    if (t <= 0.0) return 1.0;", f"    {v3} c = cross(N, H);",
                          "    return dot(c, c) / (1.0 + t);", "}", ""]
            py += [f"def {PREFIX}u(N, H):", f'    """{DOCS["u"]}"""', "    t = sum(a * b for a, b in zip(N, H))",
                   "    if t <= 0.0:", "        return 1.0",
                   "    c = (N[1] * H[2] - N[2] * H[1], N[2] * H[0] - N[0] * H[2], N[0] * H[1] - N[1] * H[0])",
                   "    return sum(x * x for x in c) / (1.0 + t)", "", ""]
    sampler = dict(p=PREFIX, m=power, m1=power + 1, result=result)
    for lines in (glsl, hlsl):
        lines += [f"// {docs['ndf']}", f"float {PREFIX}ndf(float t, float n)", "{",
                  f"    return {PREFIX}coef_exact(n) * {PREFIX}lobe(t, n);", "}", ""]
    py += [f"def {PREFIX}ndf(t, n):", f'    """{docs["ndf"]}"""', f"    return {PREFIX}coef_exact(n) * {PREFIX}lobe(t, n)",
           "", ""]
    glsl.append(SAMPLER.format(v2="vec2", v3="vec3", steps="\n    ".join(c_steps), **sampler))
    hlsl.append(SAMPLER.format(v2="float2", v3="float3", steps="\n    ".join(c_steps), **sampler))
    py.append(SAMPLER_PY.format(steps="\n    ".join(py_steps), **sampler))
    return {"cosquad.glsl": "\n".join(glsl), "cosquad.hlsl": "\n".join(hlsl),
            "cosquad_twin.py": "\n".join(py).rstrip() + "\n"}


def coef_note(hemispherical, exact) -> str:
    """How the run's coef(n) compares with the exact one at normal incidence, from the run's numbers."""
    excess, deficit = exact["paper_coef_max_excess"], exact["paper_coef_max_deficit"]
    parts = []
    if excess > 0:
        parts.append(f"up to {excess:.2%} more than arrives (n = {exact['paper_coef_n_at_max_excess']:g})")
    if deficit < 0:
        at = f" (n = {exact['paper_coef_n_at_max_abs_dev']:g})" if -deficit >= excess else ""
        parts.append(f"up to {-deficit:.2%} less{at}")
    return (f"{PREFIX}coef, {hemispherical['coef_scale_used']:.6g} ({hemispherical['coef_offset_used']:.6g} + n), "
            + ("reflects " + " and ".join(parts) if parts else "matches them"))


def write(out: Path, config, results, stage_keys) -> list[str]:
    """Writes `out/shader/` for the run; returns the file names (relative to out). The header's tag
    names the stage results the constants come from."""
    lin, h = results["linear_coefficient"], results["hemispherical"]
    version = importlib.metadata.version("cosquad-pipeline")
    tag = digest(stage_keys["linear_coefficient"], stage_keys["hemispherical"])[:12]
    e = results["exact_normalization"]
    span = f"n in [{config['derivation.n_min']:g}, {config['derivation.n_max']:g}]"
    def note(which):
        excess = e[f"asymptotic_{which}_max_excess"]
        above = f"at most {excess:.2%} above" if excess > 0 else "never above"
        dev = np.abs(np.asarray(e[f"asymptotic_{which}_dev"]))
        return (f"its albedo at normal incidence is within {e[f'asymptotic_{which}_max_abs_dev']:.2%} of 1 over {span} "
                f"({above}; farthest at n = {config['derivation.n_min'] + int(np.argmax(dev)):g}, within "
                f"{100 * dev[-1]:.2g} % at n = {config['derivation.n_max']:g})")
    notes = {f"asymptotic_{which}": note(which) for which in ("phong", "blinn")}
    files = render_sources(config, lin["slope_used"], lin["intercept_used"], h["coef_scale_used"],
                           h["coef_offset_used"], f"{version} (results {tag})",
                           coef_note(h, e), notes)
    if results.get("lobe_search", {}).get("front"):
        files.update(search_sources(config, results["lobe_search"], f"{version} (results {tag})"))
    files["cosquad.brdf"] = brdf_source(config, files["cosquad.glsl"], f"{version} (results {tag})")
    folder = out / "shader"
    folder.mkdir(exist_ok=True)
    for name, text in files.items():
        (folder / name).write_text(text)
    return [f"shader/{name}" for name in files]


# Disney's BRDF Explorer (github.com/wdas/brdf): an "analytic" .brdf file holds parameter lines
# ([type] [name] [min] [max] [default]; float, bool or color) and a GLSL function
# vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y), which the viewer pastes into its shader templates
# (GLSL 4.10) after one uniform per parameter. Lines starting with '#' are the file's comments.
BRDF_PARAMETERS = ["float n 1 1000 100", "float lobe 0 2 1", "bool blinn 1", "bool normalized 1"]
BRDF_FUNCTION = """const float PI = 3.14159265358979323846;

// The lobe's BRDF value f (the viewer multiplies by N.L): lobe 0 is cos^n, 1 the run's f_Q2, 2 the spherical
// Gaussian exp(n (t - 1)); t = N.H (blinn) or R.V. normalized: each lobe's exact coef of its form
// (cos^n: (n + 2) / (2 pi) and Giesen's Blinn form; f_Q2: {p}coef_exact and {p}coef_blinn; the spherical
// Gaussian: its Phong-form coef n^2 / (2 pi (n - 1 + exp(-n))) for both forms).
vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y)
{{
    vec3 H = normalize(L + V);
    vec3 R = reflect(-L, N);
    float t = blinn ? max(dot(N, H), 0.0) : max(dot(R, V), 0.0);
    int which = int(lobe + 0.5);
    float value;
    float coef;
    if (which == 0) {{
        value = pow(t, n);
        coef = blinn ? (n + 2.0) * (n + 4.0) / (8.0 * PI * (exp2(-0.5 * n) + n)) : (n + 2.0) / (2.0 * PI);
    }} else if (which == 1) {{
        value = {p}lobe(t, n);
        coef = blinn ? {p}coef_blinn(n) : {p}coef_exact(n);
    }} else {{
        value = exp(n * (t - 1.0));
        coef = n * n / (2.0 * PI * (n - 1.0 + exp(-n)));
    }}
    return vec3(normalized ? coef * value : value);
}}
"""


def brdf_source(config, glsl: str, version_tag: str) -> str:
    """cosquad.brdf for BRDF Explorer: the exported GLSL functions and a BRDF function that selects
    cos^n, f_Q2 or the spherical Gaussian, the Phong or Blinn form, with or without normalization."""
    return "\n".join(["analytic", "",
                      f"# cos^n, the run's f_Q2 and a spherical Gaussian, exported by cosquad-pipeline {version_tag}",
                      f"# from run '{config.name}'. lobe: 0 cos^n, 1 f_Q2, 2 exp(n (t - 1)); blinn: t = N.H, else R.V;",
                      "# normalized: each lobe's exact coef (albedo 1 at normal incidence).", "",
                      "::begin parameters", *BRDF_PARAMETERS, "::end parameters", "",
                      "::begin shader", glsl.rstrip(), "", BRDF_FUNCTION.format(p=PREFIX).rstrip(), "::end shader", ""])


SEARCH_PREFIX = "cosfit_"


def search_members(search) -> list[dict]:
    """The members of the lobe search to export: per range, each form on the front of some
    architecture, with its parameters as lines in n (the range's `members` row)."""
    on_front = {(c["family"], tuple(c["n_range"])) for c in search["front"]}
    return [m for m in search["members"] if (m["family"], tuple(m["n_range"])) in on_front]


def search_function_name(member) -> str:
    lo, hi = member["n_range"]
    return f"{SEARCH_PREFIX}{member['family']}_n{lo:g}_{hi:g}".replace(".", "p")


def u_form(family: str, slopes, intercepts):
    """A lobe-search family written in u = 1 - t: ({constant: (slope, intercept)} lines in n, GLSL body,
    Python body). A t + B = (A + B) - A u, and (A t + B) t + C = (A u - (2 A + B)) u + (A + B + C): the
    constants' lines are the lines' sums, so that nothing cancels in the shader."""
    from ..optics import lobe_families
    (sa, sb, sc), (ia, ib, ic) = (list(v) + [0.0] * (3 - len(v)) for v in (slopes, intercepts))
    linear = {"a0": (sa + sb, ia + ib), "a1": (sa, ia)}
    if family in lobe_families.POWERS:
        steps, result = registry.power_steps("b", lobe_families.POWERS[family])
        return (linear, ["float b = max(a0 - a1 * u, 0.0);"] + [f"float {a} = {e};" for a, e in steps] + [f"return {result};"],
                ["b = max(a0 - a1 * u, 0.0)"] + [f"{a} = {e}" for a, e in steps] + [f"return {result}"])
    if family == "exp2_linear":
        return linear, ["return exp2(a0 - a1 * u);"], ["return 2.0 ** (a0 - a1 * u)"]
    if family == "exp2_quadratic":
        lines = {"q0": (sa + sb + sc, ia + ib + ic), "q1": (2 * sa + sb, 2 * ia + ib), "q2": (sa, ia)}
        return lines, ["return exp2((q2 * u - q1) * u + q0);"], ["return 2.0 ** ((q2 * u - q1) * u + q0)"]
    ratio = "(1.0 - u) / (a0 - a1 * u)"
    if family == "rational":
        return linear, [f"return {ratio};"], [f"return {ratio}"]
    return linear, [f"float r = {ratio};", "return r * r;"], [f"r = {ratio}", "return r * r"]


def search_sources(config, search, version_tag: str) -> dict[str, str]:
    """The lobe search's front members as GLSL, HLSL and a Python twin: per member, a function of
    (t, n) whose parameters A, B, C are the lines in n the search fitted (per material: compute them
    once per n and pass them as uniforms in a shader that cares)."""
    from ..optics import lobe_families

    def line(a, b):
        return f"{a!r} * n + ({b!r})"

    glsl = [f"// Forms of the lobe search (cosquad-pipeline {version_tag}, run '{config.name}'): each approximates",
            "// cos^n x over its range of n, t = cos x in [0, 1]; its parameters are lines in n (computed once per",
            "// material). d: max relative error in the epicenter zone, D: max absolute error, over every integer",
            "// n of the range, with these lines.", ""]
    hlsl = list(glsl)
    py = ['"""Python twin of lobe_search.glsl: the same functions, for tests and plots."""', "", "", ]
    py += ["from math import exp, log, sqrt  # noqa: F401  (the grammar's forms may call them)", "", ""]
    for m in search_members(search):
        name = search_function_name(m)
        doc = (f"{m['expression']}, n in [{m['n_range'][0]:g}, {m['n_range'][1]:g}]: d {m['d_line']:.4g}, "
               f"D {m['D_line']:.4g}")
        names = list(m["parameters"])
        params = [(p, line(a, b)) for p, a, b in zip(names, m["parameter_slopes"], m["parameter_intercepts"])]
        if m["grammar"]:
            # A grammar form in w = n (1 - t), its constants c0, c1, ... lines in n.
            from ..symbolic import grammar
            text = grammar.glsl(grammar.parse(m["grammar"]), [], variable="w", uniforms="c")
            for i in range(len(names)):
                text = text.replace(f"c[{i}]", f"c{i}")
            body_c, body_py = ["float w = n - n * t;", f"return {text};"], ["w = n - n * t", f"return {text}"]
        else:
            family = lobe_families.FAMILIES[m["family"]]
            body_c, body_py = family.glsl.splitlines(), [f"return {family.python}"]
        for lines in (glsl, hlsl):
            lines += [f"// {doc}", f"float {name}(float t, float n)", "{"] + [f"    float {p} = {v};" for p, v in params]
            lines += [f"    {row.strip()}" for row in body_c] + ["}", ""]
        py += [f"def {name}(t, n):", f'    """{doc}"""'] + [f"    {p} = {v}" for p, v in params]
        py += [f"    {row}" for row in body_py] + ["", ""]
        if m["grammar"]:
            continue
        # The same form of u = 1 - t (from cosquad_u: no cancellation near t = 1), its constants folded
        # into lines of their own, for half precision.
        lines_u, body_u, body_u_py = u_form(m["family"], m["parameter_slopes"], m["parameter_intercepts"])
        doc_u = f"the same of u = 1 - t (u from cosquad_u), for half precision: {m['expression']} with t = 1 - u"
        params_u = [(p, line(a, b)) for p, (a, b) in lines_u.items()]
        for lines in (glsl, hlsl):
            lines += [f"// {doc_u}", f"float {name}_u(float u, float n)", "{"]
            lines += [f"    float {p} = {v};" for p, v in params_u] + [f"    {row}" for row in body_u] + ["}", ""]
        py += [f"def {name}_u(u, n):", f'    """{doc_u}"""'] + [f"    {p} = {v}" for p, v in params_u]
        py += [f"    {row}" for row in body_u_py] + ["", ""]
    return {"lobe_search.glsl": "\n".join(glsl), "lobe_search.hlsl": "\n".join(hlsl),
            "lobe_search_twin.py": "\n".join(py).rstrip() + "\n"}
