// Fast inverse trigonometry and friends in the style engines ship: the tests' library.
#include "constants.glsl"

// derive: x=0:1 exact=acos(x)
float acos_fast(float x) {
    return (-0.156583 * x + HALF_PI) * sqrt(1.0 - x);
}

// derive: x=0:1 exact=atan(x) max_error=2e-3
float atan_fast(float x) {
    return 0.25 * PI * x - x * (x - 1.0) * (0.2447 + 0.0663 * x);
}

// derive: x=0:1 exact=sin(1.5707963267948966*x) max_error=2e-3
float sin_quarter(float x) {
    float t = HALF_PI * x;
    return t * (1.0 - t * t * (0.16605 - 0.00761 * t * t));
}

// derive: x=0.01:1 metric=rel max_error=2e-3
float rsqrt_guarded(float x) {
    return inversesqrt(max(x, 1e-4));
}
