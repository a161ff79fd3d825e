"""report.html of a `pipeline derive` run: the page's data (`engine.web_page` draws it in the
browser). Per architecture its rows (front.csv's: the front, the anchors, the exact target); per
form shown (every front's members, the anchors, the exact target) its code as derive.glsl,
derive.hlsl and derive_twin.py write it (`publish.member_functions`), its GLSL ES 3.00 function
for the live shader, its cycles on every architecture and its machine-code listing (the one its
cycles were counted from: the compilations `isa.machine_code` keeps); its signed error over the
domain (one variable: executed at `CURVE_POINTS` inputs, as the run executed; several: its
mathematics in float64 on a grid of two variables at `HEAT_VALUES` values of the parameter).
"""

from __future__ import annotations

import math
import re
import shlex

import numpy as np

from . import shader_export as publish

CURVE_POINTS = 513          # inputs of a one-variable form's error curve (evenly spaced, in the format)
HEAT_POINTS = 21            # per variable: a several-variable form's error map
HEAT_VALUES = 5             # values of the parameter the map is drawn at
LIVE_POINTS = 512           # inputs the live shader computes a one-variable form at
LIVE_SIZE = 128             # pixels per side of a several-variable form's live images


def shown(results) -> list[str]:
    """The forms the page shows: every front's members, then the anchors and the exact target."""
    names = publish.exported(results)
    for r in results["rows"]:
        if r["name"] not in names and r["name"] in results["forms"]:
            names.append(r["name"])
    return names


def gles_function(glsl: str) -> str:
    """A function of derive.glsl as GLSL ES 3.00: float16_t becomes mediump float (what a phone's
    driver computes mediump in; GLSL ES has no explicit 16-bit types)."""
    text = re.sub(r"\bfloat16_t\(", "float(", glsl)
    return re.sub(r"\bfloat16_t\b", "mediump float", text)


def _listings(results, names: list[str]) -> tuple[dict, dict]:
    """({name: {architecture: listing}}, {name: {architecture: cycles}}) of the forms' shaders as
    `pipeline derive` costed them, on every architecture of the run (the compilations are kept:
    this compiles nothing new); empty where no back end runs here."""
    from ...isa import machine_code
    from ..forms import glsl as glsl_of

    target = results["target"]
    precision = results.get("precision") or "fp32"
    architectures = list(results["architectures"])
    if target.get("variables"):
        from ..engines.several_variables import glsl_text

        axes = [a["name"] for a in target["variables"]] + ([target["parameter"]["name"]] if target.get("parameter") else [])
        variables = axes[:len(target["variables"])]
        bodies = {}
        for name in names:
            expr = results["forms"][name].expression
            per = results["members"].get(name, {}).get("parameter_per", "pixel")
            read = {s.name for s in expr.free_symbols}
            used = [n for n in (axes if per == "pixel" else variables) if n in read] or axes[:1]
            try:
                bodies[name] = (f"return {glsl_text(expr, precision)};", used, [n for n in used if n in variables] or used)
            except Exception:           # (no GLSL form: the row says so already)
                continue
    else:
        axes = ["t"]
        bodies = {}
        for name in names:
            try:
                bodies[name] = (f"return {glsl_of(results['forms'][name].expression, 't', precision)};", ["t"])
            except Exception:
                continue
    from ...isa.architectures import vendor_groups

    out: dict = {}
    cycles: dict = {}
    exact = {n: b for n, b in bodies.items() if results["forms"][n].kind == "exact"}
    others = {n: b for n, b in bodies.items() if n not in exact}
    # the exact target alone, vendor by vendor, as `pipeline derive` costed it (a vendor's lowering
    # may lack one of its functions); the forms together
    for group in (others, exact):
        for _, chosen in (vendor_groups(architectures) if group is exact else [(None, architectures)]):
            if not group:
                continue
            try:
                sources, wrappers, keys = machine_code.form_sources(group, axes, precision)
                wanted = list(keys) + sorted({wrappers[k] for k in keys})
                compiled = machine_code.compile_shaders({k: sources[k] for k in wanted}, wrappers, chosen)
            except Exception:           # (no back end here, or one that cannot lower a form: no listing)
                continue
            for a, rows in compiled["rows"].items():
                for key, row in rows.items():
                    if key in keys:
                        listing = row.get("listing", "")
                        out.setdefault(keys[key], {})[a] = (listing if isinstance(listing, str)
                                                            else "\n".join(map(str, listing)))
                        cycles.setdefault(keys[key], {})[a] = max(round(row["cycles"], 2), 0.0)   # (as `form_cycles`)
    return out, cycles


