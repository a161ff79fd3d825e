"""JAX set up for the pipeline: float64, and a persistent cache of compiled XLA programs.

Every module that computes with JAX imports `jax` from here (or imports this module first), so
float64 is on before any array exists, whoever imported JAX first.
"""

import jax

jax.config.update("jax_enable_x64", True)


def use_compilation_cache(folder) -> None:
    """Keeps compiled XLA programs in `folder`, so a later run (a refit) skips their compilation."""
    jax.config.update("jax_compilation_cache_dir", str(folder))
    jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.0)
    jax.config.update("jax_persistent_cache_min_entry_size_bytes", 0)


class CompileCounter:
    """Counts XLA compilations (JAX's backend-compile events) from its creation on."""

    def __init__(self):
        self.count = 0
        jax.monitoring.register_event_duration_secs_listener(self._on_event)

    def _on_event(self, name, seconds, **kwargs):
        if name == "/jax/core/compile/backend_compile_duration":
            self.count += 1
