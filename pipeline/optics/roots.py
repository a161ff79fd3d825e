"""Bracketed scalar root finding with optimistix, safe under `jax.vmap`.

Solver failure is never turned into a silent NaN: every call returns a success flag, and the
stages raise `SolverError` naming the inputs where any flag is false.
"""

from __future__ import annotations

import dataclasses
import functools

import jax.numpy as jnp
import optimistix as optx

from .numerics import jax


class SolverError(RuntimeError):
    """A root find or fit that did not converge; the message names the inputs."""


@dataclasses.dataclass(frozen=True)
class SolverSettings:
    """Tolerances and iteration cap shared by every solve of a run (config section [solver])."""

    rtol: float
    atol: float
    max_steps: int

    @classmethod
    def from_config(cls, section: dict) -> SolverSettings:
        return cls(section["solver.rtol"], section["solver.atol"], section["solver.max_steps"])


@functools.lru_cache(maxsize=64)
def _oriented(fn):
    """The residual bisection sees for `fn`: one function object per `fn`, so that a call outside
    jit with the same `fn` and shapes reuses optimistix's traced and compiled root find (a new
    closure per call would trace and compile it again, about half a second each)."""
    def oriented(y, a):
        inner_args, lo, s, root_exists, half_atol = a
        # Bisection's guarantee is the bracket's width; it uses only the sign of the residual. The
        # residual passed on is sign * atol/2, so that optimistix's |f| < atol test always holds
        # and the width (atol + rtol |y|) alone decides convergence, whatever the residual's scale.
        return jnp.where(root_exists, half_atol * jnp.sign(s * fn(y, inner_args)), y - lo)
    return oriented


def _arrays(tree):
    """`tree` with its Python floats as arrays: optimistix's root find treats a Python number as a
    static value and compiles again for each (an eager call per n would compile once per n)."""
    return jax.tree_util.tree_map(lambda a: jnp.asarray(a, dtype=jnp.float64) if isinstance(a, float) else a, tree)


def bracketed_root(fn, lower, upper, args, settings: SolverSettings):
    """Root of `fn(y, args)` in [lower, upper], by bisection.

    Returns `(root, has_root, ok)`. Where `fn` has no sign change on the bracket there is no root
    to find: `has_root` is False and `root` is `lower` (callers evaluate the endpoints anyway).
    `ok` is False only where the solver failed on a bracket that did contain a root.
    """
    lower, upper, args = _arrays((lower, upper, args))
    f_lo = fn(lower, args)
    f_hi = fn(upper, args)
    has_root = (f_lo <= 0.0) != (f_hi <= 0.0)
    # Orient the function so that it is negative at `lower`; with no root, solve y - lower = 0.
    sign = jnp.where(f_hi > 0.0, 1.0, -1.0)
    solver = optx.Bisection(rtol=settings.rtol, atol=settings.atol, flip=False)
    sol = optx.root_find(_oriented(fn), solver, 0.5 * (lower + upper), args=(args, lower, sign, has_root, 0.5 * settings.atol),
                         options=dict(lower=lower, upper=upper), max_steps=settings.max_steps,
                         throw=False)
    ok = sol.result == optx.RESULTS.successful
    return sol.value, has_root, ok | ~has_root
