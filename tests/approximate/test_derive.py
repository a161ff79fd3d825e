"""`pipeline derive`: the fronts and the anchors' verdicts by their rules (planted numbers), bad
input, and one whole run of the command (Schlick's (1 - x)^5 on AMD's RDNA3 and GCN5), its
report.html opened in a browser."""

import contextlib
import csv
import importlib.util
import json
import math
import subprocess
import sys

import numpy as np
import pytest

from pipeline.approximate import engines, forms, targets
from pipeline.approximate.measures import fronts
from pipeline.approximate.publishing import derive_files as publish, derive_page
from pipeline.approximate.search import anchor_refits
from pipeline.engine import escape
from tests.helpers import PLANTED_SLOW_RATES, busy_cores, cli_env


def _rows(*pairs):
    return [dict(name=f"f{i}", cycles=c, max_abs_error=e) for i, (c, e) in enumerate(pairs)]


def test_the_front_keeps_what_no_cheaper_form_beats():
    rows = _rows((2, 0.1), (4, 0.01), (4, 0.02), (6, 0.05), (8, 0.001), (3, math.inf))
    assert [(r["cycles"], r["max_abs_error"]) for r in fronts.front(rows, "max_abs_error")] == \
        [(2, 0.1), (4, 0.01), (8, 0.001)]


def test_errors_below_float32_rounding_are_equal_on_the_front():
    """A form exact to 1e-15 and the exact one at more cycles: one member, at the floor."""
    rows = _rows((2, 0.1), (10, 1e-15), (12, 0.0))
    assert [r["cycles"] for r in fronts.front(rows, "max_abs_error", 1e-7)] == [2, 10]
    assert [r["cycles"] for r in fronts.front(rows, "max_abs_error")] == [2, 10, 12]
    assert fronts.verdict(12, 0.0, fronts.front(rows, "max_abs_error", 1e-7), "max_abs_error", 1e-7)["verdict"] == "matched"


@pytest.mark.parametrize("anchor, expected", [((4, 0.02), "beaten"), ((4, 0.01005), "matched"), ((4, 0.009), "missed"),
                                              ((3, 0.01), "missed"), ((1, 1.0), "missed")])
def test_an_anchors_verdict_flips_with_the_numbers(anchor, expected):
    found = fronts.front(_rows((2, 0.1), (4, 0.01), (8, 0.001)), "max_abs_error")
    v = fronts.verdict(*anchor, found, "max_abs_error")
    assert v["verdict"] == expected
    if expected != "missed" or anchor == (4, 0.009):
        assert v["by"] == "f1" and v["ratio"] == pytest.approx(0.01 / anchor[1])


def test_the_best_constant_is_the_floor_of_a_useful_form():
    schlick = targets.registry()["schlick"]
    assert fronts.constant_error(schlick, schlick.numpy()) == pytest.approx(0.5)
    positive = targets.from_expression("1 + x", "x=0:1", "rel")
    assert fronts.constant_error(positive, positive.numpy()) == pytest.approx(1 / 3)


def test_an_anchors_numbers_refitted_reach_the_minimax_of_its_form():
    """An anchor's decimal numbers refitted by minimax over the domain: the line 0.9 + 1.9 x for e^x on
    [0, 1] becomes Chebyshev's best line, whose error equioscillates at 0, log(e - 1) and 1:
    (2 - e + (e - 1) log(e - 1)) / 2 = 0.105933, to 1e-6. An anchor with no decimal number, or one
    that is that best line already, gives no refitted form."""
    import dataclasses

    slope = math.e - 1
    chebyshev = (2 - math.e + slope * math.log(slope)) / 2
    best = f"{1 - chebyshev!r} + {slope!r}*x"
    target = targets.from_expression("exp(x)", "x=0:1", "abs")
    target = dataclasses.replace(target, anchors=(targets.Anchor("rough", "0.9 + 1.9*x", "planted"),
                                                  targets.Anchor("integers", "1 + 2*x", "planted"),
                                                  targets.Anchor("best", best, "planted")))
    refits = anchor_refits.refitted_anchors(target, target.numpy(), lambda s: None)
    assert [m.name for m in refits] == ["rough_refitted"] and refits[0].family == "anchor_refit"
    assert chebyshev == pytest.approx(0.105933, abs=1e-6)
    assert anchor_refits.measured(refits[0], target, target.numpy())["max_abs_error"] == pytest.approx(chebyshev, abs=1e-6)