def _one_variable_curves(results, names: list[str]) -> tuple[dict, dict]:
    """(curves, how): each form's signed error (or relative error) at CURVE_POINTS inputs of the
    domain, executed as the run executed (lavapipe, else the per-operation emulation)."""
    from ...isa import execution
    from ..forms import glsl as glsl_of
    from ..targets import numpy_function

    target = results["target"]
    precision = results.get("precision") or "fp32"
    dtype = np.float16 if precision == "fp16" else np.float32
    lo, hi = target["domain"]
    x = np.unique(np.linspace(lo, hi, CURVE_POINTS).astype(dtype)).astype(np.float64)
    x = x[(x >= lo) & (x <= hi)]
    exact = next(n for n in names if results["forms"][n].kind == "exact") if any(
        results["forms"][n].kind == "exact" for n in names) else None
    symbol = next(iter(results["forms"][exact].expression.free_symbols)) if exact else None
    truth = numpy_function(results["forms"][exact].expression, symbol)(x) if exact else None
    bodies = {}
    for n in names:
        try:
            bodies[n] = glsl_of(results["forms"][n].expression, target["variable"], precision)
        except Exception:
            continue
    how = "lavapipe"
    values = {}
    if execution.available() is None:
        for n, v in execution.execute_forms(bodies, x, precision, target["variable"]).items():
            if not isinstance(v, Exception):
                values[n] = np.asarray(v, dtype=np.float64)
    else:
        how = "the per-operation emulation"
        for n, body in bodies.items():
            try:
                values[n] = np.asarray(execution.emulate(body, x, precision, target["variable"]), dtype=np.float64)
            except Exception:
                continue
    if truth is None:                   # (no exact row: the forms' own mathematics is all there is)
        return {}, {}
    relative = target["metric"] == "rel"
    error = {}
    with np.errstate(all="ignore"):
        for n, v in values.items():
            e = v - truth
            if relative:
                e = np.where(e == 0, 0.0, e / np.maximum(np.abs(truth), target.get("floor") or 0.0))
            error[n] = [float(round(val, 12)) if math.isfinite(val) else None for val in e.tolist()]
    return dict(kind="line", x=x.tolist(), variable=target["variable"], error=error,
                axis=("relative error" if relative else "error") + f" (executed in {precision})",
                title=f"Its signed {'relative ' if relative else ''}error over the domain, as executed ({how}, "
                      f"{x.size} inputs)"), dict(how=how)


