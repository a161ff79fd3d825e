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

from . import engine, parametric, publish, targets
from .targets import DeriveError, Target


def resolve(target=None, expr: str | None = None, var: str = "x=0:1", metric: str | None = None,
            floor: float | None = None) -> Target:
    """The checked target: a Target, a registered name, a TOML file's path, or (with `expr`) an
    expression in `var` (NAME=LO:HI); `metric` and `floor` replace the target's. Raises DeriveError."""
    if (target is None) == (expr is None):
        raise DeriveError("give --target NAME (or FILE.toml) or --expr EXPR, one of them")
    if expr is not None:
        return targets.from_expression(expr, var, metric or "abs", floor or 0.0)
    if not isinstance(target, (Target, parametric.ParametricTarget)):
        target = targets.named(str(target), parametric.registry())
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
        """The member's arguments: the target's variable, or a parametric target's variables and
        parameter (a material member: its variables and constants c0, c1, ...)."""
        member = self.raw["members"].get(name, {})
        if member.get("parameter_per") == "material":
            return ", ".join([v.name for v in self.target.variables] + [f"c{i}" for i in range(len(member["constants"]))])
        return self.target.variable

    def glsl(self, name: str) -> str:
        """The member as a GLSL expression in the target's variables (and its parameter)."""
        return publish.shader_text(self._form(name), self._arguments(name), "glsl")

    def hlsl(self, name: str) -> str:
        return publish.shader_text(self._form(name), self._arguments(name), "hlsl")

    def twin(self, name: str):
        """The member's Python twin: a function of the target's variables (and its parameter), floats,
        printed as derive_twin.py prints it."""
        arguments = self._arguments(name)
        code = f"def twin({arguments}):\n    return {publish.shader_text(self._form(name), arguments, 'python')}\n"
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


def derive(target=None, *, expr: str | None = None, var: str = "x=0:1", gpu=None, metric: str | None = None,
           floor: float | None = None, seconds: float = engine.DEFAULT_SECONDS, max_cycles: float | None = None,
           max_complexity: int = engine.MAX_COMPLEXITY, log=print) -> Derivation:
    """The cheapest accurate forms of `target` (a registered name, a TOML file, a Target) or of `expr`
    in `var`, ranked by compiled cycles on the architectures `gpu` (names, or one comma-separated
    string; default every one whose compiler runs here): `engine.derive`. Raises DeriveError for bad
    input, CompilerMissing where no GPU compiler runs."""
    chosen = resolve(target, expr, var, metric, floor)
    if isinstance(gpu, str):
        gpu = [g.strip() for g in gpu.split(",") if g.strip()]
    run = parametric.derive if isinstance(chosen, parametric.ParametricTarget) else engine.derive
    return Derivation(chosen, run(chosen, gpu, seconds, max_cycles, max_complexity, log=log))
