"""The run's configuration: one TOML file, validated in full before anything is computed.

Every key, its type, its allowed range and its default are declared once, in `SCHEMA`; the
documentation's key table (docs/reference/config.md) is generated from the same list (`python -m
pipeline keys`). The paper's reported values live in `[expectations.*]` as checks, never as inputs to
a stage.
"""

from __future__ import annotations

import dataclasses
import math
import tomllib
from collections.abc import Callable, Mapping
from pathlib import Path
from types import MappingProxyType
from typing import Any

from . import graph
from .graph import expand_patterns


class ConfigError(ValueError):
    """A config key, value, type or combination that is not allowed. The CLI exits with code 2."""


@dataclasses.dataclass(frozen=True)
class Key:
    """One config key: its dotted name, default, allowed values (as text) and validator."""

    name: str
    default: Any
    allowed: str
    check: Callable[[Any], bool]
    doc: str


def _is_number(v: Any) -> bool:
    return isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)


def _is_int(v: Any) -> bool:
    return isinstance(v, int) and not isinstance(v, bool)


def _open_unit(v: Any) -> bool:
    return _is_number(v) and 0.0 < v < 1.0


def _positive(v: Any) -> bool:
    return _is_number(v) and v > 0


def _int_in(lo: int, hi: int) -> Callable[[Any], bool]:
    return lambda v: _is_int(v) and lo <= v <= hi


GRAMMAR_OPERATIONS = ("+", "-", "*", "/", "exp", "log", "sqrt", "square", "cube", "pow")


def _operation_list(v: str) -> bool:
    items = [x.strip() for x in v.split(",")]
    return len(items) == len(set(items)) and all(x in GRAMMAR_OPERATIONS for x in items)


def _number_list(v: Any, lo: float, hi: float, longest: int) -> bool:
    return isinstance(v, list) and 1 <= len(v) <= longest and all(_is_number(x) and lo <= x <= hi for x in v)


# Seeds: a stage derives seed + 1 (Mitsuba's second render) and seed + 2 (the albedo's third stream)
# from its seed, so the largest allowed seed leaves room for them in what the library takes:
# Mitsuba's sampler seed is a 32-bit unsigned integer, JAX's PRNGKey a 64-bit signed one.
MITSUBA_SEED_MAX = 2**32 - 1 - 1
JAX_SEED_MAX = 2**63 - 1 - 2
SEED_MAX = 2**63 - 1
# Mitsuba counts a render's samples (width x height x spp) in 32 bits.
MITSUBA_SAMPLES_MAX = 2**31
# Largest powers of 4 for mitsuba.spp: the multijitter sampler takes exactly a square count, and a
# power of two keeps each pixel's samples in one of Dr.Jit's thread blocks, so a render repeats bit
# for bit (other counts are rounded up by the sampler and summed across threads in varying order).
SPP_CHOICES = tuple(4**i for i in range(7))


# The family's powers: m = 16 is four squarings; beyond it the lobe is a spherical Gaussian in all
# but name (the tests' dense grids resolve it up to here).
POWER_MAX = 16

LOBE_FAMILIES = ("square_peak1", "square", "cube", "fourth", "exp2_linear", "exp2_quadratic", "rational",
                 "rational_square")
LOBE_TARGETS = ("cos_n", "beckmann")
LIBRARY_TERMS = ("1", "n", "1/n", "1/n^2", "n^2", "sqrt(n)", "log(n)")
METRICS = ("relative_epicenter", "absolute", "rms")
FITS = ("least_squares", "minimax")

