// Colour transforms in the style engines ship: the tests' library (`pipeline derive --shader`).
#include "constants.glsl"

// derive: c=0:1 max_error=2e-3
float srgb_decode(float c) {
    return c <= 0.04045 ? c / 12.92 : pow((c + 0.055) / 1.055, 2.4);
}

// derive: x=0:4 calls=3
float reinhard(float x) {
    return x / (1.0 + x);
}

// derive: x=0:4 max_error=2e-3
float aces_narkowicz(float x) {
    return (x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14);
}

// derive: x=0:1 max_error=2e-3
float gamma_22(float x) {
    return pow(x, 1.0 / 2.2);
}
