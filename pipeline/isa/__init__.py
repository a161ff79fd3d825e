"""GPU machine code per vendor: one registry of architectures (`architectures`), the shaders to
measure written once in GLSL (`shaders`), one front end that reads a shader's optimized SPIR-V as
scalar operations (`lowering`), one back end module per vendor's compiler (`radv`: Mesa's RADV and
ACO for AMD; `nvidia`: ptxas and SASS; `intel`: ocloc and IGA; `adreno` and `mali`: Mesa's
freedreno and panfrost on their drm-shim null devices under qemu-user, through `gles`), each with
its instruction classes, its cost model and its words for the report, and the rows every consumer
reads (`machine_code`)."""
