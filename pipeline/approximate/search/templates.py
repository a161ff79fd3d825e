"""The templates of the engine of several variables: forms in the variables with free constants, from the families
(polynomials and their reciprocals and exp2s, in symmetric monomials where the target is symmetric)
and from the grammar's search at the parameter's middle value (`engines.several_variables`' step 1)."""

from __future__ import annotations

import dataclasses
import itertools

import numpy as np

from .settings import MAX_CONSTANTS, PUSH_CONSTANTS, SEARCH_TEMPLATES
from ..targets import middle, SEARCH_AXIS_POINTS, Target, variables_at


# ---- templates ----------------------------------------------------------------------------------

@dataclasses.dataclass
class Template:
    """A form in the variables with free constants k_0 ... k_{m-1} (sympy), its family, and the
    constants it starts from at the parameter's middle value (None: a linear start)."""

    name: str
    family: str
    expression: object
    count: int
    source: str
    start: np.ndarray | None = None
    outer: str = "identity"          # the families' outer function: identity or reciprocal
    basis: tuple = ()                # ... and their monomials, for the linear start


def kept_symbols(target) -> list:
    """Every symbol a found form may hold: the target's, the push constants c0, c1, ... and the
    template constants k_0, k_1, ... (real, as the forms make them)."""
    import sympy as sp

    return (target.symbols() + [sp.Symbol(f"c{i}", real=True) for i in range(PUSH_CONSTANTS)]
            + constant_symbols(MAX_CONSTANTS))


def constant_symbols(count: int) -> list:
    import sympy as sp

    return [sp.Symbol(f"k_{i}", real=True) for i in range(count)]


def _monomials(symbols, degree: int, bilinear: bool, symmetric: bool) -> list:
    """The monomials of total degree <= degree (or, `bilinear`, of degree <= 1 in each variable), the
    constant 1 first; in two symmetric variables, their symmetric sums (x + y, x y, x^2 + y^2)."""
    import sympy as sp

    powers = [p for p in itertools.product(range(degree + 1), repeat=len(symbols))
              if (max(p) <= 1 if bilinear else sum(p) <= degree)]
    powers.sort(key=lambda p: (sum(p), p[::-1]))
    out = []
    for p in powers:
        term = sp.Mul(*(s ** k for s, k in zip(symbols, p)))
        if symmetric:
            term = sp.expand(term + term.subs({symbols[0]: symbols[1], symbols[1]: symbols[0]}, simultaneous=True))
            term = term.as_coeff_Mul()[1]          # (2 x y is x y, 2 is 1)
        if term not in out:
            out.append(term)
    return out


# (label, total degree, bilinear) of the monomial bases, by the number of variables
BASES = {1: (("degree1", 1, False), ("degree2", 2, False), ("degree3", 3, False), ("degree4", 4, False)),
         2: (("degree1", 1, False), ("bilinear", 1, True), ("degree2", 2, False)),
         3: (("degree1", 1, False),)}
OUTERS = {"identity": "polynomial", "reciprocal": "reciprocal_polynomial", "exp2": "exp2_polynomial"}


def family_templates(target: Target, symmetric: bool, positive: bool = False) -> list[Template]:
    """The linear families of the module docstring, step 1 (exp2 of a polynomial where the target is
    `positive` on the box)."""
    import sympy as sp

    symbols = target.symbols()[:len(target.variables)]
    out, seen = [], set()
    for outer, family in OUTERS.items():
        if outer == "exp2" and not positive:
            continue
        for label, degree, bilinear in BASES[len(symbols)]:
            if degree > target.max_degree:
                continue
            full = _monomials(symbols, degree, bilinear, symmetric)
            for basis, constant in ((full, True), (full[1:], False)):
                key = (outer, tuple(basis))
                if key in seen or len(basis) < 1 or len(basis) > MAX_CONSTANTS:
                    continue
                seen.add(key)
                k = constant_symbols(len(basis))
                inner = sum((ki * b for ki, b in zip(k, basis)), sp.Integer(0))
                expression = {"identity": inner, "reciprocal": 1 / inner, "exp2": sp.Pow(2, inner)}[outer]
                name = f"{family}_{label}" + ("" if constant else "_no_constant") + ("_symmetric" if symmetric else "")
                out.append(Template(name, family, expression, len(basis),
                                    f"{dict(reciprocal='1 / ', exp2='exp2 of ').get(outer, '')}a sum of "
                                    f"{', '.join(str(b) for b in basis)} with constants per value",
                                    outer=outer, basis=tuple(basis)))
    return out


def grammar_templates(target: Target, f, budget, max_complexity: int, log) -> tuple[list, dict]:
    """The grammar's forms in the variables at the parameter's middle value (the ladder's front, the
    SEARCH_TEMPLATES most accurate) by the plan `budget` (a `symbolic.budgets.Budget`) gives the
    search "templates", as templates; and the search's coverage, its plan among it."""
    from ...symbolic import grammar, ladder

    value = middle(target.parameter)
    x = variables_at(target, SEARCH_AXIS_POINTS, value)
    y = f(*x, value)
    loss = _loss(target)
    plan = budget.plan("templates", len(x), y.size, max_complexity, grammar.TEN, loss)
    candidates, rungs, _ = ladder.run(np.stack(x), y, max_complexity, grammar.TEN, None, loss, plan=plan,
                                      log=lambda s: log("templates: " + s))
    symbols = target.symbols()[:len(target.variables)]
    chosen = sorted((c for c in candidates if 1 <= grammar.constants(c[0]) <= MAX_CONSTANTS and np.isfinite(c[2])),
                    key=lambda c: c[2])[:SEARCH_TEMPLATES]
    out = []
    for i, (tree, c, _, _, engine, _) in enumerate(chosen):
        k = constant_symbols(grammar.constants(tree))
        out.append(Template(f"grammar_{i + 1}", "grammar", grammar.substitute(tree, k, symbols, sympy_functions()),
                            len(k), f"grammar ({engine}): {grammar.show(tree, [s.name for s in symbols])}",
                            start=np.asarray(c, dtype=float)))
    return out, dict(rungs=[r.row() for r in rungs], points=int(y.size), loss=loss, **budget.record("templates", plan))


def sympy_functions():
    """The grammar's functions as sympy's (`symbolic.grammar.substitute` into sympy)."""
    import sympy as sp

    return {"exp": sp.exp, "log": sp.log, "sqrt": sp.sqrt, "sin": sp.sin, "cos": sp.cos, "abs": sp.Abs}


def _loss(target) -> str:
    return "max-relative" if target.metric == "rel" and target.floor == 0 else "max"
