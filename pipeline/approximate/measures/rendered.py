"""The error as seen: a derive run's forms rendered in the shading they replace and compared with the
exact term's image by FLIP (`optics.material_balls`: the scene, its lights and roles).

A target with a role (`role` in its registry entry or its file: `optics.material_balls.ROLES`) is
rendered once with its exact function in the role (float64, rounded to float32 like every other
factor) and once per form of front.csv (every architecture's front members, the anchors), the form
evaluated in the run's precision from the inputs in that precision, each input clamped to the
target's box (as an engine clamps NoV) and, for a parameter per material, its constants' formulas
computed in float64. FLIP (flip-evaluator, LDR, as the paper's renders use it) of each displayed
8-bit image against the exact term's, over the spheres' pixels: its mean, 99th percentile and largest
value (`flip_mean`, `flip_p99`, `flip_max`).

The rule (`invisible`): a form's render counts as indistinguishable from the exact term's when its
largest FLIP value over the spheres is no more than the largest that raising the whole exact image by
one display level (1/255 of its sRGB code) produces: a change nowhere larger, as FLIP sees it, than
the display's own smallest step made everywhere. The renders are deterministic (no sampling noise),
so the largest value is the difference, and it catches a highlight smaller than 1 % of the spheres,
which the 99th percentile does not. Per architecture: the FLIP front (largest FLIP against cycles),
the cheapest invisible form beside the cheapest form within the max-error budget (the smallest
error of the target's anchors, where it has anchors; else the format's rounding floor), and each
anchor's verdict by FLIP at its cycles beside its max-error verdict.
"""

from __future__ import annotations

import math
import time

import numpy as np

from ...optics.roles import ROLES

STATISTIC = "flip_max"          # what the rule and the FLIP front read
MATCH = 0.01                    # within this share the FLIPs of two forms count as equal (as the verdicts' 1 %)
DEFAULT_ROUGHNESS = (0.05, 1.0)  # a role without a roughness parameter: the env_brdf box's span
RULE = ("a form is invisible where its largest FLIP over the spheres is no more than the largest FLIP of the exact "
        "image raised one display level (1/255 of sRGB) everywhere")


def role_of(target):
    """The target's role (`material_balls.Role`), or None where it has none."""
    return ROLES.get(getattr(target, "role", "") or "")


def _inner(target):
    """A pair's first part (both have the same axes), else the target."""
    return target.parts[0] if target.parts else target


def _axes(target) -> list[tuple[float, float]]:
    """The target's variables' and parameter's ranges, in order."""
    return [(a.lo, a.hi) for a in _inner(target).axes]


def _symbols_of(target) -> list:
    return _inner(target).symbols()


def roughness_range(target, role) -> tuple[float, float]:
    """The spheres' roughness span: the target's parameter's (alpha = roughness^2; n = 2 / alpha^2 - 2)."""
    if role.parameter is None:
        return DEFAULT_ROUGHNESS
    lo, hi = _axes(target)[-1]
    if role.parameter == "alpha":
        return math.sqrt(lo), math.sqrt(hi)
    if role.parameter == "n":
        return (2.0 / (hi + 2.0)) ** 0.25, (2.0 / (lo + 2.0)) ** 0.25
    return lo, hi


def scene_of(target, size: int | None = None):
    """The material balls' scene for the target's role (its roughness span)."""
    from ...optics import material_balls as balls

    return balls.Scene(balls.roughness_grid(*roughness_range(target, role_of(target))), size or balls.SIZE)


def _inputs(target, role, scene, dtype) -> list:
    """The role's inputs at the scene's pixels, clamped to the target's box (a lobe's NoH to [0, 1]:
    its zone is where it is measured, the lobe is drawn everywhere), in `dtype`: one array per
    variable, then the parameter (shapes broadcasting to (LIGHTS, P), or (P,) for env_brdf)."""
    from ...optics import material_balls as balls

    g = balls.geometry(scene)
    source = {"VoH": g["VoH"], "NoV": g["NoV"], "NoL": g["NoL"], "NoH": g["NoH"], "alpha": g["alpha"],
              "roughness": g["roughness"]}
    with np.errstate(divide="ignore"):
        source["n"] = 2.0 / g["alpha"] ** 2 - 2.0
    names = role.inputs + ((role.parameter,) if role.parameter else ())
    ranges = [(0.0, 1.0) if name == "NoH" else box for name, box in zip(names, _axes(target))]
    return [np.clip(source[name], lo, hi).astype(dtype) for name, (lo, hi) in zip(names, ranges)]


