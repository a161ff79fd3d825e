"""A shader file's functions read as the compiler means them (`pipeline.shaders`): found by
tree-sitter's grammar (inside an include guard, overloads, the `// derive:` line above), compiled in
a harness that includes the file unchanged, optimized by spirv-opt and read back into sympy; each
expression against the function's own mathematics written apart in numpy; the refusals with their
reasons; the same function in GLSL and in HLSL the same expression."""

import dataclasses
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

from pipeline.shaders import definitions, harness
from pipeline.shaders.definitions import ShaderError

HERE = Path(__file__).parent
GLSL = HERE / "engine_style.glsl"
HLSL = HERE / "engine_style.hlsl"


def read_all(path: Path, options: harness.Options | None = None) -> dict:
    language, found = definitions.read(path)
    options = options or harness.Options(language)
    text = harness.preprocessed(path, options)
    return {(d.name, len(d.parameters)): harness.read_function(text, d, options, path) for d in found}


@pytest.fixture(scope="module")
def glsl():
    return read_all(GLSL)


def test_the_functions_of_a_file_are_found_with_their_lines_and_annotations():
    language, found = definitions.read(GLSL)
    assert language == "glsl" and definitions.language_of(HLSL) == "hlsl"
    assert [d.name for d in found] == ["pow5", "F_Schlick", "F_Schlick_pow5", "V_SmithGGXCorrelated", "srgb_decode",
                                       "srgb_encode", "acos_fast", "saturate_", "saturate_", "F_Schlick3", "swizzled",
                                       "sum_loop", "write_out", "four"]
    by_name = {d.name: d for d in found}
    lines = GLSL.read_text().splitlines()
    for d in found:         # (each definition's line is its signature's)
        assert lines[d.line - 1].startswith(d.signature.splitlines()[0])
    assert by_name["F_Schlick"].annotation == "VoH=0:1 role=fresnel"
    assert by_name["acos_fast"].annotation == "x=0:1 exact=acos(x)"
    assert by_name["pow5"].annotation is None
    assert by_name["write_out"].parameters[1] == definitions.Parameter("y", "float", ("out",))
    source = GLSL.read_bytes()
    for d in found:         # (the spans: the body is the braces' text, inside the definition's)
        assert source[d.body_start:d.body_start + 1] == b"{" and source[d.body_end - 1:d.body_end] == b"}"
        assert d.start < d.body_start < d.body_end == d.end


def _points(lo, hi, count=257):
    return np.linspace(lo, hi, count)


def test_each_function_reads_as_its_mathematics_written_apart(glsl):
    """The expression (float32 constants as the shader holds them) against the function's formula
    in numpy float64 with the source's decimal constants: within 1e-6 relative, the float32 rounding
    of a few constants (2^-24 each), away from a branch's threshold (which rounds too)."""
    def close(key, exact, *ranges):
        reading = glsl[key]
        assert reading.refused is None, reading.refused
        symbols = [sp.Symbol(p.name, real=True) for p in reading.definition.parameters]
        f = sp.lambdify(symbols, reading.expression, "numpy")
        grids = np.meshgrid(*(_points(*r, 17 if len(ranges) > 1 else 257) for r in ranges), indexing="ij")
        np.testing.assert_allclose(f(*grids), exact(*grids), rtol=1e-6)

    close(("pow5", 1), lambda x: x ** 5, (0, 2))
    close(("F_Schlick", 1), lambda v: (1 - v) ** 5, (0, 1))
    close(("F_Schlick_pow5", 1), lambda v: (1 - v) ** 5, (0, 1))

    def visibility(nov, nol, r):
        a2 = r * r
        return 0.5 / (nol * np.sqrt(nov * nov * (1 - a2) + a2) + nov * np.sqrt(nol * nol * (1 - a2) + a2))

    close(("V_SmithGGXCorrelated", 3), visibility, (1e-4, 1), (1e-4, 1), (0.045, 1))
    decode = lambda c: np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)    # noqa: E731
    close(("srgb_decode", 1), decode, (0.0, 0.04), )
    close(("srgb_decode", 1), decode, (0.041, 1.0))
    encode = lambda c: np.where(c < 0.0031308, 12.92 * c, 1.055 * c ** (1 / 2.4) - 0.055)  # noqa: E731
    close(("srgb_encode", 1), encode, (0.0, 0.0031))
    close(("srgb_encode", 1), encode, (0.0032, 1.0))
    close(("acos_fast", 1), lambda x: (-0.156583 * x + np.pi / 2) * np.sqrt(1 - x), (0, 1))
    close(("saturate_", 1), lambda x: np.clip(x, 0, 1), (-1, 2))
    close(("saturate_", 2), lambda x, y: np.clip(x * y, 0, 1), (-1, 2), (-1, 2))
    # a colour's Fresnel: every lane the same function of its own lane of f0, read once as it
    close(("F_Schlick3", 2), lambda f0, v: f0 + (1 - f0) * (1 - v) ** 5, (0, 1), (0, 1))
    assert glsl[("F_Schlick3", 2)].lanes == 3
    # a branch is a Piecewise: the ternary's and the early return's
    assert isinstance(glsl[("srgb_decode", 1)].expression, sp.Piecewise)
    assert isinstance(glsl[("srgb_encode", 1)].expression, sp.Piecewise)


