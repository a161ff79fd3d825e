"""The derivation's stages, one module each, in the paper's order (`pipeline.engine.graph` declares them).

Each module has a function `run(config, inputs, memo) -> dict`: `config` holds the config keys the
stage declares, `inputs` its declared upstream fields (keyed `stage.field`), and `memo` caches a
function call on its arguments' values (`pipeline.engine.cache.Memo`). It returns exactly its declared
outputs: plain numbers, strings, lists and numpy arrays.
"""