def _in_role(role, value, scene):
    """A term's values as the factor it replaces (`material_balls.exact_terms`' key, its array)."""
    from ...optics import material_balls as balls

    value = np.asarray(value, dtype=np.float64)
    if role.name == "fresnel":
        return "F", value
    if role.name == "visibility":
        return "V", value
    if role.name == "lobe":
        g = balls.geometry(scene)
        n = 2.0 / g["alpha"] ** 2 - 2.0
        return "D", (n + 2.0) / (2.0 * np.pi) * np.maximum(value, 0.0)
    return "env", value


def exact_factor(target, role, scene):
    """(key, values) of the target's exact function in its role, float64."""
    from ...optics import material_balls as balls

    inputs = _inputs(target, role, scene, np.float64)
    if role.name == "env_brdf":
        A, B = target.scale.numpy()(*inputs), target.bias.numpy()(*inputs)
        return "env", balls.geometry(scene)["F0"] * A[:, None] + B[:, None]
    f = target.numpy()
    value = f(*inputs) if len(inputs) > 1 else f(inputs[0])
    return _in_role(role, np.broadcast_to(value, np.broadcast_shapes(*(np.shape(x) for x in inputs))), scene)


def form_factor(expr, target, role, scene, dtype):
    """(key, values) of a form's expression (sympy, its constants already substituted) in the role,
    computed in `dtype` from inputs in `dtype`."""
    from ...optics import material_balls as balls

    import sympy as sp

    symbols = _symbols_of(target)
    inputs = _inputs(target, role, scene, dtype)
    if role.name == "env_brdf":
        F0 = sp.Symbol("F0", real=True)
        function = sp.lambdify(symbols + [F0], expr, modules="numpy")
        g = balls.geometry(scene)
        with np.errstate(all="ignore"):
            value = np.stack([np.broadcast_to(function(*inputs, g["F0"][:, c].astype(dtype)), inputs[0].shape)
                              for c in range(3)], axis=-1)
        return "env", value.astype(np.float64)
    function = sp.lambdify(symbols, expr, modules="numpy")
    with np.errstate(all="ignore"):
        value = function(*inputs)
    shape = np.broadcast_shapes(*(np.shape(x) for x in inputs))
    return _in_role(role, np.broadcast_to(np.asarray(value, dtype=np.float64), shape), scene)


def _statistics(fmap, inside) -> dict:
    values = fmap[inside]
    return dict(flip_mean=float(values.mean()), flip_p99=float(np.percentile(values, 99)), flip_max=float(values.max()))


def table_env_brdf():
    """env_brdf(NoV, roughness) -> (A, B): the split-sum tables (`targets.env_brdf_table`), their
    inputs clamped to the tables' box."""
    from ..targets import env_brdf_table

    A, B = env_brdf_table()
    (nov_lo, nov_hi), (r_lo, r_hi) = ((min(a[0], a[-1]), max(a[0], a[-1])) for a in A.axes)

    def env_brdf(nov, roughness):
        nov, roughness = np.clip(nov, nov_lo, nov_hi), np.clip(roughness, r_lo, r_hi)
        return A(nov, roughness), B(nov, roughness)
    return env_brdf


