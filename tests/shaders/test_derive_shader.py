"""`pipeline derive --shader FILE`, its whole command once: the tests' engine-style file, its acos
approximation declared `exact=acos(x)` derived on RDNA3 (a replacement more accurate at no more
cycles, as `derive --target acos` places Lagarde's), a loop refused, a function without a range
refused with the line to write; functions.csv, report.md and shader.patch written, the patch applying
by `git apply` and `patch -p1`, the patched file compiling with every signature as it was and read
back to the replacement, a second run on it proposing nothing more, the user's file never written;
and the inputs a run refuses with exit 2."""

import csv
import dataclasses
import shutil
import types
import subprocess
from pathlib import Path

import numpy as np
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
    # an exact expression with a decimal constant: its constants read as float64, the target's text reads back
    quarter = reading.from_shader_function("s", read.expression, ["c"], {"c": (0.0, 1.0)}, "here",
                                           exact="sin(1.5707963267948966*c)")
    assert quarter.expression == "sin(1.5707963267948966*c_)" and abs(quarter.numpy()(1.0) - 1.0) < 1e-15
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


def test_the_branch_of_derived_pieces_competes_by_the_same_rule():
    """The anchor that is the branch of a branch's derived pieces (`pieces.PIECES`) is a candidate as
    a front member is (chosen at fewer cycles within the budget, against a dearer front member), any
    other anchor never is (a hand fit the target carries is not the answer to its own function)."""
    from pipeline.approximate.engines.pieces import PIECES
    from pipeline.approximate.engines.shader_file import replacement

    def results(name, kind):
        return dict(error="max_abs_error", rounding_floor=1e-8, architectures=["a"],
                    members={"as shipped": dict(kind="anchor", max_abs_error=1e-3),
                             "f": dict(kind="found", max_abs_error=1e-3, parameter_per=""),
                             name: dict(kind=kind, max_abs_error=1e-3)},
                    cycles={"a": {"as shipped": 10.0, "f": 9.0, name: 6.0}})

    assert replacement(results(PIECES, "anchor"), None)[0] == PIECES
    assert replacement(results("lagarde", "anchor"), None)[0] == "f"


def _planted(target, members: dict, cycles: dict) -> dict:
    """A derivation's results as `shader_file` reads them, its members and cycles planted: {name:
    (expression text in the target's variables, error)}, {architecture: {name: cycles}}."""
    from pipeline.approximate.targets import parse

    forms = {n: types.SimpleNamespace(expression=parse(text, target.names)) for n, (text, _) in members.items()}
    return dict(error="max_abs_error", rounding_floor=1e-7, architectures=list(cycles), precision="fp32",
                forms=forms, cycles=cycles,
                members={n: dict(kind="anchor" if n in [a.name for a in target.anchors] else "found",
                                 max_abs_error=e, expression=text, parameter_per="") for n, (text, e) in members.items()})


def _branch_engine(seen: list):
    """A planted engine for srgb_decode's branch, recording each target in `seen`: piece 1 has no
    cheaper form, piece 2 a cubic at 6 cycles where it costs 12; the whole function a branch-free
    member at 10 cycles and the branch of the pieces at 9 (14 as shipped)."""
    from pipeline.approximate.engines import pieces as branch_pieces

    cubic = "c_*(c_*(0.2919*c_ + 0.7102) - 0.004271) + 0.002704"

    def derive(target, log, **settings):
        seen.append(target)
        shipped = target.anchors[0].expression
        if target.name == "srgb_decode_piece1":
            results = _planted(target, {"as shipped": (shipped, 1e-10)}, {"rdna3": {"as shipped": 2.0}})
        elif target.name == "srgb_decode_piece2":
            results = _planted(target, {"as shipped": (shipped, 5e-7), "p": (cubic, 6e-4)},
                               {"rdna3": {"as shipped": 12.0, "p": 6.0}})
        else:
            branch = target.anchors[1].expression
            results = _planted(target, {"as shipped": (shipped, 5e-7), branch_pieces.PIECES: (branch, 6e-4),
                                        "whole": ("c_*c_", 1e-3)},
                               {"rdna3": {"as shipped": 14.0, branch_pieces.PIECES: 9.0, "whole": 10.0}})
        return types.SimpleNamespace(raw=results)

    return derive


@pytest.fixture(scope="module")
def branch_run(tmp_path_factory):
    """srgb_decode derived by a planted engine that records its targets (`test_a_branch_s_pieces_...`):
    (the folder, the file, the outcomes, the targets in the order derived)."""
    from pipeline.approximate.engines import shader_file
    from pipeline.shaders import intent

    tmp_path = tmp_path_factory.mktemp("branch")
    for name in ("engine_style.glsl", "engine_constants.glsl"):
        shutil.copy(HERE / name, tmp_path / name)
    path = tmp_path / "engine_style.glsl"
    seen = []
    derive = _branch_engine(seen)
    outcomes, _ = shader_file.derive_file(path, harness.Options("glsl"), derive, ["srgb_decode"],
                                          intent.parse("c=0:1 max_error=2e-3", "the command line"), ["rdna3"],
                                          log=lambda s: None)
    return tmp_path, path, outcomes, seen