def test_what_is_not_read_is_refused_with_its_reason(glsl):
    refused = {key[0]: r.refused for key, r in glsl.items() if r.refused is not None}
    assert refused == {"swizzled": "a vector result whose lanes are not one scalar function of their own lane "
                                   "(lane 0 reads another lane)",
                       "sum_loop": "a loop left after optimization",
                       "write_out": "an out or inout parameter (y)",
                       "four": "4 arguments; at most 3 free scalars are derived"}


def test_the_same_function_in_hlsl_is_the_same_expression(glsl):
    hlsl = read_all(HLSL)
    for key in (("srgb_decode", 1), ("acos_fast", 1), ("V_SmithGGXCorrelated", 3), ("F_Schlick3", 2)):
        assert hlsl[key].expression == glsl[key].expression, key


def test_includes_and_defines_are_the_compiler_s(tmp_path):
    """-I finds an include outside the file's folder; -D NAME=VALUE sets a macro the file reads."""
    (tmp_path / "lib").mkdir()
    (tmp_path / "lib" / "scale.glsl").write_text("float scaled(float x) { return x * SCALE; }\n")
    path = tmp_path / "user.glsl"
    path.write_text('#include "scale.glsl"\nfloat twice(float x) { return scaled(x) + OFFSET; }\n')
    read = read_all(path, harness.Options("glsl", (str(tmp_path / "lib"),), ("SCALE=2.0", "OFFSET=0.5")))
    x = sp.Symbol("x", real=True)
    assert sp.simplify(read[("twice", 1)].expression - (2 * x + sp.Rational(1, 2))) == 0
    with pytest.raises(ShaderError, match=r"user\.glsl does not compile: .*scale\.glsl"):
        harness.preprocessed(path, harness.Options("glsl"))


def test_a_file_that_does_not_compile_is_one_line_with_its_file_and_line(tmp_path):
    path = tmp_path / "bad.glsl"
    path.write_text("float ok(float x) { return x; }\nfloat bad(float x) { return x + ; }\n")
    language, found = definitions.read(path)
    options = harness.Options(language)
    text = harness.preprocessed(path, options)
    with pytest.raises(ShaderError, match=r"bad\.glsl.*:2:"):
        harness.read_function(text, found[0], options, path)
    with pytest.raises(ShaderError, match="no such file"):
        definitions.read(tmp_path / "none.glsl")


RANGES = {"pow5": [(0, 2)], "F_Schlick": [(0, 1)], "F_Schlick_pow5": [(0, 1)], "F_Schlick3": [(0, 1), (0, 1)],
          "V_SmithGGXCorrelated": [(1e-4, 1), (1e-4, 1), (0.045, 1)], "srgb_decode": [(0, 1)], "srgb_encode": [(0, 1)],
          "acos_fast": [(0, 1)]}


def _round_trips(path=GLSL, ranges=RANGES):
    from pipeline.shaders import round_trip

    language, found = definitions.read(path)
    options = harness.Options(language)
    text = harness.preprocessed(path, options)
    out = {}
    for d in found:
        if d.name in ranges:
            expression, transliteration, _ = harness.reading(text, d, options, path)
            out[d.name] = round_trip.round_trip(text, d, expression, transliteration, ranges[d.name], language)
    return out


def test_every_reading_executes_as_the_function_to_the_last_bit():
    """On lavapipe (both shaders through spirv-opt -O, as the reading was): the transliteration and the
    function agree in every bit at 2^16 inputs or more (the branches' both sides among them), and the
    sympy expression in float64 agrees to float32's rounding (drift below 1)."""
    from pipeline.isa import execution

    if execution.available() is not None:
        pytest.skip(f"lavapipe cannot run here: {execution.available()}")
    checks = _round_trips()
    assert {name: (c.how, c.ulps, c.mismatch) for name, c in checks.items()} == {
        name: ("lavapipe", 0, None) for name in RANGES}
    assert all(c.inputs >= 1 << 16 and c.drift < 1 for c in checks.values())


