"""Reproduction of the modified cosine-quadratic specular lobe (Zavalniuk, Romanyuk, Kotlyk 2025).

The derivation runs in stages that follow the paper; `pipeline.engine.graph` declares them. Importing the
package imports no numerical library, so that `pipeline keys`, `pipeline graph` and config errors
answer at once; `pipeline.optics.numerics` switches JAX to float64 and is imported by every module that
computes with JAX.
"""

import os

# float64 must be on before any JAX array exists: an array made earlier stays float32. The
# variable is read when JAX is first imported; `pipeline.optics.numerics` also sets the flag directly.
os.environ.setdefault("JAX_ENABLE_X64", "1")
# The derivation runs on the CPU however it is started (a CUDA jaxlib would otherwise take a GPU,
# and its last bits differ); JAX_PLATFORMS set by the user is kept.
os.environ.setdefault("JAX_PLATFORMS", "cpu")

# The outside tools are found by the package itself, before any library that needs them loads:
# DRJIT_LIBLLVM_PATH for Dr.Jit, unless the user set it (a glob of the library folders, nothing loaded).
from .engine import toolchains  # noqa: E402

toolchains.prepare()

from .engine.config import Config as Config, ConfigError as ConfigError, load_config as load_config  # noqa: E402


def derive(target=None, *, shader=None, function=None, **options):
    """`pipeline derive` in Python: the cheapest accurate forms of a function a shader approximates,
    ranked by compiled cycles per GPU architecture (`pipeline.approximate.api.derive`, which says the
    options: expr, var, gpu, metric, floor, seconds, max_cycles, max_complexity, log). Returns a
    `Derivation`: its `front` (rows), `rows`, `results`, `glsl(name)`, `hlsl(name)`, `twin(name)`,
    `plot(path)`, `write(folder)` and `dataframe()` (with pandas). With `shader` (a GLSL or HLSL
    file's path; `function`, the functions to derive), every function of the file derived
    (`pipeline.approximate.api.derive_shader`, which says its options): a `ShaderDerivation`, its
    `rows` (functions.csv's), `patch` and `write(folder)`."""
    from .approximate.api import derive as derive_forms, derive_shader

    if shader is not None:
        if target is not None:
            raise ValueError("derive: give a target or shader=, not both")
        return derive_shader(shader, function, **options)
    if function is not None:
        raise ValueError("derive: function= goes with shader=")
    return derive_forms(target, **options)


def _toml(value) -> str:
    """A Python value as TOML writes it (an override's value)."""
    import json

    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_toml(v) for v in value) + "]"
    return repr(value)


def run(config="configs/paper.toml", set=(), only=None, log=print, write_outputs: bool = False,
        cache_dir=None) -> dict:
    """A run of the derivation from Python: `config` a TOML file's path (relative paths from the
    project's folder where not found here) or a `Config`, `set` overrides as `pipeline refit --set`
    takes them ("key=value" strings, or a dict of key: value), `only` stage names (those and what
    they read). Returns the run's results as `results.json` holds them; with `write_outputs`, the
    run's folder `outputs/<run.name>/` is written too. Raises ConfigError for a bad config or
    override, `optics.roots.SolverError` where a solver does not converge."""
    from pathlib import Path

    from .engine import paths
    from .engine.config import Config as _Config
    from .publish import results as results_mod
    from .runner import run_derivation

    if isinstance(set, dict):
        set = tuple(f"{key}={_toml(value)}" for key, value in set.items())
    elif isinstance(set, str):
        set = (set,)
    if isinstance(config, _Config):
        chosen = load_config(config.source, tuple(set), name=config.name) if set else config
    else:
        path = Path(config)
        if not path.exists() and (paths.ROOT / path).exists():
            path = paths.ROOT / path
        chosen = load_config(path, tuple(set))
    if only is not None:
        only = (only,) if isinstance(only, str) else tuple(only)
    outcome = run_derivation(chosen, Path(cache_dir) if cache_dir is not None else paths.CACHE, log=log,
                             write_outputs=write_outputs, only=only)
    return results_mod.document(chosen, outcome.keys, outcome.results, outcome.checks)