@pytest.mark.parametrize("argv, message", [
    (["--target", "nope"], "--target 'nope'"),
    (["--expr", "log(x)"], "not finite at x = 0"),
    (["--expr", "sin(x"], "does not parse"),
    (["--target", "acos", "--gpu", "rdna9"], "--gpu 'rdna9'"),
    (["--target", "acos", "--expr", "x"], "one of them"),
    (["--target", "schlick", "--metric", "rel"], "give a floor"),
    (["--target", "acos", "--seconds", "1"], "--seconds 1"),
    (["--target", "acos", "--plan", "/nonexistent/results.json"], "--plan /nonexistent/results.json: no such file"),
    (["--target", "acos", "--plan", "results.json", "--seconds", "10"], "--plan fixes the work; --seconds would"),
    (["--target", "acos", "--timeout", "0"], "--timeout 0: give a positive number"),
])
def test_bad_input_is_one_line_and_exit_2(argv, message, capsys):
    from pipeline.cli import main

    assert main(["derive", *argv]) == 2
    err = capsys.readouterr().err.strip()
    assert message in err and len(err.splitlines()) == 1


def test_an_out_that_is_a_file_is_refused_and_the_file_left_as_it_was(tmp_path, capsys):
    """`derive --out FILE` where FILE exists: exit 2, one line, the file's bytes as they were, nothing
    beside it (no hidden `.FILE.old`); the Python API's `write` refuses it too (publish)."""
    from pipeline.cli import main
    from pipeline.engine.publishing import publish

    path = tmp_path / "notes.txt"
    path.write_bytes(b"mine\n")
    assert main(["derive", "--expr", "x*x", "--out", str(path)]) == 2
    err = capsys.readouterr().err.strip()
    assert "a file, not a folder" in err and str(path) in err and len(err.splitlines()) == 1
    with pytest.raises(NotADirectoryError, match="notes.txt"):
        publish(path, "key", lambda s: None, lambda tmp: "nothing")
    assert path.read_bytes() == b"mine\n" and sorted(p.name for p in tmp_path.iterdir()) == ["notes.txt"]


def test_a_short_write_names_the_file_and_its_cause(tmp_path, monkeypatch):
    """A writer that stops short with numpy's words ("N requested and M written", no errno): the
    error names the file where it lands and the cause read off the device (no room: ENOSPC) or the
    file-size limit (EFBIG); `faults.describe` says it in one line."""
    import errno
    import resource
    import shutil

    from pipeline.engine import faults

    def short():
        raise OSError("5254432 requested and 51168 written")

    shown = tmp_path / "run" / "report.html"
    monkeypatch.setattr(shutil, "disk_usage", lambda path: shutil._ntuple_diskusage(100, 100, 0))
    with pytest.raises(OSError) as full:
        with faults.writing(shown):
            short()
    assert full.value.errno == errno.ENOSPC and full.value.filename == str(shown)
    assert faults.describe(full.value).startswith(f"no space left on the device ({shown})")
    monkeypatch.setattr(shutil, "disk_usage", lambda path: shutil._ntuple_diskusage(1 << 40, 0, 1 << 40))
    monkeypatch.setattr(resource, "getrlimit", lambda which: (1 << 20, resource.RLIM_INFINITY))
    with pytest.raises(OSError) as limited:
        with faults.writing(shown):
            short()
    assert limited.value.errno == errno.EFBIG and "size limit" in faults.describe(limited.value)
    assert len(faults.describe(limited.value).splitlines()) == 1


# A target file's text that must stay text in every output (`engine.escape`): the registered schlick,
# named and described by a colleague who writes HTML, Markdown and mathtext into them
HOSTILE_NAME = "</script><script>alert(1)</script>"
HOSTILE_SOURCE = "Karis 2013 | $5.55$ `tick` </script>"


