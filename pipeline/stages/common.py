"""Helpers shared by the stages: the exponent range, the vectorized error measures of a lobe of the
family (k (t - 1) + 1)^m, and the regression sample and its alternatives."""


from ..optics.numerics import jax
import jax.numpy as jnp
import numpy as np

from ..optics.error_measures import absolute_parts, relative_parts, rms_relative
from ..mitsuba import bsdf
from ..engine.exponents import n_range  # noqa: F401  (the stages' one n range)
from ..optics.roots import SolverError, SolverSettings


def lobe_measures(n, k, level, settings: SolverSettings, power: int = 2):
    """Per-n error measures of the lobe (k (t - 1) + 1)^power with coefficients k (arrays over n);
    the power may be traced (`measures` traces it: one program for every power).

    Returns a dict of arrays over n: d (relative, epicenter zone) and D (absolute, [0, pi/2]) with
    their signed parts and the u = 1 - cos x where each is attained, the relative RMS error, and
    the solver success flags.
    """
    d_over, d_under, d_u_over, d_u_under = jax.vmap(lambda n_, k_: relative_parts(n_, k_, level, power))(n, k)
    D_over, D_under, D_u_over, D_u_under, ok = jax.vmap(lambda n_, k_: absolute_parts(n_, k_, settings, power))(n, k)
    return dict(d_over=d_over, d_under=d_under, d=jnp.maximum(d_over, d_under),
                d_u=jnp.where(d_over >= d_under, d_u_over, d_u_under),
                D_over=D_over, D_under=D_under, D=jnp.maximum(D_over, D_under),
                D_u=jnp.where(D_over >= D_under, D_u_over, D_u_under),
                rms=jax.vmap(lambda n_, k_: rms_relative(n_, k_, power))(n, k), ok=ok)


_measures = jax.jit(lobe_measures, static_argnames="settings")


def measures(n, k, level, settings: SolverSettings, power=2):
    """`lobe_measures`, jitted, with the power traced (as a float)."""
    return _measures(n, k, level, settings, jnp.asarray(float(power)))


def require_converged(ok, what: str, **inputs) -> None:
    """Raises `SolverError` naming the first inputs at which a solve failed."""
    ok = np.asarray(ok)
    if ok.all():
        return
    where = np.argwhere(~ok)[0]
    named = ", ".join(f"{name}={np.asarray(v)[tuple(where[:np.ndim(v)])]:.6g}" for name, v in inputs.items())
    raise SolverError(f"{what}: the root finder did not converge at {named} "
                      f"({int((~ok).sum())} failures); raise solver.max_steps or loosen solver.rtol/atol")


def mitsuba_settings(config, register, log=None) -> dict:
    """The settings the Mitsuba stages share: the spheres' exponents, the frame, the seed, the
    variant (chosen by `register`, which registers the stage's plugins) and its samples per pixel,
    the quadrature nodes of the normalizations. Where "auto" fell back to the scalar variant
    although an LLVM was found, `log` gets one line saying so."""
    wanted = config["mitsuba.variant"]
    variant = register(None if wanted == "auto" else wanted)
    warning = bsdf.fallback_warning(variant) if wanted == "auto" else ""
    if warning and log is not None:
        log(warning)
    fast = variant == bsdf.FAST_VARIANT
    return dict(exponents=[float(n) for n in config["mitsuba.exponents"]], width=config["mitsuba.width"],
                height=config["mitsuba.height"], seed=config["mitsuba.seed"], variant=variant,
                spp=config["mitsuba.spp"] if fast else config["mitsuba.fallback_spp"],
                nodes=config["albedo.quadrature_nodes"])


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


def family_errors(n, k, level, levels, rtol, atol, max_steps, power=2):
    """Measures of the lobe (k (t - 1) + 1)^power with coefficients k over n: curves of d, D and
    rms, where D is attained (u), and max d at each zone level of `levels`."""
    settings = SolverSettings(rtol, atol, max_steps)
    m = measures(n, k, level, settings, power)
    require_converged(m["ok"], "max D", n=n)
    return dict(d=np.asarray(m["d"]), D=np.asarray(m["D"]), rms=np.asarray(m["rms"]), D_u=np.asarray(m["D_u"]),
                zone_d=np.array([float(np.max(measures(n, k, L, settings, power)["d"])) for L in levels]))


def summary(name, n, m) -> dict:
    """The stage fields of one lobe's measures: maxima, curves and where the maxima are attained."""
    d, D = m["d"], m["D"]
    return {f"d_{name}_curve": d, f"D_{name}_curve": D, f"d_{name}": float(d.max()), f"D_{name}": float(D.max()),
            f"rms_{name}": float(m["rms"].max()), f"d_{name}_n_at_max": float(n[d.argmax()]),
            f"D_{name}_n_at_max": float(n[D.argmax()]),
            f"D_{name}_x_at_max": float(np.arccos(1.0 - m["D_u"][D.argmax()])), f"zone_d_{name}": m["zone_d"]}


def sample_exponents(config) -> np.ndarray:
    """The regression sample: n_min..consecutive_to, then spread_count evenly spaced n up to n_max."""
    head = np.arange(config["derivation.n_min"], config["sample.consecutive_to"] + 1)
    tail = np.round(np.linspace(config["sample.spread_from"], config["derivation.n_max"],
                                config["sample.spread_count"]))
    sample = np.unique(np.concatenate([head, tail]).astype(np.int64))
    if len(sample) != len(head) + len(tail):
        raise ValueError(f"sample.spread_count = {config['sample.spread_count']} makes repeated n "
                         f"between {config['sample.spread_from']} and {config['derivation.n_max']}")
    return sample


def alternative_samples(config, n_s, y_s, y_all) -> dict:
    """Other samples of the kind the paper's could be, each as (n, y) with y rounded as configured:
    the configured one, it unrounded, every n, other splits between consecutive and spread n
    (same size), and log-spaced n. Used to say how fitted constants depend on the unknown sample."""
    n_min, n_max = config["derivation.n_min"], config["derivation.n_max"]
    n_all = n_range(config)
    decimals = config["sample.y_decimals"]

    def at(ns, rounded=True):
        y = y_all[np.asarray(ns, dtype=np.int64) - n_min]
        return np.round(y, decimals) if rounded and decimals >= 0 else y

    alternatives = {"configured sample": (n_s, y_s),
                    "configured sample, y unrounded": (n_s, at(n_s, rounded=False)),
                    "every n in range": (n_all, y_all)}
    size = len(n_s)
    for head_to in (11, 21, 41):
        if n_min <= head_to < n_max and size - (head_to - n_min + 1) >= 2:
            cfg = dict(config) | {"sample.consecutive_to": head_to, "sample.spread_from": head_to + 1,
                                  "sample.spread_count": size - (head_to - n_min + 1)}
            ns = sample_exponents(cfg).astype(np.float64)
            alternatives[f"n_min..{head_to}, then {size - (head_to - n_min + 1)} evenly spaced"] = (ns, at(ns))
    geo = np.unique(np.round(np.geomspace(n_min, n_max, size)))
    alternatives[f"{len(geo)} log-spaced n"] = (geo, at(geo))
    return alternatives


def same_kind(label: str, size: int, configured_size: int) -> bool:
    """Whether an alternative sample is of the configured sample's kind: its size, y rounded."""
    return size == configured_size and "unrounded" not in label
