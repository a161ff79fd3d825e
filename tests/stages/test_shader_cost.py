"""The rendered comparison against a direct numpy computation, and the exported shader against the
pipeline's own lobe (through its Python twin) and, where glslangValidator is installed, a compiler.
"""


import pytest




def test_shader_cost_table(paper_run):
    cost = paper_run["shader_cost"]
    if not cost["available"]:
        pytest.skip(cost["tools"])
    rows = {row["lobe"]: row for row in cost["lobes"]}
    assert rows["f_b"]["ops"] == {"Pow": 1}
    assert rows["f_Q2"]["transcendental"] == 0 and rows["f_Q2"]["division"] == 0
    # What a shader author wrote, kept by the optimizer: k t, 1 - k, their sum, the max and the square.
    assert rows["f_Q2"]["ops"] == {"FMax": 1, "OpFAdd": 1, "OpFMul": 2, "OpFSub": 1}
    assert rows["Schlick"]["division"] == 1 and rows["Schlick"]["transcendental"] == 0
    assert rows["SG"]["ops"]["Exp"] == 1


