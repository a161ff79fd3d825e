"""`pipeline derive --shader FILE`, its whole command once: the tests' engine-style file, its acos
approximation declared `exact=acos(x)` derived on RDNA3 (a replacement more accurate at no more
cycles, as `derive --target acos` places Lagarde's), a loop refused, a function without a range
refused with the line to write; functions.csv, report.md and shader.patch written, the patch applying
by `git apply` and `patch -p1`, the patched file compiling with every signature as it was and read
back to the replacement, a second run on it proposing nothing more, the user's file never written;
and the inputs a run refuses with exit 2."""

import csv
import shutil
import subprocess
from pathlib import Path

import pytest

from pipeline.cli import main
from pipeline.shaders import definitions, harness

HERE = Path(__file__).parent
ARGS = ["--gpu", "rdna3", "--seconds", "5", "--max-complexity", "4"]


@pytest.fixture(scope="module")
def shader_run(tmp_path_factory):
    from pipeline.approximate import engines

    if "rdna3" not in engines.available_architectures():
        pytest.skip("RADV cannot compile for RDNA3 here")
    work = tmp_path_factory.mktemp("shader")
    for name in ("engine_style.glsl", "engine_constants.glsl"):
        shutil.copy(HERE / name, work / name)
    path = work / "engine_style.glsl"
    before = path.read_bytes()
    code = main(["derive", "--shader", str(path), "--function", "acos_fast,sum_loop,srgb_decode", *ARGS,
                 "--out", str(work / "out")])
    return work, path, before, code


def test_a_shader_file_is_derived_and_patched(shader_run, capsys):
    work, path, before, code = shader_run
    assert code == 0 and path.read_bytes() == before        # (the user's file never written)
    out = work / "out"
    assert {p.name for p in out.iterdir()} >= {"functions.csv", "shader.patch", "report.md", "functions"}
    rows = {r["function"]: r for r in csv.DictReader((out / "functions.csv").read_text().splitlines())}
    assert rows["sum_loop"]["status"] == "refused" and rows["sum_loop"]["reason"] == "a loop left after optimization"
    assert rows["srgb_decode"]["status"] == "refused" and "write `// derive: c=LO:HI`" in rows["srgb_decode"]["reason"]
    acos = rows["acos_fast"]
    assert acos["status"] == "derived" and acos["architecture"] == "rdna3"
    assert float(acos["cycles_after"]) <= float(acos["cycles_before"])
    assert float(acos["error_after"]) < float(acos["error_before"]) * 0.99       # (more accurate: beaten)
    results = __import__("json").loads((out / "functions" / "acos_fast" / "results.json").read_text())
    assert results["verdicts"]["rdna3"]["as shipped"]["verdict"] in ("beaten", "matched")
    # the patch applies, keeps every signature, compiles and reads back to the replacement
    patch = (out / "shader.patch").read_text()
    assert patch.startswith("--- a/engine_style.glsl\n+++ b/engine_style.glsl\n")
    if shutil.which("git"):
        subprocess.run(["git", "init", "-q", str(work)], check=True)
        done = subprocess.run(["git", "apply", "--check", str(out / "shader.patch")], cwd=work, capture_output=True,
                              text=True)
        assert done.returncode == 0, done.stderr
    if shutil.which("patch"):
        done = subprocess.run(["patch", "-p1", "-i", str(out / "shader.patch")], cwd=work, capture_output=True,
                              text=True)
        assert done.returncode == 0, done.stdout + done.stderr
    else:
        pytest.skip("patch is not installed here")
    assert [d.signature for d in definitions.read(path)[1]] == [d.signature for d in
                                                                definitions.read(HERE / "engine_style.glsl")[1]]
    after = {d.name: d for d in definitions.read(path)[1]}
    options = harness.Options("glsl")
    reading = harness.read_function(harness.preprocessed(path, options), after["acos_fast"], options, path)
    assert reading.refused is None and "0.00279" in str(reading.expression)
    # a second run on the patched file proposes nothing more for it
    capsys.readouterr()
    assert main(["derive", "--shader", str(path), "--function", "acos_fast", *ARGS, "--out", str(work / "again")]) == 0
    again = {r["function"]: r for r in csv.DictReader((work / "again" / "functions.csv").read_text().splitlines())}
    assert again["acos_fast"]["status"] == "none cheaper" and (work / "again" / "shader.patch").read_text() == ""