def _several_variable_curves(results, names: list[str]) -> dict:
    """Each form's signed error (relative where the metric is) in float64 over a HEAT_POINTS grid of
    the first two variables at HEAT_VALUES values of the parameter (the form's constants as executed)."""
    from ..forms import in_format
    from ..targets import parse, several_variable_targets

    target = results["target"]
    axes = target["variables"] + ([target["parameter"]] if target.get("parameter") else [])
    if len(axes) < 3:
        return {}
    registered = several_variable_targets().get(target["name"])
    names_of = [a["name"] for a in axes]
    grid = [np.linspace(a["lo"], a["hi"], HEAT_POINTS) for a in axes[:2]]
    values = np.linspace(axes[2]["lo"], axes[2]["hi"], HEAT_VALUES)
    u, v, p = np.meshgrid(grid[0], grid[1], values, indexing="ij")
    f = registered.numpy() if registered is not None else None
    if f is None:
        return {}
    with np.errstate(all="ignore"):
        truth = f(u, v, p)
    import sympy as sp

    symbols = {s: sp.Symbol(s, real=True) for s in names_of}
    relative = target["metric"] == "rel"
    error = {}
    precision = results.get("precision") or "fp32"
    for n in names:
        expr = in_format(results["forms"][n].expression, precision)
        member = results["members"].get(n, {})
        if member.get("parameter_per") == "material":
            parameter = axes[2]["name"]
            formulas = {sp.Symbol(f"c{i}", real=True): parse(c, (parameter,)).subs(sp.Symbol(parameter), symbols[parameter])
                        for i, c in enumerate(member.get("constants", []))}
            expr = expr.subs(formulas)
        free = {s.name: s for s in expr.free_symbols}
        ordered = [free.get(s, symbols[s]) for s in names_of]
        g = sp.lambdify(ordered, expr, modules=["numpy", "scipy"])
        with np.errstate(all="ignore"):
            value = np.broadcast_to(np.asarray(g(u, v, p), dtype=np.float64), u.shape)
            e = value - truth
            if relative:
                e = np.where(e == 0, 0.0, e / np.maximum(np.abs(truth), target.get("floor") or 0.0))
        # [parameter value][first variable][second variable]
        error[n] = [[[float(round(val, 10)) if math.isfinite(val) else None for val in line] for line in plane]
                    for plane in np.moveaxis(e, 2, 0).tolist()]
    return dict(kind="heat", axes=[g_.tolist() for g_ in grid], names=names_of[:2],
                parameter=dict(name=names_of[2], values=values.tolist()), error=error,
                axis="relative error" if relative else "error",
                title=f"Its signed {'relative ' if relative else ''}error over {names_of[0]} and {names_of[1]} "
                      f"(its mathematics in float64, its constants as executed), the parameter on a slider")


def _live(results, names: list[str], functions: dict) -> dict:
    """What the live shader needs: the domain, the exact target's GLSL ES function and each form's
    call; {"why": ...} where it cannot run."""
    target = results["target"]
    exact = next((n for n in names if results["forms"][n].kind == "exact"), None)
    if not target.get("variables"):
        out = dict(kind="line", lo=target["domain"][0], hi=target["domain"][1], count=LIVE_POINTS,
                   variable=target["variable"])
    else:
        axes = target["variables"] + ([target["parameter"]] if target.get("parameter") else [])
        if len(axes) != 3 or target["variable"].endswith("F0"):
            sphere = _sphere(results)
            if sphere and exact and functions.get(exact, {}).get("gles"):
                return dict(kind="sphere", sphere=sphere, exact=functions[exact]["gles"],
                            exact_call=functions[exact]["call"])
            return dict(why="The live shader draws targets of two variables and a parameter, and terms with a "
                            "role in a shading on a lit sphere.")
        out = dict(kind="heat", size=LIVE_SIZE, names=[a["name"] for a in axes[:2]],
                   lo=[_glsl_float(a["lo"]) for a in axes[:2]], hi=[_glsl_float(a["hi"]) for a in axes[:2]],
                   parameter=dict(name=axes[2]["name"], lo=axes[2]["lo"], hi=axes[2]["hi"],
                                  middle=0.5 * (axes[2]["lo"] + axes[2]["hi"])),
                   relative=target["metric"] == "rel")
    if exact and functions.get(exact, {}).get("gles"):
        out |= dict(exact=functions[exact]["gles"], exact_call=functions[exact]["call"])
        sphere = _sphere(results)
        if sphere:
            out["sphere"] = sphere
    return out


def _sphere(results) -> dict | None:
    """What the live lit sphere needs for a target with a role (`rendered`) that is not a pair: the
    role, the target's variable and parameter names in the role's order with their box (the inputs
    clamped to it, as the renders clamp them), and the spheres' roughness span."""
    from ...optics.roles import ROLES

    rendered = results.get("rendered") or {}
    role = ROLES.get(rendered.get("role") or "")
    target = results["target"]
    if role is None or role.name == "env_brdf":
        return None
    axes = (target["variables"] + ([target["parameter"]] if target.get("parameter") else [])
            if target.get("variables") else [dict(name=target["variable"], lo=target["domain"][0], hi=target["domain"][1])])
    roughness = rendered["scene"]["roughness"]
    inputs = list(role.inputs) + ([role.parameter] if role.parameter else [])
    box = [(0.0, 1.0) if name == "NoH" else (a["lo"], a["hi"]) for name, a in zip(inputs, axes)]   # (as `rendered`)
    return dict(role=role.name, what=role.what, names=[a["name"] for a in axes], inputs=inputs,
                lo=[_glsl_float(lo) for lo, _ in box], hi=[_glsl_float(hi) for _, hi in box],
                roughness=[roughness[0], roughness[-1]])


