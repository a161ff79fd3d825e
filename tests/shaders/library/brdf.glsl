// Microfacet terms of several variables: the tests' library (`pipeline derive --shader`).
#include "constants.glsl"

// derive: NoV=1e-4:1 NoL=1e-4:1 roughness=0.045:1 parameter=roughness metric=rel max_error=0.25
float V_SmithGGXCorrelated(float NoV, float NoL, float roughness) {
    float a2 = roughness * roughness;
    float GGXV = NoL * sqrt(NoV * NoV * (1.0 - a2) + a2);
    float GGXL = NoV * sqrt(NoL * NoL * (1.0 - a2) + a2);
    return 0.5 / (GGXV + GGXL);
}

// derive: NoH=0:1 roughness=0.045:1 parameter=roughness metric=rel max_error=0.05
float D_GGX(float NoH, float roughness) {
    float a2 = roughness * roughness * roughness * roughness;
    float d = NoH * NoH * (a2 - 1.0) + 1.0;
    return a2 / (PI * d * d);
}
