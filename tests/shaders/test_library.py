"""A shader library as one batch (`approximate.engines.library`): the files a folder or a glob names,
a task per function on a LocalCluster of 2 workers, each task's outcome kept by what the function
computes; a planted engine (every function none cheaper) so that the batch's own work is tested."""

import dataclasses
import shutil
import sys
import types
from pathlib import Path

import pytest

from pipeline.approximate.engines import library
from pipeline.shaders import definitions, harness

HERE = Path(__file__).parent
LIBRARY = HERE / "library"
TONEMAP = """// derive: x=0:4 calls=3
float reinhard(float x) { return x / (1.0 + x); }

// derive: x=0:1
float gamma_22(float x) { return pow(x, 1.0 / 2.2); }
"""


def planted_derive(target, log, **settings):
    """Every function none cheaper: its anchor alone, 10 cycles on each architecture asked for."""
    from pipeline.approximate.targets import parse

    architectures = settings.get("gpu") or ["rdna3"]
    members = {"as shipped": target.anchors[0].expression}
    if target.name == "reinhard":                   # (reinhard alone gets a cheaper form: derived)
        members["found"] = "1 - 1/(1 + x)"
    return types.SimpleNamespace(raw=dict(
        error="max_abs_error", rounding_floor=1e-7, architectures=architectures, precision="fp32",
        forms={n: types.SimpleNamespace(expression=parse(t, target.names)) for n, t in members.items()},
        members={n: dict(kind="anchor" if n == "as shipped" else "found", max_abs_error=1e-7, expression=t)
                 for n, t in members.items()},
        cycles={a: {"as shipped": 10.0, "found": 6.0} for a in architectures}))


@pytest.fixture(scope="module")
def cluster():
    import cloudpickle

    from pipeline.engine.cluster import client

    cloudpickle.register_pickle_by_value(sys.modules[__name__])     # (the planted engine, into the workers)
    dask_client, local = client(workers=2)
    yield dask_client
    dask_client.close()
    local.close()


def _library(root: Path) -> Path:
    """The tests' library (`tests/shaders/library/`: 14 annotated functions in GLSL and HLSL, and a file
    of constants they include), the engine-style file beside it, a file that does not compile, and a
    file that is not a shader."""
    shaders = root / "shaders"
    shutil.copytree(LIBRARY, shaders)
    for name in ("engine_style.glsl", "engine_constants.glsl"):
        shutil.copy(HERE / name, shaders / name)
    (shaders / "post").mkdir()
    (shaders / "post" / "broken.glsl").write_text("float half_of(float x) { return x * ; }\n")
    (shaders / "notes.txt").write_text("not a shader")
    return shaders


def records(cache: Path) -> list[str]:
    return (cache / "records.log").read_text().splitlines() if (cache / "records.log").exists() else []


