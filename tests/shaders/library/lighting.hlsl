// Lighting terms in the style engines ship: the tests' library (`pipeline derive --shader`).

// derive: VoH=0:1 role=fresnel calls=2
float F_Schlick(float VoH) {
    return 0.04 + 0.96 * pow(1.0 - VoH, 5.0);
}

// derive: x=0:1 max_error=2e-3
float distance_falloff(float x) {
    float x2 = x * x;
    float smooth_factor = saturate(1.0 - x2 * x2);
    return smooth_factor * smooth_factor;
}

// derive: NoL=-1:1
float wrap_diffuse(float NoL) {
    return saturate((NoL + 0.5) / 1.5);
}

// derive: x=0:1 max_error=2e-3
float fog_density(float x) {
    return 1.0 - exp(-3.0 * x * x);
}
