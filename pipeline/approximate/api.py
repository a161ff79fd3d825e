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

from . import engines, targets
from .measures import rendered
from .publishing import derive_files as publish
from .targets import DeriveError, Target


resolve = targets.read         # the checked target of any source (`targets.reading.read`)


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


def gpu_of(gpu, platforms=None, precision: str | None = None) -> tuple[list[str] | None, str | None, dict]:
    """(the architectures `gpu` names: a list or one comma-separated string of architectures' and
    platforms' names, `isa.platforms`, from the shipped platforms and the file `platforms` where
    given; the precision: `precision` where given, else that of the platforms named where they agree;
    {name: Platform} of the platforms named). Raises DeriveError for an unknown name, a wrong
    platforms file, platforms of two formats without `precision`."""
    from ..isa import platforms as shipped

    table = _platforms(platforms)           # (a wrong file is named even where no --gpu word uses it)
    if gpu is None:
        return None, precision, {}
    if isinstance(gpu, str):
        gpu = [g.strip() for g in gpu.split(",") if g.strip()]
    try:
        architectures = shipped.architectures_of(gpu, table)
    except shipped.PlatformError as e:
        raise DeriveError(str(e)) from None
    named = {w: table[w] for w in gpu if w in table}
    formats = {p.precision for p in named.values()}
    if precision is None and len(formats) > 1:
        raise DeriveError(f"--gpu {','.join(gpu)}: its platforms compute in {' and '.join(sorted(formats))}: "
                          "give --precision")
    return architectures, precision if precision is not None or not formats else formats.pop(), named


def _platforms(path) -> dict:
    """The shipped platforms and those of the file `path` where given; DeriveError for a wrong file."""
    from ..isa import platforms as shipped

    try:
        return shipped.read(path)
    except shipped.PlatformError as e:
        raise DeriveError(str(e)) from None


def derive(target=None, *, expr: str | None = None, var: str = "x=0:1", table: str | None = None,
           x: str | None = None, parameter: str | None = None, y: str | None = None, gpu=None,
           metric: str | None = None, floor: float | None = None, seconds: float | None = None,
           max_cycles: float | None = None, max_complexity: int = engines.MAX_COMPLEXITY, parameter_range=None,
           formula_complexity: int = 0, precision: str | None = None, name: str | None = None,
           plan=None, platforms=None, certify: bool = False, contract: str = "allowed", log=print) -> Derivation:
    """The cheapest accurate forms of `target` (a registered name, a TOML file, a Target), of `expr`
    in `var`, or of a CSV `table`'s column `y` over `x` and `parameter` (its range `parameter_range`,
    "LO:HI", where given; with `formula_complexity` > 0 the constants' lines also corrected by the
    symbolic regression, `search.formulas.corrected`), read and checked once (`targets.read`), ranked
    by compiled cycles on the architectures `gpu` (names of architectures or of platforms, `gpu_of`;
    default every one whose compiler runs here) by the engine of its shape (`engines.derive`: one variable,
    several variables or a parameter, a pair). Raises DeriveError for bad input, CompilerMissing
    where no GPU compiler runs. `precision` (fp32 or fp16; default the target's, fp32): the format
    every form is costed and executed in (`executed`, `executed_box`; a pair of outputs: fp32 only).
    `seconds` (default `engines.DEFAULT_SECONDS`): the searches' budget, planned as work before they
    start (`symbolic.ladder.make_plan`); `plan`, the plans of an earlier run to run exactly instead (a
    path to its results.json or plan file, or a `symbolic.budgets.Budget`); results.json's `plan`
    records the plans run. `certify` (or the target file's `certify = true`): every front member's,
    anchor's and the exact target's largest error as executed taken over every input of the domain in
    the format (`measures.exhaustive`; one variable), the fronts read off those. `contract` "never":
    every form costed and written with its value `precise` (no fused multiply-add, no reordering by a
    driver), which makes the worst a conforming driver may give (`--certify`) a bound of it."""
    from ..symbolic import budgets
    from .targets import PRECISIONS

    chosen = resolve(target, expr, var, metric, floor, table, x, parameter, y, parameter_range, name)
    if precision is not None and precision not in PRECISIONS:
        raise DeriveError(f"--precision {precision!r}: give one of {', '.join(PRECISIONS)}")
    gpu, precision, _ = gpu_of(gpu, platforms, precision)
    if plan is not None and seconds is not None:
        raise DeriveError("--plan fixes the work; --seconds would change it: give one or the other")
    try:
        budget = (budgets.Budget(engines.DEFAULT_SECONDS if seconds is None else seconds) if plan is None
                  else plan if isinstance(plan, budgets.Budget) else budgets.recorded(plan))
    except budgets.PlanError as e:
        raise DeriveError(str(e)) from None
    try:
        raw = engines.derive(chosen, gpu, budget, max_cycles, max_complexity, formula_complexity, precision, log,
                             certify=certify, contract=contract)
    except budgets.PlanError as e:
        raise DeriveError(f"--plan: {e}") from None
    raw["plan"] = dict(seconds=budget.seconds, searches=budgets.plans_of(raw["coverage"]))
    rendered.compare(raw, chosen, log=log)
    return Derivation(chosen, raw)


