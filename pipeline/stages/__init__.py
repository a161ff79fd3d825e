"""The derivation's stages, in the paper's order.

Each stage module declares the config keys it reads (`READS`), the stages whose results it reads
(`UPSTREAM`), and a function `run(config, upstream) -> dict` returning plain numbers, strings,
lists and numpy arrays. The cache key of a stage covers exactly these inputs and its code.
"""

from . import (
    accuracy,
    directional_albedo,
    energy_dataset,
    exact_normalization,
    hemispherical,
    linear_coefficient,
    lobe_comparison,
    q_scan,
    render,
    sparse_regression,
    zone,
)

# The paper's derivation, then the checks it never made.
PAPER_STAGES = (zone, q_scan, linear_coefficient, accuracy, energy_dataset, sparse_regression, hemispherical)
BEYOND_STAGES = (exact_normalization, directional_albedo, lobe_comparison, render)
STAGES = PAPER_STAGES + BEYOND_STAGES


def stage_name(module) -> str:
    """A stage's name: its module's last component, e.g. `q_scan`."""
    return module.__name__.rsplit(".", 1)[1]