def _glsl_float(value: float) -> str:
    text = repr(float(value))
    return text if ("." in text or "e" in text) else text + ".0"


def data(results) -> dict:
    """The page's data (module docstring); every number from `results`."""
    from ...isa.architectures import ARCHITECTURES, VENDORS
    from ...isa.machine_code import backend
    from ...symbolic.budgets import plan_text

    target = results["target"]
    precision = results.get("precision") or "fp32"
    names = shown(results)
    error_key = results["error"]
    names_of = publish.function_names(results)
    functions = {}
    for n in names:
        fn = names_of.get(n) or publish.function_name(target["name"], n)
        try:
            code = publish.member_functions(results, n, fn)
        except Exception:               # (a function the printers do not know)
            code = {}
        arguments = [a.strip() for a in publish.arguments_of(results, n).split(",")]
        call = None
        if results["members"].get(n, {}).get("parameter_per") == "material":
            from ..forms import _GLSL, printed
            from ..targets import parse

            parameter = target["parameter"]["name"]
            constants = [f"({printed(_GLSL(), parse(c, (parameter,)), precision)})"
                         for c in results["members"][n].get("constants", [])]
            call = f"{fn}({', '.join(arguments[:-len(constants)] + constants if constants else arguments)})"
        elif "glsl" in code:
            call = f"{fn}({', '.join(arguments)})"
        functions[n] = dict(code=code, gles=gles_function(code["glsl"]) if "glsl" in code else None, call=call)
    listings, cycles = _listings(results, names)
    rows: dict = {}
    for r in results["rows"]:
        cycles.setdefault(r["name"], {})[r["architecture"]] = r["cycles"]     # (the row's, where it has one)
        rows.setdefault(r["architecture"], []).append(dict(
            name=r["name"], kind=r["kind"], cycles=r["cycles"], error=r[error_key], error_real=r.get(error_key + "_real"),
            on_front=bool(r["on_front"]), expression=r["expression"], front=r.get("parameter_per") or "",
            flip=r.get("flip_max"), certified=r.get("certified"), error_sampled=r.get(error_key + "_sampled"),
            error_spec=r.get(error_key + "_spec")))
    if target.get("variables"):
        curves, how = _several_variable_curves(results, names), {}
    else:
        curves, how = _one_variable_curves(results, names)
    if not curves:
        axis_count = len(target.get("variables") or []) + bool(target.get("parameter"))
        curves = dict(kind="none", error={}, title=(
            f"No error map: the page draws one over two variables and a parameter, and this target has "
            f"{len(target['variables'])} variable(s){' and a parameter' if target.get('parameter') else ''} "
            "(each form's error is in the table)" if target.get("variables") and axis_count != 3 else
            "No error curve: the target has no exact form to compare with"))
    forms = {}
    for n in names:
        form, member = results["forms"][n], results["members"].get(n, {})
        forms[n] = dict(kind=form.kind, expression=member.get("expression") or str(form.expression),
                        source=member.get("source", ""), code=functions[n]["code"], gles=functions[n]["gles"],
                        call=functions[n]["call"], cycles=cycles.get(n, {}), listing=listings.get(n, {}))
    anchors = [a["name"] for a in target.get("anchors", [])]
    exact = next((n for n in names if results["forms"][n].kind == "exact"), None)
    metric = "relative" if error_key == "max_rel_error" else "absolute"
    execution = results.get("execution") or {}
    summary = [["architectures", ", ".join(results["architectures"])],
               ["executed by", execution.get("how")],
               ["inputs executed", f"{execution['inputs']:,}" if execution.get("inputs") else None],
               ["families", ", ".join(results.get("families", []))],
               ["search", _coverage_text(results.get("coverage") or {})],
               ["plan", plan_text(results["plan"]) if (results.get("plan") or {}).get("searches") else None],
               ["time", f"{results['seconds']} s" + (f" (forecast {results['estimated_seconds']} s)"
                                                     if results.get("estimated_seconds") else "")]]
    notes = [f"{vendor}: {why}" for vendor, why in (results.get("missing") or {}).items()]
    return dict(
        kind="derive",
        title=target["name"] if target["name"] == target["expression"] else f"{target['name']}: {target['expression']}",
        target=dict(name=target["name"], expression=target["expression"], description=target.get("description") or "",
                    domain_text=publish.domain_text(target), metric=target["metric"], precision=precision),
        command=rerun_command(results),
        summary=summary, notes=notes,
        error_label=f"largest {metric} error as executed in {precision}",
        floor=results.get("rounding_floor") or 0.0,
        architectures=[dict(name=a, title=ARCHITECTURES[a].title, vendor=ARCHITECTURES[a].vendor,
                            vendor_title=VENDORS[ARCHITECTURES[a].vendor], cost_model=backend(a).UNIT)
                       for a in results["architectures"]],
        rows=rows, forms=forms, curves=curves, anchors=anchors, exact=exact,
        verdicts=results.get("verdicts") or {},
        verdict_columns=anchors + (["exact"] if any("exact" in v for v in (results.get("verdicts") or {}).values()) else []),
        special=[dict(arch=a, functions=f) for a, f in (results.get("special_functions") or {}).items()],
        live=_live(results, names, functions) | how,
    )


