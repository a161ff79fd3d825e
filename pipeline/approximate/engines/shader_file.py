"""`derive --shader FILE`: every function of a GLSL or HLSL file read as the compiler means it
(`shaders.harness`), checked against itself as it executes (`shaders.round_trip`), derived by the
engine of its shape as a target whose anchor "as shipped" is the function as written
(`targets.reading.from_shader_function`), and its replacement chosen by the rule (`replacement`).
A function with a branch on one argument has each piece derived first on the interval where it is
taken (`engines.pieces`), each piece's replacement chosen by the same rule against the piece as
shipped; where one is, the branch of the pieces' replacements is an anchor of the whole function
(`pieces.PIECES`), costed and measured whole, and competes with the branch-free forms.

The rule: a replacement is a front member (or the branch of derived pieces) whose error as executed is within the budget (the
author's `max_error`; without one, the function's own error as shipped, or the format's rounding
floor where that is larger: only rewrites no less accurate), at no more cycles than the function as
shipped on every architecture asked for, and better: fewer cycles on at least one, or more accurate
than the function as shipped (its error below the shipped one's by more than `fronts.MATCH`, errors
below the rounding floor counting as the floor: the verdict `beaten`); of those, the fewest cycles
over the architectures (then the smallest error). Every function gets a status: `derived`, `none cheaper`
(with the reason read off the fronts) or `refused` (with its reason in one line).
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

from ..targets import DeriveError
from ..targets.reading import from_shader_function, SHIPPED
from . import pieces as branch_pieces

DERIVED, NONE_CHEAPER, REFUSED = "derived", "none cheaper", "refused"


@dataclasses.dataclass
class Outcome:
    """One function of the file: its status, reason, and (derived or none cheaper) its derivation's
    results, the replacement's name, GLSL or HLSL expression and rows per architecture; its branch's
    `pieces`; per platform named by `--gpu`, the answer for it (`platform_answer.answer`); how many
    times a pixel `calls` it (its annotation's; 1 by default)."""

    name: str
    line: int
    status: str
    reason: str = ""
    results: dict | None = None
    replacement: str | None = None
    expression: str | None = None
    rows: list = dataclasses.field(default_factory=list)
    budget: float | None = None
    metric: str = ""
    definition: object = None
    check: object = None
    pieces: list = dataclasses.field(default_factory=list)
    pieces_reason: str = ""
    platforms: dict = dataclasses.field(default_factory=dict)
    calls: float = 1.0


def replacement(results: dict, max_error: float | None) -> tuple[str | None, str, float]:
    """(the chosen member's name or None, the reason where none, the budget) by the module
    docstring's rule, from a derivation's results (its members' executed errors, every form's cycles
    per architecture, `cycles`)."""
    key = results["error"]
    members, cycles, architectures = results["members"], results["cycles"], results["architectures"]
    from ..measures.fronts import MATCH

    shipped = members[SHIPPED]
    floor = results["rounding_floor"]
    budget = max_error if max_error is not None else max(shipped[key], floor)
    before = {a: cycles[a].get(SHIPPED) for a in architectures}
    if any(c is None for c in before.values()):
        missing = [a for a, c in before.items() if c is None]
        return None, f"the function as shipped did not compile for {', '.join(missing)}", budget
    candidate = {n for n, m in members.items() if m["kind"] == "found" or n == branch_pieces.PIECES}
    eligible = []
    for name, m in members.items():
        if name not in candidate or not (math.isfinite(m[key]) and m[key] <= budget):
            continue
        if m.get("parameter_per") == "material":        # (its constants per material: not a function body)
            continue
        after = {a: cycles[a].get(name) for a in architectures}
        if any(c is None for c in after.values()):
            continue
        cheaper = any(after[a] < before[a] for a in architectures)
        more_accurate = max(m[key], floor) < max(shipped[key], floor) * (1 - MATCH)
        if all(after[a] <= before[a] for a in architectures) and (cheaper or more_accurate):
            eligible.append((sum(after.values()), m[key], name))
    if eligible:
        return min(eligible)[2], "", budget
    within = [n for n, m in members.items() if n in candidate and math.isfinite(m[key]) and m[key] <= budget]
    least = {a: min((cycles[a][n] for n in within if n in cycles[a]), default=None) for a in architectures}
    held = [f"{a}: {before[a]:g} cycles as shipped, the least within it {least[a]:g}" for a in architectures
            if least[a] is not None and least[a] >= before[a]]
    return None, (f"no form within the budget ({key} {budget:.3g}) is cheaper or more accurate at no more cycles on "
                  "every architecture asked for"
                  + (f" ({'; '.join(held)}: the compiler already computes it as cheaply)" if held else
                     "" if within else ": none is within it")), budget


def derive_file(path: Path, options, derive, functions: list[str] | None = None, command_line: dict | None = None,
                gpu=None, seconds: float | None = None, max_complexity: int = 12, precision: str | None = None,
                log=print) -> tuple[list[Outcome], str]:
    """(every function's Outcome, the file's preprocessed text) of `path` compiled with `options`
    (`shaders.harness.Options`), each target derived by `derive` (`api.derive`: a Derivation):
    `functions` (names; default every function of the file), the command
    line's ranges and settings (`shaders.intent.parse`'d) where a function's comment gives none.
    Raises ShaderError for a file that does not compile, a named function it does not define, or a
    file with no function."""
    from ...shaders import definitions as shader_definitions
    from ...shaders import harness, intent as intents, round_trip, spirv_reader

    language, found = shader_definitions.read(path, options.language)
    if not found:
        raise shader_definitions.ShaderError(f"{path}: no function definition found (read as {language.upper()})")
    names = [d.name for d in found]
    unknown = [f for f in functions or [] if f not in names]
    if unknown:
        raise shader_definitions.ShaderError(f"--function {unknown[0]!r}: {path} defines {', '.join(dict.fromkeys(names))}")
    chosen = [d for d in found if not functions or d.name in functions]
    text = harness.preprocessed(path, options)
    overloaded = {n for n in names if names.count(n) > 1}
    outcomes = []
    for d in chosen:
        shown = f"{d.name}({', '.join(p.type for p in d.parameters)})" if d.name in overloaded else d.name
        log(f"{shown} (line {d.line}):")
        why = harness.refusal(d)
        if why is None and d.name == "main":
            why = "the file's entry point"
        if why is not None:
            outcomes.append(Outcome(shown, d.line, REFUSED, why, definition=d))
            log(f"  refused: {why}")
            continue
        try:
            expression, transliteration, lanes = harness.reading(text, d, options, path)
        except spirv_reader.Refused as e:
            outcomes.append(Outcome(shown, d.line, REFUSED, str(e), definition=d))
            log(f"  refused: {e}")
            continue
        try:
            intent = intents.intent(d, path, command_line)
        except shader_definitions.ShaderError as e:
            outcomes.append(Outcome(shown, d.line, REFUSED, str(e), definition=d))
            log(f"  refused: {e}")
            continue
        arguments = [p.name for p in d.parameters]
        check = round_trip.round_trip(text, d, expression, transliteration, [intent.ranges[a] for a in arguments],
                                      language)
        log(f"  read: {expression}; executed beside it: {check.how}"
            + (f", {check.inputs} inputs, to the last bit" if check.checked and check.mismatch is None else ""))
        if check.mismatch is not None:
            outcomes.append(Outcome(shown, d.line, REFUSED, check.mismatch, definition=d, check=check))
            continue
        source = f"{path.name}:{d.line}"
        settings = dict(gpu=gpu, seconds=seconds, max_complexity=max_complexity, precision=precision)
        pieces, pieces_reason, branch = derived_pieces(d.name, expression, arguments, intent, source, settings,
                                                       derive, log)
        try:
            target = from_shader_function(d.name, expression, arguments, intent.ranges, source,
                                          intent.parameter, intent.exact, intent.metric, intent.floor,
                                          precision or intent.precision, intent.role,
                                          {branch_pieces.PIECES: branch} if branch is not None else None)
            found_forms = derive(target, log=lambda s: log("  " + s), **settings)
        except DeriveError as e:
            outcomes.append(Outcome(shown, d.line, REFUSED, str(e), definition=d, check=check))
            log(f"  refused: {e}")
            continue
        results = found_forms.raw
        name, reason, budget = replacement(results, intent.max_error)
        outcome = Outcome(shown, d.line, DERIVED if name else NONE_CHEAPER, reason, results, name,
                          budget=budget, metric=results["error"], definition=d, check=check, pieces=pieces,
                          pieces_reason=pieces_reason, calls=intent.calls)
        if name is not None:
            outcome.expression = replacement_text(results["forms"][name].expression, d, lanes, language,
                                                  results.get("precision"))
        key = results["error"]
        for a in results["architectures"]:
            after = name or SHIPPED
            outcome.rows.append(dict(architecture=a, cycles_before=results["cycles"][a][SHIPPED],
                                     cycles_after=results["cycles"][a][after],
                                     error_before=results["members"][SHIPPED][key],
                                     error_after=results["members"][after][key],
                                     flip_before=flip(results, SHIPPED), flip_after=flip(results, after)))
        log(f"  {outcome.status}" + (f": {name} ({outcome.expression})" if name else f": {reason}"))
        outcomes.append(outcome)
    compiled(path, options, outcomes, log)
    return outcomes, text


def flip(results: dict, name: str) -> float | None:
    """The member's largest FLIP over the rendered spheres (`rendered.STATISTIC`) where the function
    has a role and was rendered, else None."""
    from ..measures import rendered

    if not (results.get("rendered") or {}).get("role"):
        return None
    return results["members"][name].get(rendered.STATISTIC)


def derived_pieces(name: str, expression, arguments: list[str], intent, source: str, settings: dict, derive,
                   log=print) -> tuple[list, str, object]:
    """(the pieces of a function's branch, why none is replaced where none is, the branch of their
    replacements in the arguments or None): each piece taken on an interval derived there by
    `derive` (approximating the author's `exact` there where one is named, else the piece itself;
    the piece as written its anchor "as shipped"; not rendered: a piece alone has no place in a
    shading) and its replacement chosen by `replacement` within the author's `max_error`, else
    within the piece's own error as shipped."""
    pieces, why = branch_pieces.sub_domains(expression, intent.ranges)
    if not pieces:
        return [], why, None
    for p in (p for p in pieces if p.domain is not None):
        lo, hi = p.domain
        log(f"  piece {p.index}, {p.where}: {p.argument} in [{lo:.6g}, {hi:.6g}]")
        try:
            target = from_shader_function(f"{name}_piece{p.index}", p.shipped, arguments,
                                          intent.ranges | {p.argument: p.domain}, f"{source}, piece {p.index}",
                                          intent.parameter, intent.exact, intent.metric, intent.floor,
                                          settings.get("precision") or intent.precision, "")
            p.results = derive(target, log=lambda s: log("    " + s), **settings).raw
        except DeriveError as e:
            p.reason = str(e)
            log(f"    not derived: {e}")
            continue
        p.chosen, p.reason, _ = replacement(p.results, intent.max_error)
        if p.chosen is not None:
            p.form = in_arguments(p.results["forms"][p.chosen].expression, arguments)
        log(f"    {p.chosen}: {p.form}" if p.chosen else f"    kept: {p.reason}")
    if not any(p.chosen for p in pieces):
        return pieces, "no piece has a replacement on its interval", None
    return pieces, "", branch_pieces.assembled(pieces)


def compiled(path: Path, options, outcomes: list[Outcome], log=print) -> None:
    """Each replacement compiled in the file patched with it alone (a copy in a temporary folder, the
    file's own folder searched for its includes): a replacement that does not compile is refused with
    the compiler's message, and the patch leaves its function as it was."""
    import tempfile

    from ...shaders import definitions as shader_definitions
    from ...shaders import harness, patch

    source = Path(path).read_bytes()
    checked = dataclasses.replace(options, include=(str(Path(path).resolve().parent),) + tuple(options.include))
    for o in (o for o in outcomes if o.status == DERIVED):
        with tempfile.TemporaryDirectory(prefix="patched_") as folder:
            copy = Path(folder) / Path(path).name
            copy.write_bytes(patch.replaced(source, {o.definition: o.expression}))
            try:
                text = harness.preprocessed(copy, checked)
                twin = next(d for d in shader_definitions.definitions(copy.read_bytes(), options.language)
                            if d.name == o.definition.name and d.types == o.definition.types)
                harness.disassembly(text, twin, checked, copy)
            except shader_definitions.ShaderError as e:
                o.status, o.reason = REFUSED, f"its replacement does not compile: {str(e).replace(folder + '/', '')}"
                log(f"{o.name}: {o.reason}")


def replacement_text(expression, definition, lanes: int, language: str, precision: str | None) -> str:
    """A replacement's body expression in the function's own arguments (the target's names for them
    undone, `variable_names`), its numbers the format's; a vector function's, its result's type built
    of the scalar form once per lane, each vector argument read at that lane (f0.x, f0.y, ...)."""
    import sympy as sp

    from ...shaders.harness import width
    from ..forms import _GLSL, _HLSL, printed

    expression = in_arguments(expression, [p.name for p in definition.parameters])
    printer = _HLSL if language == "hlsl" else _GLSL
    if lanes == 1:
        return printed(printer(), expression, precision)
    vectors = [p.name for p in definition.parameters if width(p.type) > 1]
    texts = [printed(printer(), expression.xreplace({sp.Symbol(a, real=True): sp.Symbol(f"{a}.{c}", real=True)
                                                     for a in vectors}), precision) for c in "xyzw"[:lanes]]
    kind = f"float{lanes}" if language == "hlsl" else f"vec{lanes}"
    return f"{kind}({', '.join(texts)})"


def in_arguments(expression, arguments: list[str]):
    """A form of the function's target in the function's own arguments (the target's names for them,
    `variable_names`, undone)."""
    import sympy as sp

    from ..targets.reading import variable_names

    return expression.xreplace({sp.Symbol(v, real=True): sp.Symbol(a, real=True)
                                for a, v in variable_names(arguments).items()})
