"""Every source of a target read into the one `Target` and checked once (`read`): a registered name
(`registered`), an expression with its variable and domain (`--expr EXPR --var NAME=LO:HI`), a TOML
file, a table in a CSV file, a function of a shader file (`from_shader_function`); the run's replacements (its name, metric, floor, the parameter's range)
applied before the one check (`check`), which says what is wrong in one line.

A TOML file of one variable:

    [target]
    name = "atan"
    expression = "atan(x)"
    variable = "x"
    domain = [0, 1]
    metric = "abs"          # or "rel"
    floor = 0.0             # rel only: |f| below floor counts as floor
    precision = "fp32"      # or "fp16": the format the shader computes in (`measures.executed`)
    role = "fresnel"        # optional: where it enters a shading (`optics.roles`), rendered there
    certify = true          # optional: every error proven over every input of the domain (`--certify`)
    [[anchor]]
    name = "mine"
    expression = "x * (0.97 - 0.19 * x * x)"
    source = "where it comes from"

and of several variables and a parameter: the same [target] table (without variable and domain),
[[variable]] tables (name, range = [lo, hi]) and at most one [parameter] table (name, range).
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np

from ...optics.roles import role_fault
from .box import lower_end, place, unit_box
from .target import (Anchor, Axis, DeriveError, MAX_AXES, METRICS, ONE_VARIABLE, PAIR, PRECISIONS, Table, Target,
                     parse)

LINE_POINTS = 4097          # a target of one axis: the points of its range on which it must be finite
BOX_POINTS = 33             # of several: per axis, the grid on which it must be finite


# ---- the one reader ------------------------------------------------------------------------------

def read(target=None, expr: str | None = None, var: str = "x=0:1", metric: str | None = None,
         floor: float | None = None, table: str | None = None, x: str | None = None,
         parameter: str | None = None, y: str | None = None, parameter_range=None, name: str | None = None) -> Target:
    """The checked target: a Target, a registered name, a TOML file's path, (with `expr`) an
    expression in `var` (NAME=LO:HI), or (with `table`) a CSV file's column `y` over the variables `x`
    (comma-separated) and the `parameter` (`from_csv`); `metric` and `floor` replace the target's,
    `parameter_range` ("LO:HI" or (lo, hi)) its parameter's range (`with_range`: one of the ranges
    the lobe search splits n into); `name` names the run (its titles, its functions' names; default
    the target's name, or an expression's own text). Checked once, after every replacement. Raises
    DeriveError."""
    if isinstance(var, (list, tuple)):         # (the command line's --var, which --shader takes several times)
        if len(var) != 1:
            raise DeriveError("--var: give one with --expr (several go with --shader)")
        var = var[0]
    chosen = _source(target, expr, var if var is not None else "x=0:1", metric, floor, table, x, parameter, y)
    if name is not None:
        if not name.strip():
            raise DeriveError("--name: give the run a name (it titles the outputs and names the functions)")
        chosen = dataclasses.replace(chosen, name=name.strip())
    if parameter_range is not None:
        chosen = _ranged(chosen, parameter_range)
    return check(chosen)


def _source(target, expr, var, metric, floor, table, x, parameter, y) -> Target:
    """The target of one source, its metric and floor replaced, not yet checked."""
    if sum(v is not None for v in (target, expr, table)) != 1:
        raise DeriveError("give --target NAME (or FILE.toml), --expr EXPR or --table FILE.csv, one of them")
    if (x is not None or parameter is not None or y is not None) and table is None:
        raise DeriveError("--x, --parameter and --y go with --table")
    if expr is not None:
        return _expression_target(expr, var, metric or "abs", floor or 0.0)
    if table is not None:
        if not x:
            raise DeriveError("--table: name its variables' columns (--x NAME[,NAME])")
        return _csv_target(table, [v.strip() for v in x.split(",") if v.strip()], parameter, y, metric or "abs",
                           floor or 0.0)
    if not isinstance(target, Target):
        target = _named(str(target))
    if target.shape == PAIR:
        if metric is not None or floor is not None:
            raise DeriveError(f"{target.name}: its metric is its parts' (abs); --metric and --floor do not apply")
        return target
    if metric is not None or floor is not None:
        target = dataclasses.replace(target, metric=metric or target.metric,
                                     floor=target.floor if floor is None else floor)
    return target


def named(name: str) -> Target:
    """A registered target (`registered.registry`) or a TOML file's (a path ending in .toml),
    checked. Raises DeriveError."""
    return check(_named(name))


def _named(name: str) -> Target:
    from .registered import registry

    if name.endswith(".toml"):
        return _file_target(Path(name))
    targets = registry()
    if name not in targets:
        raise DeriveError(f"--target {name!r}: give one of {', '.join(targets)}, or a .toml file")
    return targets[name]


# ---- the one check -------------------------------------------------------------------------------

def check(target: Target) -> Target:
    """The target itself, checked: a known metric and precision, at least one variable and at most
    MAX_AXES axes, distinct names the grammar allows (not the constants' c, c0, c1, ..., k_...),
    finite ranges lo < hi, a table covering them, a variable's moving lower end below its upper one
    for every value of the parameter, an expression finite (and, for `rel` with floor 0, nonzero) on
    a grid of the box (LINE_POINTS on one axis, BOX_POINTS per axis on several), anchors that parse,
    a role that fits its variables; a pair's two parts each checked, of one box and one metric.
    Raises DeriveError naming the first fault."""
    from ...engine import expressions

    if target.shape == PAIR:
        return _check_pair(target)
    if target.metric not in METRICS:
        raise DeriveError(f"--metric {target.metric!r}: give one of {', '.join(METRICS)}")
    if target.precision not in PRECISIONS:
        raise DeriveError(f"precision {target.precision!r}: give one of {', '.join(PRECISIONS)}")
    if not target.variables:
        raise DeriveError(f"{target.name}: give at least one variable")
    if len(target.axes) > MAX_AXES:
        raise DeriveError(f"{target.name}: {len(target.axes)} variables and parameter; at most {MAX_AXES}")
    names = target.names
    if len(set(names)) != len(names):
        raise DeriveError(f"{target.name}: the names {', '.join(names)} repeat one")
    for a in target.axes:
        fault = expressions.name_fault(a.name) or (
            "c, c0, c1, ... and k_... name the constants" if a.name == "c" or a.name.startswith("k_")
            or (a.name[0] == "c" and a.name[1:].isdigit()) else None)
        if fault:
            raise DeriveError(f"variable {a.name!r}: {fault}")
        if not (math.isfinite(a.lo) and math.isfinite(a.hi) and a.lo < a.hi):
            raise DeriveError(f"{a.name} in [{a.lo}, {a.hi}]: give finite numbers lo < hi")
    if not (math.isfinite(target.floor) and target.floor >= 0):
        raise DeriveError(f"floor {target.floor}: give a number >= 0")
    if target.table is not None:
        if len(target.table.axes) != len(target.axes):
            raise DeriveError(f"{target.name}: the table has {len(target.table.axes)} axes, the target "
                              f"{len(target.axes)}")
        for a, grid in zip(target.axes, target.table.axes):
            if a.lo < grid[0] or a.hi > grid[-1]:
                raise DeriveError(f"{a.name} in [{a.lo:g}, {a.hi:g}]: the table covers [{grid[0]:g}, {grid[-1]:g}]")
    for a in target.variables:
        if a.lo_of:
            if target.parameter is None:
                raise DeriveError(f"{a.name}: its range moves with the parameter ({a.lo_of}), and there is none")
            ends = lower_end(a, target.parameter)(np.linspace(target.parameter.lo, target.parameter.hi, BOX_POINTS))
            if not (np.all(np.isfinite(ends)) and np.all(ends < a.hi)):
                raise DeriveError(f"{a.name} in [{a.lo_of}, {a.hi:g}]: give a lower end below {a.hi:g} for every "
                                  f"{target.parameter.name} of its range")
    count = LINE_POINTS if len(target.axes) == 1 else BOX_POINTS
    mesh = place(target, [m.ravel() for m in np.meshgrid(*(np.linspace(lo, hi, count) for lo, hi in zip(*unit_box(target))),
                                                         indexing="ij")])
    f = target.numpy()(*mesh)
    for bad, why in ((~np.isfinite(f), "is not finite"),
                     ((f == 0) if target.metric == "rel" and target.floor == 0 else np.zeros(f.shape, bool),
                      "is 0 (the relative error divides by it; give a floor (--floor) or --metric abs)")):
        if bad.any():
            at = ", ".join(f"{a.name} = {m[bad][0]:.6g}" for a, m in zip(target.axes, mesh))
            raise DeriveError(f"{target.expression} {why} at {at}: narrow the "
                              + ("domain" if target.shape == ONE_VARIABLE else "ranges"))
    for anchor in target.anchors:
        parse(anchor.expression, names, f"anchor {anchor.name!r}")
    fault = role_fault(target.role, len(target.variables), target.parameter is not None)
    if fault:
        raise DeriveError(f"{target.name}: {fault}")
    return target


def _check_pair(target: Target) -> Target:
    scale, bias = target.parts
    check(scale)
    check(bias)
    if scale.axes != bias.axes or scale.metric != bias.metric:
        raise DeriveError(f"{target.name}: its two targets need the same variables, parameter and metric")
    fault = role_fault(target.role, len(scale.variables), scale.parameter is not None)
    if fault:
        raise DeriveError(f"{target.name}: {fault}")
    return target


# ---- the parameter's range replaced ---------------------------------------------------------------

def with_range(target: Target, parameter_range) -> Target:
    """The target (or a pair's two parts) with its parameter's range replaced: "LO:HI" or (lo, hi),
    checked (a variable whose range moves with the parameter keeps its formula, its lowest end
    recomputed). Raises DeriveError where the target has no parameter or the range is not two
    numbers lo < hi."""
    return check(_ranged(target, parameter_range))


def _ranged(target: Target, parameter_range) -> Target:
    if isinstance(parameter_range, str):
        try:
            lo, hi = (float(v) for v in parameter_range.split(":"))
        except ValueError:
            raise DeriveError(f"--range {parameter_range!r}: give LO:HI, two numbers") from None
    else:
        lo, hi = (float(v) for v in parameter_range)
    if target.shape == PAIR:
        return dataclasses.replace(target, parts=tuple(_ranged(t, (lo, hi)) for t in target.parts))
    if target.parameter is None:
        raise DeriveError(f"{target.name} has no parameter: --range applies to targets with one")
    parameter = dataclasses.replace(target.parameter, lo=lo, hi=hi)
    if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
        raise DeriveError(f"--range {lo:g}:{hi:g}: give finite numbers lo < hi")
    variables = []
    for a in target.variables:
        if a.lo_of:
            with np.errstate(all="ignore"):
                ends = lower_end(a, parameter)(np.linspace(lo, hi, BOX_POINTS))
            a = dataclasses.replace(a, lo=float(np.min(ends)) if np.all(np.isfinite(ends)) else a.lo)
        variables.append(a)
    return dataclasses.replace(target, variables=tuple(variables), parameter=parameter)


# ---- an expression -------------------------------------------------------------------------------

def parse_domain(text: str) -> tuple[str, tuple[float, float]]:
    """`--var x=LO:HI` as (name, (lo, hi)). Raises DeriveError."""
    try:
        name, rest = text.split("=", 1)
        lo, hi = (float(v) for v in rest.split(":"))
    except ValueError:
        raise DeriveError(f"--var {text!r}: give NAME=LO:HI, e.g. x=0:1") from None
    return name.strip(), (lo, hi)


def from_expression(expression: str, var: str = "x=0:1", metric: str = "abs", floor: float = 0.0,
                    name: str | None = None) -> Target:
    """A target from an expression and `--var NAME=LO:HI`, checked (`check`)."""
    return check(_expression_target(expression, var, metric, floor, name))


def _expression_target(expression: str, var: str, metric: str, floor: float, name: str | None = None) -> Target:
    variable, domain = parse_domain(var)
    return Target(name or expression.strip(), expression, (Axis(variable, *domain),), None, metric, floor,
                  description=f"{expression} on [{domain[0]:g}, {domain[1]:g}]")


# ---- a TOML file ---------------------------------------------------------------------------------

TARGET_KEYS = {"name", "expression", "metric", "floor", "description", "precision", "role", "certify"}
ONE_VARIABLE_KEYS = {"variable", "domain"}      # a file of one variable's [target] (without [[variable]])
ANCHOR_KEYS = {"name", "expression", "source"}
AXIS_KEYS = {"name", "range"}


def from_file(path) -> Target:
    """A target from a TOML file (module docstring), checked. Raises DeriveError naming a missing or
    unknown key or a bad value."""
    return check(_file_target(Path(path)))


def _file_target(path: Path) -> Target:
    data = read_toml(path)
    boxed = "variable" in data or "parameter" in data
    unknown = sorted(set(data) - {"target", "anchor"} - ({"variable", "parameter"} if boxed else set()))
    table = data.get("target")
    if unknown or not isinstance(table, dict):
        raise DeriveError(f"{path}: unknown table {unknown[0]!r}" if unknown else f"{path}: no [target] table")
    keys = TARGET_KEYS | (set() if boxed else ONE_VARIABLE_KEYS)
    bad = sorted(set(table) - keys)
    if bad:
        raise DeriveError(f"{path}: [target] has an unknown key {bad[0]!r} (keys: {', '.join(sorted(keys))})")
    if "expression" not in table:
        raise DeriveError(f"{path}: [target] needs an expression")
    if boxed:
        variables = data.get("variable", [])
        if not isinstance(variables, list) or not variables:
            raise DeriveError(f"{path}: give the variables as [[variable]] tables")
        variables = tuple(_axis(v, f"[[variable]] {i + 1}", path) for i, v in enumerate(variables))
        parameter = _axis(data["parameter"], "[parameter]", path) if "parameter" in data else None
    else:
        domain = table.get("domain", [0.0, 1.0])
        if not (isinstance(domain, list) and len(domain) == 2 and all(isinstance(v, (int, float)) for v in domain)):
            raise DeriveError(f"{path}: domain = {domain!r}: give [lo, hi]")
        variables = (Axis(str(table.get("variable", "x")), float(domain[0]), float(domain[1])),)
        parameter = None
    certify = table.get("certify", False)
    if not isinstance(certify, bool):
        raise DeriveError(f"{path}: certify = {certify!r}: give true or false")
    return Target(str(table.get("name", path.stem)), str(table["expression"]), variables, parameter,
                  str(table.get("metric", "abs")), read_floor(table, path), read_anchors(data, path),
                  str(table.get("description", "")), precision=str(table.get("precision", "fp32")),
                  role=str(table.get("role", "")), certify=certify)


def _axis(entry, where: str, path: Path) -> Axis:
    if not isinstance(entry, dict) or set(entry) != AXIS_KEYS:
        raise DeriveError(f"{path}: {where}: give name and range = [lo, hi] (only)")
    lo_hi = entry["range"]
    if not (isinstance(lo_hi, list) and len(lo_hi) == 2 and all(isinstance(v, (int, float)) and not isinstance(v, bool)
                                                                  for v in lo_hi)):
        raise DeriveError(f"{path}: {where}: range = {lo_hi!r}: give [lo, hi]")
    return Axis(str(entry["name"]), float(lo_hi[0]), float(lo_hi[1]))


def read_toml(path: Path) -> dict:
    """A target file's TOML (`engine.toml_files.read_toml`). Raises DeriveError naming the fault."""
    from ...engine.toml_files import read_toml as read_file

    return read_file(path, "target file", DeriveError)


def read_anchors(data: dict, path: Path) -> tuple[Anchor, ...]:
    """A target file's [[anchor]] tables (name, expression, source)."""
    anchors = []
    for i, a in enumerate(data.get("anchor", [])):
        if not isinstance(a, dict) or set(a) - ANCHOR_KEYS or not {"name", "expression"} <= set(a):
            raise DeriveError(f"{path}: [[anchor]] {i + 1}: give name, expression and source (only)")
        anchors.append(Anchor(str(a["name"]), str(a["expression"]), str(a.get("source", path.name))))
    return tuple(anchors)


def read_floor(table: dict, path: Path) -> float:
    """A target file's floor (a number >= 0, checked later by `check`)."""
    floor = table.get("floor", 0.0)
    if isinstance(floor, bool) or not isinstance(floor, (int, float)):
        raise DeriveError(f"{path}: floor = {floor!r}: give a number >= 0")
    return float(floor)


# ---- a table in a CSV file -----------------------------------------------------------------------

def from_csv(path, variables, parameter: str | None = None, output: str | None = None, metric: str = "abs",
             floor: float = 0.0) -> Target:
    """A table target from a CSV file: a header, then one row per point of a full grid of the
    `variables` (and the `parameter`) with the value in the column `output` (default: the one column
    left), checked. Each axis's range is its values' span. Raises DeriveError naming a missing file
    or column, a value that is not a number, or rows that do not fill the grid."""
    return check(_csv_target(path, variables, parameter, output, metric, floor))


def _csv_target(path, variables, parameter: str | None, output: str | None, metric: str, floor: float) -> Target:
    import csv

    path = Path(path)
    if not path.is_file():
        raise DeriveError(f"{path}: no such file")
    try:
        with open(path, newline="", encoding="utf-8") as f:
            rows = list(csv.reader(f))
    except (UnicodeDecodeError, csv.Error) as e:
        raise DeriveError(f"{path}: not a CSV file ({e})") from None
    if len(rows) < 2:
        raise DeriveError(f"{path}: a header and at least one row are needed")
    header = [h.strip() for h in rows[0]]
    names = list(variables) + ([parameter] if parameter else [])
    missing = [n for n in names if n not in header]
    if missing:
        raise DeriveError(f"{path}: no column {missing[0]!r} (the columns: {', '.join(header)})")
    rest = [h for h in header if h not in names]
    if output is None:
        if len(rest) != 1:
            raise DeriveError(f"{path}: name the value's column (--output): the other columns are {', '.join(rest)}")
        output = rest[0]
    if output not in header:
        raise DeriveError(f"{path}: no column {output!r} (the columns: {', '.join(header)})")
    columns = [header.index(n) for n in names + [output]]
    data = np.empty((len(rows) - 1, len(columns)))
    for i, row in enumerate(rows[1:]):
        try:
            data[i] = [float(row[j]) for j in columns]
        except (ValueError, IndexError):
            raise DeriveError(f"{path}: row {i + 2}: {','.join(row)!r} has no number in every column named") from None
    axes = [np.unique(data[:, k]) for k in range(len(names))]
    shape = tuple(a.size for a in axes)
    if int(np.prod(shape)) != data.shape[0]:
        raise DeriveError(f"{path}: {data.shape[0]} rows do not fill the grid of {' x '.join(map(str, shape))} "
                          f"values of {', '.join(names)}")
    values = np.full(shape, np.nan)
    index = tuple(np.searchsorted(a, data[:, k]) for k, a in enumerate(axes))
    values[index] = data[:, -1]
    if np.isnan(values).any():
        raise DeriveError(f"{path}: a point of the grid of {', '.join(names)} repeats, another is missing")
    table = Table(axes, values, path.name)
    axis = [Axis(n, float(a[0]), float(a[-1])) for n, a in zip(names, axes)]
    return Target(path.stem, f"{output} in {path.name}", tuple(axis[:len(variables)]), axis[-1] if parameter else None,
                  metric, floor, table=table,
                  description=f"the column {output} of {path.name}, interpolated by cubic splines")


# ---- a function of a shader file ------------------------------------------------------------------

SHIPPED = "as shipped"      # the anchor that is the function as its file writes it


def variable_names(arguments: list[str]) -> dict[str, str]:
    """{argument: the target's name for it}: the argument's own name, or where the grammar keeps it
    for the constants (c, c0, c1, ..., k_...) or refuses it, that name with _ appended (a k_ name
    with v prepended) until it is free: a shader's argument `c` is the target's `c_`."""
    from ...engine import expressions

    out: dict[str, str] = {}
    for a in arguments:
        name = a
        while (expressions.name_fault(name) or name == "c" or name.startswith("k_") or
               (name[0] == "c" and name[1:].isdigit()) or name in out.values() or
               (name != a and name in arguments)):
            name = "v" + name if name.startswith("k_") else name + "_"
        out[a] = name
    return out


def from_shader_function(name: str, expression, arguments: list[str], ranges: dict, source: str,
                         parameter: str | None = None, exact: str | None = None, metric: str = "abs",
                         floor: float = 0.0, precision: str = "fp32", role: str = "",
                         more_anchors: dict | None = None) -> Target:
    """The target of a shader function read as the compiler means it (`shaders.harness`: its sympy
    `expression` in `arguments`), checked: its arguments the variables (`ranges`: {argument: (lo,
    hi)}; each named by `variable_names`), the one named `parameter` the material parameter; the
    function as written its anchor "as shipped" (from `source`, its file and line); the function
    approximated the `exact` expression where the author names one (`exact=acos(x)`, in the
    arguments' names), else the function's own mathematics (a branch, an if or ?:, written
    `a if c else b`: every form, branch-free, competes with it over the whole domain); `more_anchors`
    ({name: sympy expression in the arguments}) anchors beside it (the branch of a branch's derived
    pieces, `engines.pieces`). Raises DeriveError for an exact expression that does not parse in the
    arguments."""
    import sympy as sp

    from ...engine import expressions

    names = variable_names(arguments)
    renamed = {sp.Symbol(a, real=True): sp.Symbol(names[a], real=True) for a in arguments}
    symbols = {names[a]: sp.Symbol(names[a], real=True) for a in arguments}
    written = expressions.text(expression.xreplace(renamed), symbols)
    variables = tuple(Axis(names[a], *ranges[a]) for a in arguments if a != parameter)
    axis = Axis(names[parameter], *ranges[parameter]) if parameter is not None else None
    if exact is not None:
        read = parse(exact, arguments, f"{name}'s exact").xreplace(renamed)       # (its constants as float64)
        exact = expressions.text(read.xreplace({f: sp.Float(float(f), precision=53) for f in read.atoms(sp.Float)}), symbols)
    return check(Target(name, exact or written, variables, axis, metric, floor,
                        (Anchor(SHIPPED, written, source),)
                        + tuple(Anchor(n, expressions.text(e.xreplace(renamed), symbols), source)
                                for n, e in (more_anchors or {}).items()),
                        f"{name} of {source}" + (f", approximating {exact}" if exact else ", its own mathematics"),
                        precision=precision, role=role))