def test_a_library_is_derived_as_one_batch_and_a_rerun_computes_only_what_changed(tmp_path, cluster):
    shaders = _library(tmp_path)
    files = library.shader_files([shaders])
    assert [f.name for f in files] == ["brdf.glsl", "color.glsl", "constants.glsl", "engine_constants.glsl",
                                       "engine_style.glsl", "lighting.hlsl", "math.glsl", "broken.glsl"]
    assert library.shader_files([str(shaders / "**" / "*.glsl")]) == \
        [f for f in files if f.suffix == ".glsl"]
    with pytest.raises(definitions.ShaderError, match="no such file or folder"):
        library.shader_files([tmp_path / "none"])
    options_of = lambda p: harness.Options(definitions.language_of(p))       # noqa: E731
    work = library.tasks(files, options_of)                 # (the constants' files: no task)
    files = [f for f in files if "constants" not in f.name]
    assert len(work) == 2 + 4 + 13 + 4 + 4 + 1 and len(set(work)) == len(work)     # (saturate_'s overloads one task)
    settings = dict(gpu=["rdna3"])
    cache = tmp_path / "kept"
    said = []
    found = library.derive_library(work, options_of, None, settings, cache, cluster, planted_derive, said.append)
    assert list(found) == work and said[0] == "28 functions of 6 files on 2 Dask workers"
    assert said[-1].startswith("[28/28] ") and "0 running, 0 left" in said[-1]
    assert all(0 <= int(s.split("; ")[1].split()[0]) <= 2 for s in said[1:])      # (running: at most a task a worker)
    status = {(p.name, n): [o.status for o in outcomes] for (p, n), outcomes in found.items()}
    assert status[("color.glsl", "reinhard")] == ["derived"] and status[("math.glsl", "acos_fast")] == \
        ["none cheaper"]
    assert sum(s == ["none cheaper"] for (f, _), s in status.items() if f != "engine_style.glsl") == 13
    assert status[("engine_style.glsl", "sum_loop")] == ["refused"] and status[("engine_style.glsl", "saturate_")] \
        == ["refused", "refused"]
    (broken,) = found[(files[-1], "half_of")]
    assert broken.status == "refused" and "does not compile" in broken.reason and \
        "broken.glsl" in broken.reason
    assert sorted(r.split()[0] for r in records(cache)) == ["computed"] * 28
    # nothing changed: every task kept
    again = library.derive_library(work, options_of, None, settings, cache, cluster, planted_derive, lambda s: None)
    assert [r.split()[0] for r in records(cache)[28:]] == ["kept"] * 28
    assert {k: [o.status for o in v] for k, v in again.items()} == {k: [o.status for o in v] for k, v in found.items()}
    # one function's body edited (the same lines), and a comment added above another: that function alone
    # computed again (math.glsl's acos_fast, the same text, is another file's: kept), the other kept in its new place
    glsl = next(f for f in files if f.name == "engine_style.glsl")
    glsl.write_text(glsl.read_text().replace("(-0.156583 * x + HALF_PI)", "(-0.156500 * x + HALF_PI)"))
    color = next(f for f in files if f.name == "color.glsl")
    color.write_text(color.read_text().replace("// derive: x=0:4 calls=3", "// Reinhard's operator\n// derive: x=0:4 calls=3"))
    moved = library.derive_library(work, options_of, None, settings, cache, cluster, planted_derive, lambda s: None)
    computed = [r.split()[1:3] for r in records(cache)[56:] if r.startswith("computed")]
    assert computed == [["engine_style.glsl", "acos_fast"]]
    (reinhard,) = moved[(color, "reinhard")]
    assert reinhard.line == found[(color, "reinhard")][0].line + 1 and \
        color.read_bytes()[reinhard.definition.start:].startswith(b"float reinhard(")
    # what the library run writes: each file's run under files/, one patch that applies, the totals the rows' sums
    from pipeline.approximate.publishing import library_outputs

    from pipeline.approximate.engines import platform_answer

    by_file = {}
    for (path, _), outcomes in moved.items():        # (the planted results hold no derive run's files)
        by_file.setdefault(path, []).extend(dataclasses.replace(
            o, results=None, pieces=[dataclasses.replace(p, results=None) for p in o.pieces],
            platforms={"one": platform_answer.answer(o.results, ["rdna3"], o.budget)} if o.results else {})
            for o in outcomes)
    out = tmp_path / "out"
    library_outputs.write(out, by_file, {p: definitions.language_of(p) for p in by_file}, dict(workers=2, seconds=1.0),
                          log=lambda s: None)
    assert sorted(p.name for p in (out / "files").iterdir()) == ["brdf.glsl", "color.glsl", "engine_style.glsl",
                                                                  "lighting.hlsl", "math.glsl", "post__broken.glsl"]
    data = __import__("json").loads((out / "library.json").read_text())
    rows = [r for r in data["rows"] if r["architecture"] == "rdna3"]
    assert {r["function"]: r["calls"] for r in rows}["reinhard"] == 3.0
    assert data["totals"]["rdna3"] == dict(functions=len(rows),
                                           cycles_before=sum(r["calls"] * r["cycles_before"] for r in rows),
                                           cycles_after=sum(r["calls"] * r["cycles_after"] for r in rows))
    assert data["totals"]["rdna3"]["cycles_before"] - data["totals"]["rdna3"]["cycles_after"] == 3 * 4.0
    assert data["platforms"]["one"]["cycles_before"] - data["platforms"]["one"]["cycles_after"] == 3 * 4.0
    shipped = [r for r in data["platform_rows"] if r["form"] is not None]
    assert data["platforms"]["one"] == dict(functions=len(shipped),
                                            cycles_before=sum(r["calls"] * r["cycles_before"] for r in shipped),
                                            cycles_after=sum(r["calls"] * r["cycles_after"] for r in shipped))
    assert {r["function"]: r["form"] for r in shipped}["reinhard"] == "found"
    text = (out / "library.md").read_text()
    assert "## Totals per platform" in text and "| color.glsl | reinhard | one | found | 10 → 6 |" in text
    assert (out / "savings.png").read_bytes()[:4] == b"\x89PNG"
    # library.html: every function, the derived one first (sorted by saving), the totals among the facts
    from tests.helpers import open_page

    with open_page(out / "library.html") as opened:
        page = opened.page
        first = page.locator("#functions-table tbody tr").first.locator("td")
        assert first.nth(0).text_content() == "color.glsl: reinhard" and first.nth(2).text_content() == "derived"
        names = {a.text_content() for a in page.locator("#functions-table tbody tr td:first-child a").all()}
        assert len(names) == 29          # (28 tasks; saturate_ has two overloads)
        assert "total cycles, rdna3" in page.locator("dl.facts").first.text_content()
        assert page.evaluate("pageState.views.cycles.data('source_0').length") == 2    # (the derived one's bars)
        assert opened.problems == []
    patch = (out / "library.patch").read_text()
    assert patch.count("+++ b/") == 1 and patch.startswith("--- a/color.glsl\n")
    assert "-    return x / (1.0 + x);\n+    return 1.0 - 1.0/(x + 1.0);\n" in patch
    # it applies to a copy of the library from the library's folder, and the patched file compiles
    import subprocess

    copy = tmp_path / "copy"
    shutil.copytree(shaders, copy)
    done = subprocess.run(["git", "apply", str(out / "library.patch")], cwd=copy, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    patched = copy / "color.glsl"
    options = harness.Options("glsl")
    reinhard = next(d for d in definitions.read(patched)[1] if d.name == "reinhard")
    assert "OpFunction" in harness.disassembly(harness.preprocessed(patched, options), reinhard, options, patched)
    assert "library.md" in [p.name for p in out.iterdir()]


class DyingEngine:
    """The planted engine, whose worker dies the first time it derives reinhard (the file `marker`
    says it did)."""

    def __init__(self, marker: Path):
        self.marker = marker

    def __call__(self, target, log, **settings):
        import os

        if target.name == "reinhard" and not self.marker.exists():
            self.marker.write_text("died once")
            os._exit(1)
        return planted_derive(target, log, **settings)


def test_a_worker_killed_mid_batch_leaves_a_complete_batch(tmp_path, cluster):
    """reinhard's worker dies mid-task: Dask runs it again on a worker that lives, the batch completes
    with every row, and each function is derived once (the dead attempt recorded nothing)."""
    shaders = tmp_path / "shaders"
    shaders.mkdir()
    (shaders / "tonemap.glsl").write_text(TONEMAP)
    marker = tmp_path / "marker"
    work = library.tasks(library.shader_files([shaders]), lambda p: harness.Options("glsl"))
    cache = tmp_path / "kept"
    found = library.derive_library(work, lambda p: harness.Options("glsl"), None, dict(gpu=["rdna3"]), cache, cluster,
                                   DyingEngine(marker), lambda s: None)
    assert marker.read_text() == "died once"
    assert {n: [o.status for o in v] for (_, n), v in found.items()} == dict(reinhard=["derived"],
                                                                           gamma_22=["none cheaper"])
    assert sorted(r.split()[2] for r in records(cache)) == ["gamma_22", "reinhard"]


@pytest.mark.parametrize("argv, message", [
    (["--shader", "a.glsl", "b.glsl", "--function", "f"], "--function goes with one file"),
    (["--expr", "x*x", "--workers", "2"], "--workers goes with --shader"),
    (["--shader", str(HERE / "engine_style.glsl"), "--workers", "2"], "--scheduler and --workers go with a library"),
    (["--shader", "no_such_folder/"], "--shader no_such_folder/: no such file or folder"),
    (["--shader", ".", "--seconds", "1"], "--seconds 1: give a number in [5, 3600]"),
])
def test_a_library_s_options_out_of_place_are_one_line_and_exit_2(argv, message, tmp_path, capsys, monkeypatch):
    from pipeline.cli import main

    monkeypatch.chdir(tmp_path)
    for name in ("a.glsl", "b.glsl"):
        (tmp_path / name).write_text("float f(float x) { return x; }\n")
    assert main(["derive", *argv, "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1 and not (tmp_path / "out").exists()


def test_calls_is_a_positive_number():
    from pipeline.shaders import intent

    assert intent.parse("x=0:1 calls=2.5", "here")["calls"] == 2.5
    for bad, message in (("calls=0", "calls=0: give a number > 0"), ("calls=many", "calls = 'many': give a number")):
        with pytest.raises(definitions.ShaderError, match=message):
            intent.parse(bad, "here")


def test_the_command_runs_a_library_on_an_existing_cluster(tmp_path, cluster):
    """`pipeline derive --shader DIR --scheduler ADDRESS`, the real engine, on a cluster started before
    it (the fixture's, as another process would start one): its workers derive the one function, the
    cost table compiled once first, and library.md names the cluster and its 2 workers; the run's
    exit is 0 and every file is written."""
    import subprocess

    from tests.helpers import cli_env

    shaders = tmp_path / "shaders"
    shaders.mkdir()
    (shaders / "tonemap.glsl").write_text(TONEMAP.split("\n\n")[0] + "\n")
    address = cluster.scheduler.address
    done = subprocess.run([sys.executable, "-m", "pipeline", "derive", "--shader", str(shaders), "--scheduler", address,
                           "--gpu", "rdna3", "--seconds", "5", "--max-complexity", "3", "--out", str(tmp_path / "out")],
                          capture_output=True, text=True, timeout=600,
                          env=cli_env(tmp_path, PIPELINE_DERIVE_CACHE=str(tmp_path / "derive")))
    assert done.returncode == 0, done.stdout + done.stderr
    assert "cost tables of 1 architecture ready" in done.stdout and "[1/1] tonemap.glsl:reinhard computed" in \
        done.stdout
    text = (tmp_path / "out" / "library.md").read_text()
    assert f"on 2 Dask workers of the cluster at `{address}`" in text
    assert {p.name for p in (tmp_path / "out").iterdir()} >= {"library.md", "library.json", "library.html",
                                                               "library.patch", "savings.png", "files"}
