"""What the searches of a command may do: a budget in seconds, each search's plan made from it
before the search (`ladder.make_plan`), or the plans a run recorded (`--plan FILE`), replayed
exactly.

A run's plans are named by their search: "regress" for `pipeline regress`; "grammar" for the
one-variable search of `pipeline derive`; "templates" and "pixel search" for the searches of a
target of several variables or with a parameter; a pair's parts' prefixed by the part's name
("scale/pixel search"). A plan file is `results.json` of `pipeline derive` or `plan.json` of
`pipeline regress` (`{"plan": {"seconds": S, "searches": {name: plan}}}`), or that `plan` alone.
"""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

from . import ladder
from .ladder import PlanError


@dataclasses.dataclass(frozen=True)
class Budget:
    """`seconds` to plan each search from (None: every form, however long), or `recorded` plans (JSON
    text of {name: plan}) to replay; `scope`, the prefix of this part's plans' names (a pair's part)."""

    seconds: float | None
    recorded: str | None = None
    scope: str = ""

    def share(self, fraction: float) -> "Budget":
        """This budget for a search that has `fraction` of the seconds (a recorded plan: its own)."""
        return dataclasses.replace(self, seconds=self.seconds * fraction)

    def within(self, part: str) -> "Budget":
        """This budget for the searches of a pair's part `part`."""
        return dataclasses.replace(self, scope=f"{self.scope}{part}/")

    def named(self, name: str) -> str:
        """The name of this part's search `name` among a run's plans."""
        return self.scope + name

    def record(self, name: str, plan: dict) -> dict:
        """The entries of a search's coverage that record its plan (`plans_of` finds them)."""
        return dict(plan_name=self.named(name), plan=plan)

    def key(self) -> list:
        """What a kept search is keyed by (with its target, its settings and the code)."""
        return [self.seconds, self.scope, self.recorded]

    def plan(self, name: str, variables: int, points: int, max_complexity: int, ops, loss: str,
             operon: str = "auto", seed: int = 0) -> dict:
        """The plan of the search `name`: the recorded one, checked against the search
        (`ladder.check`), else the one this budget's seconds buy (`ladder.make_plan`)."""
        if self.recorded is None:
            return ladder.make_plan(variables, points, max_complexity, ops, self.seconds, loss, operon, seed)
        plans, named = json.loads(self.recorded), self.named(name)
        if named not in plans:
            raise PlanError(f"the plan file has no plan for the search {named!r} (it has "
                            f"{', '.join(repr(k) for k in plans) or 'none'}): it was made by another command")
        try:
            return ladder.check(plans[named], variables, points, max_complexity, ops, loss)
        except PlanError as e:
            raise PlanError(f"the plan of the search {named!r}: {e}") from None


def recorded(path) -> Budget:
    """The Budget replaying the plans of a plan file (module docstring); PlanError naming what is
    wrong with the file."""
    path = Path(path)
    try:
        content = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise PlanError(f"--plan {path}: no such file") from None
    except (OSError, UnicodeDecodeError, ValueError) as e:
        raise PlanError(f"--plan {path}: not a JSON file ({type(e).__name__}: {e})") from None
    plan = content.get("plan", content) if isinstance(content, dict) else None
    if not isinstance(plan, dict) or not isinstance(plan.get("searches"), dict) or not plan["searches"]:
        raise PlanError(f"--plan {path}: no plan in it (a results.json of pipeline derive or a plan.json of "
                        "pipeline regress holds one, under \"plan\")")
    seconds = plan.get("seconds")
    if seconds is not None and (not isinstance(seconds, (int, float)) or not math.isfinite(seconds)):
        raise PlanError(f"--plan {path}: the plan's budget \"seconds\" is {seconds!r}, not a number (nor null: "
                        "every form, however long)")
    return Budget(None if seconds is None else float(seconds), json.dumps(plan["searches"], sort_keys=True))


def plans_of(coverage) -> dict:
    """{name: plan} of every search a run's coverage records (`record`), sorted by name."""
    out = {}

    def walk(node):
        if isinstance(node, dict):
            if isinstance(node.get("plan_name"), str):
                out[node["plan_name"]] = node["plan"]
            for value in node.values():
                walk(value)
        elif isinstance(node, list):
            for value in node:
                walk(value)

    walk(coverage)
    return dict(sorted(out.items()))


def plan_text(plan: dict) -> str:
    """A run's plans (results.json's `plan`) in a line: what each search covered, and how to run them
    again."""
    return (f"each search's work planned before it started from {plan['seconds']:g} s at the reference machine's "
            "rates, then run to its end whatever the clock: "
            + "; ".join(f"{name}: {ladder.covered_text(p)}" for name, p in plan["searches"].items())
            + ". The same command with --plan results.json runs exactly these plans again: the same front on any "
            "machine")