SCHEMA: tuple[Key, ...] = (
    Key("run.name", "paper", "a name of letters, digits, '-', '_'",
        lambda v: isinstance(v, str) and v != "" and all(c.isalnum() or c in "-_" for c in v),
        "output folder name: outputs/<name>/"),
    Key("run.question", "", "a string", lambda v: isinstance(v, str),
        "the question this run answers, one sentence (printed in the report)"),
    Key("derivation.n_min", 2, "an integer >= 1", lambda v: _is_int(v) and v >= 1,
        "smallest specular exponent n (paper: 2)"),
    Key("derivation.n_max", 1000, "an integer > n_min and <= 100000",
        lambda v: _is_int(v) and 1 < v <= 100_000, "largest specular exponent n (paper: 1000)"),
    Key("derivation.Q", "scan", 'a number in (0, 1), "scan" or "optimize"',
        lambda v: _open_unit(v) or v in ("scan", "optimize"),
        'shape parameter of f_Q used downstream: "scan" = best on the paper\'s grid, '
        '"optimize" = continuous optimum of the metric'),
    Key("derivation.metric", "relative_epicenter", " or ".join(f'"{m}"' for m in METRICS),
        lambda v: v in METRICS,
        "objective that picks Q: max relative error in the epicenter zone (paper), max absolute "
        "error over [0, pi/2], or RMS error over the lobe"),
    Key("derivation.fit", "least_squares", " or ".join(f'"{f}"' for f in FITS),
        lambda v: v in FITS,
        "line through k_Q(n): ordinary least squares (paper) or minimax relative error"),
    Key("derivation.constants", "fitted", '"paper" or "fitted"', lambda v: v in ("paper", "fitted"),
        'constants used downstream: the paper\'s rounded ones (only with the paper\'s settings) or '
        "this run's full-precision fits"),
    Key("lobe.power", 2, "an integer in [2, 16]", _int_in(2, POWER_MAX),
        "power m of the family f_Qm = (k (cos x - 1) + 1)^m that every stage derives (paper: 2, f_Q2; "
        "m = 3, 4, ... give f_Q3, f_Q4, ...)"),
    Key("paper_model.slope", 0.448, "a number in (0, 10]", lambda v: _positive(v) and v <= 10,
        "the paper's rounded slope of k_Q2(n)"),
    Key("paper_model.intercept", 0.099, "a number in [-10, 10], with slope n_min + intercept > 0",
        lambda v: _is_number(v) and -10 <= v <= 10, "the paper's rounded intercept of k_Q2(n)"),
    Key("paper_model.coef_scale", 0.214, "a number in (0, 10]", lambda v: _positive(v) and v <= 10,
        "the paper's coef(n) = scale (offset + n)"),
    Key("paper_model.coef_offset", 0.807, "a number in (-n_min, 1000]", lambda v: _is_number(v) and abs(v) <= 1000,
        "the paper's coef(n) offset"),
    Key("paper_model.line_max_rel_error", 0.005, "a number in (0, 1)", _open_unit,
        "the paper's stated bound on the relative error of its line against k_Q(n) (P6: 0.5 %)"),
    Key("paper_model.turingbot_size12", [0.213904, 0.779213, 0.308609, 0.326302],
        "a list of 4 numbers in [-1000, 1000]: [scale, offset, residue, pole]",
        lambda v: _number_list(v, -1000, 1000, 4) and len(v) == 4,
        "the paper's size-12 row scale (offset + residue/(n - pole) + n), compared with the exact coef"),
    Key("zone.level", "calibrate", 'a number in (0, 1) or "calibrate"',
        lambda v: _open_unit(v) or v == "calibrate",
        "epicenter zone = {x : cos(x)^n >= level}; \"calibrate\" solves for the level at which max d "
        "of f_2 equals zone.calibration_target"),
    Key("zone.calibration_target", 0.07924, "a number in (0, 1)", _open_unit,
        "max relative error of f_2 in the zone that calibrates the level (paper P9: 7.924 %)"),
    Key("zone.sensitivity_levels", [0.5, 0.55, 0.6, 0.65, 0.7], "a list of 1 to 32 numbers in (0, 1)",
        lambda v: isinstance(v, list) and 1 <= len(v) <= 32 and all(_open_unit(x) for x in v),
        "zone levels at which the report shows how the epicenter figures move"),
    Key("scan.coarse_step", 0.1, "a number in [0.001, 0.5]", lambda v: _is_number(v) and 0.001 <= v <= 0.5,
        "step of the coarse Q grid (paper: 0.1)"),
    Key("scan.fine_step", 0.01, "a number in [coarse_step / 1000, coarse_step)",
        lambda v: _is_number(v) and 1e-6 <= v < 0.5,
        "step of the refined Q grid around the coarse optimum (paper: 0.01)"),
    Key("scan.curve_points", 161, "an integer in [11, 2001]", lambda v: _is_int(v) and 11 <= v <= 2001,
        "Q values on the curves of Figs. 2 and 3"),
    Key("solver.rtol", 1e-12, "a number in [1e-15, 1e-3]", lambda v: _is_number(v) and 1e-15 <= v <= 1e-3,
        "relative tolerance of every root find"),
    Key("solver.atol", 1e-12, "a number in [1e-15, 1e-3]", lambda v: _is_number(v) and 1e-15 <= v <= 1e-3,
        "absolute tolerance of every root find"),
    Key("solver.max_steps", 256, "an integer in [8, 100000]", lambda v: _is_int(v) and 8 <= v <= 100_000,
        "iteration cap of every solver; hitting it is an error"),
    Key("energy.quadrature_nodes", 64, "an integer in [4, 4096]", lambda v: _is_int(v) and 4 <= v <= 4096,
        "Gauss-Legendre nodes over [0, gran(n)] for Int(n)"),
    Key("sample.consecutive_to", 31, "an integer in [n_min, spread_from)", _is_int,
        "the 50-point sample takes every n from n_min to this value ..."),
    Key("sample.spread_from", 74, "an integer in (consecutive_to, n_max)", _is_int,
        "... then spread_count values evenly spaced (rounded) from this value to n_max"),
    Key("sample.spread_count", 20, "an integer in [2, n_max - spread_from + 1]", lambda v: _is_int(v) and v >= 2,
        "number of evenly spaced large n in the sample"),
    Key("sample.y_decimals", 3, "an integer in [-1, 15] (-1: no rounding)",
        lambda v: _is_int(v) and -1 <= v <= 15,
        "decimals kept in the sample's y, as in the paper's newenergy.txt (3)"),
    Key("regression.library", ["1", "n", "1/n", "1/n^2"],
        "a list of distinct terms from " + ", ".join(LIBRARY_TERMS) + ', containing "1" and "n"',
        lambda v: isinstance(v, list) and len(set(v)) == len(v) and {"1", "n"} <= set(v)
        and all(t in LIBRARY_TERMS for t in v),
        "candidate terms of coef(n) for the sparse regression"),
    Key("regression.threshold_min", 1e-5, "a number in [1e-12, 1e6]", lambda v: _is_number(v) and 1e-12 <= v <= 1e6,
        "smallest STLSQ threshold of the sweep"),
    Key("regression.threshold_max", 1.0, "a number in (threshold_min, 1e6]", lambda v: _positive(v) and v <= 1e6,
        "largest STLSQ threshold of the sweep"),
    Key("regression.threshold_count", 80, "an integer in [2, 10000]",
        lambda v: _is_int(v) and 2 <= v <= 10_000, "thresholds in the (log-spaced) sweep"),
    Key("symbolic.max_complexity", 12, "an integer in [1, 14]", lambda v: _is_int(v) and 1 <= v <= 14,
        "largest complexity (TuringBot's: constants, n, +, -, * count 1, / counts 2) the exhaustive search reaches"),
    Key("symbolic.operations", "+-*/", 'a string of distinct characters from "+-*/"',
        lambda v: isinstance(v, str) and len(v) >= 1 and len(set(v)) == len(v) and set(v) <= set("+-*/"),
        "operations of the symbolic-regression grammar"),
    Key("symbolic.starts", 2, "an integer in [1, 64]", lambda v: _is_int(v) and 1 <= v <= 64,
        "deterministic starts of the nonlinear constants per expression in the screening fit (2x more "
        "where only one start reached the best)"),
    Key("symbolic.iterations", 7, "an integer in [1, 1000]", lambda v: _is_int(v) and 1 <= v <= 1000,
        "variable-projection Levenberg-Marquardt steps per start in the screening fit"),
    Key("symbolic.refine", 8, "an integer in [1, 1000]", lambda v: _is_int(v) and 1 <= v <= 1000,
        "best screened expressions per complexity refitted to convergence"),
    Key("symbolic.polish_starts", 4, "an integer in [1, 64]", lambda v: _is_int(v) and 1 <= v <= 64,
        "starts of that refit: the screened constants and this many minus one others"),
    Key("symbolic.seed", 0, "an integer in [0, 2^63 - 1]", _int_in(0, SEED_MAX),
        "seed of the random starts (used beyond the eight deterministic ones)"),
    Key("albedo.angles", 91, "an integer in [2, 1801]", lambda v: _is_int(v) and 2 <= v <= 1801,
        "incidence angles, evenly spaced over [0, 90] degrees, at which the directional albedo is computed"),
    Key("albedo.quadrature_nodes", 96, "an integer in [8, 4096]", lambda v: _is_int(v) and 8 <= v <= 4096,
        "Gauss-Legendre nodes per piece of the albedo integral (its error is measured against twice as many)"),
    Key("albedo.curve_n", [2, 5, 10, 50, 100, 1000],
        "a list of 1 to 64 integers in [1, 100000], one at least in [n_min, n_max]",
        lambda v: isinstance(v, list) and 1 <= len(v) <= 64 and all(_is_int(x) and 1 <= x <= 100_000 for x in v),
        "exponents whose albedo curves are drawn and cross-checked by Monte Carlo (those in range)"),
    Key("albedo.mc_samples", 200_000, "an integer in [1000, 10000000]",
        lambda v: _is_int(v) and 1000 <= v <= 10_000_000, "Monte Carlo samples per (n, angle) cross-check"),
    Key("albedo.mc_seed", 0, "an integer in [0, 2^63 - 3]", _int_in(0, JAX_SEED_MAX),
        "seed of the Monte Carlo cross-check"),
    Key("comparison.grid_cells", 512, "an integer in [32, 100000]", lambda v: _is_int(v) and 32 <= v <= 100_000,
        "cells of the log(1 + n u) grid that brackets each extremum of a lobe without a closed form"),
    Key("comparison.albedo_angles", 19, "an integer in [2, 1801]", lambda v: _is_int(v) and 2 <= v <= 1801,
        "incidence angles over [0, 90] degrees for the comparison's largest albedo"),
    Key("front.powers", [2, 3, 4, 8], "a list of 1 to 8 distinct integers in [2, 16]",
        lambda v: isinstance(v, list) and 1 <= len(v) <= 8 and len(set(v)) == len(v)
        and all(_is_int(x) and 2 <= x <= POWER_MAX for x in v),
        "powers m of the family compared in the accuracy/cost front, each with its own best Q and line"),
    Key("lobe_search.families", list(LOBE_FAMILIES), "a list of distinct names from " + ", ".join(LOBE_FAMILIES),
        lambda v: isinstance(v, list) and 1 <= len(v) and len(set(v)) == len(v) and all(x in LOBE_FAMILIES for x in v),
        "cheap forms g(t; A, B, C) the lobe search fits to cos^n per n (pipeline.optics.lobe_families)"),
    Key("lobe_search.target", "cos_n", " or ".join(f'"{t}"' for t in LOBE_TARGETS), lambda v: v in LOBE_TARGETS,
        "what the lobe search approximates: cos^n (the paper's lobe), or Beckmann's D over its peak with the "
        "roughness matched to n, a^2 = 2/(n + 2) (the registry's lobes are placed on cos^n's fronts only)"),
    Key("lobe_search.n_ranges", [[2, 10], [10, 100], [100, 1000], [2, 1000]],
        "a list of 1 to 8 pairs [lo, hi] of numbers with 1 <= lo < hi <= 100000",
        lambda v: isinstance(v, list) and 1 <= len(v) <= 8 and all(
            isinstance(r, list) and len(r) == 2 and all(_is_number(x) for x in r) and 1 <= r[0] < r[1] <= 100_000
            for r in v),
        "ranges of n of the lobe search's fronts (clipped to [n_min, n_max])"),
    Key("lobe_search.grammar_complexity", 0, "an integer in [0, 8] (0: the families alone)", _int_in(0, 8),
        "largest complexity of the grammar's forms in w = n (1 - t) that the lobe search screens beside its families"),
    Key("lobe_search.grammar_operations", "+,-,*,/,exp,square,cube,sqrt",
        "a comma list of distinct operations from +, -, *, /, exp, log, sqrt, square, cube, pow",
        lambda v: isinstance(v, str) and _operation_list(v), "operations of the grammar's forms in the lobe search"),
    Key("lobe_search.formula_complexity", 0, "an integer in [0, 9] (0: lines alone)", _int_in(0, 9),
        "largest complexity of the symbolic regression's correction to a parameter's line in n, where a line is not "
        "enough (its d more than 10 % above the per-n optimum's)"),
    Key("lobe_search.grammar_keep", 4, "an integer in [1, 16]", _int_in(1, 16),
        "grammar forms kept after screening (those no cheaper form beats) and fitted per n like the families"),
    Key("lobe_search.points_per_range", 6, "an integer in [2, 200]", _int_in(2, 200),
        "log-spaced exponents per range at which each family is fitted (ends included; checked halfway between)"),
    Key("lobe_search.zone_points", 256, "an integer in [8, 4096]", _int_in(8, 4096),
        "points of the epicenter zone on which each family's minimax fit runs (its d is then measured exactly)"),
    Key("lobe_search.calibration_forms", 60, "an integer in [20, 2000]", _int_in(20, 2000),
        "random forms compiled to fit the cost tables that predict each family's cycles"),
    Key("decision.max_d", 0.02, "a number in (0, 1)", _open_unit,
        "budget of the decision: largest max d (relative error in the epicenter zone) a shipped lobe may have"),
    Key("decision.max_D", 0.15, "a number in (0, 1)", _open_unit,
        "budget of the decision: largest max D (absolute error, peak 1; plus the float16 error in fp16)"),
    Key("decision.max_energy_excess", 0.01, "a number in (0, 1)", _open_unit,
        "budget of the decision with n per pixel: how much more than arrives a coef computed in the shader may "
        "reflect (largest albedo - 1)"),
    Key("render.resolution", 512, "an integer in [16, 4096]", lambda v: _is_int(v) and 16 <= v <= 4096,
        "width and height of each rendered image, in pixels"),
    Key("render.exponents", [10, 100, 1000], "a list of 1 to 8 numbers in [1, 100000]",
        lambda v: _number_list(v, 1, 100_000, 8),
        "specular exponents n of the rendered comparison"),
    Key("mitsuba.exponents", [10, 100, 1000], "a list of 3 numbers in [1, 100000]",
        lambda v: _number_list(v, 1, 100_000, 3) and len(v) == 3,
        "exponents n of the three spheres of the Mitsuba renders"),
    Key("mitsuba.width", 320, "an integer in [16, 4096]", lambda v: _is_int(v) and 16 <= v <= 4096,
        "width of the Mitsuba renders, in pixels"),
    Key("mitsuba.height", 160, "an integer in [16, 4096]", lambda v: _is_int(v) and 16 <= v <= 4096,
        "height of the Mitsuba renders, in pixels"),
    Key("mitsuba.spp", 64, "a power of 4 from 1 to 4096, with width x height x spp <= 2^31",
        lambda v: _is_int(v) and v in SPP_CHOICES,
        "samples per pixel of each Mitsuba render (each lobe is rendered twice, two seeds); a power of 4, so "
        "that the multijitter sampler takes it exactly and a render repeats bit for bit"),
    Key("mitsuba.fallback_spp", 4, "a power of 4 from 1 to 4096", lambda v: _is_int(v) and v in SPP_CHOICES,
        "samples per pixel where only the scalar variant runs (Python plugins, one sample at a time)"),
    Key("mitsuba.seed", 0, "an integer in [0, 2^32 - 2]", _int_in(0, MITSUBA_SEED_MAX),
        "seed of the first render of each lobe (the second uses seed + 1)"),
    Key("mitsuba.variant", "auto", '"auto", "llvm_ad_rgb" or "scalar_rgb"',
        lambda v: v in ("auto", "llvm_ad_rgb", "scalar_rgb"),
        "Mitsuba variant: auto takes llvm_ad_rgb where its LLVM back end runs, else scalar_rgb"),
    Key("render.normalization", "reference", '"reference" or "exact"', lambda v: v in ("reference", "exact"),
        "normalization of the rendered candidates: cos^n's own (Giesen; equal peaks, shape differences only) "
        "or each lobe's exact Blinn-form coef (equal energy)"),
)
KEYS: Mapping[str, Key] = MappingProxyType({k.name: k for k in SCHEMA})
SECTIONS = tuple(dict.fromkeys(k.name.split(".")[0] for k in SCHEMA))
OUTPUT_PATHS = frozenset(graph.output_paths())
EXPECTATION_FIELDS = ("quantity", "paper", "result", "tolerance", "reason")
EXPECTATION_OPTIONAL = ("compare", "known_difference", "known_value", "known_tolerance", "agreement")
# How an agreement holds: from an independent computation; because a setting was solved for it (the
# zone level is calibrated on P9); or because a choice was designed to match it (the sample design).
AGREEMENTS = ("independent", "by calibration", "by design")


