// Constants the library's GLSL files include (no function: no task of its own).
#define PI 3.14159265358979
#define HALF_PI 1.5707963267948966