def compare_images(scene, base: dict, exact: tuple, factors: dict) -> dict:
    """The scene shaded with `base` (`material_balls.exact_terms`) and the exact factor `exact` (key,
    values), then with each of `factors` ({name: (key, values)}) in its place: the displayed images,
    the FLIP maps against the exact one, their statistics over the spheres, and the rule's threshold
    (the FLIP of the exact image raised one display level)."""
    from ...optics import material_balls as balls
    from ...optics.images import flip_map

    key, value = exact
    reference = balls.display(balls.shade(scene, base | {key: value}))
    inside = balls.mask(scene)
    raised = np.minimum(reference.astype(np.int32) + 1, 255).astype(np.uint8)
    threshold = _statistics(flip_map(reference, raised), inside)[STATISTIC]
    images, maps, statistics = {}, {}, {}
    for name, (key, value) in factors.items():
        image = balls.display(balls.shade(scene, base | {key: value}))
        fmap = flip_map(reference, image)
        images[name], maps[name], statistics[name] = image, fmap.astype(np.float16), _statistics(fmap, inside)
    return dict(exact=reference, images=images, maps=maps, statistics=statistics, threshold=threshold)


def render(target, forms: dict, precision: str = "fp32", size: int | None = None, log=print) -> dict:
    """The exact term's image and each form's ({name: sympy expression, constants substituted}), its
    FLIP map and statistics, and the rule's threshold (module docstring)."""
    from ...optics import material_balls as balls

    role = role_of(target)
    scene = scene_of(target, size)
    dtype = np.float16 if precision == "fp16" else np.float32
    started = time.perf_counter()
    # (a pair's own environment BRDF replaces the table's, which its role leaves unread)
    base = balls.exact_terms(scene, table_env_brdf() if role.name != "env_brdf" else
                             lambda nov, roughness: (np.zeros_like(nov), np.zeros_like(nov)))
    drawn = compare_images(scene, base, exact_factor(target, role, scene),
                           {name: form_factor(expr, target, role, scene, dtype) for name, expr in forms.items()})
    seconds = time.perf_counter() - started
    log(f"rendered: the exact {target.name} and {len(forms)} forms in {role.name}'s place, FLIP each "
        f"({seconds:.1f} s)")
    return drawn | dict(role=role, scene=scene, seconds=seconds)


def forms_of(results) -> dict:
    """{name: sympy expression} of every form of front.csv's rows, in the run's format, a material
    form's constants replaced by their formulas in the parameter."""
    import sympy as sp

    from ..forms import in_format
    from ..targets import parse

    precision = results.get("precision") or "fp32"
    parameter = (results["target"].get("parameter") or {}).get("name")
    out = {}
    for r in results["rows"]:
        name = r["name"]
        if name in out or name not in results["forms"]:
            continue
        expr = in_format(results["forms"][name].expression, precision)
        member = results["members"].get(name, {})
        if member.get("parameter_per") == "material" and parameter:
            formulas = {sp.Symbol(f"c{i}", real=True): parse(c, (parameter,))
                        for i, c in enumerate(member.get("constants", []))}
            expr = expr.subs(formulas)
        out[name] = expr
    return out


def invisible(statistics: dict, threshold: float) -> bool:
    return statistics[STATISTIC] <= threshold


