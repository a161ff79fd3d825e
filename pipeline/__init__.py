"""Reproduction of the modified cosine-quadratic specular lobe (Zavalniuk, Romanyuk, Kotlyk 2025).

The derivation runs in stages that follow the paper; see `pipeline.run` for their order.
"""

import os

# float64 must be on before any JAX array exists: an array made earlier stays float32.
os.environ.setdefault("JAX_ENABLE_X64", "1")
import jax  # noqa: E402

jax.config.update("jax_enable_x64", True)

from .config import Config as Config, ConfigError as ConfigError, load_config as load_config  # noqa: E402
from .run import run_derivation as run_derivation  # noqa: E402