@dataclasses.dataclass(frozen=True)
class Expectation:
    """A reported value to check: |reproduced - paper| <= tolerance (elementwise for lists)."""

    id: str
    quantity: str
    paper: Any
    result: str
    tolerance: float
    reason: str
    compare: str = "equal"
    known_difference: str = ""
    known_value: Any = None
    known_tolerance: float = 0.0
    agreement: str = "independent"


@dataclasses.dataclass(frozen=True)
class Config:
    """A validated configuration. `values` maps every dotted key of `SCHEMA` to its value;
    `file_values` are those of the config file itself, before `--set` overrides: the settings its
    expectations were reported for."""

    values: Mapping[str, Any]
    expectations: tuple[Expectation, ...]
    source: str
    file_values: Mapping[str, Any] = dataclasses.field(default_factory=dict)

    def __getitem__(self, key: str) -> Any:
        return self.values[key]

    def __reduce__(self):
        # Pickled as plain dicts (a sweep sends each point's resolved config to a Dask worker).
        return _config_from, (dict(self.values), self.expectations, self.source, dict(self.file_values))

    @property
    def name(self) -> str:
        return self.values["run.name"]

    def subset(self, patterns: tuple[str, ...]) -> dict[str, Any]:
        """The keys a stage reads: exact names, or `section.*` for a whole section."""
        return {k: self.values[k] for k in expand_patterns(patterns, self.values)}

    def changed_from_file(self, keys) -> list[str]:
        """Those of `keys` whose value differs from the config file's own (set by --set)."""
        return sorted(k for k in keys if self.file_values.get(k, self.values[k]) != self.values[k])

    def uses_paper_settings(self) -> bool:
        """Whether the derivation settings are the paper's, so that its rounded constants apply."""
        v = self.values
        return (v["derivation.n_min"] == 2 and v["derivation.n_max"] == 1000
                and v["derivation.Q"] in ("scan", 0.64) and v["derivation.metric"] == "relative_epicenter"
                and v["derivation.fit"] == "least_squares" and v["lobe.power"] == 2)