@pytest.fixture(scope="module")
def schlick_runs(tmp_path_factory):
    """The whole command once, on RDNA3 and GCN5 with a small budget, on schlick as a target file
    whose name, description and anchor's source hold HTML, |, $ and backticks; then again in float16
    from the kept search: (folder, float32 output, float16 output, the first run's stdout)."""
    if "rdna3" not in engines.available_architectures():
        pytest.skip("Mesa's RADV does not run here: pipeline derive was not run")
    tmp_path = tmp_path_factory.mktemp("schlick")
    schlick = targets.registry()["schlick"]
    (karis,) = schlick.anchors
    (tmp_path / "schlick.toml").write_text(
        f'[target]\nname = "{HOSTILE_NAME}"\nexpression = "{schlick.expression}"\ndescription = "a | b $x$ `c`"\n'
        f'role = "{schlick.role}"\n'
        f'[[anchor]]\nname = "Karis"\nexpression = "{karis.expression}"\nsource = "{HOSTILE_SOURCE}"\n')
    out = tmp_path / "schlick"
    command = [sys.executable, "-m", "pipeline", "derive", "--target", str(tmp_path / "schlick.toml"), "--gpu",
               "rdna3,gcn5", "--seconds", "12", "--max-complexity", "6", "--out", str(out)]
    env = cli_env(tmp_path, PIPELINE_DERIVE_CACHE=str(tmp_path / "derive"))
    done = subprocess.run(command, capture_output=True, text=True, env=env, timeout=600)
    assert done.returncode == 0, done.stdout + done.stderr
    half = tmp_path / "half"
    again = subprocess.run(command[:-1] + [str(half), "--precision", "fp16", "--certify"], capture_output=True,
                           text=True, env=env, timeout=600)
    assert again.returncode == 0, again.stdout + again.stderr
    # the same command once more, its search not kept, both cores busy with other processes while its
    # grammar is searched (the ladder: from its first line to the cost tables' line; the families
    # before it and what follows never read the clock), and this machine's kept rates a machine's
    # 1000 times slower
    (tmp_path / "slow.json").write_text(json.dumps(PLANTED_SLOW_RATES))
    said, spinning = [], []
    with subprocess.Popen(
            command[:-1] + [str(tmp_path / "loaded")], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
            env=env | dict(PIPELINE_DERIVE_CACHE=str(tmp_path / "derive_loaded"), PYTHONUNBUFFERED="1",
                           PIPELINE_RATES=str(tmp_path / "slow.json"))) as loaded:
        with contextlib.ExitStack() as load:
            for line in loaded.stdout:
                said.append(line)
                if line.startswith("grammar: ") and not spinning:
                    spinning.append(load.enter_context(busy_cores(2)))
                if line.startswith("cost tables:"):
                    load.close()
    assert loaded.wait(timeout=600) == 0, "".join(said)
    assert "the search of an earlier run" not in "".join(said) and spinning
    assert [line.startswith("cost tables:") for line in said].count(True) == 1
    return tmp_path, out, half, done.stdout, again.stdout


def test_the_same_derive_command_gives_the_same_front_on_a_busy_machine(schlick_runs):
    """The whole command again with its search computed anew, both cores busy with other processes
    while it searched, and kept rates that say the machine is 1000 times slower: front.csv
    byte-identical, the same plans in results.json, which
    names them (the first run's plan: + - * / and the ten operations to their planned depths); the
    page's command reruns exactly that plan."""
    tmp_path, out, *_ = schlick_runs
    assert (out / "front.csv").read_bytes() == (tmp_path / "loaded" / "front.csv").read_bytes()
    results = json.loads((out / "results.json").read_text())
    loaded = json.loads((tmp_path / "loaded" / "results.json").read_text())
    assert results["plan"] == loaded["plan"] and list(results["plan"]["searches"]) == ["grammar"]
    grammar = results["plan"]["searches"]["grammar"]
    assert grammar["max_complexity"] == 6 and grammar["rungs"][0]["engine"] == "exhaustive"
    assert derive_page.rerun_command(results).endswith("--max-complexity 6 --plan results.json")
    assert "The same command with --plan results.json runs exactly these plans again" in (out / "report.md").read_text()


