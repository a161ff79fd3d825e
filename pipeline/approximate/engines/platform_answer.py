"""The answer for a platform: one shader ships to every architecture of a platform (`isa.platforms`),
so a function's replacement there is the one form whose worst cycles over the platform's
architectures are least among the forms within the error budget; beside it, each architecture's own
cheapest form within the budget, and what a variant per architecture would save over the one shader.

The candidates are the function as shipped (so that a platform where nothing is cheaper keeps it),
the front members and the branch of a branch's derived pieces (`pieces.PIECES`), each compiled for
every architecture of the platform; a member whose constants are computed per material is not a
function body and is not a candidate. Ties: the least total cycles over the platform, then the
smallest error, then the name (so that the answer is the same on every machine).
"""

from __future__ import annotations

import math

from ..targets.reading import SHIPPED
from .pieces import PIECES


def candidates(results: dict, architectures, budget: float) -> list[str]:
    """The names of the module docstring's candidates within `budget` (the run's error key)."""
    key, cycles = results["error"], results["cycles"]
    out = []
    for name, m in results["members"].items():
        if not (m["kind"] == "found" or name in (SHIPPED, PIECES)) or m.get("parameter_per") == "material":
            continue
        if not (math.isfinite(m[key]) and m[key] <= budget):
            continue
        if all(cycles[a].get(name) is not None for a in architectures):
            out.append(name)
    return out


def answer(results: dict, architectures, budget: float) -> dict | None:
    """{name, cycles: {architecture: cycles}, worst, error, own: {architecture: (name, cycles)},
    variant_saving: {architecture: cycles}} of the platform of `architectures` (module docstring), or
    None where no candidate is within `budget`."""
    key, cycles = results["error"], results["cycles"]
    within = candidates(results, architectures, budget)
    if not within:
        return None

    def order(name):
        on = [cycles[a][name] for a in architectures]
        return max(on), sum(on), results["members"][name][key], name

    chosen = min(within, key=order)
    own = {a: min(((cycles[a][n], results["members"][n][key], n) for n in within)) for a in architectures}
    return dict(name=chosen, cycles={a: cycles[a][chosen] for a in architectures}, worst=order(chosen)[0],
                error=results["members"][chosen][key], own={a: (n, c) for a, (c, _, n) in own.items()},
                variant_saving={a: cycles[a][chosen] - own[a][0] for a in architectures})
