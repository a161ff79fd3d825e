"""Platforms as data (`isa.platforms`) and the answer for a platform (`engines.platform_answer`): the
shipped file's platforms, a user's file adding and replacing them, each fault in one line; `--gpu`
words as platforms and architectures; the answer against a brute-force choice on planted cycles."""


import numpy as np
import pytest

from pipeline.approximate.engines.pieces import PIECES
from pipeline.approximate.engines.platform_answer import answer
from pipeline.isa import platforms
from pipeline.isa.architectures import ARCHITECTURES


def test_the_shipped_platforms_and_a_user_s_file(tmp_path):
    shipped = platforms.read()
    assert shipped["desktop"].architectures == ("rdna3", "rdna2", "sm_89", "sm_86", "xe_hpg")
    assert shipped["android"].architectures == ("a740", "a630", "g610", "g72") and shipped["android"].precision == "fp16"
    assert shipped["all"].architectures == tuple(ARCHITECTURES)
    mine = tmp_path / "mine.toml"
    mine.write_text('[console]\narchitectures = ["rdna2"]\n\n[android]\narchitectures = ["a740"]\nprecision = "fp32"\n')
    read = platforms.read(mine)
    assert read["console"].architectures == ("rdna2",) and read["android"] == platforms.Platform(
        "android", ("a740",), "fp32", "") and read["desktop"] == shipped["desktop"]
    assert platforms.architectures_of(["android", "rdna3", "a740", "desktop"], read) == \
        ["a740", "rdna3", "rdna2", "sm_89", "sm_86", "xe_hpg"]


@pytest.mark.parametrize("text, message", [
    ('[m]\narchitectures = ["a999"]\n', "[m] architectures: 'a999' is not an architecture"),
    ('[m]\narchitectures = []\n', "[m] architectures: give a list of architectures' names"),
    ('[m]\narchitectures = ["g72"]\nprecision = "fp8"\n', "[m] precision = 'fp8': give one of fp32, fp16"),
    ('[m]\narchitectures = ["g72"]\ntier = 2\n', "[m] tier: unknown key"),
    ('[rdna3]\narchitectures = ["g72"]\n', "[rdna3]: an architecture's name"),
    ('m = 3\n', "m = 3: a platform is a table"),
    ('[m\n', "is not valid TOML"),
])
def test_a_wrong_platforms_file_is_one_line_naming_it(tmp_path, text, message):
    path = tmp_path / "p.toml"
    path.write_text(text)
    with pytest.raises(platforms.PlatformError) as e:
        platforms.read(path)
    assert message in str(e.value) and "\n" not in str(e.value)


def test_an_unknown_gpu_word_names_both_lists():
    with pytest.raises(platforms.PlatformError, match=r"--gpu 'mobile': neither a platform \(desktop, android, all\)"):
        platforms.architectures_of(["mobile"], platforms.read())


def _results(rng, names, architectures):
    members = {"as shipped": dict(kind="anchor", max_abs_error=float(rng.uniform(0, 1e-3)))}
    members |= {n: dict(kind="found", max_abs_error=float(rng.uniform(0, 2e-3)), parameter_per="") for n in names}
    members["hand fit"] = dict(kind="anchor", max_abs_error=0.0)
    members[PIECES] = dict(kind="anchor", max_abs_error=float(rng.uniform(0, 2e-3)))
    cycles = {a: {n: float(rng.integers(2, 12)) for n in members} for a in architectures}
    return dict(error="max_abs_error", members=members, cycles=cycles)


def test_the_answer_is_the_brute_force_choice_on_planted_cycles():
    """200 planted derivations (6 found members, the shipped function, a hand fit, the branch of
    pieces; cycles 2 to 11 on 4 architectures): the answer is the candidate whose worst cycles are
    least (then total, error, name), found by trying every candidate; the hand fit never; each
    architecture's own cheapest; the variant's saving the difference."""
    rng = np.random.default_rng(1)
    architectures = ["a740", "a630", "g610", "g72"]
    for trial in range(200):
        results = _results(rng, [f"f{i}" for i in range(6)], architectures)
        budget = 1e-3
        got = answer(results, architectures, budget)
        allowed = [n for n, m in results["members"].items() if n != "hand fit" and m["max_abs_error"] <= budget]
        if not allowed:
            assert got is None
            continue
        best = None
        for n in allowed:
            on = [results["cycles"][a][n] for a in architectures]
            key = (max(on), sum(on), results["members"][n]["max_abs_error"], n)
            best = key if best is None or key < best else best
        assert got["name"] == best[3] and got["worst"] == best[0], trial
        for a in architectures:
            cheapest = min(results["cycles"][a][n] for n in allowed)
            assert got["own"][a][1] == cheapest and got["variant_saving"][a] == results["cycles"][a][got["name"]] - cheapest
    # one architecture's cycles flip the answer: f0 is cheapest everywhere but on g72
    results = dict(error="max_abs_error", members={"as shipped": dict(kind="anchor", max_abs_error=1e-4),
                                                   "f0": dict(kind="found", max_abs_error=1e-4),
                                                   "f1": dict(kind="found", max_abs_error=1e-4)},
                   cycles={a: {"as shipped": 10.0, "f0": 3.0, "f1": 5.0} for a in architectures})
    assert answer(results, architectures, 1e-3)["name"] == "f0"
    results["cycles"]["g72"]["f0"] = 6.0
    got = answer(results, architectures, 1e-3)
    assert got["name"] == "f1" and got["own"]["a740"] == ("f0", 3.0) and got["variant_saving"]["a740"] == 2.0
    assert list(got["cycles"]) == architectures