def test_pipeline_derive_renders_schlick_in_its_place(schlick_runs):
    """The whole command with the file's role: every row's FLIP in front.csv, the rule's answer per
    architecture in results.json (the cheapest invisible form no dearer than the exact target's
    cycles, its FLIP under the threshold), the figures, the report's section; in float16 too."""
    tmp_path, out, half, stdout, stdout_half = schlick_runs
    for folder in (out, half):
        results = json.loads((folder / "results.json").read_text())
        r = results["rendered"]
        assert r["role"] == "fresnel" and 0.02 < r["threshold"] < 0.1
        assert set(r["architectures"]) == {"rdna3", "gcn5"}
        with open(folder / "front.csv") as f:
            rows = list(csv.DictReader(f))
        assert all(r_["flip_max"] != "" and 0 <= float(r_["flip_mean"]) <= float(r_["flip_max"]) <= 1 for r_ in rows)
        for a, v in r["architectures"].items():
            seen = v["cheapest_invisible"]
            exact = next(r_ for r_ in rows if r_["architecture"] == a and r_["kind"] == "exact")
            assert seen["flip"] <= r["threshold"] and seen["cycles"] <= float(exact["cycles"])
            assert all(float(r_["flip_max"]) > r["threshold"] for r_ in rows
                       if r_["architecture"] == a and float(r_["cycles"]) < seen["cycles"])
            assert v["anchors"]["Karis"]["verdict"] in ("beaten", "matched", "missed")
        assert (folder / "renders.png").stat().st_size > 20_000 and (folder / "rendered_front.png").is_file()
        report = (folder / "report.md").read_text()
        assert "## As rendered" in report and f"({r['threshold']:.3g} here)" in report
    assert "rendered: the exact" in stdout