@dataclasses.dataclass
class ShaderDerivation:
    """What `derive_shader` found for a shader file: per function its `outcomes`
    (`engines.shader_file.Outcome`: status, reason, replacement, rows), the file's `patch` (a unified
    diff; empty where nothing was derived) and its functions.csv `rows`."""

    path: Path
    language: str
    outcomes: list
    keep_reference: bool = False

    @property
    def rows(self) -> list[dict]:
        from .publishing import shader_outputs

        return shader_outputs.function_rows(self.path, self.outcomes)

    @property
    def patch(self) -> str:
        from .publishing import shader_outputs

        return shader_outputs.patch_text(self.path, self.outcomes, self.keep_reference)

    def write(self, out) -> list[Path]:
        """functions.csv, shader.patch, report.md and each derived function's files, into `out`."""
        from .publishing import shader_outputs

        return shader_outputs.write(Path(out), self.path, self.outcomes, self.language, self.keep_reference,
                                    log=lambda s: None)


def _shader_settings(lang, include, define, var, parameter, metric, floor, max_error, exact, gpu, platforms,
                     precision):
    """(a file's `shaders.harness.Options` by its path, the command line's intent `shaders.intent.parse`'d,
    the architectures, the precision, {name: Platform} of the platforms `gpu` names) of `derive_shader`'s
    and `derive_library`'s settings."""
    import shlex

    from ..shaders import definitions, harness, intent as intents

    def options_of(path):
        return harness.Options(definitions.language_of(path, lang), tuple(str(d) for d in include), tuple(define))

    words = [var] if isinstance(var, str) else list(var or [])
    if parameter is not None:
        name, _, rest = parameter.partition("=")
        words += [f"parameter={name}"] + ([f"{name}={rest}"] if rest else [])
    words += [f"{k}={v}" for k, v in (("metric", metric), ("floor", floor), ("max_error", max_error)) if v is not None]
    if exact is not None:
        words.append(shlex.quote(f"exact={exact}"))
    command_line = intents.parse(" ".join(words), "the command line")
    gpu, precision, named = gpu_of(gpu, platforms, precision)
    return options_of, command_line, gpu, precision, named


def _answer_platforms(outcomes, named: dict) -> None:
    """Each derived or none-cheaper function's answer for each platform `named` (`platform_answer`)."""
    from .engines import platform_answer

    for o in (o for o in outcomes if o.results is not None):
        o.platforms = {name: platform_answer.answer(o.results, p.architectures, o.budget) for name, p in named.items()}


