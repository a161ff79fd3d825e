"""GPU machine code per vendor: one front end (the shader's optimized SPIR-V read as scalar
operations, `lowering`) and one back end module per vendor's compiler (`nvidia`: ptxas and SASS),
each with its architectures, its listing's instruction classes and its cost model."""
