"""Decisions (beyond the paper): which lobe a renderer should ship, per scenario, by one declared rule.

A scenario is an architecture (each one `gpu_isa` compiled for: rdna3, ..., sm_120) x a range of n (the lobe
search's ranges) x a use ("phong": the lobe of t = R.V; "blinn": of t = N.H; "ndf": the microfacet
distribution, against Beckmann at the matched roughness a^2 = 2 / (n + 2)) x where n lives
("material": the lobe's parameters and coef are uniforms, the coef computed exactly on the CPU;
"pixel": both computed in the shader) x the precision ("fp32", "fp16").

The candidates: the reference itself (cos^n; Beckmann for the NDF), every registry lobe that
approximates it, the family's other powers (`power_front`, each with its own line), the lobe search's
families with their parameters as lines in n per range (what its exported shader computes), and for
the NDF GGX and the family. Per candidate and range (`candidates`):
- `d`, `D`: max over the range at equal peak (1 at t = 1), as the stages measured them
  (`lobe_comparison`, `power_front`, `lobe_search`'s d_line and D_line, `ndf`);
- `peak_ratio`: its normalized peak over the reference's (Phong-form coefs, 1 / (2 pi int g t dt); for
  the NDF the same integral, int D (N.h) dw_h = 1), the value farthest from 1 at the grid's n in the
  range: what a material switched to it without retuning gets at the highlight's centre;
- `fp16_error`: the largest absolute error (peak 1) of its float16 evaluation over the visible
  highlight (where the reference >= 1/255) at the grid's n in the range, the better of two routes
  (t = dot(N, H) in float16; u = 1 - t from the cross product, the form rewritten in u: `family` says
  how), against its own float64 value: its GLSL executed in float16 by lavapipe (`executed_float16`:
  explicit 16-bit types, its parameters float16 as uniforms are, pow and exp Mesa's float16
  lowerings), all candidates in one batch; `fp16_error_emulated` is numpy's per-operation float16
  (transcendentals in float32, rounded), which stands where lavapipe cannot run, and
  `fp16_changed_by_execution` lists the fp16 scenarios whose winner the two differ on;
- per architecture, `cycles` with n per material (the lobe's shader alone) and, for the registry's
  lobes and the NDFs (`ndf_per_pixel`), `pixel`: per normalization of each form, the cycles of lobe and
  coef compiled together (n per pixel),
  with that coef's largest albedo (`lobe_comparison`) and its float16 error relative to its float64
  value (inf where it overflows float16).

The rule (`RULE`): a candidate qualifies when its max d <= `decision.max_d`, its max D (plus its
float16 error in fp16: the two bound the error of what the shader returns) <= `decision.max_D`
and, with n per pixel, its coef's largest albedo exceeds 1 by at most `decision.max_energy_excess`.
The winner is the cheapest candidate that qualifies, equal cycles going to the smaller d, then to the
earlier listed; the runner-up is the next by the same order. The reference qualifies in fp32 by
construction (d = D = 0), so it wins when nothing cheaper qualifies; in fp16 nothing may qualify,
and the row says so. A candidate whose cost was not compiled for the scenario is not ranked in it.
Each row's `reason` is written from its numbers. The shape measures (normalized peak, float16 error)
are memoized by the candidate's parameters, so that a refit re-measures only the candidates it moves.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from ..engine import toolchains
from ..isa import machine_code
from ..optics import lobe_families, registry
from ..optics.float16 import routes, vectors
from ..optics.normalizations import normalizations
from ..optics.lobe_candidates import (_f16, _transcendental16, beckmann_over_peak, cos_power,  # noqa: F401
                                      evaluator, exponential, family, ggx_over_peak, linear_power, phong_integral,
                                      registry_descriptor, schlick)
from .common import n_range

USES = ("phong", "blinn", "ndf")
N_PER = ("material", "pixel")
PRECISIONS = ("fp32", "fp16")
VISIBLE = 1.0 / 255.0
SAMPLES = 4096
RULE = ("a candidate qualifies when max d <= {max_d:.4g} % and max D (plus its float16 error in fp16) <= {max_D:.4g} "
        "of the peak over the range (and, with n per pixel, its coef reflects at most {excess:.4g} % more than "
        "arrives); the cheapest that qualifies wins (ties: the smaller d); the reference wins when nothing cheaper "
        "qualifies")


def rule_text(max_d: float, max_D: float, max_energy_excess: float) -> str:
    return RULE.format(max_d=100 * max_d, max_D=max_D, excess=100 * max_energy_excess)


# ---------------------------------------------------------------------------------------------------
# Each candidate's value in float64 (of t) and in float16 (of t16 and u16, per route): `optics.lobe_candidates`.

def float16_error(make, n_values, reference) -> tuple[float, str]:
    """(largest absolute float16 error over the n values, its better route): `make(n)` gives a
    candidate's (float64, float16) pair at n, `reference(n)` the reference's, whose visible highlight
    (>= 1/255 of its peak) is sampled."""
    worst = {"t": 0.0, "u": 0.0}
    for n in n_values:
        v64, v16, _ = make(n)
        ref64 = reference(n)[0]
        x, t16, u16 = _highlight(_visible_angle(ref64))
        exact = v64(np.cos(x))
        with np.errstate(all="ignore"):
            by_route = v16(t16, u16)
        for route, values in by_route.items():
            error = np.abs(values.astype(np.float64) - exact)
            worst[route] = max(worst[route], float(np.max(np.where(np.isfinite(error), error, np.inf))))
    route = min(worst, key=worst.get)
    return worst[route], route


@functools.lru_cache(maxsize=64)
def _highlight(angle: float):
    """(x, t, u): angles over [0, angle] and, from float16 vectors N, H at those angles (fixed seed),
    t = N.H and u = |N x H|^2 / (1 + N.H) in float16, as a shader forms them."""
    x = np.linspace(0.0, angle, SAMPLES)
    N, H = (v.astype(np.float16) for v in vectors(x, seed=0))
    return (x,) + routes(N, H)


def _visible_angle(v64) -> float:
    """The angle where a lobe (peak 1, decreasing) falls to 1/255, by bisection on [0, pi/2]."""
    lo, hi = 0.0, 0.5 * np.pi
    if v64(np.cos(hi)) >= VISIBLE:
        return hi
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if v64(np.cos(mid)) >= VISIBLE else (lo, mid)
    return lo


def coef_float16_error(expr, n_values) -> float:
    """The largest relative error of a normalization coef(n) (sympy, in n) evaluated in float16 (one
    rounding per operation, integer powers as products), inf where it overflows."""
    import sympy as sp
    (n,) = expr.free_symbols
    expr = expr.doit()
    expr = expr.subs(sp.pi, sp.Float(math.pi, 17))
    f = sp.lambdify(n, expr.replace(lambda e: e.is_Pow and e.exp.is_Integer and 1 < e.exp <= 8,
                                    lambda e: sp.Mul(*([e.base] * int(e.exp)), evaluate=False)), "numpy")
    g = sp.lambdify(n, expr, "numpy")
    nv = np.asarray(n_values, dtype=np.float64)
    with np.errstate(all="ignore"):
        half = np.asarray(f(nv.astype(np.float16)), dtype=np.float64)
        exact = np.asarray(g(nv), dtype=np.float64)
        error = np.abs(half / exact - 1.0)
    return float(np.max(np.where(np.isfinite(error), error, np.inf)))


@toolchains.uses("lavapipe")
def executed_float16(jobs) -> dict:
    """The float16 error of each candidate as lavapipe executes its GLSL (`isa.execution`, explicit
    16-bit types; its parameters float16 inputs, as uniforms are): `jobs` [(descriptor, target, n)],
    each candidate's routes over the visible highlight of every n, all in one child process, one
    shader per GLSL text. Returns dict(errors=[[error, route] or None per job], executed_by): None
    where lavapipe cannot run (the emulation's numbers stand) or a shader failed."""
    from ..isa import execution

    why = execution.available()
    if why is not None:
        return dict(errors=[None] * len(jobs), executed_by=f"numpy's per-operation float16 emulation ({why})")
    groups: dict = {}              # GLSL -> [inputs x, p0, p1, p2 per sample], and its segments
    segments = []                  # (job, route, body, start, stop, exact values)
    for j, (descriptor, target, n_values) in enumerate(jobs):
        make = evaluator(descriptor)
        reference = cos_power if target == "cos_n" else beckmann_over_peak
        for n in n_values:
            v64, _, shader = make(n)
            x, t16, u16 = _highlight(_visible_angle(reference(n)[0]))
            exact = v64(np.cos(x))
            for route, values in (("t", t16), ("u", u16)):
                body, parameters = shader[route]
                inputs = groups.setdefault(body, [[], [], [], []])
                start = sum(len(a) for a in inputs[0])
                inputs[0].append(values)
                for i in range(3):
                    inputs[i + 1].append(np.full(values.size, parameters[i] if i < len(parameters) else 0.0))
                segments.append((j, route, body, start, start + values.size, exact))
    sets = [({body: body}, {name: np.concatenate(a) for name, a in zip(("x", "p0", "p1", "p2"), arrays)}, None, 0.0)
            for body, arrays in groups.items()]
    done = dict(zip(groups, execution.execute_sets(sets, "fp16")))
    worst = [dict(t=0.0, u=0.0) for _ in jobs]
    failed = set()
    for j, route, body, start, stop, exact in segments:
        values = done[body][body]
        if isinstance(values, execution.ExecutionError):
            failed.add(j)
            continue
        with np.errstate(all="ignore"):
            error = np.abs(values[start:stop].astype(np.float64) - exact)
        worst[j][route] = max(worst[j][route], float(np.max(np.where(np.isfinite(error), error, np.inf))))
    errors = [None if j in failed else [worst[j][min(worst[j], key=worst[j].get)], min(worst[j], key=worst[j].get)]
              for j in range(len(jobs))]
    return dict(errors=errors, executed_by="lavapipe (Mesa's Vulkan driver on the CPU), float16 with explicit "
                                           "16-bit types")


# ---------------------------------------------------------------------------------------------------
# The rule.

def ranked(options: list[dict]) -> list[dict]:
    """Options (dicts with `cycles`, `d` and `qualifies`) in the rule's order: qualifying first, the
    cheapest first, equal cycles by the smaller d, then as listed."""
    order = sorted(range(len(options)), key=lambda i: (not options[i]["qualifies"], options[i]["cycles"],
                                                      options[i]["d"], i))
    return [options[i] for i in order]


def decide(options: list[dict], reference: str, budget: dict) -> dict:
    """The winner and runner-up of one scenario, and the reason in numbers. `options`: per candidate
    name, label, cycles, d, D (plus float16 error in fp16), albedo_max (per pixel) and fp16_error; the
    reference among them. `budget`: max_d, max_D, max_energy_excess, precision, n_per."""
    for o in options:
        energy_ok = budget["n_per"] == "material" or o["albedo_max"] - 1.0 <= budget["max_energy_excess"]
        o["qualifies"] = bool(o["d"] <= budget["max_d"] and o["D_total"] <= budget["max_D"] and energy_ok)
    order = ranked(options)
    qualifying = [o for o in order if o["qualifies"]]
    ref = next((o for o in options if o["name"] == reference), None)
    if not qualifying:
        closest = min(options, key=lambda o: (max(o["d"] / budget["max_d"], o["D_total"] / budget["max_D"]), o["cycles"]))
        lost = [o for o in options if o["d"] <= budget["max_d"] and o["D"] <= budget["max_D"] < o["D_total"]]
        return dict(winner="", runner_up="", qualifying=0, reason=_float16_text(lost) + (
            f"nothing qualifies: the closest, {closest['name']}, has max d {_pct(closest['d'])} and max D "
            f"{closest['D_total']:.4g}" + (f" (float16 error {closest['fp16_error']:.3g})" if budget["precision"] == "fp16"
                                            else "") + f" against budgets {_pct(budget['max_d'])} and {budget['max_D']:.4g}"))
    win = qualifying[0]
    runner = qualifying[1] if len(qualifying) > 1 else None
    lost = [o for o in options if not o["qualifies"] and o["d"] <= budget["max_d"]
            and o["D"] <= budget["max_D"] < o["D_total"]] if budget["precision"] == "fp16" else []
    text = f"{win['name']} qualifies at {win['cycles']:g} cycles (max d {_pct(win['d'])}, max D {win['D_total']:.4g}"
    text += (f", albedo up to {win['albedo_max']:.4f})" if budget["n_per"] == "pixel" else ")")
    if win["name"] == reference:
        cheaper = [o for o in order if o["cycles"] < win["cycles"]]
        if cheaper:
            best = min(cheaper, key=lambda o: (o["d"], o["D_total"]))
            text += (f"; nothing cheaper qualifies: the closest cheaper, {best['name']} at {best['cycles']:g} cycles, "
                     f"has max d {_pct(best['d'])} and max D {best['D_total']:.4g}")
        else:
            text += "; no candidate is cheaper"
    elif ref is not None:
        text += f"; {reference} costs {ref['cycles']:g}" + ("" if ref["qualifies"] else " and does not qualify")
    if runner is not None:
        text += f"; runner-up {runner['name']} at {runner['cycles']:g} cycles, max d {_pct(runner['d'])}"
    text += f"; {len(qualifying)} of {len(options)} candidates qualify"
    if lost:
        text += "; " + _float16_text(lost).removesuffix(": ")
    return dict(winner=win["name"], runner_up=runner["name"] if runner else "", qualifying=len(qualifying), reason=text)


def _float16_text(lost) -> str:
    """Which options the float16 error disqualifies, and why (a coef that overflows float16 said so)."""
    if not lost:
        return ""
    parts = []
    for o in lost:
        why = ("its coef overflows float16" if not math.isfinite(o["coef_fp16_error"])
               else f"float16 error {o['fp16_error']:.3g}")
        parts.append(f"{o['name']} ({why})")
    return "in float16, " + ", ".join(parts) + (" no longer qualifies: " if len(parts) == 1 else " no longer qualify: ")


def _pct(x: float) -> str:
    return f"{100 * x:.3g} %"


# ---------------------------------------------------------------------------------------------------

def shape_measures(descriptor, target: str, n) -> dict:
    """A candidate's normalized peak over the reference's (the value farthest from 1 at the exponents n)
    and its float16 error with its better route: the decision's measures that depend on the candidate's
    shape alone (memoized by descriptor)."""
    make = evaluator(descriptor)
    reference = cos_power if target == "cos_n" else beckmann_over_peak
    ratios = [phong_integral(reference(x)[0], x) / phong_integral(make(x)[0], x) for x in n]
    fp16, route = float16_error(make, n, reference)
    return dict(peak_ratio=float(max(ratios, key=lambda r: abs(math.log(r)))), fp16_error=fp16, fp16_route=route)


def coef_measure(normalization: str, parameters: dict, n) -> dict:
    """`coef_float16_error` of the normalization `normalization` (`optics.normalizations`) of the run's
    `parameters` (`registry.Parameters`' fields; memoized by them): its expression made again from
    them, not read from text."""
    return dict(error=coef_float16_error(normalizations(registry.Parameters(**parameters))[normalization].expr, n))


def ndf_per_pixel(rows, architecture: str, name: str, power: int):
    """(its normalization's name, the normalization key whose float16 error it has, cycles) of an NDF with
    n per pixel, or None where it was not compiled: Beckmann and GGX with alpha^2 = 2 / (n + 2) in the
    shader ("alpha_per_pixel": their 1 / (pi alpha^2) is cos^n's (n + 2) / (2 pi), whose float16 error
    stands for it); cos^n and f_Q2 are their Phong-form lobe-and-coef shaders (the
    NDF's normalization, int D (N.h) dw_h = 1, is the Phong-form coef), f_Q2 at the paper's power only.
    Each normalization is exact: projected area 1 (`ndf`), so no energy excess."""
    if name in machine_code.NDF_PER_PIXEL:
        cycles = _cycles(rows, architecture, name, "NDF, n per pixel")
        return None if cycles is None else ("alpha_per_pixel", registry.PHONG_COS_N, cycles)
    key = {registry.REFERENCE: registry.PHONG_COS_N, "f_Q2": "exact_phong"}.get(name)
    if key is None or (name == "f_Q2" and power != 2):
        return None
    cycles = _cycles(rows, architecture, name, "lobe and coef, n per pixel", f"phong {key}")
    return None if cycles is None else (key, key, cycles)


def _cycles(rows, architecture: str, lobe: str, what: str, normalization: str = ""):
    row = next((r for r in rows if r["architecture"] == architecture and r["lobe"] == lobe and r["what"] == what
                and r["normalization"] == normalization), None)
    return None if row is None else float(row["cycles"])


def run(config, inputs, memo):
    n_all = np.asarray(n_range(config), dtype=np.float64)
    power = config["lobe.power"]
    budget = dict(max_d=config["decision.max_d"], max_D=config["decision.max_D"],
                  max_energy_excess=config["decision.max_energy_excess"])
    p = registry.Parameters(Q=inputs["q_choice.Q_used"], slope=inputs["linear_coefficient.slope_used"],
                            intercept=inputs["linear_coefficient.intercept_used"],
                            coef_scale=inputs["hemispherical.coef_scale_used"],
                            coef_offset=inputs["hemispherical.coef_offset_used"], power=power)
    ranges = [tuple(r) for r in inputs["lobe_search.ranges"]]
    grid = np.asarray(inputs["lobe_search.n_grid"], dtype=np.float64)
    gpu_rows = inputs["gpu_isa.rows"] if inputs["gpu_isa.available"] else []
    chips = [a for a in machine_code.ARCHITECTURES if any(r["architecture"] == a for r in gpu_rows)]
    norms = normalizations(p)
    albedo = {(r["lobe"], r["form"], r["normalization"]): r["albedo_max"] for r in inputs["lobe_comparison.rows"]}

    # Candidates: (name, label, target, make(n) -> (float64, float16) pair, d/D per range, cycles).
    cands = [dict(name=registry.REFERENCE, label="cos^n (the reference)", target="cos_n", kind="reference",
                  desc=["cos_n"], dD=lambda lo, hi: (0.0, 0.0), lobe_key=registry.REFERENCE,
                  curves=(np.zeros_like(n_all), np.zeros_like(n_all)))]
    d_curves, D_curves = (np.asarray(inputs[f"lobe_comparison.{c}"]) for c in ("d_curves", "D_curves"))
    for i, lobe in enumerate(inputs["lobe_comparison.lobes"]):
        key = lobe["registry_key"]
        if lobe["lobe"] != key or key == registry.REFERENCE:
            continue
        cands.append(dict(name=lobe["name"], label=lobe["label"], target="cos_n", kind="registry",
                          desc=registry_descriptor(key, p),
                          dD=_range_max(n_all, d_curves[i], D_curves[i]), lobe_key=key, curves=(d_curves[i], D_curves[i])))
    pf_d, pf_D = (np.asarray(inputs[f"power_front.{c}"]) for c in ("d_curves", "D_curves"))
    for i, member in enumerate(inputs["power_front.members"]):
        if member["power"] == power:
            continue
        slope, intercept, m = member["slope"], member["intercept"], member["power"]
        cands.append(dict(name=member["name"], label=f"{member['name']} ({slope:.4g} n + {intercept:.4g})",
                          target="cos_n", kind="power",
                          desc=["power", float(slope), float(intercept), int(m)],
                          dD=_range_max(n_all, pf_d[i], pf_D[i]), lobe_key=member["name"], curves=(pf_d[i], pf_D[i])))
    search = {(m["family"], tuple(m["n_range"])): m for m in inputs["lobe_search.members"]
              if not m["grammar"] and m["admissible"]}
    for name in inputs["lobe_search.families"]:
        lines = {r: search[(name, r)] for r in ranges if (name, r) in search}
        if not lines:
            continue
        cands.append(dict(name=name, label=lobe_families.FAMILIES[name].formula + " (parameters as lines in n)",
                          target="cos_n", kind="search", search=lines, lobe_key=name))
    ndf_d, ndf_D = (np.asarray(inputs[f"ndf.{c}"]) for c in ("d_curves", "D_curves"))
    ndf_names = list(inputs["ndf.lobes"]) + ["GGX"]
    ndf_cands = [dict(name="Beckmann", label="Beckmann (the reference)", target="beckmann", kind="ndf",
                      desc=["beckmann"], dD=lambda lo, hi: (0.0, 0.0), ndf_row="Beckmann")]
    for i, name in enumerate(ndf_names):
        desc = (["ggx"] if name == "GGX" else ["cos_n"] if name == registry.REFERENCE else registry_descriptor(name, p))
        row = {"f_Q2": registry.family_name(power), "f_2": registry.family_name(2)}.get(name, name)
        ndf_cands.append(dict(name=name, label=name, target="beckmann", kind="ndf", desc=desc,
                              dD=_range_max(n_all, ndf_d[i], ndf_D[i]), ndf_row=row))

    # Measures per candidate and range.
    measures, jobs = [], []
    for lo, hi in ranges:
        n_here = grid[(grid >= lo) & (grid <= hi)]
        for c in cands + ndf_cands:
            if "search" in c:
                if (lo, hi) not in c["search"]:
                    continue
                member = c["search"][(lo, hi)]
                desc = ["family", c["name"], [float(v) for v in member["parameter_slopes"]],
                        [float(v) for v in member["parameter_intercepts"]]]
                d, D = member["d_line"], member["D_line"]
            else:
                desc, (d, D) = c["desc"], c["dD"](lo, hi)
            shaped = memo("decision_shape", shape_measures, descriptor=desc, target=c["target"],
                          n=[float(x) for x in n_here])
            jobs.append([desc, c["target"], [float(x) for x in n_here]])
            measure = dict(name=c["name"], label=c["label"], kind=c["kind"],
                           use="ndf" if c["target"] == "beckmann" else "lobe",
                           n_range=[lo, hi], d=float(d), D=float(D), **shaped, cycles={}, pixel={}, descriptor=desc)
            for arch in chips:
                if c["target"] == "beckmann":
                    cycles = _cycles(gpu_rows, arch, c["ndf_row"], "NDF")
                    pixel = ndf_per_pixel(gpu_rows, arch, c["name"], power)
                    if pixel is not None:
                        label, key, px = pixel
                        measure["pixel"][arch] = [dict(
                            form="ndf", normalization=label, cycles=px, albedo_max=1.0,
                            coef_fp16_error=memo("decision_coef", coef_measure, normalization=key, parameters=p._asdict(),
                                                 n=[float(x) for x in n_here])["error"])]
                elif "search" in c:
                    cycles = next((r["cycles"] for r in inputs["lobe_search.candidates"] if r["architecture"] == arch
                                   and r["family"] == c["name"] and tuple(r["n_range"]) == (lo, hi)), None)
                elif c["kind"] == "power":
                    cycles = _cycles(gpu_rows, arch, c["lobe_key"], "family lobe")
                elif c["lobe_key"] in registry.LOBES and registry.LOBES[c["lobe_key"]].follows_power:
                    # f_Q and f_Q2 at the run's power m: the family's shader at m, k a uniform (gpu_isa
                    # compiles the registry's own shaders at m = 2).
                    cycles = _cycles(gpu_rows, arch, registry.family_name(power), "family lobe")
                else:
                    cycles = _cycles(gpu_rows, arch, c["lobe_key"], "lobe")
                if cycles is not None:
                    measure["cycles"][arch] = cycles
                if (c["target"] == "cos_n" and c["lobe_key"] in registry.LOBES
                        and not (registry.LOBES[c["lobe_key"]].follows_power and power != 2)):
                    for form, key in registry.LOBES[c["lobe_key"]].energy:
                        px = _cycles(gpu_rows, arch, c["lobe_key"], "lobe and coef, n per pixel", f"{form} {key}")
                        if px is None:
                            continue
                        measure["pixel"].setdefault(arch, []).append(dict(
                            form=form, normalization=key, cycles=px,
                            albedo_max=float(albedo.get((c["name"], form, key), np.nan)),
                            coef_fp16_error=memo("decision_coef", coef_measure, normalization=key, parameters=p._asdict(),
                                                 n=[float(x) for x in n_here])["error"]))
            measures.append(measure)

    # the float16 errors as executed (one batch; the emulation's kept beside them), and the fp16
    # scenarios whose answer they change
    executed = memo("decision_fp16", executed_float16, jobs=jobs)
    for m, e in zip(measures, executed["errors"]):
        m["fp16_error_emulated"], m["fp16_route_emulated"] = m["fp16_error"], m["fp16_route"]
        if e is not None:
            m["fp16_error"], m["fp16_route"] = float(e[0]), e[1]
    table = scenario_table(measures, ranges, chips, budget)
    emulated = scenario_table([dict(m, fp16_error=m["fp16_error_emulated"], fp16_route=m["fp16_route_emulated"])
                               for m in measures], ranges, chips, budget)
    changed = fp16_changes(table, emulated)
    found = facts(measures, table, budget)
    per_n = per_n_winners(measures, cands, n_all, grid, inputs["lobe_search.per_n"], budget)
    paper_line = []
    for lo, hi in ranges:
        own = search.get(("square_peak1", (lo, hi)))
        f_Q2 = next((m for m in measures if m["name"] == registry.family_name(power) and m["n_range"] == [lo, hi]
                     and m["use"] == "lobe"), None)
        if own is not None and f_Q2 is not None and power == 2:
            paper_line.append(dict(n_range=[lo, hi], d_line=f_Q2["d"], d_per_n_optimum=own["d"],
                                   ratio=f_Q2["d"] / own["d"]))
    return dict(available=bool(chips), reason="" if chips else (inputs["gpu_isa.reason"] or "no machine code"),
                rule=rule_text(budget["max_d"], budget["max_D"], budget["max_energy_excess"]),
                budgets=budget, candidates=measures, table=table, facts=found, per_n=per_n,
                fp16_executed_by=executed["executed_by"], fp16_changed_by_execution=changed,
                paper_line_vs_per_n_optimum=paper_line)


def fp16_changes(table: list[dict], emulated: list[dict]) -> list[dict]:
    """The fp16 scenarios whose winner differs between the float16 errors as executed (`table`) and
    as emulated (`emulated`: the same rule on numpy's per-operation errors): each with both winners
    and their float16 errors."""
    out = []
    for row, other in zip(table, emulated):
        if row["precision"] == "fp16" and row["winner"] != other["winner"]:
            out.append(dict(architecture=row["architecture"], n_range=row["n_range"], use=row["use"],
                            n_per=row["n_per"], winner=row["winner"], winner_fp16_error=row["winner_fp16_error"],
                            winner_emulated=other["winner"], winner_emulated_fp16_error=other["winner_fp16_error"]))
    return out


def _range_max(n_all, d, D):
    def at(lo, hi):
        inside = (n_all >= lo) & (n_all <= hi)
        return float(np.asarray(d)[inside].max()), float(np.asarray(D)[inside].max())
    return at


def scenario_options(measures, n_range, arch: str, use: str, n_per: str, precision: str) -> list[dict]:
    """The options of one scenario: per candidate of the use's target measured on the range, its cost
    there (per pixel: one option per normalization of the use's form), d, D plus its float16 error in
    fp16, and its coef's albedo and float16 error per pixel."""
    target_use = "ndf" if use == "ndf" else "lobe"
    options = []
    for m in measures:
        if m["use"] != target_use or m["n_range"] != list(n_range):
            continue
        if n_per == "material":
            if arch not in m["cycles"]:
                continue
            variants = [dict(name=m["name"], cycles=m["cycles"][arch], albedo_max=1.0, coef_fp16_error=0.0)]
        else:
            variants = [dict(name=f"{m['name']} + {v['normalization']}", cycles=v["cycles"], albedo_max=v["albedo_max"],
                             coef_fp16_error=v["coef_fp16_error"])
                        for v in m["pixel"].get(arch, []) if v["form"] == use]
        for v in variants:
            fp16 = m["fp16_error"] + v["coef_fp16_error"] if precision == "fp16" else 0.0
            options.append(dict(v, label=m["label"], lobe=m["name"], d=m["d"], D=m["D"], fp16_error=fp16,
                                fp16_route=m["fp16_route"],
                                D_total=m["D"] + fp16, peak_ratio=m["peak_ratio"]))
    return options


def scenario_table(measures, ranges, chips, budget) -> list[dict]:
    """One row per scenario: the winner and runner-up by `decide`, or why there is none."""
    rows = []
    for arch in chips:
        for lo, hi in ranges:
            for use in USES:
                reference = "Beckmann" if use == "ndf" else registry.REFERENCE
                for n_per in N_PER:
                    for precision in PRECISIONS:
                        options = scenario_options(measures, (lo, hi), arch, use, n_per, precision)
                        row = dict(architecture=arch, n_range=[lo, hi], use=use, n_per=n_per, precision=precision,
                                   candidates=len(options))
                        ref_name = reference if n_per == "material" else next(
                            (o["name"] for o in options if o["lobe"] == reference), reference)
                        if not any(o["lobe"] == reference for o in options):
                            row.update(winner="", runner_up="", qualifying=0, reason=(
                                f"not decided: the reference {reference} was not compiled "
                                f"{'with n per pixel' if n_per == 'pixel' else 'per material'} for {arch}"))
                        else:
                            row.update(decide(options, ref_name, dict(budget, n_per=n_per, precision=precision)))
                        win = next((o for o in options if o["name"] == row["winner"]), None)
                        row.update(winner_lobe=win["lobe"] if win else "", winner_cycles=win["cycles"] if win else -1.0,
                                   winner_d=win["d"] if win else -1.0, winner_D=win["D_total"] if win else -1.0,
                                   winner_peak_ratio=win["peak_ratio"] if win else -1.0,
                                   winner_fp16_error=win["fp16_error"] if win else -1.0,
                                   winner_fp16_route=win["fp16_route"] if win and precision == "fp16" else "")
                        rows.append(row)
    return rows


EXP_CLASS = ("SG", "SG_Lagarde", "exp2_linear", "exp2_quadratic")   # the spherical Gaussian's class: exp of t


def _key(row):
    return row["architecture"], tuple(row["n_range"]), row["use"]


def facts(measures, table, budget) -> list[dict]:
    """The facts that change the common case's answer (Phong or Blinn lobe, n per material, fp32), each
    with how many of its decided scenarios they change, most first:

    - "n_per_pixel": the winner's lobe differs when n, and so the coef, is per pixel;
    - "fp16": the winner differs in half precision;
    - "exp_class": the winner differs when the spherical Gaussian's class (exp or exp2 of a function of t:
      `EXP_CLASS`) is left out (decided again without it);
    - "normalized_peak": the winner's normalized peak differs from the reference's by more than max_d
      (the budget of the relative error at the highlight's centre): a material switched to it needs
      retuning.

    Each fact carries its scenarios' winners before and after ("changed": list of dicts)."""
    common = [r for r in table if r["use"] != "ndf" and r["n_per"] == "material" and r["precision"] == "fp32"
              and r["winner"]]
    by = {(_key(r), r["n_per"], r["precision"]): r for r in table}
    found = []

    def changes(name, pairs):
        found.append(dict(fact=name, count=len(pairs), of=len(common), changed=[
            dict(architecture=r["architecture"], n_range=r["n_range"], use=r["use"], before=r["winner"], after=after,
                 **extra) for r, after, extra in pairs]))

    pixel = [(r, by[(_key(r), "pixel", "fp32")]) for r in common]
    changes("n_per_pixel", [(r, o["winner"], dict(before_cycles=r["winner_cycles"], after_cycles=o["winner_cycles"]))
                            for r, o in pixel if o["winner_lobe"] != r["winner_lobe"]])
    half = [(r, by[(_key(r), "material", "fp16")]) for r in common]
    changes("fp16", [(r, o["winner"], dict(reason=o["reason"])) for r, o in half if o["winner"] != r["winner"]])
    without = []
    for r in common:
        options = [o for o in scenario_options(measures, r["n_range"], r["architecture"], r["use"], "material", "fp32")
                   if o["lobe"] not in EXP_CLASS]
        again = decide(options, registry.REFERENCE, dict(budget, n_per="material", precision="fp32"))
        if again["winner"] != r["winner"]:
            cycles = next(o["cycles"] for o in options if o["name"] == again["winner"]) if again["winner"] else -1.0
            without.append((r, again["winner"], dict(before_cycles=r["winner_cycles"], after_cycles=cycles)))
    changes("exp_class", without)
    changes("normalized_peak", [(r, r["winner"], dict(peak_ratio=r["winner_peak_ratio"],
                                                                     retune_scale=1.0 / r["winner_peak_ratio"])) for r in common
                                if abs(r["winner_peak_ratio"] - 1.0) > budget["max_d"]])
    return sorted(found, key=lambda f: -f["count"])


def per_n_winners(measures, cands, n_all, grid, search_per_n, budget) -> dict:
    """The common case's winner (Phong or Blinn lobe, n per material, fp32) at each n of the lobe
    search's grid, by the same rule on each candidate's d and D at that n alone: the registry's lobes and
    the family's powers from their curves over every integer n (interpolated), the search's forms at
    their per-n fit (`lobe_search.per_n`: the shipped lines err a little more, `d_line`)."""
    at_n = {}
    for c in cands:
        if "curves" in c:
            at_n[c["name"]] = tuple(np.interp(grid, n_all, np.asarray(curve)) for curve in c["curves"])
    for row in search_per_n:
        if row["family"] in lobe_families.FAMILIES:
            at_n[row["family"]] = (np.asarray(row["d"]), np.asarray(row["D"]))
    architectures = list(dict.fromkeys(a for m in measures for a in m["cycles"]))
    cycles = {a: {m["name"]: m["cycles"][a] for m in measures if m["use"] == "lobe" and a in m["cycles"]}
              for a in architectures}
    winners = {}
    for a in architectures:
        names = [name for name in at_n if name in cycles[a]]
        column = []
        for i in range(len(grid)):
            options = [dict(name=name, cycles=cycles[a][name], d=float(at_n[name][0][i]), D=float(at_n[name][1][i]),
                            D_total=float(at_n[name][1][i]), albedo_max=1.0, fp16_error=0.0, coef_fp16_error=0.0)
                       for name in names]
            column.append(decide(options, registry.REFERENCE, dict(budget, n_per="material", precision="fp32"))["winner"])
        winners[a] = column
    return dict(n=[float(x) for x in grid], winners=winners)