def derive_shader(path, function=None, *, lang: str | None = None, include=(), define=(), var=None,
                  parameter: str | None = None, metric: str | None = None, floor: float | None = None,
                  max_error: float | None = None, exact: str | None = None, gpu=None, seconds: float | None = None,
                  max_complexity: int = engines.MAX_COMPLEXITY, precision: str | None = None,
                  keep_reference: bool = False, platforms=None, log=print) -> ShaderDerivation:
    """Every function of the GLSL or HLSL file `path` (or those `function` names: a list or one
    comma-separated string) derived (`engines.shader_file`): `lang` (default by the file's suffix),
    `include` folders and `define`d macros as a shader compiler takes them; `var` ("NAME=LO:HI" or a
    list of them), `parameter` ("NAME" or "NAME=LO:HI"), `metric`, `floor`, `max_error`, `exact` where
    a function's `// derive:` line gives none. Raises ShaderError (`shaders.definitions`) for a file
    that does not compile or a named function it does not define, DeriveError for a bad setting."""
    from .engines import shader_file

    path = Path(path)
    options_of, command_line, gpu, precision, named = _shader_settings(lang, include, define, var, parameter, metric,
                                                                       floor, max_error, exact, gpu, platforms,
                                                                       precision)
    if isinstance(function, str):
        function = [f.strip() for f in function.split(",") if f.strip()]
    language = options_of(path).language
    outcomes, _ = shader_file.derive_file(path, options_of(path), derive, function, command_line, gpu, seconds,
                                          max_complexity, precision, log)
    _answer_platforms(outcomes, named)
    return ShaderDerivation(path, language, outcomes, keep_reference)


def derive_library(paths, *, lang: str | None = None, include=(), define=(), var=None, parameter: str | None = None,
                   metric: str | None = None, floor: float | None = None, max_error: float | None = None,
                   exact: str | None = None, gpu=None, seconds: float | None = None,
                   max_complexity: int = engines.MAX_COMPLEXITY, precision: str | None = None, platforms=None,
                   client=None, scheduler: str | None = None, workers: int | None = None, log=print,
                   run: dict | None = None) -> dict:
    """Every function of every shader file `paths` names (files, folders, globs:
    `engines.library.shader_files`) derived as one batch of tasks on Dask (`engines.library`): on
    `client` where given, else on the cluster `scheduler` names, else on a LocalCluster of `workers`
    processes (`engine.cluster.client`); the other settings as `derive_shader`'s. Returns {path:
    [every Outcome of the file]}, each function's platforms' answers set; `run`, where given, gets the
    cluster's scheduler address and its workers."""
    from ..engine import paths as pipeline_paths
    from ..engine.cluster import client as cluster_client
    from .engines import library

    options_of, command_line, gpu, precision, named = _shader_settings(lang, include, define, var, parameter, metric,
                                                                       floor, max_error, exact, gpu, platforms,
                                                                       precision)
    from ..symbolic import budgets

    # (the options every task would refuse alike, refused once before the batch)
    engines.checked_options(gpu, budgets.Budget(engines.DEFAULT_SECONDS if seconds is None else seconds), None,
                            max_complexity)
    files = library.shader_files([paths] if isinstance(paths, (str, Path)) else paths)
    work = library.tasks(files, options_of)
    settings = dict(gpu=gpu, seconds=seconds, max_complexity=max_complexity, precision=precision)
    started = None
    if client is None:
        client, started = cluster_client(scheduler, None, workers)
    if run is not None:
        run.update(scheduler=client.scheduler.address, workers=len(client.scheduler_info()["workers"]))
    try:
        library.calibrate(client, gpu or engines.available_architectures(), log)
        found = library.derive_library(work, options_of, command_line, settings,
                                       pipeline_paths.DERIVE_CACHE / "library", client, derive, log=log)
    finally:
        if started is not None:
            client.close()
            started.close()
    out: dict = {path: [] for path in files}
    for (path, _), outcomes in found.items():
        _answer_platforms(outcomes, named)
        out[path] += outcomes
    return out
