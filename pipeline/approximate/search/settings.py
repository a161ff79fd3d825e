"""The settings the search of several variables and a parameter shares: its templates, the formulas'
polish and pruning, the pixel search's share of the budget, the constants a shader takes."""

from ...isa.shaders import FORM_CONSTANTS

EXCHANGES = 2               # the box's worst point joins the polish's points, and it polishes again
PRUNE = 1e-9                # a formula's coefficient below this share of the largest is dropped, where no worse
SEARCH_TEMPLATES = 8        # grammar forms (the ladder's front) taken as templates, the most accurate
PIXEL_SHARE = 0.5           # of the budget: the pixel search (the rest, the templates' search)
MAX_CONSTANTS = 8           # constants of a template (push constants of a material form)
MAX_FORMULA_COMPLEXITY = 9  # of a constant's correction found by the symbolic regression
PUSH_CONSTANTS = 2 * MAX_CONSTANTS  # the shaders' push constants c0, c1, ... (a pair's two forms), and F0
assert PUSH_CONSTANTS <= FORM_CONSTANTS, "isa.shaders.form_shader's push constants hold a pair's"
