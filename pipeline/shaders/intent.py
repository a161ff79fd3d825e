"""What the author says of a function, on the comment line directly above it or on the command line:

    // derive: NoV=1e-4:1 NoL=1e-4:1 roughness=0.045:1 parameter=roughness metric=rel max_error=1e-3 role=visibility

each argument's range (NAME=LO:HI), the argument that is a material `parameter`, the `metric` (and
its `floor`), the `max_error` a replacement may have, the `precision`, the `role`, how many times a
pixel `calls` it (a library's totals weigh its cycles by it; 1 by default) and, for a function that
is itself an approximation, the `exact` function it approximates (`exact=acos(x)`; a value with
spaces in double quotes). The command line's values (`--var`, `--parameter`, `--metric`, ...) stand
where the comment gives none. A function without a range for each argument is one line naming it
and the line to write.
"""

from __future__ import annotations

import dataclasses
import math
import shlex

from .definitions import Definition, ShaderError

KEYS = ("parameter", "metric", "floor", "max_error", "precision", "role", "exact", "calls")
METRICS = ("abs", "rel")
PRECISIONS = ("fp32", "fp16")


@dataclasses.dataclass(frozen=True)
class Intent:
    """A function's ranges ({argument: (lo, hi)}) and the settings of the module docstring."""

    ranges: dict
    parameter: str | None = None
    metric: str = "abs"
    floor: float = 0.0
    max_error: float | None = None
    precision: str = "fp32"
    role: str = ""
    exact: str | None = None
    calls: float = 1.0


def _number(text: str, what: str, where: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise ShaderError(f"{where}: {what} = {text!r}: give a number") from None
    if not math.isfinite(value):
        raise ShaderError(f"{where}: {what} = {text!r}: give a finite number")
    return value


def _range(text: str, name: str, where: str) -> tuple[float, float]:
    parts = text.split(":")
    if len(parts) != 2:
        raise ShaderError(f"{where}: {name}={text}: give {name}=LO:HI")
    lo, hi = (_number(p, name, where) for p in parts)
    if not lo < hi:
        raise ShaderError(f"{where}: {name}={text}: give LO < HI")
    return lo, hi


def parse(text: str, where: str) -> dict:
    """The key=value pairs of an annotation (or of the command line's words), checked one by one:
    {key: value} with ranges under their argument's name. Raises ShaderError naming `where`."""
    try:
        words = shlex.split(text)
    except ValueError as e:
        raise ShaderError(f"{where}: {e}") from None
    out: dict = {}
    for word in words:
        key, sep, value = word.partition("=")
        if not sep or not key or not value:
            raise ShaderError(f"{where}: {word!r}: give KEY=VALUE (a range: NAME=LO:HI)")
        if key in out:
            raise ShaderError(f"{where}: {key} given twice")
        if key == "metric" and value not in METRICS:
            raise ShaderError(f"{where}: metric={value}: give one of {', '.join(METRICS)}")
        if key == "precision" and value not in PRECISIONS:
            raise ShaderError(f"{where}: precision={value}: give one of {', '.join(PRECISIONS)}")
        if key in ("floor", "max_error", "calls"):
            out[key] = _number(value, key, where)
            if out[key] < 0 or (key in ("max_error", "calls") and out[key] == 0):
                raise ShaderError(f"{where}: {key}={value}: give a number {'>=' if key == 'floor' else '>'} 0")
        elif key in KEYS:
            out[key] = value
        else:
            out[key] = _range(value, key, where)
    return out


def intent(definition: Definition, path, command_line: dict | None = None) -> Intent:
    """The function's intent: its annotation's pairs, then the command line's where the annotation
    gives none (`command_line`: the same keys, `parse`d). Raises ShaderError naming the function where
    a pair names no argument, the parameter is not an argument, or an argument has no range (the
    line to write shown)."""
    where = f"{path}:{definition.line - 1 if definition.annotation is not None else definition.line}"
    given = parse(definition.annotation, where) if definition.annotation else {}
    arguments = [p.name for p in definition.parameters]
    for key, value in (command_line or {}).items():
        if key in KEYS and key not in given:
            given[key] = value
        elif key not in KEYS and key in arguments and key not in given:
            given[key] = value
    unknown = [k for k in given if k not in KEYS and k not in arguments]
    if unknown:
        raise ShaderError(f"{where}: {definition.name} has no argument {unknown[0]!r} (its arguments: "
                          f"{', '.join(arguments)}; the other keys: {', '.join(KEYS)})")
    parameter = given.get("parameter")
    if parameter is not None and parameter not in arguments:
        raise ShaderError(f"{where}: parameter={parameter}: {definition.name} has no such argument "
                          f"(its arguments: {', '.join(arguments)})")
    missing = [a for a in arguments if a not in given]
    if missing:
        example = " ".join(f"{a}=LO:HI" for a in arguments)
        raise ShaderError(f"{path}:{definition.line}: {definition.name} has no range for {', '.join(missing)}: write "
                          f"`// derive: {example}` on the line above it, or give --var {missing[0]}=LO:HI")
    return Intent({a: given[a] for a in arguments}, parameter, given.get("metric", "abs"), given.get("floor", 0.0),
                  given.get("max_error"), given.get("precision", "fp32"), given.get("role", ""), given.get("exact"),
                  given.get("calls", 1.0))
