"""The engines of `derive`, one per shape of target (`targets.Target.shape`): a function of one
variable (`one_variable`), of several variables and a material parameter (`several_variables`), a
pair of outputs computed together (`pairs`); the options they share (`options`). `derive` hands a
checked target to its engine."""

from ..targets import DeriveError, ONE_VARIABLE, PAIR, Target
from .options import available_architectures, checked_options, DEFAULT_SECONDS, MAX_COMPLEXITY  # noqa: F401


def derive(target: Target, gpu, budget, max_cycles, max_complexity: int, formula_complexity: int = 0,
           precision: str | None = None, log=print, certify: bool = False, contract: str = "allowed") -> dict:
    """The results of the engine that derives a checked `target`'s shape (`Target.shape`), every form
    costed and executed in `precision` (default the target's). Raises DeriveError for an option the
    shape does not take. `certify`: every front member's error as executed proven over the whole
    domain (one variable: every input, `one_variable.certified`; several: interval branch and bound,
    `several_variables._certified`). `contract` "never": every form costed and written `precise`."""
    from . import one_variable, pairs, several_variables

    precision = precision or target.precision
    certify = certify or target.certify
    if contract not in ("allowed", "never"):
        raise DeriveError(f"--contract {contract!r}: give allowed or never")
    if contract == "never" and target.shape == PAIR:
        raise DeriveError(f"{target.name}: --contract never: a pair of outputs is costed as written only")
    if certify and (target.shape == PAIR or target.table is not None):
        raise DeriveError(f"{target.name}: --certify proves errors against a target's expression; "
                          + ("a pair of outputs" if target.shape == PAIR else "a table") + " is not certified")
    if target.shape == PAIR:
        if precision != "fp32":
            raise DeriveError(f"{target.name}: --precision {precision}: a pair of outputs is executed and costed in "
                              "float32 only")
        return pairs.derive_pair(target, gpu, budget, max_cycles, max_complexity, log=log,
                                 formula_complexity=formula_complexity)
    if target.shape == ONE_VARIABLE:
        if formula_complexity:
            raise DeriveError(f"{target.name} has no parameter: --formula-complexity applies to targets with one")
        return one_variable.derive(target, gpu, budget, max_cycles, max_complexity, log=log, precision=precision,
                                   certify=certify, contract=contract)
    return several_variables.derive(target, gpu, budget, max_cycles, max_complexity, log=log,
                                    formula_complexity=formula_complexity, precision=precision, certify=certify,
                                    contract=contract)