@pytest.mark.parametrize("argv, message", [
    (["--function", "nope"], "--function 'nope': "),
    (["--function", "sum_loop,four"], "no function could be derived: sum_loop: a loop"),
    (["--target", "acos"], "--shader and --target"),
])
def test_bad_shader_input_is_one_line_and_exit_2(argv, message, tmp_path, capsys):
    assert main(["derive", "--shader", str(HERE / "engine_style.glsl"), *argv, "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip()
    assert message in err and len(err.splitlines()) == 1
    assert not (tmp_path / "out").exists()


def test_a_file_that_does_not_compile_is_exit_2_with_its_line(tmp_path, capsys):
    path = tmp_path / "bad.glsl"
    path.write_text("// derive: x=0:1\nfloat f(float x) {\n    return x + ;\n}\n")
    assert main(["derive", "--shader", str(path), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip()
    assert "bad.glsl" in err and ":3:" in err and len(err.splitlines()) == 1
    assert main(["derive", "--expr", "x", "--exact", "acos(x)"]) == 2
    assert "--exact goes with --shader" in capsys.readouterr().err


def test_a_replacement_that_does_not_compile_is_refused_and_left_out_of_the_patch(tmp_path):
    """`shader_file.compiled`: each replacement compiled in a copy of the patched file (its includes
    found in the file's folder); a planted one that does not compile (an undeclared name) is refused
    with the compiler's message, the other stays derived."""
    from pipeline.approximate.engines import shader_file
    from pipeline.approximate.publishing import shader_outputs

    for name in ("engine_style.glsl", "engine_constants.glsl"):
        shutil.copy(HERE / name, tmp_path / name)
    path = tmp_path / "engine_style.glsl"
    found = {d.name: d for d in definitions.read(path)[1]}
    good = shader_file.Outcome("pow5", found["pow5"].line, shader_file.DERIVED, expression="x * x * x * x * x",
                               definition=found["pow5"])
    bad = shader_file.Outcome("acos_fast", found["acos_fast"].line, shader_file.DERIVED, expression="HALF_PI - y",
                              definition=found["acos_fast"])
    shader_file.compiled(path, harness.Options("glsl"), [good, bad], log=lambda s: None)
    assert good.status == shader_file.DERIVED
    assert bad.status == shader_file.REFUSED and "its replacement does not compile" in bad.reason and "'y'" in bad.reason
    diff = shader_outputs.patch_text(path, [good, bad])
    assert "x * x * x * x * x" in diff and "HALF_PI - y" not in diff


def test_a_function_s_arguments_and_branches_become_a_target_and_come_back():
    """srgb_decode(float c): its argument c, a name the grammar keeps for the constants, is the
    target's c_; its branch the target's `a if c_ <= ... else b`, checked like any target; a
    replacement in c_ printed back in c, its numbers the format's."""
    import sympy as sp

    from pipeline.approximate.engines.shader_file import replacement_text
    from pipeline.approximate.targets import reading

    assert reading.variable_names(["c", "c_", "x", "k_s", "c0"]) == {"c": "c__", "c_": "c_", "x": "x", "k_s": "vk_s",
                                                                   "c0": "c0_"}
    options = harness.Options("glsl")
    path = HERE / "engine_style.glsl"
    found = {d.name: d for d in definitions.read(path)[1]}
    read = harness.read_function(harness.preprocessed(path, options), found["srgb_decode"], options, path)
    target = reading.from_shader_function("srgb_decode", read.expression, ["c"], {"c": (0.0, 1.0)}, "engine_style.glsl:28")
    assert target.names == ("c_",) and target.shape == "one variable" and " if c_ <= " in target.expression
    assert target.anchors[0].name == "as shipped" and target.anchors[0].expression == target.expression
    c_ = sp.Symbol("c_", real=True)
    assert replacement_text(sp.Float(0.5) * c_ + sp.Float(0.1), found["srgb_decode"], 1, "glsl", "fp32") == "0.5*c + 0.100000001"


def test_the_replacement_rule_flips_with_planted_numbers():
    """`shader_file.replacement` on planted results (two architectures): a form within the budget at
    no more cycles and fewer on one is chosen; one cycle more on either architecture, or an error
    above the budget, and none is; at equal cycles only an error below the shipped one by more than
    1 % (derive's beaten) counts; with max_error, a less accurate but cheaper form is chosen; the
    reason names the architectures where the least within the budget costs what the shipped does."""
    from pipeline.approximate.engines.shader_file import replacement

    def results(cycles_a, cycles_b, error):
        return dict(error="max_abs_error", rounding_floor=1e-8, architectures=["a", "b"],
                    members={"as shipped": dict(kind="anchor", max_abs_error=1e-3),
                             "f": dict(kind="found", max_abs_error=error, parameter_per="")},
                    cycles={"a": {"as shipped": 10.0, "f": cycles_a}, "b": {"as shipped": 8.0, "f": cycles_b}})

    assert replacement(results(9.0, 8.0, 1e-3), None)[0] == "f"
    assert replacement(results(11.0, 6.0, 1e-3), None)[0] is None
    assert replacement(results(9.0, 9.0, 1e-3), None)[0] is None
    assert replacement(results(9.0, 8.0, 1.1e-3), None)[0] is None
    assert replacement(results(10.0, 8.0, 0.98e-3), None)[0] == "f"          # more accurate by 2 %
    assert replacement(results(10.0, 8.0, 0.995e-3), None)[0] is None        # within 1 %: matched
    assert replacement(results(9.0, 8.0, 5e-3), 1e-2)[0] == "f"
    name, reason, budget = replacement(results(10.0, 8.0, 1e-3), None)
    assert name is None and budget == 1e-3 and "a: 10 cycles as shipped, the least within it 10" in reason
    assert "the compiler already computes it as cheaply" in reason
    material = results(9.0, 8.0, 1e-3)
    material["members"]["f"]["parameter_per"] = "material"
    assert replacement(material, None)[0] is None
