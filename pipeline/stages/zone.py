"""Epicenter zone: {x : cos(x)^n >= L}. The paper never defines L; by default it is calibrated so
that the maximum relative error of f_2 in the zone equals one reported figure (P9, 7.924 %).
"""

import jax
import jax.numpy as jnp
import numpy as np

from ..error_measures import relative_error_u, zone_u
from ..lobes import k_2
from ..roots import SolverError, SolverSettings, bracketed_root
from .common import RANGE_KEYS, n_range

READS = RANGE_KEYS + ("zone.level", "zone.calibration_target", "solver.*")
UPSTREAM = ()


def f2_max_relative_error(level, n):
    """max over n of |f_2 / f_b - 1| at the zone edge (f_2's only extremum in the zone: its
    stationary point is u* = 0)."""
    r = jax.vmap(lambda n_: relative_error_u(zone_u(n_, level), n_, k_2(n_)))(n)
    return jnp.max(jnp.abs(r))


def run(config, upstream):
    n = n_range(config)
    settings = SolverSettings.from_config(config)
    target = config["zone.calibration_target"]
    if config["zone.level"] == "calibrate":
        def residual(level, args):
            return f2_max_relative_error(level, n) - args
        lo, hi = 1e-6, 1.0 - 1e-9
        level, has_root, ok = jax.jit(lambda t: bracketed_root(residual, lo, hi, t, settings))(target)
        if not bool(has_root):
            raise SolverError(f"zone calibration: no level L in ({lo}, {hi}) gives max d of f_2 = "
                              f"{target} for n in [{config['derivation.n_min']}, "
                              f"{config['derivation.n_max']}]; set zone.level directly")
        if not bool(ok):
            raise SolverError(f"zone calibration: bisection on L did not converge for target {target}")
        level = float(level)
        calibrated = True
    else:
        level = float(config["zone.level"])
        calibrated = False
    d_f2 = float(f2_max_relative_error(level, n))
    r = np.abs(np.asarray(jax.vmap(lambda n_: relative_error_u(zone_u(n_, level), n_, k_2(n_)))(n)))
    return dict(level=level, calibrated=calibrated, d_f2_at_level=d_f2,
                n_at_max=float(np.asarray(n)[np.argmax(r)]))
