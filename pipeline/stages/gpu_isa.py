"""Cost in GPU machine code (beyond the paper): every lobe of the registry at the run's power, the
family at each power of `front.powers`, and each lobe times each of its normalizations with n per
pixel, compiled by Mesa's RADV driver (ACO back end) for RDNA3, RDNA2 and GCN5 on its null device
(`pipeline.optics.machine_code`): instructions by kind and ACO's cycle estimates, net of the
shader's fixed wrapper.

The shaders are compiled with the paper's constants as stand-ins (`CONSTANTS`): each constant is
one literal in the code, so the machine code does not depend on its value, and a refit that moves
Q or the line keeps this stage. Where the compiler cannot run (no Vulkan loader, no RADV, no
`vulkan` package), the stage says why and returns no rows.
"""

from ..optics import machine_code, registry

CONSTANTS = registry.Parameters(Q=0.64, slope=0.448, intercept=0.099, coef_scale=0.214, coef_offset=0.807)


def run(config, inputs, memo):
    p = CONSTANTS._replace(power=config["lobe.power"])
    powers = sorted(set(config["front.powers"]) | {config["lobe.power"]})
    try:
        found = machine_code.costs(p, powers)
    except machine_code.CompilerMissing as e:
        return dict(available=False, reason=str(e), devices={}, rows=[], pow_transcendental=-1,
                    family_transcendental_max=-1)
    rows = found["rows"]
    family = [r for r in rows if r["what"] == "family lobe"]
    pow_rows = [r for r in rows if r["what"] == "lobe" and r["lobe"] == registry.REFERENCE]
    return dict(available=True, reason="", devices=found["devices"], rows=rows,
                pow_transcendental=min(r["transcendental"] for r in pow_rows),
                family_transcendental_max=max(r["transcendental"] for r in family))