def rerun_command(results) -> str:
    """The command that reruns the run: its registered target by name, an expression's by --expr and
    --var (and --name where the run was named otherwise), its architectures, its precision, --certify
    and --contract never where it ran with them; where
    it recorded its plans, its largest complexity and `--plan results.json` (the same front again)."""
    from ..targets import registry

    target = results["target"]
    precision = results.get("precision") or "fp32"
    command = ["pipeline", "derive"]
    if target["name"] in registry():
        command += ["--target", target["name"]]
    elif not target.get("variables"):         # (an expression's: the same target as --expr)
        command += ["--expr", shlex.quote(target["expression"]),
                     f"--var {target['variable']}={target['domain'][0]:g}:{target['domain'][1]:g}"]
        if target["name"] != target["expression"]:
            command += ["--name", shlex.quote(target["name"])]
    command += ["--gpu", ",".join(results["architectures"])]
    if precision != "fp32":
        command += ["--precision", precision]
    if results.get("certification") is not None:
        command += ["--certify"]
    if results.get("contract") == "never":
        command += ["--contract", "never"]
    from ..engines.options import MAX_COMPLEXITY

    plans = list(((results.get("plan") or {}).get("searches") or {}).values())
    if plans:
        if plans[0]["max_complexity"] != MAX_COMPLEXITY:
            command += ["--max-complexity", str(plans[0]["max_complexity"])]
        command += ["--plan", "results.json"]
    return " ".join(command)


def _coverage_text(coverage: dict) -> str | None:
    if not coverage.get("rungs"):
        return None
    return "; ".join(f"{r['name']}: {r['forms']} forms to complexity {r['complexity']} ({r['seconds']} s, forecast "
                     f"{r['estimated_seconds']} s)" for r in coverage["rungs"])


def _rendered(results, folder) -> dict | None:
    """The rendered comparison (`rendered`): results.json's object and renders.png (written beside the
    page before it) as PNG data; None where the run rendered nothing."""
    import base64

    r = results.get("rendered")
    if not r or not r.get("role"):
        return dict(why=r["why"]) if r else None
    figure = folder / "renders.png"
    return dict(rule=r["rule"], threshold=r["threshold"], what=r["what"], budget=r["budget"], budget_is=r["budget_is"],
                architectures=r["architectures"],
                png=base64.b64encode(figure.read_bytes()).decode("ascii") if figure.exists() else None)


def write(path, results) -> None:
    """report.html at `path` (after renders.png beside it, which it embeds)."""
    from ...engine import web_page

    page = data(results) | dict(rendered=_rendered(results, path.parent))
    path.write_text(web_page.page(page["title"], page))