def test_pipeline_derive_on_schlick(schlick_runs):
    """The whole command's outputs: its files, its columns, an anchor placed and a found form at
    least as accurate at no more cycles (Karis's exp2 form: exp2 of a minimax quadratic), each
    exported function compiled and its twin equal to the member's value, the file's strings as text
    in every output (escaped where the format needs it); then in float16 from the kept search."""
    tmp_path, out, half, stdout, stdout_half = schlick_runs
    assert "the search of an earlier run" not in stdout
    results = json.loads((out / "results.json").read_text())
    # again in float16: the search kept (the same forms: their float64 errors as before), every form
    # executed and costed in 16 bits
    assert "the search of an earlier run" in stdout_half
    halves = json.loads((half / "results.json").read_text())
    assert halves["precision"] == "fp16" and halves["execution"]["inputs"] == 15361       # every float16 of [0, 1]
    shared = set(results["members"]) & set(halves["members"])
    assert len(shared) >= 3
    for name in shared:
        assert halves["members"][name]["max_abs_error_real"] == results["members"][name]["max_abs_error_real"]
    with open(half / "front.csv") as f:
        half_rows = list(csv.DictReader(f))
    assert {r["precision"] for r in half_rows} == {"fp16"}
    # float16's rounding: no executed form is nearer than half its spacing at 0.5 (values near 1 round so)
    assert min(float(r["max_abs_error"]) for r in half_rows) >= 2.0 ** -12
    # --certify: in float16 the sample was every input already, so the certified maxima are the sampled
    # ones; every front member, anchor and the exact target certified, each with Vulkan's worst beside it
    certification = halves["certification"]
    assert certification["inputs"] == 15361 and certification["passes"] >= 1
    for r in half_rows:
        assert r["certified"] == "exhaustive", r
        assert float(r["max_abs_error"]) == float(r["max_abs_error_sampled"])
        if r["max_abs_error_spec"]:
            assert float(r["max_abs_error_spec"]) >= float(r["max_abs_error"]) * (1 - 1e-9)
    report = (half / "report.md").read_text()
    assert "- Certified (`certified` = exhaustive in front.csv)" in report and "The worst a conforming driver" in report
    glsl16 = (half / "derive.glsl").read_text()
    assert "float16_t" in glsl16 and "GL_EXT_shader_explicit_arithmetic_types_float16" in glsl16
    with open(out / "front.csv") as f:
        rows = list(csv.DictReader(f))
    assert {"architecture", "expression", "cycles", "cycles_predicted", "max_abs_error", "max_rel_error",
            "kind", "max_abs_error_real", "max_rel_error_real", "precision"} <= set(rows[0])
    assert {r["kind"] for r in rows} == {"found", "anchor", "exact"} and {r["precision"] for r in rows} == {"fp32"}
    # the target itself as executed in float32: exact in float64, a few of float32's units as executed
    (exact,) = [r for r in rows if r["kind"] == "exact" and r["architecture"] == "rdna3"]
    assert float(exact["max_abs_error_real"]) == 0 and 0 < float(exact["max_abs_error"]) < 16 * 2.0 ** -24
    assert results["execution"]["inputs"] >= 1 << 22
    karis = next(r for r in rows if r["name"] == "Karis")
    found = [r for r in rows if r["kind"] == "found"]
    assert any(float(r["cycles"]) <= float(karis["cycles"]) and float(r["max_abs_error"]) <= float(karis["max_abs_error"])
               for r in found)
    assert results["verdicts"]["rdna3"]["Karis"]["verdict"] in ("beaten", "matched")
    assert results["coverage"]["exhaustive_complexity"] >= 5
    # the file's strings: as they are in results.json and front.csv; escaped in report.md (no HTML,
    # no cell split, no math); the function names identifiers of their own
    assert results["target"]["name"] == HOSTILE_NAME and karis["source"] == HOSTILE_SOURCE
    report = (out / "report.md").read_text()
    assert "<" not in report and escape.markdown(HOSTILE_NAME) in report and HOSTILE_NAME not in report
    assert f"Karis: {escape.markdown(HOSTILE_SOURCE)}" in report and escape.markdown("a | b $x$ `c`") in report
    # (the verdicts' rows and the rendered cheapest forms': 7 cells; the special functions' rows: 4; the
    # rendered verdicts': 8)
    assert all(line.count("|") in (8, 5, 9) for line in report.splitlines() if line.startswith("| rdna3 |"))
    assert publish.function_name(HOSTILE_NAME, "polynomial_1") == "script_script_alert_1_script_polynomial_1"
    assert "<" not in (out / "derive.glsl").read_text() + (out / "derive_twin.py").read_text()
    # Karis's error as measured, in the report as in results.json
    assert f"{results['verdicts']['rdna3']['Karis']['error']:.3g}" in (out / "report.md").read_text()
    spec = importlib.util.spec_from_file_location("derive_twin", out / "derive_twin.py")
    twin = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(twin)
    x = np.array([0.0, 0.2, 0.55, 0.9, 1.0])
    for name, member in results["members"].items():
        if member["kind"] != "found":
            continue
        value = targets.numpy_function(targets.parse(member["expression"]), targets.parse("x").free_symbols.pop())(x)
        got = [getattr(twin, publish.function_name(HOSTILE_NAME, name))(float(v)) for v in x]
        # (the twin holds the constants as executed, float32; the expression the float64 ones to 9 digits: terms
        # of size 1 differ by float32 rounding, a few 2^-24, which cancelling terms leave as an absolute difference)
        np.testing.assert_allclose(got, value, rtol=1e-6, atol=2e-7)
    # each function's comment shows the constants its body executes (float32: the same value)
    import re
    number = re.compile(r"(?<![\w.])\d+\.\d+(?:e[-+]?\d+)?")
    lines = (out / "derive.glsl").read_text().splitlines()
    bodies = [i for i, line in enumerate(lines) if line.startswith("    return ")]
    assert bodies
    for i in bodies:
        comment = lines[i - 3].split(": max abs error")[0]
        shown = [np.float32(float(v)) for v in number.findall(comment) if float(v) not in (1.0, 2.0)]
        executed = [np.float32(float(v)) for v in number.findall(lines[i]) if float(v) not in (1.0, 2.0)]
        assert sorted(shown) == sorted(executed), (lines[i - 3], lines[i])
    from tests.approximate.test_targets_and_forms import _validator
    validator = _validator()
    if validator is None:
        pytest.skip("glslangValidator not found: the exported functions were not compiled")
    first = publish.function_name(HOSTILE_NAME, next(n for n, m in results["members"].items() if m["kind"] == "found"))
    (tmp_path / "a.frag").write_text("#version 450\n" + (out / "derive.glsl").read_text()
                                     + f"\nlayout(location = 0) out vec4 c;\nvoid main() {{ c = vec4({first}(0.5)); }}\n")
    (tmp_path / "a.hlsl").write_text((out / "derive.hlsl").read_text()
                                     + f"\nfloat4 main() : SV_Target {{ return {first}(0.5); }}\n")
    first16 = publish.function_names(halves)[publish.exported(halves)[0]]
    (tmp_path / "h.frag").write_text("#version 450\n" + glsl16 + "\nlayout(location = 0) out vec4 c;\n"
                                     f"void main() {{ c = vec4(float({first16}(float16_t(0.5)))); }}\n")
    for args in ([str(tmp_path / "a.frag")], ["-D", "-e", "main", "-S", "frag", str(tmp_path / "a.hlsl")],
                 [str(tmp_path / "h.frag")]):
        done = subprocess.run([validator, "-V", "-o", str(tmp_path / "o.spv"), *args], capture_output=True, text=True)
        assert done.returncode == 0, done.stdout + done.stderr


