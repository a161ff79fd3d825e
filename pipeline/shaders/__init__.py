"""Shader code in: the functions of a GLSL or HLSL file found (`definitions`), each compiled as the
compiler means it in a harness that holds the file unchanged, optimized, and its SPIR-V read back
into the pipeline's expression tree (`harness`, `spirv_reader`), or refused with its reason."""