def _fail(key: str, value: Any, allowed: str) -> ConfigError:
    return ConfigError(f"config key '{key}' = {value!r} is not allowed: expected {allowed}")


def parse_override(text: str) -> tuple[str, Any]:
    """Reads one `--set KEY=VALUE`; VALUE is a TOML literal, or a string if it is a bare word."""
    if "=" not in text:
        raise ConfigError(f"--set {text!r} is not allowed: expected KEY=VALUE, e.g. derivation.Q=0.5")
    key, raw = (s.strip() for s in text.split("=", 1))
    try:
        value = tomllib.loads(f"v = {raw}")["v"]
    except tomllib.TOMLDecodeError:
        value = raw
    return key, value


def _flatten(raw: Mapping[str, Any]) -> tuple[dict[str, Any], dict[str, Any]]:
    values, expectations = {}, {}
    for section, body in raw.items():
        if section == "expectations":
            if not isinstance(body, dict):
                raise _fail("expectations", body, "a table of [expectations.ID] tables")
            expectations = body
            continue
        if section not in SECTIONS:
            raise ConfigError(f"config section '[{section}]' is unknown: allowed sections are "
                              + ", ".join(SECTIONS + ("expectations",)))
        if not isinstance(body, dict):
            raise _fail(section, body, "a table")
        for key, value in body.items():
            values[f"{section}.{key}"] = value
    return values, expectations


