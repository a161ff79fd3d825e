"""The registered targets of several variables or a parameter (the Smith-GGX visibility, the
environment BRDF's scale and bias and their pair, cos^n in its zone) and the targets a user brings:
a TOML file (`from_file`) or a table in a CSV file (`from_csv`)."""

from __future__ import annotations

import functools

import numpy as np

from .parametric_targets import _chebyshev, Axis, check, PairTarget, ParametricTarget, Table
from .targets import Anchor, DeriveError, paper_lobes


COS_N_LEVEL = 0.5           # the registered cos_n's zone: cos^n at least half its peak (the lobe's half maximum)


def cos_n_target(level: float = COS_N_LEVEL, n: tuple[float, float] = (2.0, 1000.0)) -> ParametricTarget:
    """cos^n over its epicenter zone {cos^n >= level} (t = cos in [level^(1/n), 1], a range that moves
    with n) and n per material, by the relative error (the paper's d): the lobe search's problem, which
    the `lobe_search` stage poses at the run's calibrated level. Anchors: the paper's and the
    engines' lobes of `optics.registry` with the paper's constants (`targets.paper_lobes`). Its family
    templates go to degree 2 in t, as the lobe search's families do: at n = 1000 the zone is
    t in [0.9993, 1], where the monomials of degree 3 and 4 are nearly dependent and the formulas'
    polish does not converge (a reciprocal cubic fits each n closely, and errs above 1 with every
    formula in n)."""
    if not 0.0 < level < 1.0:
        raise DeriveError(f"cos_n: the zone's level {level}: give a number in (0, 1)")
    lowest = level ** (1.0 / n[0])
    return ParametricTarget(
        "cos_n", "t**n", (Axis("t", lowest, 1.0, lo_of=f"{level!r}**(1/n)"),), Axis("n", float(n[0]), float(n[1])),
        "rel", anchors=paper_lobes(), max_degree=2,
        description=f"cos^n in its epicenter zone cos^n >= {level:g} (the paper's lobe search), n the Phong exponent",
        role="lobe")


def registry() -> dict[str, ParametricTarget]:
    """The registered targets of several variables or a parameter, by name."""
    from ..optics import brdf

    unit = (0.01, 1.0)
    return {
        "smith_ggx_visibility": ParametricTarget(
            "smith_ggx_visibility",
            "0.5/(NoL*sqrt(NoV**2*(1 - alpha**2) + alpha**2) + NoV*sqrt(NoL**2*(1 - alpha**2) + alpha**2))",
            (Axis("NoV", *unit), Axis("NoL", *unit)), Axis("alpha", 0.02, 1.0), "rel",
            anchors=(Anchor("Hammon", "0.5/(2*NoL*NoV*(1 - alpha) + (NoL + NoV)*alpha)", brdf.HAMMON_2017),
                     Anchor("Filament_fast", "0.5/(NoV*(NoL*(1 - alpha) + alpha) + NoL*(NoV*(1 - alpha) + alpha))",
                            brdf.FILAMENT_2018)),
            description="the height-correlated Smith-GGX visibility V = G2 / (4 NoV NoL) (Heitz 2014), alpha the "
                        "GGX roughness", role="visibility"),
        **env_brdf_targets(),
        "cos_n": cos_n_target(),
    }


ENV_BRDF_POINTS = 65        # the table's Chebyshev-Lobatto points per axis (cubic splines between: within 2e-6)
ENV_BRDF_BOX = (Axis("NoV", 0.02, 1.0), Axis("roughness", 0.05, 1.0))
# (A, B) of Karis's EnvBRDFApprox and Lazarov's fit (optics.brdf), in the targets' names
ENV_BRDF_ANCHORS = {
    "Karis": ("-1.04*(min((1 - roughness)**2, exp2(-9.28*NoV))*(1 - roughness) + 0.0425 - 0.0275*roughness) "
              "+ 1.04 - 0.572*roughness",
              "1.04*(min((1 - roughness)**2, exp2(-9.28*NoV))*(1 - roughness) + 0.0425 - 0.0275*roughness) "
              "- 0.04 + 0.022*roughness"),
    "Lazarov": ("0.25*(1 - roughness) + 0.75 - ((1 - roughness)/0.96*min(0.475*(1 - roughness), exp2(-9.28*NoV)) "
                "+ (0.0275 - 0.25*0.04)/0.96*(1 - roughness) + (0.015 - 0.75*0.04)/0.96)",
                "(1 - roughness)/0.96*min(0.475*(1 - roughness), exp2(-9.28*NoV)) "
                "+ (0.0275 - 0.25*0.04)/0.96*(1 - roughness) + (0.015 - 0.75*0.04)/0.96"),
}


@functools.cache
def env_brdf_table() -> tuple[Table, Table]:
    """(A, B) of the split-sum environment BRDF of GGX (`optics.brdf.env_brdf`, its quadrature) on
    ENV_BRDF_POINTS x ENV_BRDF_POINTS Chebyshev points of NoV and roughness, as tables."""
    from ..optics import brdf

    axes = [_chebyshev(a.lo, a.hi, ENV_BRDF_POINTS) for a in ENV_BRDF_BOX]
    A, B = brdf.env_brdf_table(*axes)
    return (Table(axes, A, "env_brdf A (optics.brdf.env_brdf)"), Table(axes, B, "env_brdf B (optics.brdf.env_brdf)"))


