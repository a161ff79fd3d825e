"""`pipeline derive`: the cheapest accurate forms of a function a shader approximates, ranked by
compiled cycles per GPU architecture (`engine`), for a registered target or the user's own
(`targets`); the families fitted by minimax (`families`, `minimax`), the error measured over the
whole domain (`measure`), the forms printed as GLSL, HLSL and Python (`forms`), the outputs
(`publish`)."""
