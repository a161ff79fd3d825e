"""The targets' room: the one kind of target (`target.Target`: variables, a parameter, an expression
or a table, one output or a pair; its `shape` says which engine derives it), the box it is measured
on (`box`), the registered targets (`registered`), and every source read into one and checked once
(`reading.read`)."""

from .box import (AXIS_POINTS, axes_mesh, chebyshev_points, is_symmetric, lower_end, MEASURE_GRID, mesh,  # noqa: F401
                  middle, PARAMETER_VALUES, parameter_values, place, SEARCH_AXIS_POINTS, SYMMETRY, unit_box,
                  variables_at, weight_of)
from .reading import (check, from_csv, from_expression, from_file, named, parse_domain, read, read_anchors,  # noqa: F401
                      read_floor, read_toml, with_range)
from .registered import (COS_N_LEVEL, cos_n_target, ENV_BRDF_ANCHORS, ENV_BRDF_BOX, ENV_BRDF_POINTS,  # noqa: F401
                         env_brdf_table, env_brdf_targets, one_variable_targets, pairs, paper_lobes, registry,
                         several_variable_targets)
from .target import (Anchor, Axis, DeriveError, MAX_AXES, METRICS, numpy_function, ONE_VARIABLE, PAIR,  # noqa: F401
                     PAIR_PARTS, pair, parse, PRECISIONS, SEVERAL_VARIABLES, Table, Target)
