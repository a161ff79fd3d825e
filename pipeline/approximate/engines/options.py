"""The options every engine of `derive` shares, checked: the architectures (default every one whose
compiler runs here), the search's budget, the largest cycles and complexity."""

from __future__ import annotations

import math

from ..targets import DeriveError

DEFAULT_SECONDS = 60.0
MAX_COMPLEXITY = 12


def available_architectures() -> list[str]:
    """Every architecture whose compiler runs here."""
    from ...isa.architectures import ARCHITECTURES, CompilerMissing
    from ...isa.machine_code import backend

    out = []
    for name in ARCHITECTURES:
        try:
            backend(name).check()
        except (CompilerMissing, OSError, RuntimeError):
            continue
        out.append(name)
    return out


def checked_options(gpu, budget, max_cycles: float | None, max_complexity: int) -> list[str]:
    """The architectures `gpu` names (default every one whose compiler runs here), the other options
    (`budget`, a `symbolic.budgets.Budget`) checked. Raises DeriveError naming a bad one,
    CompilerMissing where no compiler runs."""
    seconds = budget.seconds
    from ...isa.architectures import ARCHITECTURES
    from ...isa.machine_code import CompilerMissing
    from ...symbolic import regress

    if budget.recorded is None and not (math.isfinite(seconds) and 5 <= seconds <= 3600):
        raise DeriveError(f"--seconds {seconds:g}: give a number in [5, 3600]")
    if max_cycles is not None and not (math.isfinite(max_cycles) and max_cycles > 0):
        raise DeriveError(f"--max-cycles {max_cycles:g}: give a number > 0")
    if not 1 <= max_complexity <= regress.MAX_COMPLEXITY:
        raise DeriveError(f"--max-complexity {max_complexity}: give an integer in [1, {regress.MAX_COMPLEXITY}]")
    if gpu is None:
        architectures = available_architectures()
        if not architectures:
            raise CompilerMissing("no GPU compiler runs here (make installs Mesa's RADV, NVIDIA's ptxas, Intel's ocloc)")
        return architectures
    unknown = [a for a in gpu if a not in ARCHITECTURES]
    if unknown or not gpu:
        raise DeriveError(f"--gpu {unknown[0] if unknown else ''!r}: give architectures among {', '.join(ARCHITECTURES)}")
    return list(dict.fromkeys(gpu))
