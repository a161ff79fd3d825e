"""The shader code a `pipeline derive` run exports: each member as a function of GLSL, HLSL and a
Python twin (`member_functions`), named from the target's and the member's names, in the target's
variables (a parametric target's parameter, or a material member's constants c0, c1, ...), its
numbers the format's values that were executed; derive.glsl, derive.hlsl and derive_twin.py hold
every front's members (`shader_sources`)."""

from __future__ import annotations

from ...engine import escape
from ..forms import glsl, hlsl, python
from ..targets import parse

TYPES = {None: ("float", "float"), "fp32": ("float", "float"), "fp16": ("float16_t", "half")}    # (GLSL, HLSL)
GLSL_FLOAT16 = "#extension GL_EXT_shader_explicit_arithmetic_types_float16 : require"


def domain_text(target: dict) -> str:
    """"x in [0, 1]", or each variable's and the parameter's range."""
    if target.get("variables"):
        axes = target["variables"] + ([target["parameter"]] if target.get("parameter") else [])
        return ", ".join(f"{a['name']} in [{a['lo_of'].replace('**', '^') if a.get('lo_of') else format(a['lo'], 'g')}, "
                         f"{a['hi']:g}]" for a in axes)
    return f"{target['variable']} in [{target['domain'][0]:g}, {target['domain'][1]:g}]"


def shader_text(expr, arguments: str, language: str, precision: str | None = None) -> str:
    """A form as a GLSL, HLSL or Python expression: in the one variable `arguments` (renamed to it),
    or in its symbols' own names where `arguments` names several (comma-separated); with
    `precision`, its numbers the format's values (`forms.in_format`), in fp16 GLSL each a float16_t
    and HLSL each a half, so that the arithmetic stays in 16 bits."""
    from .. import forms
    from ...isa.shaders import LITERAL, half_literals

    if "," not in arguments:
        text = {"glsl": glsl, "hlsl": hlsl, "python": python}[language](expr, arguments.strip(), precision)
    else:
        text = forms.printed({"glsl": forms._GLSL, "hlsl": forms._HLSL, "python": forms._Python}[language](), expr,
                             precision)
    if precision == "fp16" and language == "glsl":
        return half_literals(text)
    if precision == "fp16" and language == "hlsl":
        return LITERAL.sub(lambda m: f"half({m.group(1)})", text)
    return text


def function_name(target_name: str, member: str) -> str:
    """A member's function name in derive.glsl, derive.hlsl and derive_twin.py: an identifier made
    from the target's and the member's names (`escape.identifier`)."""
    return escape.identifier(f"{target_name}_{member}")


def function_names(results) -> dict[str, str]:
    """Each exported member's function name, distinct (a name that two members' names sanitize to
    takes a number)."""
    out: dict[str, str] = {}
    for name in exported(results):
        fn = base = function_name(results["target"]["name"], name)
        count = 1
        while fn in out.values() or fn + "_constants" in out.values():
            count += 1
            fn = f"{base}_{count}"
        out[name] = fn
    return out


def exported(results) -> list[str]:
    """The members exported as shader functions: every front's, in order of first appearance."""
    names = []
    for members in results["fronts"].values():
        names += [m for m in members if m not in names]
    return names


def arguments_of(results, name: str) -> str:
    """A member's arguments, comma-separated: the target's variable; a parametric target's variables
    and its parameter (a material member: its variables and constants c0, c1, ..., which the CPU
    computes); F0 where a pair's member computes F0 A + B."""
    target, member = results["target"], results["members"].get(name, {})
    if not target.get("variables"):
        return target["variable"]
    names = [a["name"] for a in target["variables"]]
    if member.get("parameter_per") == "material":
        names += [f"c{i}" for i in range(len(member.get("constants", [])))]
    elif target.get("parameter"):
        names.append(target["parameter"]["name"])
    if target["variable"].endswith("F0"):
        names.append("F0")
    return ", ".join(names)


def member_functions(results, name: str, fn: str | None = None) -> dict[str, str]:
    """A member as derive.glsl, derive.hlsl and derive_twin.py write it: {"glsl", "hlsl", "python"}:
    each the function's whole text (its comment or docstring included; a material member's twin
    with its `_constants` function), named `fn` (default its `function_names` name)."""
    target = results["target"]
    precision = results.get("precision")
    kinds = TYPES[precision]
    form = results["forms"][name]
    m = results["members"][name]
    fn = fn or function_names(results).get(name) or function_name(target["name"], name)
    expression, names = form.expression, arguments_of(results, name)
    # the form with the constants that were executed (a material member's formulas, computed on the
    # CPU in float64, as the twin computes them)
    written = m["expression"] if m.get("parameter_per") == "material" else shader_text(expression, names, "python",
                                                                                          precision)
    doc = (f"{written}: max abs error {m['max_abs_error']:.4g}, max rel error {m['max_rel_error']:.4g}"
           + (f" (as executed in {precision})" if precision else ""))
    out = {}
    for language, kind in (("glsl", kinds[0]), ("hlsl", kinds[1])):
        signature = ", ".join(f"{kind} {n.strip()}" for n in names.split(","))
        value = shader_text(expression, names, language, precision)
        body = ([f"    precise {kind} value_ = {value};", "    return value_;"] if results.get("contract") == "never"
                else [f"    return {value};"])      # (`--contract never`: no fused multiply-add, no reordering)
        out[language] = "\n".join([f"// {escape.comment(doc)}", f"{kind} {fn}({signature})", "{", *body, "}"])
    py = []
    if m.get("parameter_per") == "material":
        # the constants are the function's arguments; the twin computes them from the formulas
        parameter = target["parameter"]["name"]
        values = ", ".join(python(parse(c, (parameter,)), parameter) for c in m["constants"])
        py += [f"def {fn}_constants({parameter}):", f'    """c0, c1, ... of {fn}, once per material."""',
               f"    return [{values}]", "", ""]
    py += [f"def {fn}({names}):", f"    {escape.python_string(doc)}",
           f"    return {shader_text(expression, names, 'python', precision)}"]
    out["python"] = "\n".join(py)
    return out


def shader_sources(results) -> dict[str, str]:
    """derive.glsl, derive.hlsl and derive_twin.py as text: a head, then every exported member's
    `member_functions`."""
    target = results["target"]
    precision = results.get("precision")
    measured = (f"as executed in {precision} over the domain" if precision else "measured in float64 over the whole domain")
    head = ["// " + escape.comment(f"Forms of {target['expression']} for {domain_text(target)} found by "
                                   f"pipeline derive (error {target['metric']}, {measured})"), ""]
    glsl_lines, hlsl_lines = list(head), list(head)
    if precision == "fp16":
        glsl_lines[1:1] = [GLSL_FLOAT16]
        hlsl_lines[1:1] = ["// half: 16 bits with dxc -enable-16bit-types (min16float otherwise)"]
    py = [escape.python_string(f"Python twin of derive.glsl: the forms of {target['expression']}, for tests and plots."),
          "", "import math  # noqa: F401", "", ""]
    for name, fn in function_names(results).items():
        texts = member_functions(results, name, fn)
        glsl_lines += [texts["glsl"], ""]
        hlsl_lines += [texts["hlsl"], ""]
        py += [texts["python"], "", ""]
    return {"derive.glsl": "\n".join(glsl_lines), "derive.hlsl": "\n".join(hlsl_lines),
            "derive_twin.py": "\n".join(py).rstrip() + "\n"}