def decide(rows: list[dict], statistics: dict, threshold: float, error: str, budget: float, architectures) -> dict:
    """Per architecture (rows: front.csv's, each with its cycles and `error`): the FLIP front (names,
    cheapest first), the form of least FLIP (the exact target aside), the cheapest invisible form and
    the cheapest within the max-error `budget`, and
    each anchor's verdict by FLIP at its cycles: beaten (a found form at no more cycles whose FLIP is
    lower by more than MATCH, where the anchor is not itself invisible), matched (within MATCH, or both
    invisible), missed."""
    out = {}
    for a in architectures:
        mine = [r for r in rows if r["architecture"] == a and r["name"] in statistics
                and math.isfinite(r["cycles"])]
        order = sorted(mine, key=lambda r: (r["cycles"], statistics[r["name"]][STATISTIC]))
        front, best = [], math.inf
        for r in order:
            if r["kind"] == "found" and statistics[r["name"]][STATISTIC] < best:
                front.append(r["name"])
                best = statistics[r["name"]][STATISTIC]
        seen = next((r for r in order if invisible(statistics[r["name"]], threshold)), None)
        within = next((r for r in sorted(mine, key=lambda r: (r["cycles"], r[error]))
                       if r[error] is not None and r[error] <= budget), None)
        verdicts = {}
        for r in (r for r in mine if r["kind"] == "anchor"):
            mine_flip = statistics[r["name"]][STATISTIC]
            rivals = [x for x in mine if x["kind"] == "found" and x["cycles"] <= r["cycles"]]
            if not rivals:
                verdicts[r["name"]] = dict(verdict="missed", by=None, flip=mine_flip, rival_flip=None,
                                           cycles=r["cycles"])
                continue
            rival = min(rivals, key=lambda x: (statistics[x["name"]][STATISTIC], x["cycles"]))
            theirs = statistics[rival["name"]][STATISTIC]
            both = invisible(statistics[r["name"]], threshold) and invisible(statistics[rival["name"]], threshold)
            verdict = ("matched" if both or abs(theirs - mine_flip) <= MATCH * max(mine_flip, theirs) else
                       "beaten" if theirs < mine_flip else "missed")
            verdicts[r["name"]] = dict(verdict=verdict, by=rival["name"], flip=mine_flip, rival_flip=theirs,
                                       cycles=r["cycles"])
        least = min((r for r in mine if r["kind"] != "exact"), key=lambda r: (statistics[r["name"]][STATISTIC], r["cycles"]),
                    default=None)
        out[a] = dict(front=front,
                      least_flip=None if least is None else dict(
                          name=least["name"], kind=least["kind"], cycles=least["cycles"],
                          flip=statistics[least["name"]][STATISTIC]),
                      cheapest_invisible=None if seen is None else dict(
                          name=seen["name"], kind=seen["kind"], cycles=seen["cycles"],
                          flip=statistics[seen["name"]][STATISTIC]),
                      cheapest_within_budget=None if within is None else dict(
                          name=within["name"], kind=within["kind"], cycles=within["cycles"], error=within[error]),
                      anchors=verdicts)
    return out


def budget_of(results) -> tuple[float, str]:
    """The max-error budget: the anchors' smallest error (what an engine ships), else the rounding floor."""
    error = results["error"]
    anchors = [r[error] for r in results["rows"] if r["kind"] == "anchor" and r[error] is not None
               and math.isfinite(r[error])]
    if anchors:
        return min(anchors), "the anchors' smallest error (what an engine already ships)"
    return results["rounding_floor"], "the format's rounding floor (the target has no anchor)"


def compare(results: dict, target, size: int | None = None, log=print) -> None:
    """Adds the rendered comparison to a derive run's results (in place): flip_mean, flip_p99 and
    flip_max on each row and member, `rendered` (results.json's object) and `renders` (the images,
    for the figure; not in results.json). A target without a role gets `rendered` saying so."""
    from ...optics import material_balls as balls

    role = role_of(target)
    if role is None:
        results["rendered"] = dict(role=None, why=f"{target.name} has no role in a shading (a target file's `role` "
                                                  f"declares one: {', '.join(ROLES)}), so it is not rendered")
        return
    forms = forms_of(results)
    drawn = render(target, forms, results.get("precision") or "fp32", size, log)
    statistics = drawn["statistics"]
    for r in results["rows"]:
        r.update(statistics.get(r["name"], {}))
    for name, s in statistics.items():
        if name in results["members"]:
            results["members"][name].update(s)
    budget, why = budget_of(results)
    scene = drawn["scene"]
    results["rendered"] = dict(
        role=role.name, what=role.what, rule=RULE, statistic=STATISTIC, threshold=drawn["threshold"],
        budget=budget, budget_is=why, seconds=round(drawn["seconds"], 1),
        scene=dict(roughness=list(scene.roughness), materials=dict(dielectric=balls.DIELECTRIC, metal=balls.METAL),
                   pixels=list(scene.shape), tone_map="Khronos PBR Neutral, sRGB, 8 bits",
                   lights="a key and a rim directional light, a point light beside each sphere, an environment "
                          "(split sum)"),
        architectures=decide(results["rows"], statistics, drawn["threshold"], results["error"], budget,
                             results["architectures"]))
    results["renders"] = dict(exact=drawn["exact"], images=drawn["images"], maps=drawn["maps"])