def test_the_readme_example_of_the_python_api_runs(tmp_path, capsys, monkeypatch):
    """The README's Python example of `pipeline.derive`, executed as written: the member it picks is
    on RDNA3's front with an error below 1e-3, its GLSL is printed and its twin is the member's value
    at 0.5 (the Derivation's own forms, to 1e-12); the figure and the files are written."""
    import re
    from pathlib import Path

    import pipeline
    from pipeline.engine import paths

    if "rdna3" not in engines.available_architectures():
        pytest.skip("Mesa's RADV does not run here: the example was not run")
    monkeypatch.setattr(paths, "DERIVE_CACHE", tmp_path / "derive")
    readme = (Path(pipeline.__file__).parent.parent / "README.md").read_text()
    section = readme[readme.index("## `pipeline derive`"):]
    code = re.search(r"```python\n(.*?)```", section, re.S).group(1)
    scope: dict = {}
    exec(compile(code, "README.md", "exec"), scope)
    lines = capsys.readouterr().out.strip().splitlines()[-3:]
    found, best = scope["found"], scope["best"]
    assert best in found.front and best["architecture"] == "rdna3" and best["max_abs_error"] < 1e-3
    # the exact row: GLSL's acos as the driver executes it (Mesa's lowering, as RADV's), not 0, and a
    # found form beats it at fewer cycles
    (exact,) = [r for r in found.rows if r["kind"] == "exact"]
    assert exact["max_abs_error_real"] == 0 and 1e-5 < exact["max_abs_error"] < 1e-3
    judged = found.raw["verdicts"]["rdna3"]["exact"]
    assert judged["verdict"] == "beaten" and judged["by_cycles"] < exact["cycles"]
    assert exact["max_error_bound"] == exact["max_abs_error"]          # (Mesa's acos: nothing more on RDNA3)
    assert lines[0].split()[0] == best["name"] and lines[1] == found.glsl(best["name"])
    x = targets.parse("x").free_symbols.pop()
    printed = forms.in_format(found.raw["forms"][best["name"]].expression, "fp32")      # (float32's constants)
    exact_value = targets.numpy_function(printed, x)(np.array([0.5]))[0]
    assert float(lines[2]) == pytest.approx(exact_value, rel=1e-12)
    assert found.plot(tmp_path / "front.png").stat().st_size > 0
    assert {p.name for p in found.write(tmp_path / "out")} >= {"front.csv", "results.json", "report.md"}
    assert json.loads((tmp_path / "out" / "results.json").read_text())["target"]["name"] == "acos"
    try:
        import pandas  # noqa: F401
    except ImportError:
        with pytest.raises(ImportError, match="pandas"):
            found.dataframe()
    else:
        assert len(found.dataframe()) == len(found.rows)


def _function_in(text: str, name: str) -> str:
    """The function `name` of derive.glsl, its comment line included, as `publish.member_functions` writes it."""
    lines = text.splitlines()
    start = next(i for i, line in enumerate(lines) if f" {name}(" in line) - 1
    end = next(i for i in range(start, len(lines)) if lines[i] == "}")
    return "\n".join(lines[start:end + 1])