def test_a_branch_s_pieces_are_derived_where_taken_and_their_branch_competes_whole(branch_run):
    """srgb_decode's branch, read and executed as the file means it, derived by a planted engine that
    records its targets: each piece a target on the interval where it is taken (not rendered), piece
    2's cheaper form chosen by the rule, piece 1 kept; the whole function's target carries the
    branch of the pieces' replacements as the anchor `derived pieces`, chosen where it is the
    cheapest within the budget, printed back as the file's ternary, compiled in the patched file; the
    report and the page say what each piece became and what the branch costs whole."""
    import sympy as sp

    from pipeline.approximate.engines import pieces as branch_pieces, shader_file
    from pipeline.approximate.publishing import shader_outputs, shader_page
    from pipeline.shaders import patch as shader_patch

    tmp_path, path, outcomes, seen = branch_run
    (o,) = outcomes
    piece1, piece2, whole = seen
    threshold = float(np.float32(0.04045))         # (the file's 0.04045 as the float32 it compiles to)
    assert [(t.variables[0].lo, t.variables[0].hi) for t in (piece1, piece2, whole)] == \
        [(0.0, threshold), (threshold, 1.0), (0.0, 1.0)]
    assert piece1.role == piece2.role == "" and piece2.anchors[0].expression.startswith("(0.947867")
    assert [p.chosen for p in o.pieces] == [None, "p"] and o.pieces[0].reason.endswith("none is within it")
    assert [a.name for a in whole.anchors] == ["as shipped", branch_pieces.PIECES]
    assert " if c_ <= 0.04044999" in whole.anchors[1].expression and "0.2919*c_" in whole.anchors[1].expression
    assert o.status == shader_file.DERIVED and o.replacement == branch_pieces.PIECES   # (cheaper than "whole")
    assert o.expression.startswith("(c <= 0.0404499993 ? 0.0773993805*c : c*(c*(0.291900009*c + 0.710200012)")
    assert "c_" not in o.expression
    # the patched file compiles (shader_file.compiled kept it derived) and reads back as a branch
    patched = tmp_path / "patched.glsl"
    patched.write_bytes(shader_patch.replaced(path.read_bytes(), {o.definition: o.expression}))
    options = harness.Options("glsl")
    again = next(d for d in definitions.read(patched)[1] if d.name == "srgb_decode")
    read = harness.read_function(harness.preprocessed(patched, options), again, options, patched)
    assert isinstance(read.expression, sp.Piecewise)
    # what the report and the page say
    report = shader_outputs.report(path, outcomes, "glsl")
    assert "The branch of the pieces' replacements, costed and measured whole: rdna3 9 cycles" in report
    assert "(the replacement)." in report and "| 2 | `otherwise` | [0.04045, 1] |" in report
    page = shader_page.data(path, outcomes, "glsl", "")
    (f,) = page["functions"]
    assert f["branch"]["cycles"] == {"rdna3": 9.0} and [p["page"] for p in f["pieces"]] == \
        ["functions/srgb_decode_piece1/report.html", "functions/srgb_decode_piece2/report.html"]
    assert page["bars"] == [dict(function="srgb_decode", architecture="rdna3", when="before", cycles=14.0),
                            dict(function="srgb_decode", architecture="rdna3", when="after", cycles=9.0)]


def test_the_run_s_page_shows_every_function_and_opens_each_derivation(branch_run):
    """report.html of the branch run in Chromium: a row per function and architecture, each naming
    its function by a link to its section, the pieces' table with a link to each piece's derive
    page, the branch's whole cost, the chart's bars, nothing asked of the network, no error."""
    from pipeline.approximate.publishing import shader_outputs, shader_page
    from tests.helpers import open_page

    from pipeline.approximate.engines import platform_answer

    tmp_path, path, outcomes, _ = branch_run
    outcomes = [dataclasses.replace(o, platforms={"console": platform_answer.answer(o.results, ["rdna3"], o.budget),
                                                  "none": None}) for o in outcomes]
    page_path = tmp_path / "report.html"
    shader_page.write(page_path, path, outcomes, "glsl", shader_outputs.patch_text(path, outcomes))
    with open_page(page_path) as opened:
        page = opened.page
        rows = page.locator("#functions-table tbody tr")
        assert rows.count() == 1 and rows.locator("a").first.text_content() == "srgb_decode"
        assert rows.locator("td").nth(4).text_content() == "14 → 9"
        section = page.locator("#function-0")
        assert "derived pieces" in section.text_content() and "rdna3 9 cycles" in section.text_content()
        links = [a.get_attribute("href") for a in section.locator("table a").all()]
        assert links == ["functions/srgb_decode_piece1/report.html", "functions/srgb_decode_piece2/report.html"]
        assert page.evaluate("pageState.views.cycles.data('source_0').length") == 2
        assert "+    return (c <= 0.0404499993 ?" in page.locator("#patch").text_content()
        platforms = page.locator("#platforms-0 tbody tr")
        assert platforms.count() == 2 and platforms.nth(0).locator("td").nth(1).text_content() == "derived pieces"
        assert platforms.nth(1).locator("td").nth(1).text_content() == "none within the budget"
        assert opened.problems == [] and all(r.startswith("file://") for r in opened.requests)


