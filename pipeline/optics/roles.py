"""The roles a shading term plays in a real-time engine's shading: where a form of it enters
(`material_balls` renders each), declared by a derive target's registry entry or its file's `role`."""

from __future__ import annotations

import dataclasses


@dataclasses.dataclass(frozen=True)
class Role:
    """Where a shading term enters the shading: its inputs (the target's variables, in order), its
    parameter (None: none) and what a form replaces."""

    name: str
    inputs: tuple[str, ...]
    parameter: str | None
    what: str


ROLES = {r.name: r for r in (
    Role("fresnel", ("VoH",), None, "the Fresnel weight f(VoH) of each light's GGX specular: F = F0 + (1 - F0) f(VoH)"),
    Role("visibility", ("NoV", "NoL"), "alpha", "the visibility V(NoV, NoL; alpha) = G2 / (4 NoV NoL) of each light's "
                                                "GGX specular, alpha = roughness^2"),
    Role("env_brdf", ("NoV",), "roughness", "the split-sum environment BRDF F0 A + B(NoV; roughness) of the ambient "
                                            "specular"),
    Role("lobe", ("NoH",), "n", "the specular lobe: each light's D = (n + 2) / (2 pi) max(f(NoH; n), 0), the Phong "
                                "exponent n = 2 / alpha^2 - 2 of the sphere's roughness (Walter et al. 2007)"),
)}


def role_fault(name: str, variables: int, parameter: bool) -> str | None:
    """Why a declared role does not fit a target of `variables` variables and (`parameter`) a
    parameter; None where it fits or none is declared."""
    if not name:
        return None
    role = ROLES.get(name)
    if role is None:
        return f"role {name!r}: give one of {', '.join(ROLES)}"
    if len(role.inputs) != variables or (role.parameter is not None) != parameter:
        return (f"role {name!r} takes the variables {', '.join(role.inputs)}"
                + (f" and the parameter {role.parameter}" if role.parameter else " and no parameter")
                + f"; the target has {variables} variable(s) and " + ("a parameter" if parameter else "no parameter"))
    return None
