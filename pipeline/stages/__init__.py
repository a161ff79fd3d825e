"""The derivation's stages, in the paper's order.

Each stage module declares the config keys it reads (`READS`), the stages whose results it reads
(`UPSTREAM`), and a function `run(config, upstream) -> dict` returning plain numbers, strings,
lists and numpy arrays. The cache key of a stage covers exactly these inputs and its code.
"""

from . import (
    accuracy,
    energy_dataset,
    hemispherical,
    linear_coefficient,
    q_scan,
    sparse_regression,
    zone,
)

STAGES = (zone, q_scan, linear_coefficient, accuracy, energy_dataset, sparse_regression,
          hemispherical)


def stage_name(module) -> str:
    """A stage's name: its module's last component, e.g. `q_scan`."""
    return module.__name__.rsplit(".", 1)[1]
