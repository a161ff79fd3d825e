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


def derive(target=None, **options):
    """`pipeline derive` in Python: the cheapest accurate forms of a function a shader approximates,
    ranked by compiled cycles per GPU architecture (`pipeline.approximate.api.derive`, which says the
    options: expr, var, gpu, metric, floor, seconds, max_cycles, max_complexity, log). Returns a
    `Derivation`: its `front` (rows), `rows`, `results`, `glsl(name)`, `hlsl(name)`, `twin(name)`,
    `plot(path)`, `write(folder)` and `dataframe()` (with pandas)."""
    from .approximate.api import derive as derive_forms

    return derive_forms(target, **options)