def test_the_visibility_with_its_roughness_is_a_target_of_two_variables_and_a_parameter(tmp_path):
    """V_SmithGGXCorrelated(NoV, NoL, roughness) with its annotation (parameter=roughness metric=rel
    max_error=0.25), derived by a planted engine: the target is two variables on [1e-4, 1] and the
    parameter roughness on [0.045, 1], relative error, its anchor the function as read; Hammon's form
    planted at fewer cycles on both architectures and within the budget is the replacement, printed in
    the function's own arguments, compiled in the patched file, its signature unchanged."""
    from pipeline.approximate.engines import shader_file
    from pipeline.approximate.publishing import shader_outputs

    for name in ("engine_style.glsl", "engine_constants.glsl"):
        shutil.copy(HERE / name, tmp_path / name)
    path = tmp_path / "engine_style.glsl"
    seen = []
    hammon = "0.5/(2*NoL*NoV*(1 - roughness) + roughness*(NoL + NoV))"

    def derive(target, log, **settings):
        seen.append(target)
        results = _planted(target, {"as shipped": (target.anchors[0].expression, 1e-6), "hammon": (hammon, 0.2),
                                    "loose": ("0.25/NoV", 0.3)},
                           {"rdna3": {"as shipped": 26.0, "hammon": 12.0, "loose": 4.0},
                            "sm_89": {"as shipped": 24.0, "hammon": 9.0, "loose": 3.0}})
        results["error"] = "max_rel_error"
        for m in results["members"].values():
            m["max_rel_error"] = m.pop("max_abs_error")
        return types.SimpleNamespace(raw=results)

    (o,), _ = shader_file.derive_file(path, harness.Options("glsl"), derive, ["V_SmithGGXCorrelated"], None,
                                      ["rdna3", "sm_89"], log=lambda s: None)
    (target,) = seen
    assert target.shape == "several variables" and target.metric == "rel"
    assert [(a.name, a.lo, a.hi) for a in target.variables] == [("NoV", 1e-4, 1.0), ("NoL", 1e-4, 1.0)]
    assert (target.parameter.name, target.parameter.lo, target.parameter.hi) == ("roughness", 0.045, 1.0)
    assert o.status == shader_file.DERIVED and o.replacement == "hammon" and o.budget == 0.25   # ("loose": 0.3 > 0.25)
    assert "roughness" in o.expression and "NoV" in o.expression
    assert [(r["cycles_before"], r["cycles_after"]) for r in o.rows] == [(26.0, 12.0), (24.0, 9.0)]
    diff = shader_outputs.patch_text(path, [o])
    assert "+    return " in diff and diff.count("\n+") == 2 and "float V_SmithGGXCorrelated(float NoV, float NoL, " \
        "float roughness) {" in diff


def test_a_branch_of_derived_pieces_is_written_back_as_hlsl_s_ternary(tmp_path):
    """The same planted engine on the HLSL twin of srgb_decode: the branch of the pieces printed in
    HLSL, compiled by glslang's HLSL front end in the patched file (kept derived), read back as a branch."""
    import sympy as sp

    from pipeline.approximate.engines import pieces as branch_pieces, shader_file
    from pipeline.shaders import intent, patch as shader_patch

    path = tmp_path / "engine_style.hlsl"
    shutil.copy(HERE / "engine_style.hlsl", path)
    options = harness.Options("hlsl")
    (o,), _ = shader_file.derive_file(path, options, _branch_engine([]), ["srgb_decode"],
                                      intent.parse("c=0:1 max_error=2e-3", "the command line"), ["rdna3"],
                                      log=lambda s: None)
    assert o.status == shader_file.DERIVED and o.replacement == branch_pieces.PIECES, o.reason
    assert o.expression.startswith("(c <= 0.0404499993 ? 0.0773993805*c : ")
    patched = tmp_path / "patched.hlsl"
    patched.write_bytes(shader_patch.replaced(path.read_bytes(), {o.definition: o.expression}))
    again = next(d for d in definitions.read(patched)[1] if d.name == "srgb_decode")
    assert isinstance(harness.read_function(harness.preprocessed(patched, options), again, options, patched).expression,
                      sp.Piecewise)
