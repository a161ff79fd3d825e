"""Shader code in: the functions of a GLSL or HLSL file found (`definitions`), each compiled as the
compiler means it in a harness that holds the file unchanged, optimized, and its SPIR-V read back
into the pipeline's expression tree and transliterated into GLSL (`harness`, `spirv_reader`), or
refused with its reason; the reading executed beside the function on lavapipe to the last bit
(`round_trip`); the author's ranges and intent from the comment above each function or the command
line (`intent`)."""