def _check_expectations(raw: Mapping[str, Any]) -> tuple[Expectation, ...]:
    out = []
    for eid, body in raw.items():
        where = f"expectations.{eid}"
        if not isinstance(body, dict):
            raise _fail(where, body, "a table with " + ", ".join(EXPECTATION_FIELDS))
        missing = set(EXPECTATION_FIELDS) - set(body)
        extra = set(body) - set(EXPECTATION_FIELDS) - set(EXPECTATION_OPTIONAL)
        if extra:
            raise ConfigError(f"config key '{where}.{sorted(extra)[0]}' is unknown: allowed keys are "
                              + ", ".join(EXPECTATION_FIELDS + EXPECTATION_OPTIONAL))
        if missing:
            raise ConfigError(f"config table '{where}' lacks '{sorted(missing)[0]}'")
        for field in ("quantity", "result", "reason"):
            if not isinstance(body[field], str) or not body[field]:
                raise _fail(f"{where}.{field}", body[field], "a non-empty string")
        if body["result"] not in OUTPUT_PATHS:
            stage = body["result"].split(".", 1)[0]
            if stage in graph.BY_NAME:
                allowed = "one of " + ", ".join(f"{stage}.{f}" for f in graph.BY_NAME[stage].outputs)
            else:
                allowed = "a declared output 'stage.field'; stages: " + ", ".join(graph.BY_NAME)
            raise _fail(f"{where}.result", body["result"], allowed + " (`pipeline graph` lists them all)")
        tol, paper = body["tolerance"], body["paper"]
        if not (_is_number(tol) and tol >= 0):
            raise _fail(f"{where}.tolerance", tol, "a number >= 0")
        ok_paper = (_is_number(paper) or isinstance(paper, bool)
                    or (isinstance(paper, list) and paper and all(_is_number(p) for p in paper)))
        if not ok_paper:
            raise _fail(f"{where}.paper", paper, "a number, a boolean or a list of numbers")
        compare = body.get("compare", "equal")
        if compare not in ("equal", "at_most"):
            raise _fail(f"{where}.compare", compare, '"equal" or "at_most"')
        if compare == "at_most" and not _is_number(paper):
            raise _fail(f"{where}.paper", paper, 'a number (compare = "at_most")')
        known = body.get("known_difference", "")
        if not isinstance(known, str):
            raise _fail(f"{where}.known_difference", known, "a string")
        known_value, known_tol = body.get("known_value"), body.get("known_tolerance", 0.0)
        if bool(known) != (known_value is not None):
            raise ConfigError(f"config table '{where}': known_difference and known_value go together")
        if known_value is not None and not (_is_number(known_value) and _is_number(known_tol) and known_tol >= 0):
            raise _fail(f"{where}.known_value/known_tolerance", (known_value, known_tol), "numbers, tolerance >= 0")
        agreement = body.get("agreement", "independent")
        if agreement not in AGREEMENTS:
            raise _fail(f"{where}.agreement", agreement, " or ".join(f'"{a}"' for a in AGREEMENTS))
        out.append(Expectation(eid, body["quantity"], paper, body["result"], float(tol), body["reason"],
                               compare, known, known_value, float(known_tol), agreement))
    return tuple(out)


