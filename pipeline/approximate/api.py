"""`pipeline.derive` in Python, as a notebook uses it; the command `pipeline derive` calls the same
functions:

    from pipeline import derive
    found = derive("schlick", gpu=["rdna3"])
    found.front                  # rows: architecture, name, expression, cycles, errors, ...
    found.glsl("exp2_polynomial_2"), found.twin("exp2_polynomial_2")(0.5)
    found.plot("front.png"); found.dataframe()     # (pandas, where installed)
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

from . import engine, parametric, publish, rendered, targets
from .targets import DeriveError, Target


def resolve(target=None, expr: str | None = None, var: str = "x=0:1", metric: str | None = None,
            floor: float | None = None, table: str | None = None, x: str | None = None,
            parameter: str | None = None, y: str | None = None, parameter_range=None, name: str | None = None):
    """The checked target: a Target, a registered name, a TOML file's path, (with `expr`) an
    expression in `var` (NAME=LO:HI), or (with `table`) a CSV file's column `y` over the variables `x`
    (comma-separated) and the `parameter` (`parametric.from_csv`); `metric` and `floor` replace the
    target's, `parameter_range` ("LO:HI" or (lo, hi)) its parameter's range (`parametric.with_range`:
    one of the ranges the lobe search splits n into); `name` names the run (its titles, its functions'
    names; default the target's name, or an expression's own text). Raises DeriveError."""
    chosen = _resolve(target, expr, var, metric, floor, table, x, parameter, y)
    if name is not None:
        if not name.strip():
            raise DeriveError("--name: give the run a name (it titles the outputs and names the functions)")
        chosen = dataclasses.replace(chosen, name=name.strip())
    if parameter_range is None:
        return chosen
    return parametric.with_range(chosen, parameter_range)


def _resolve(target, expr, var, metric, floor, table, x, parameter, y):
    if sum(v is not None for v in (target, expr, table)) != 1:
        raise DeriveError("give --target NAME (or FILE.toml), --expr EXPR or --table FILE.csv, one of them")
    if (x is not None or parameter is not None or y is not None) and table is None:
        raise DeriveError("--x, --parameter and --y go with --table")
    if expr is not None:
        return targets.from_expression(expr, var, metric or "abs", floor or 0.0)
    if table is not None:
        if not x:
            raise DeriveError("--table: name its variables' columns (--x NAME[,NAME])")
        return parametric.from_csv(table, [v.strip() for v in x.split(",") if v.strip()], parameter, y,
                                   metric or "abs", floor or 0.0)
    if isinstance(target, str) and target.endswith(".toml"):
        target = parametric.from_file(target)
    if not isinstance(target, (Target, parametric.ParametricTarget, parametric.PairTarget)):
        target = targets.named(str(target), parametric.registry() | parametric.pairs())
    if isinstance(target, parametric.PairTarget):
        if metric is not None or floor is not None:
            raise DeriveError(f"{target.name}: its metric is its parts' (abs); --metric and --floor do not apply")
        return parametric.check_pair(target)
    if metric is not None or floor is not None:
        target = dataclasses.replace(target, metric=metric or target.metric,
                                     floor=target.floor if floor is None else floor)
    return parametric.check(target) if isinstance(target, parametric.ParametricTarget) else targets.check(target)


@dataclasses.dataclass
class Derivation:
    """What `derive` found: `results` (results.json's content), `target`, and per member its
    shader code, Python twin and figure."""

    target: Target
    raw: dict

    @property
    def results(self) -> dict:
        return publish.results_json(self.raw)

    @property
    def front(self) -> list[dict]:
        """Every architecture's front members, as rows of front.csv."""
        return [r for r in self.raw["rows"] if r["on_front"]]

    @property
    def rows(self) -> list[dict]:
        """Every row of front.csv (front members, anchors, the exact target)."""
        return list(self.raw["rows"])

    def dataframe(self):
        """The rows as a pandas DataFrame. Raises ImportError naming pandas where it is missing."""
        try:
            import pandas
        except ImportError:
            raise ImportError("Derivation.dataframe needs pandas (pip install pandas); .rows has the same "
                              "rows as dicts") from None
        return pandas.DataFrame(self.rows)

    def _form(self, name: str):
        if name not in self.raw["forms"]:
            raise KeyError(f"no member {name!r}; the members are {', '.join(self.raw['members'])}")
        return self.raw["forms"][name].expression

    def _arguments(self, name: str) -> str:
        """The member's arguments (`publish.arguments_of`)."""
        return publish.arguments_of(self.raw, name)

    def glsl(self, name: str) -> str:
        """The member as a GLSL expression in the target's variables (and its parameter)."""
        return publish.shader_text(self._form(name), self._arguments(name), "glsl", self.raw.get("precision"))

    def hlsl(self, name: str) -> str:
        return publish.shader_text(self._form(name), self._arguments(name), "hlsl", self.raw.get("precision"))

    def twin(self, name: str):
        """The member's Python twin: a function of the target's variables (and its parameter), floats,
        printed as derive_twin.py prints it."""
        arguments = self._arguments(name)
        code = (f"def twin({arguments}):\n    return "
                f"{publish.shader_text(self._form(name), arguments, 'python', self.raw.get('precision'))}\n")
        scope = {"math": math}
        exec(compile(code, f"<twin of {name}>", "exec"), scope)
        return scope["twin"]

    def plot(self, path) -> Path:
        """front.png's figure, written to `path`."""
        publish.figure(Path(path), self.raw)
        return Path(path)

    def write(self, out) -> list[Path]:
        """Every file `pipeline derive` writes, into `out`."""
        return publish.write(Path(out), self.raw)


def derive(target=None, *, expr: str | None = None, var: str = "x=0:1", table: str | None = None,
           x: str | None = None, parameter: str | None = None, y: str | None = None, gpu=None,
           metric: str | None = None, floor: float | None = None, seconds: float | None = None,
           max_cycles: float | None = None, max_complexity: int = engine.MAX_COMPLEXITY, parameter_range=None,
           formula_complexity: int = 0, precision: str | None = None, name: str | None = None,
           plan=None, log=print) -> Derivation:
    """The cheapest accurate forms of `target` (a registered name, a TOML file, a Target, a
    ParametricTarget), of `expr` in `var`, or of a CSV `table`'s column `y` over `x` and `parameter`
    (its range `parameter_range`, "LO:HI", where given; with `formula_complexity` > 0 the constants'
    lines also corrected by the symbolic regression, `parametric.corrected`),
    ranked by compiled cycles on the architectures `gpu` (names, or one comma-separated string; default
    every one whose compiler runs here): `engine.derive`, `parametric.derive` (several variables or a
    parameter), `parametric.derive_pair` (env_brdf). Raises DeriveError for bad input, CompilerMissing
    where no GPU compiler runs. `precision` (fp32 or fp16; default the target's, fp32): the format
    every form is costed and executed in (`executed`, `executed_box`; a pair of outputs: fp32 only).
    `seconds` (default `engine.DEFAULT_SECONDS`): the searches' budget, planned as work before they
    start (`symbolic.ladder.make_plan`); `plan`, the plans of an earlier run to run exactly instead (a
    path to its results.json or plan file, or a `symbolic.budgets.Budget`); results.json's `plan`
    records the plans run."""
    from ..symbolic import budgets
    from .targets import PRECISIONS

    chosen = resolve(target, expr, var, metric, floor, table, x, parameter, y, parameter_range, name)
    if precision is not None and precision not in PRECISIONS:
        raise DeriveError(f"--precision {precision!r}: give one of {', '.join(PRECISIONS)}")
    if isinstance(gpu, str):
        gpu = [g.strip() for g in gpu.split(",") if g.strip()]
    if plan is not None and seconds is not None:
        raise DeriveError("--plan fixes the work; --seconds would change it: give one or the other")
    try:
        budget = (budgets.Budget(engine.DEFAULT_SECONDS if seconds is None else seconds) if plan is None
                  else plan if isinstance(plan, budgets.Budget) else budgets.recorded(plan))
    except budgets.PlanError as e:
        raise DeriveError(str(e)) from None
    try:
        raw = _derived(chosen, gpu, budget, max_cycles, max_complexity, formula_complexity, precision, log)
    except budgets.PlanError as e:
        raise DeriveError(f"--plan: {e}") from None
    raw["plan"] = dict(seconds=budget.seconds, searches=budgets.plans_of(raw["coverage"]))
    rendered.compare(raw, chosen, log=log)
    return Derivation(chosen, raw)


def _derived(chosen, gpu, budget, max_cycles, max_complexity: int, formula_complexity: int, precision, log) -> dict:
    """The results of the engine that derives `chosen`'s kind of target."""
    if isinstance(chosen, parametric.PairTarget):
        if precision not in (None, "fp32"):
            raise DeriveError(f"{chosen.name}: --precision {precision}: a pair of outputs is executed and costed in "
                              "float32 only")
        return parametric.derive_pair(chosen, gpu, budget, max_cycles, max_complexity, log=log,
                                      formula_complexity=formula_complexity)
    if isinstance(chosen, parametric.ParametricTarget):
        return parametric.derive(chosen, gpu, budget, max_cycles, max_complexity, log=log,
                                 formula_complexity=formula_complexity, precision=precision or "fp32")
    if formula_complexity:
        raise DeriveError(f"{chosen.name} has no parameter: --formula-complexity applies to targets with one")
    return engine.derive(chosen, gpu, budget, max_cycles, max_complexity, log=log,
                         precision=precision or chosen.precision)