def test_report_html_opens_offline_in_a_browser(schlick_runs):
    """report.html from file:// in headless Chromium, the network blocked: one file under 3 MB that
    asks for nothing else, draws without a console error, shows each GPU's rows of front.csv as its
    points, opens a member's code as derive.glsl holds it, and runs the member's GLSL live, as a curve
    and in its role on a lit sphere, whose values equal the Python twin's at the inputs the shader used
    (float32: 1e-5 relative, 1e-6 absolute: the twin in float64 of the same constants, the shader's
    exp2 and rounding in float32)."""
    from tests.helpers import open_page

    _, out, half, _, _ = schlick_runs
    page_path = out / "report.html"
    text = page_path.read_text()
    assert page_path.stat().st_size < 3e6
    # the target's hostile name: only inside the JSON island, escaped (no script element it could close)
    assert HOSTILE_NAME not in text and "\\u003c/script\\u003e\\u003cscript\\u003ealert(1)" in text
    with open(out / "front.csv") as f:
        rows = list(csv.DictReader(f))
    spec = importlib.util.spec_from_file_location("derive_twin_page", out / "derive_twin.py")
    twin = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(twin)
    glsl = (out / "derive.glsl").read_text()
    with open_page(page_path) as opened:
        page = opened.page
        assert page.evaluate("document.title") == f"{HOSTILE_NAME}: (1 - x)**5"    # (as text)
        for architecture in ("rdna3", "gcn5"):
            page.evaluate(f"pageState.selectGpu('{architecture}')")
            points = page.evaluate("pageState.views.front.data('points').filter((p) => p.arch === pageState.arch).length")
            assert points == sum(r["architecture"] == architecture for r in rows)
            assert page.locator("#front-table tbody tr").count() == points
        member = next(r["name"] for r in rows if r["kind"] == "found" and r["architecture"] == "gcn5")
        page.locator(f"#front-table tbody tr[data-key='{member}']").click()
        page.wait_for_selector("#code")
        name = publish.function_name(HOSTILE_NAME, member)
        assert page.locator("#code").text_content() == _function_in(glsl, name)
        assert "v_" in page.locator("#listing").text_content()           # (AMD's listing: vector instructions)
        live = page.evaluate("pageState.live")
        assert live is not None and live["name"] == member, page.evaluate("document.getElementById('live-note')?.textContent")
        x = np.array(live["x"], dtype=np.float64)
        expected = np.array([getattr(twin, name)(float(v)) for v in x])
        np.testing.assert_allclose(live["form"], expected, rtol=1e-5, atol=1e-6)
        # in its place (the role the file declares): the Fresnel weight on a lit sphere, its inputs (VoH
        # from a light near the sphere) spread, the shader's values the twin's there
        sphere = page.evaluate("pageState.sphere")
        assert sphere is not None and sphere["name"] == member, page.locator("#live-note").all_text_contents()
        x = np.array(sphere["x"], dtype=np.float64)
        assert x.size > 10_000 and x.max() - x.min() > 0.2
        expected = np.array([getattr(twin, name)(float(v)) for v in x])
        np.testing.assert_allclose(sphere["term"], expected, rtol=1e-5, atol=1e-6)
        # the anchors' verdicts: one row per architecture
        assert page.locator("#verdicts tbody tr").count() == 2
        # as seen: each row's largest FLIP as front.csv has it, the rule's answer on the selected GPU, the renders
        assert page.locator("#front-table thead th").all_text_contents()[-1] == "largest FLIP"
        shown = {tr.get_attribute("data-key"): float(tr.locator("td").last.text_content())
                 for tr in page.locator("#front-table tbody tr").all()}
        assert shown == pytest.approx({r["name"]: float(r["flip_max"]) for r in rows if r["architecture"] == "gcn5"},
                                      rel=1e-3, abs=1e-6)       # (the table prints 4 significant digits)
        assert page.locator("#rendered-verdicts tbody tr").count() == 1
        assert page.locator("#rendered img").count() == 1
        assert opened.problems == [] and page.evaluate("pageState.errors") == []
        assert all(u.startswith("file://") for u in opened.requests) and len(set(opened.requests)) == 1
    # the float16 run's page: its live shader in mediump
    with open_page(half / "report.html") as opened:
        first = opened.page.evaluate("Object.keys(JSON.parse(document.getElementById('data').textContent).forms)[0]")
        opened.page.evaluate(f"pageState.openForm({json.dumps(first)})")
        opened.page.wait_for_selector("#code")
        assert "mediump float" in opened.page.evaluate(f"JSON.parse(document.getElementById('data').textContent).forms[{json.dumps(first)}].gles")
        assert opened.page.evaluate("pageState.live") is not None
        assert opened.problems == []