def test_derive_takes_a_platform_s_name_and_its_format(tmp_path, capsys):
    """`--gpu` words become architectures and the platforms' format the run's where --precision is
    not given (`api.gpu_of`); an unknown word, platforms of two formats without --precision, a wrong
    --platforms file: exit 2, one line, nothing written."""
    from pipeline.approximate import api
    from pipeline.cli import main

    shipped = platforms.read()
    assert api.gpu_of("android,rdna3") == (["a740", "a630", "g610", "g72", "rdna3"], "fp16",
                                           {"android": shipped["android"]})
    assert api.gpu_of(["desktop"], precision="fp16") == (["rdna3", "rdna2", "sm_89", "sm_86", "xe_hpg"], "fp16",
                                                         {"desktop": shipped["desktop"]})
    assert api.gpu_of(["sm_89"]) == (["sm_89"], None, {})
    out = tmp_path / "out"
    for argv, message in ((["--gpu", "mobile"], "--gpu 'mobile': neither a platform"),
                          (["--gpu", "android,desktop"], "its platforms compute in fp16 and fp32: give --precision"),
                          (["--platforms", str(tmp_path / "none.toml")], "the platforms file"),):
        capsys.readouterr()
        assert main(["derive", "--expr", "x*x", *argv, "--out", str(out)]) == 2
        err = capsys.readouterr().err
        assert message in err and err.count("\n") == 1 and not out.exists()


def test_a_shader_run_on_a_platform_states_its_answer(monkeypatch):
    """`derive --shader --gpu android`: the platform's architectures derived in its format (fp16),
    and per function the platform's answer (planted cycles: f1 is cheapest on three of four
    architectures, f2 has the least worst cycles), in report.md with what variants would save."""
    import types
    from pathlib import Path

    from pipeline.approximate import api
    from pipeline.approximate.publishing import shader_outputs
    from pipeline.approximate.targets import parse

    asked = {}

    def derive(target, log, gpu, precision, **settings):
        asked.update(gpu=gpu, precision=precision)
        members = {"as shipped": (target.anchors[0].expression, 9e-3), "f1": ("x", 5e-3), "f2": ("x*x", 5e-3)}
        cycles = {"a740": (9.0, 3.0, 4.0), "a630": (9.0, 3.0, 4.0), "g610": (9.0, 3.0, 4.0), "g72": (9.0, 7.0, 5.0)}
        return types.SimpleNamespace(raw=dict(
            error="max_abs_error", rounding_floor=1e-3, architectures=list(cycles), precision=precision,
            forms={n: types.SimpleNamespace(expression=parse(t, target.names)) for n, (t, _) in members.items()},
            members={n: dict(kind="anchor" if n == "as shipped" else "found", max_abs_error=e, expression=t)
                     for n, (t, e) in members.items()},
            cycles={a: dict(zip(members, c)) for a, c in cycles.items()}))

    monkeypatch.setattr(api, "derive", derive)
    path = Path(__file__).parents[1] / "shaders" / "engine_style.glsl"
    found = api.derive_shader(path, "acos_fast", gpu="android", log=lambda s: None)
    assert asked == dict(gpu=["a740", "a630", "g610", "g72"], precision="fp16")
    (o,) = found.outcomes
    answer = o.platforms["android"]
    assert answer["name"] == "f2" and answer["worst"] == 5.0 and answer["variant_saving"] == dict(
        a740=1.0, a630=1.0, g610=1.0, g72=0.0)
    report = shader_outputs.report(path, found.outcomes, "glsl")
    assert "| android | f2 | 5 | 0.005 | a740 4, a630 4, g610 4, g72 5 | a740 1, a630 1, g610 1 |" in report