def test_an_hlsl_function_executes_as_its_reading_to_the_last_bit():
    """The HLSL twins run in an HLSL compute harness (glslang's HLSL front end), their readings'
    transliterations in GLSL's: the same bits at 2^16 inputs or more."""
    from pipeline.isa import execution

    if execution.available() is not None:
        pytest.skip(f"lavapipe cannot run here: {execution.available()}")
    checks = _round_trips(HLSL, {name: RANGES[name] for name in ("srgb_decode", "acos_fast", "V_SmithGGXCorrelated",
                                                                 "F_Schlick3")})
    assert {name: (c.how, c.ulps, c.mismatch) for name, c in checks.items()} == {
        name: ("lavapipe", 0, None) for name in ("srgb_decode", "acos_fast", "V_SmithGGXCorrelated", "F_Schlick3")}


def test_a_misreading_is_caught_by_the_round_trip(monkeypatch):
    """A planted misreading of pow (the transliteration's max for pow; the expression's exponent 1 %
    off) is a mismatch of one line naming the function and an input."""
    from pipeline.isa import execution
    from pipeline.shaders import spirv_reader

    if execution.available() is not None:
        pytest.skip(f"lavapipe cannot run here: {execution.available()}")
    monkeypatch.setitem(spirv_reader.GLSL_FUNCTIONS, "Pow", "max")
    check = _round_trips(ranges={"F_Schlick": [(0, 1)]})["F_Schlick"]
    assert check.mismatch.startswith("F_Schlick: its reading computes") and "the reader misread it" in check.mismatch
    monkeypatch.setitem(spirv_reader.GLSL_FUNCTIONS, "Pow", "pow")
    monkeypatch.setitem(spirv_reader.FUNCTIONS, "Pow", lambda x, y: x ** (y * 1.01))
    check = _round_trips(ranges={"F_Schlick": [(0, 1)]})["F_Schlick"]
    assert check.ulps == 0 and check.drift > 1 and "the expression misreads it" in check.mismatch


def test_the_inputs_cover_the_box_with_at_least_2_to_the_16():
    from pipeline.shaders.round_trip import grid

    for ranges in ([(0, 1)], [(0, 1), (2, 3)], [(0, 1), (2, 3), (-1, 0)]):
        points = grid(ranges)
        assert points[0].size >= 1 << 16 and all(p.dtype == np.float32 for p in points)
        assert [(float(p.min()), float(p.max())) for p in points] == [(float(np.float32(lo)), float(np.float32(hi)))
                                                                      for lo, hi in ranges]


def test_the_author_s_intent_is_read_from_the_line_above_or_the_command_line():
    """`// derive:` pairs: each argument's range, the parameter, the metric, max_error, exact (a
    value with spaces in quotes); the command line's where the comment is silent; a function with no
    range for an argument is one line showing the line to write; a bad pair names itself."""
    from pipeline.shaders import intent as intents

    found = {d.name: d for d in definitions.read(GLSL)[1]}
    visibility = intents.intent(found["V_SmithGGXCorrelated"], GLSL)
    assert visibility == intents.Intent({"NoV": (1e-4, 1.0), "NoL": (1e-4, 1.0), "roughness": (0.045, 1.0)},
                                        "roughness", "rel", 0.0, 0.25)
    assert intents.intent(found["acos_fast"], GLSL).exact == "acos(x)"
    assert intents.intent(found["F_Schlick"], GLSL).role == "fresnel"
    # the command line where the comment says nothing; the comment wins where both speak
    pow5 = intents.intent(found["pow5"], GLSL, intents.parse("x=0:2 metric=rel max_error=1e-3", "--var"))
    assert (pow5.ranges, pow5.metric, pow5.max_error) == ({"x": (0.0, 2.0)}, "rel", 1e-3)
    assert intents.intent(found["F_Schlick"], GLSL, {"VoH": (0.5, 1.0)}).ranges == {"VoH": (0.0, 1.0)}
    with pytest.raises(ShaderError) as none:
        intents.intent(found["srgb_decode"], GLSL)
    assert str(none.value) == (f"{GLSL}:{found['srgb_decode'].line}: srgb_decode has no range for c: write "
                               "`// derive: c=LO:HI` on the line above it, or give --var c=LO:HI")
    for text, message in (('x=1:0', "give LO < HI"), ("x=0:1 metric=max", "metric=max"), ("x=0", "give x=LO:HI"),
                          ("x=0:1 max_error=0", "max_error=0"), ("x=0:1 y=0:1", "has no argument 'y'"),
                          ("x=0:1 parameter=a", "parameter=a"), ('x=0:1 exact="acos(x', "No closing quotation"),
                          ("x=0:1 x=0:2", "x given twice"), ("x", "give KEY=VALUE")):
        with pytest.raises(ShaderError, match=message):
            intents.intent(dataclasses.replace(found["pow5"], annotation=text), GLSL)


