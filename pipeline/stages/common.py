"""Helpers shared by the stages: the exponent range and the vectorized error measures."""


from ..optics.numerics import jax
import jax.numpy as jnp
import numpy as np

from ..optics.error_measures import absolute_parts, relative_parts, rms_relative
from ..optics.roots import SolverError, SolverSettings


def n_range(config) -> np.ndarray:
    """Every integer exponent n in [n_min, n_max], as float64."""
    return np.arange(config["derivation.n_min"], config["derivation.n_max"] + 1, dtype=np.float64)


def lobe_measures(n, k, level, settings: SolverSettings):
    """Per-n error measures of the quadratic lobe with coefficients k (arrays over n).

    Returns a dict of arrays over n: d (relative, epicenter zone) and D (absolute, [0, pi/2]) with
    their signed parts and the u = 1 - cos x where each is attained, the relative RMS error, and
    the solver success flags.
    """
    d_over, d_under, d_u_over, d_u_under = jax.vmap(relative_parts, (0, 0, None))(n, k, level)
    D_over, D_under, D_u_over, D_u_under, ok = jax.vmap(lambda n_, k_: absolute_parts(n_, k_, settings))(n, k)
    return dict(d_over=d_over, d_under=d_under, d=jnp.maximum(d_over, d_under),
                d_u=jnp.where(d_over >= d_under, d_u_over, d_u_under),
                D_over=D_over, D_under=D_under, D=jnp.maximum(D_over, D_under),
                D_u=jnp.where(D_over >= D_under, D_u_over, D_u_under),
                rms=jax.vmap(rms_relative)(n, k), ok=ok)


measures = jax.jit(lobe_measures, static_argnames="settings")


def require_converged(ok, what: str, **inputs) -> None:
    """Raises `SolverError` naming the first inputs at which a solve failed."""
    ok = np.asarray(ok)
    if ok.all():
        return
    where = np.argwhere(~ok)[0]
    named = ", ".join(f"{name}={np.asarray(v)[tuple(where[:np.ndim(v)])]:.6g}" for name, v in inputs.items())
    raise SolverError(f"{what}: the root finder did not converge at {named} "
                      f"({int((~ok).sum())} failures); raise solver.max_steps or loosen solver.rtol/atol")


def runs_of(mask, n):
    """Contiguous [first, last] n where mask holds."""
    out, start = [], None
    for i, m in enumerate(mask):
        if m and start is None:
            start = i
        if start is not None and (not m or i == len(mask) - 1):
            end = i if m else i - 1
            out.append([float(n[start]), float(n[end])])
            start = None
    return out
