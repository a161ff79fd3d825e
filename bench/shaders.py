"""`make bench`'s reading of a shader file, in a process of its own: every function of the tests'
engine-style file (13 functions) found, compiled in its harness, optimized, read back and, where it
is read, executed beside itself on lavapipe at 2^16 inputs of [0, 1] per argument
(`pipeline.shaders`). Prints the number of functions, read, checked, and the seconds."""

import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def main() -> None:
    from pipeline.shaders import definitions, harness, round_trip, spirv_reader

    path = ROOT / "tests" / "shaders" / "engine_style.glsl"
    start = time.perf_counter()
    language, found = definitions.read(path)
    options = harness.Options(language)
    text = harness.preprocessed(path, options)
    read = checked = 0
    for d in found:
        if harness.refusal(d) is not None:
            continue
        try:
            expression, code = spirv_reader.read_both(harness.disassembly(text, d, options, path),
                                                      [p.name for p in d.parameters])
        except spirv_reader.Refused:
            continue
        read += 1
        check = round_trip.round_trip(text, d, expression, code, [(0.0, 1.0)] * len(d.parameters), language)
        checked += check.checked and check.mismatch is None
    print(len(found), read, checked, time.perf_counter() - start)


if __name__ == "__main__":
    main()