def validate(values: Mapping[str, Any], raw_expectations: Mapping[str, Any], source: str,
             file_values: Mapping[str, Any] | None = None) -> Config:
    """Checks every key, value, type and combination; raises `ConfigError` on the first problem."""
    for key in values:
        if key not in KEYS:
            section = key.split(".")[0]
            near = [k for k in KEYS if k.startswith(section + ".")]
            if not near:
                raise ConfigError(f"config key '{key}' is unknown: section '{section}' does not exist; "
                                  "allowed sections are " + ", ".join(SECTIONS))
            raise ConfigError(f"config key '{key}' is unknown: allowed keys in [{section}] are "
                              + ", ".join(k.split(".", 1)[1] for k in near))
    full = {k.name: values.get(k.name, k.default) for k in SCHEMA}
    for k in SCHEMA:
        if not k.check(full[k.name]):
            raise _fail(k.name, full[k.name], k.allowed)
    if full["derivation.n_max"] <= full["derivation.n_min"]:
        raise _fail("derivation.n_max", full["derivation.n_max"],
                    f"an integer > derivation.n_min = {full['derivation.n_min']}")
    if full["scan.fine_step"] >= full["scan.coarse_step"]:
        raise _fail("scan.fine_step", full["scan.fine_step"],
                    f"a number < scan.coarse_step = {full['scan.coarse_step']}")
    if full["regression.threshold_max"] <= full["regression.threshold_min"]:
        raise _fail("regression.threshold_max", full["regression.threshold_max"],
                    f"a number > regression.threshold_min = {full['regression.threshold_min']}")
    if full["scan.fine_step"] * 1000 < full["scan.coarse_step"]:
        raise _fail("scan.fine_step", full["scan.fine_step"],
                    f"a number >= scan.coarse_step / 1000 = {full['scan.coarse_step'] / 1000:g} "
                    "(at most 2000 points in the refined grid)")
    lo, hi = full["derivation.n_min"], full["derivation.n_max"]
    if not lo <= full["sample.consecutive_to"] < full["sample.spread_from"] < hi:
        raise _fail("sample.consecutive_to/spread_from",
                    (full["sample.consecutive_to"], full["sample.spread_from"]),
                    f"n_min = {lo} <= consecutive_to < spread_from < n_max = {hi}")
    # More evenly spaced integers than the span holds must repeat: checked by arithmetic first, so
    # that the list built below has at most n_max (<= 100000) members.
    count, start = full["sample.spread_count"], full["sample.spread_from"]
    if count > hi - start + 1:
        raise _fail("sample.spread_count", count,
                    f"at most n_max - spread_from + 1 = {hi - start + 1}: more evenly spaced integers from "
                    f"{start} to {hi} than that repeat")
    spread = [round(start + i * (hi - start) / (count - 1)) for i in range(count)]
    if len(set(spread)) != len(spread):
        raise _fail("sample.spread_count", full["sample.spread_count"],
                    f"a count whose evenly spaced n from {full['sample.spread_from']} to {hi} do not repeat")
    if not any(lo <= m <= hi for m in full["albedo.curve_n"]):
        raise _fail("albedo.curve_n", full["albedo.curve_n"],
                    f"a list with at least one integer in [n_min, n_max] = [{lo}, {hi}]")
    if full["paper_model.slope"] * lo + full["paper_model.intercept"] <= 0:
        raise _fail("paper_model.intercept", full["paper_model.intercept"],
                    f"a number > -paper_model.slope * n_min = {-full['paper_model.slope'] * lo:g} (k(n) > 0)")
    if full["paper_model.coef_offset"] <= -lo:
        raise _fail("paper_model.coef_offset", full["paper_model.coef_offset"],
                    f"a number > -n_min = {-lo} (coef(n) > 0)")
    samples = full["mitsuba.width"] * full["mitsuba.height"] * max(full["mitsuba.spp"], full["mitsuba.fallback_spp"])
    if samples > MITSUBA_SAMPLES_MAX:
        raise _fail("mitsuba.spp", full["mitsuba.spp"],
                    f"a count with width x height x spp <= 2^31 (Mitsuba counts a render's samples in 32 bits); "
                    f"{full['mitsuba.width']} x {full['mitsuba.height']} x spp = {samples}")
    own = {k.name: (file_values or values).get(k.name, k.default) for k in SCHEMA}
    config = Config(MappingProxyType(full), _check_expectations(raw_expectations), source, MappingProxyType(own))
    if full["derivation.constants"] == "paper" and not config.uses_paper_settings():
        raise _fail("derivation.constants", "paper",
                    '"fitted": the paper\'s rounded constants hold only with its settings '
                    '(n in [2, 1000], Q = 0.64 or "scan", metric "relative_epicenter", fit "least_squares", '
                    'lobe.power 2)')
    return config


def _config_from(values: dict, expectations, source: str, file_values: dict) -> Config:
    return Config(MappingProxyType(values), expectations, source, MappingProxyType(file_values))


def load_config(path: str | Path, overrides: tuple[str, ...] = (), name: str | None = None) -> Config:
    """Reads a TOML config, applies `--set` overrides and an output name, and validates it all."""
    from .toml_files import read_toml

    path = Path(path)
    raw = read_toml(path, "config file", ConfigError)
    values, expectations = _flatten(raw)
    file_values = dict(values)
    for text in overrides:
        key, value = parse_override(text)
        if key.startswith("expectations."):
            raise ConfigError(f"--set {key}: expectations are set in the config file, not with --set")
        values[key] = value
    if name is not None:
        values["run.name"] = name
    return validate(values, expectations, str(path), file_values)


def key_table() -> str:
    """Markdown table of every key with its default and allowed values (`pipeline keys`; docs/reference/config.md)."""
    rows = ["| key | default | allowed | meaning |", "|---|---|---|---|"]
    for k in SCHEMA:
        default = f"`{k.default!r}`".replace("'", '"')
        rows.append(f"| `{k.name}` | {default} | {k.allowed} | {k.doc} |")
    return "\n".join(rows)