def test_a_constant_at_rounding_s_level_is_dropped_where_the_error_does_not_rise():
    """exp2(3.5e-18 - 1.44 x) for exp(-x): the 3.5e-18 goes (the error is the same without it); a
    1e-12 that the target holds stays (without it the error would be 1e-12)."""
    import sympy as sp

    x = sp.Symbol("x", real=True)
    target = targets.from_expression("exp(-x)", "x=0:4")
    form = forms.Form("exp2_polynomial_1", "found", "exp2_polynomial",
                      sp.Pow(2, sp.Float(3.516712879335507e-18) - sp.Float(1.4426950408889634) * x))
    dropped = anchor_refits.without_negligible(form, target, target.numpy())
    assert dropped.expression == sp.Pow(2, -sp.Float(1.4426950408889634) * x)
    shifted = targets.from_expression("x + 1e-12 + 2", "x=0:1")
    kept = forms.Form("line", "found", "polynomial", x + sp.Float(1e-12) + sp.Float(2.0))
    assert anchor_refits.without_negligible(kept, shifted, shifted.numpy()) == kept


def test_a_run_is_named_by_name_else_by_its_target_or_expression():
    """--expr names the run by the expression itself (no "expr"), --name replaces any name, a blank
    --name is refused naming the option; the functions are identifiers made from the name."""
    from pipeline.approximate import api

    assert api.resolve(expr="exp(-x)", var="x=0:4").name == "exp(-x)"
    assert api.resolve(target="schlick").name == "schlick"
    assert api.resolve(expr="exp(-x)", var="x=0:4", name="decay").name == "decay"
    with pytest.raises(targets.DeriveError, match="--name: give the run a name"):
        api.resolve(expr="exp(-x)", var="x=0:4", name="  ")
    assert publish.function_name("exp(-x)", "polynomial_1") == "exp_x_polynomial_1"


@pytest.mark.parametrize("target, name, precision, expected", [
    (dict(name="schlick", expression="(1 - x)**5", variable="x", domain=[0.0, 1.0]), None, "fp32",
     "pipeline derive --target schlick --gpu rdna3,sm_89"),
    (dict(name="exp(-x)", expression="exp(-x)", variable="x", domain=[0.0, 4.0]), None, "fp16",
     "pipeline derive --expr 'exp(-x)' --var x=0:4 --gpu rdna3,sm_89 --precision fp16"),
    (dict(name="decay", expression="exp(-t)", variable="t", domain=[0.5, 2.0]), "decay", "fp32",
     "pipeline derive --expr 'exp(-t)' --var t=0.5:2 --name decay --gpu rdna3,sm_89"),
])
def test_the_page_s_rerun_command_names_the_run_as_it_was_made(target, name, precision, expected):
    """A registered target by name; an expression by --expr and --var, and --name where the run was
    named otherwise; read back by the CLI's own parser and `api.resolve`, the same target."""
    import shlex

    from pipeline.approximate import api
    from pipeline.approximate.publishing import derive_page
    from pipeline.cli import build_parser

    command = derive_page.rerun_command(dict(target=target, architectures=["rdna3", "sm_89"], precision=precision))
    assert command == expected
    args = build_parser().parse_args(shlex.split(command)[1:])
    again = api.resolve(args.target, args.expr, args.var, name=args.name)
    assert (again.name, again.expression, again.variable, list(again.domain)) == (
        target["name"], target["expression"], target["variable"], target["domain"])
    # a certified run, and one whose forms were written precise, rerun as such (read back by the parser)
    flagged = derive_page.rerun_command(dict(target=target, architectures=["rdna3"], precision=precision,
                                             certification={}, contract="never"))
    args = build_parser().parse_args(shlex.split(flagged)[1:])
    assert flagged.endswith("--certify --contract never") and args.certify and args.contract == "never"


def test_a_run_without_anchors_says_why_it_has_no_verdict():
    text = publish.no_verdict_text(dict(missing={"nvidia": "ptxas is not installed"}))
    assert text.startswith("No verdict: the target has no hand fit") and "(nvidia: ptxas is not installed)." in text
    assert publish.no_verdict_text(dict(missing={})).endswith("is not judged for a target of several variables.")


def test_what_was_not_compiled_is_said_with_its_reason():
    """The report's and the command's line for an architecture whose compiler did not run: each
    missing part with its reason; nothing where every architecture compiled."""
    missing = {"arm": "its compiler did not run", "exact on arm": "Arm: the arm64 Mesa in /x lacks usr/bin/python3.11"}
    text = publish.not_compiled_text(dict(missing=missing))
    assert text == ("Not compiled: arm: its compiler did not run; exact on arm: Arm: the arm64 Mesa in /x lacks "
                    "usr/bin/python3.11.")
    assert publish.not_compiled_text(dict(missing={})) == ""
