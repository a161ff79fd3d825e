"""Epicenter zone: {x : cos(x)^n >= L}. The paper never defines L; by default it is calibrated so
that the maximum relative error of f_2 in the zone equals one reported figure (P9, 7.924 %).
"""

import functools

from ..optics.numerics import jax
import jax.numpy as jnp

from ..optics.error_measures import relative_error_u, zone_u
from ..optics.lobes import k_2
from ..optics.roots import SolverError, SolverSettings, bracketed_root
from .common import n_range

LOWEST, HIGHEST = 1e-6, 1.0 - 1e-9


def f2_max_relative_error(level, n):
    """max over n of |f_2 / f_b - 1| at the zone edge (f_2's only extremum in the zone: its
    stationary point is u* = 0)."""
    r = jax.vmap(lambda n_: relative_error_u(zone_u(n_, level), n_, k_2(n_)))(n)
    return jnp.max(jnp.abs(r))


def _residual(level, args):
    n, target = args
    return f2_max_relative_error(level, n) - target


@functools.partial(jax.jit, static_argnames="settings")
def calibrate(n, target, settings: SolverSettings):
    """(level, has_root, ok): the L in (LOWEST, HIGHEST) where max d of f_2 over n equals target."""
    return bracketed_root(_residual, LOWEST, HIGHEST, (n, target), settings)


def run(config, inputs, memo):
    if config["zone.level"] != "calibrate":
        return dict(level=float(config["zone.level"]), calibrated=False)
    n = n_range(config)
    target = config["zone.calibration_target"]
    level, has_root, ok = calibrate(n, target, SolverSettings.from_config(config))
    if not bool(has_root):
        raise SolverError(f"zone calibration: no level L in ({LOWEST}, {HIGHEST}) gives max d of f_2 = "
                          f"{target} for n in [{config['derivation.n_min']}, "
                          f"{config['derivation.n_max']}]; set zone.level directly")
    if not bool(ok):
        raise SolverError(f"zone calibration: bisection on L did not converge for target {target} "
                          f"(solver.max_steps = {config['solver.max_steps']})")
    return dict(level=float(level), calibrated=True)