def test_a_patch_replaces_only_the_bodies_and_applies(tmp_path):
    """Two bodies replaced (F_Schlick by squarings, acos_fast keeping its original as
    acos_fast_reference): the diff applies by `git apply --check` and `patch -p1` (where installed),
    the patched file has every other line and every signature as before, compiles, and reads back to
    the new bodies; a diff of nothing changed is empty."""
    import shutil
    import subprocess

    from pipeline.shaders import patch

    work = tmp_path / "repo"
    (work / "shaders").mkdir(parents=True)
    for name in ("engine_style.glsl", "engine_constants.glsl"):
        shutil.copy(HERE / name, work / "shaders" / name)
    path = work / "shaders" / "engine_style.glsl"
    before = path.read_bytes()
    found = {d.name: d for d in definitions.read(path)[1]}
    after = patch.replaced(before, {found["F_Schlick"]: "(1.0 - VoH) * (1.0 - VoH) * (1.0 - VoH) * (1.0 - VoH) * "
                                                        "(1.0 - VoH)", found["acos_fast"]: "1.5707964 - x"},
                           keep_reference=False)
    diff = patch.unified_diff("shaders/engine_style.glsl", before, after)
    assert patch.unified_diff("shaders/engine_style.glsl", before, before) == ""
    (tmp_path / "shader.patch").write_text(diff)
    if shutil.which("git"):
        subprocess.run(["git", "init", "-q", str(work)], check=True)
        done = subprocess.run(["git", "apply", "--check", str(tmp_path / "shader.patch")], cwd=work,
                              capture_output=True, text=True)
        assert done.returncode == 0, done.stderr
    if shutil.which("patch"):
        done = subprocess.run(["patch", "-p1", "--dry-run", "-i", str(tmp_path / "shader.patch")], cwd=work,
                              capture_output=True, text=True)
        assert done.returncode == 0, done.stdout + done.stderr
    path.write_bytes(after)
    patched = {d.name: d for d in definitions.read(path)[1]}
    assert [d.signature for d in patched.values()] == [d.signature for d in found.values()]
    changed = [line for line in difflib_lines(before, after) if line[0] in "+-"]
    assert all("return" in line or line.strip() in ("-", "+", "-{", "+{", "-}", "+}") for line in changed), changed
    read = read_all(path)
    x, voh = sp.Symbol("x", real=True), sp.Symbol("VoH", real=True)
    assert sp.simplify(read[("F_Schlick", 1)].expression - (1 - voh) ** 5) == 0
    assert sp.simplify(read[("acos_fast", 1)].expression - (sp.Float(float(np.float32(1.5707964))) - x)) == 0
    kept = patch.replaced(before, {found["acos_fast"]: "1.5707964 - x"}, keep_reference=True)
    path.write_bytes(kept)
    both = read_all(path)
    assert both[("acos_fast_reference", 1)].expression == read_all(GLSL)[("acos_fast", 1)].expression


def difflib_lines(before: bytes, after: bytes) -> list[str]:
    import difflib

    return [line for line in difflib.unified_diff(before.decode().splitlines(), after.decode().splitlines(),
                                                  lineterm="", n=0) if not line.startswith(("---", "+++", "@@"))]


def test_without_lavapipe_the_round_trip_says_so(monkeypatch):
    """Where lavapipe cannot run, the check is not executed and says why (one line); nothing fails."""
    from pipeline.isa import execution
    from pipeline.shaders import round_trip

    monkeypatch.setattr(execution, "available", lambda: "no lavapipe here (planted)")
    check = _round_trips(ranges={"acos_fast": [(0, 1)]})["acos_fast"]
    assert (check.how, check.checked, check.mismatch) == ("not executed: no lavapipe here (planted)", False, None)
    assert round_trip.RoundTrip(check.how, check.inputs).checked is False