class _LazyTable(Table):
    """`env_brdf_table()[part]`, computed when first read (the registry is listed often)."""

    def __init__(self, part: int):                     # noqa: super().__init__ runs on first use
        self.part = part
        self.text = f"table env_brdf {'AB'[part]} (optics.brdf.env_brdf, {ENV_BRDF_POINTS} x {ENV_BRDF_POINTS} values)"

    def __repr__(self) -> str:          # (the computed table's digest: a kept search follows its numbers)
        return env_brdf_table()[self.part].text

    def __getattr__(self, name):
        if name in ("axes", "values", "source", "_spline"):
            table = env_brdf_table()[self.part]
            self.axes, self.values, self.source, self._spline = table.axes, table.values, table.source, None
            return getattr(self, name)
        raise AttributeError(name)


def env_brdf_targets() -> dict[str, ParametricTarget]:
    """The environment BRDF's scale A and bias B (`optics.brdf.env_brdf`) over NoV and the roughness
    (per material, or per pixel from a texture), absolute error, Karis's and Lazarov's fits as anchors
    (`pipeline derive --target env_brdf` derives both and pairs them: `derive_pair`)."""
    from ..optics import brdf

    out = {}
    for part, (name, what) in enumerate((("env_brdf_scale", "A, the scale of F0"), ("env_brdf_bias", "B, the bias"))):
        out[name] = ParametricTarget(
            name, name, (ENV_BRDF_BOX[0],), ENV_BRDF_BOX[1], "abs",
            anchors=tuple(Anchor(a, pair[part], brdf.KARIS_2014 if a == "Karis" else brdf.LAZAROV_2013)
                          for a, pair in ENV_BRDF_ANCHORS.items()),
            description=f"the split-sum environment BRDF of GGX (alpha = roughness^2, Schlick-Smith k = alpha / 2), {what}: "
                        "a table by the pipeline's quadrature",
            table=_LazyTable(part))
    return out


# ---- a TOML file --------------------------------------------------------------------------------

AXIS_KEYS = {"name", "range"}


def from_file(path):
    """A target from a TOML file: with [[variable]] tables (name, range = [lo, hi]) and at most one
    [parameter] table, a ParametricTarget (its [target] table: name, expression, metric, floor,
    description; its [[anchor]] tables as one variable's file has them); without, the one-variable
    file of `targets.from_file`. Raises DeriveError naming a missing or unknown key or a bad value."""
    from pathlib import Path

    from . import targets

    path = Path(path)
    data = targets.read_toml(path)
    if "variable" not in data and "parameter" not in data:
        return targets.from_file(path)
    unknown = sorted(set(data) - {"target", "anchor", "variable", "parameter"})
    table = data.get("target")
    if unknown or not isinstance(table, dict):
        raise DeriveError(f"{path}: unknown table {unknown[0]!r}" if unknown else f"{path}: no [target] table")
    keys = {"name", "expression", "metric", "floor", "description", "role"}
    bad = sorted(set(table) - keys)
    if bad or "expression" not in table:
        raise DeriveError(f"{path}: [target] has an unknown key {bad[0]!r} (keys: {', '.join(sorted(keys))})" if bad
                          else f"{path}: [target] needs an expression")

    def axis(entry, where):
        if not isinstance(entry, dict) or set(entry) != AXIS_KEYS:
            raise DeriveError(f"{path}: {where}: give name and range = [lo, hi] (only)")
        lo_hi = entry["range"]
        if not (isinstance(lo_hi, list) and len(lo_hi) == 2 and all(isinstance(v, (int, float)) and not isinstance(v, bool)
                                                                      for v in lo_hi)):
            raise DeriveError(f"{path}: {where}: range = {lo_hi!r}: give [lo, hi]")
        return Axis(str(entry["name"]), float(lo_hi[0]), float(lo_hi[1]))

    variables = data.get("variable", [])
    if not isinstance(variables, list) or not variables:
        raise DeriveError(f"{path}: give the variables as [[variable]] tables")
    return check(ParametricTarget(
        str(table.get("name", path.stem)), str(table["expression"]),
        tuple(axis(v, f"[[variable]] {i + 1}") for i, v in enumerate(variables)),
        axis(data["parameter"], "[parameter]") if "parameter" in data else None,
        str(table.get("metric", "abs")), targets.read_floor(table, path), targets.read_anchors(data, path),
        str(table.get("description", "")), role=str(table.get("role", ""))))


# ---- a table in a CSV file ------------------------------------------------------------------------

def from_csv(path, variables, parameter: str | None = None, output: str | None = None, metric: str = "abs",
             floor: float = 0.0) -> ParametricTarget:
    """A table target from a CSV file: a header, then one row per point of a full grid of the
    `variables` (and the `parameter`) with the value in the column `output` (default: the one column
    left). Each axis's range is its values' span. Raises DeriveError naming a missing file or column,
    a value that is not a number, or rows that do not fill the grid."""
    import csv
    from pathlib import Path

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
    return check(ParametricTarget(path.stem, f"{output} in {path.name}", tuple(axis[:len(variables)]),
                                  axis[-1] if parameter else None, metric, floor, table=table,
                                  description=f"the column {output} of {path.name}, interpolated by cubic splines"))


def pairs() -> dict[str, PairTarget]:
    targets = env_brdf_targets()
    return {"env_brdf": PairTarget("env_brdf", targets["env_brdf_scale"], targets["env_brdf_bias"],
                                   "the split-sum environment BRDF of GGX: its scale A and bias B together, "
                                   "as a shader computes F0 A + B", role="env_brdf")}
