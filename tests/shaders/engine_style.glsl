// Functions in the style engines ship, for the tests of `pipeline.shaders` (not a shader of its own).
#ifndef ENGINE_STYLE_GLSL
#define ENGINE_STYLE_GLSL
#include "engine_constants.glsl"

float pow5(float x) {
    float x2 = x * x;
    return x2 * x2 * x;
}

// derive: VoH=0:1 role=fresnel
float F_Schlick(float VoH) {
    return pow(1.0 - VoH, 5.0);
}

float F_Schlick_pow5(float VoH) {
    return pow5(1.0 - VoH);
}

// derive: NoV=1e-4:1 NoL=1e-4:1 roughness=0.045:1 parameter=roughness metric=rel max_error=0.25
float V_SmithGGXCorrelated(float NoV, float NoL, float roughness) {
    float a2 = roughness * roughness;
    float GGXV = NoL * sqrt(NoV * NoV * (1.0 - a2) + a2);
    float GGXL = NoV * sqrt(NoL * NoL * (1.0 - a2) + a2);
    return 0.5 / (GGXV + GGXL);
}

float srgb_decode(float c) {
    return c <= 0.04045 ? c / 12.92 : pow((c + 0.055) / 1.055, 2.4);
}

float srgb_encode(float c) {
    if (c < 0.0031308) {
        return 12.92 * c;
    }
    return 1.055 * pow(c, 1.0 / 2.4) - 0.055;
}

// derive: x=0:1 exact=acos(x)
float acos_fast(float x) {
    return (-0.156583 * x + HALF_PI) * sqrt(1.0 - x);
}

float saturate_(float x) { return clamp(x, 0.0, 1.0); }
float saturate_(float x, float y) { return clamp(x * y, 0.0, 1.0); }

vec3 F_Schlick3(vec3 f0, float VoH) {
    return f0 + (vec3(1.0) - f0) * pow(1.0 - VoH, 5.0);
}

vec3 swizzled(vec3 c) {
    return c.zyx * vec3(1.0, 2.0, 3.0);
}

float sum_loop(float x) {
    float s = 0.0;
    for (int i = 0; i < int(x * 10.0); i++) { s += x; }
    return s;
}

void write_out(float x, out float y) { y = 2.0 * x; }

float four(float a, float b, float c, float d) { return a * b + c * d; }

#endif
