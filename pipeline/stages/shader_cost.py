"""Cost on a GPU (beyond the paper): each cheap lobe written in GLSL, compiled to SPIR-V and
optimized by spirv-opt, its instructions counted by kind (`pipeline.optics.spirv`), for every lobe of
the registry. If the
compilers are not installed, the stage says so instead of counting.
"""

from ..optics import registry, spirv


def run(config, inputs, memo):
    try:
        p = registry.Parameters(power=config["lobe.power"])
        return dict(available=True, tools=spirv.tool_versions(), lobes=spirv.lobe_costs(registry.LOBES.values(), p))
    except spirv.ToolMissing as e:
        return dict(available=False, tools=str(e), lobes=[])
