"""The target registry, a user's target (expression or TOML file) and its faults, and the printing
of a form as GLSL, HLSL and a Python twin."""

import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

from pipeline.approximate import forms, targets
from pipeline.approximate.measures import measure
from pipeline.approximate.targets import DeriveError


@pytest.mark.parametrize("name", list(targets.one_variable_targets()))
def test_a_registered_target_is_one_expression_in_numpy_jax_and_sympy(name):
    target = targets.check(targets.registry()[name])
    x = np.linspace(*target.domain, 7)
    numpy_value = target.numpy()(x)
    jax_value = np.asarray(target.jax()(x))
    sympy_value = [float(target.sympy().subs(target.symbol(), v)) for v in x]
    np.testing.assert_allclose(jax_value, numpy_value, rtol=1e-13, atol=1e-300)
    np.testing.assert_allclose(sympy_value, numpy_value, rtol=1e-13, atol=1e-300)
    assert target.anchors and all(a.source for a in target.anchors)


def test_the_anchors_errors_against_an_independent_grid():
    """Karis's and Lagarde's published fits, measured by `measure.max_error`, against a 10^6-point
    grid: Karis's exp2 form errs up to 3.77e-3 on (1 - x)^5, Lagarde's up to 9.01e-3 on acos."""
    for name, anchor in (("schlick", "Karis"), ("acos", "Lagarde")):
        target = targets.registry()[name]
        approx = targets.numpy_function(target.anchor_expressions()[anchor], target.symbol())
        found = measure.max_error(approx, target.numpy(), *target.domain)["max_abs_error"]
        x = np.linspace(*target.domain, 1_000_001)
        assert found == pytest.approx(np.max(np.abs(approx(x) - target.numpy()(x))), rel=1e-6)
    assert measure.max_error(targets.numpy_function(targets.registry()["schlick"].anchor_expressions()["Karis"],
                                                    sp.Symbol("x", real=True)),
                             lambda s: (1 - s) ** 5, 0.0, 1.0)["max_abs_error"] == pytest.approx(3.77e-3, rel=2e-3)


@pytest.mark.parametrize("expression, var, message", [
    ("log(x)", "x=0:1", "not finite at x = 0"),
    ("atan(x", "x=0:1", "does not parse"),
    ("y * x", "x=0:1", "unknown name 'y'"),
    ("foo(x)", "x=0:1", "unknown function 'foo'"),
    ("x", "x=1:0", "lo < hi"),
    ("x", "x:0:1", "NAME=LO:HI"),
    ("x", "c=0:1", "variable 'c'"),
])
def test_a_bad_expression_is_one_clear_message(expression, var, message):
    with pytest.raises(DeriveError, match=message):
        targets.from_expression(expression, var)


def test_a_target_of_any_sympy_function():
    """erf, which no shader language has, is a target all the same (numpy through scipy)."""
    target = targets.from_expression("erf(t)", "t=0:2")
    assert target.numpy()(np.array([1.0]))[0] == pytest.approx(0.8427007929497149, rel=1e-14)


def test_a_target_from_a_file(tmp_path):
    path = tmp_path / "atan.toml"
    path.write_text('[target]\nname = "atan"\nexpression = "atan(x)"\ndomain = [0, 1]\nmetric = "rel"\nfloor = 0.01\n'
                    '[[anchor]]\nname = "mine"\nexpression = "x * (0.97 - 0.19 * x * x)"\nsource = "a test"\n')
    target = targets.named(str(path))
    assert (target.name, target.metric, target.floor, target.anchors[0].name) == ("atan", "rel", 0.01, "mine")
    path.write_text('[target]\nexpression = "atan(x)"\ncolour = "red"\n')
    with pytest.raises(DeriveError, match="unknown key 'colour'"):
        targets.named(str(path))
    path.write_text('[target]\nexpression = "x"\n[[anchor]]\nname = "a"\n')
    with pytest.raises(DeriveError, match="anchor"):
        targets.named(str(path))
    with pytest.raises(DeriveError, match="target file '.*' does not exist"):
        targets.named(str(tmp_path / "none.toml"))


def test_every_source_of_a_target_yields_the_one_type(tmp_path):
    """A registered name of each shape, an expression, a TOML file of one variable and of [[variable]]
    tables, a CSV table and a Target given: each read by the one reader (`targets.read`) into a
    `targets.Target`, whose `shape` names the engine that derives it (a pair's two parts Targets
    too); a one-variable expression and a one-variable file are the same target."""
    one = tmp_path / "one.toml"
    one.write_text('[target]\nname = "atan"\nexpression = "atan(x)"\ndomain = [0, 1]\n')
    box = tmp_path / "box.toml"
    box.write_text('[target]\nname = "d"\nexpression = "1/(1 + x*y*a)"\nmetric = "rel"\n'
                   '[[variable]]\nname = "x"\nrange = [0, 1]\n[[variable]]\nname = "y"\nrange = [0, 1]\n'
                   '[parameter]\nname = "a"\nrange = [0.5, 2]\n')
    table = tmp_path / "law.csv"
    table.write_text("x,a,value\n" + "".join(f"{x},{a},{1 / (1 + a * x)!r}\n" for x in (0.0, 0.25, 0.5, 0.75, 1.0)
                                             for a in (0.5, 1.0, 1.5, 2.0)))
    given = targets.Target("mine", "x*x", (targets.Axis("x", 0.0, 2.0),))
    sources = {
        "a registered function of one variable": (dict(target="schlick"), targets.ONE_VARIABLE),
        "a registered function of several variables": (dict(target="smith_ggx_visibility"), targets.SEVERAL_VARIABLES),
        "a registered table": (dict(target="env_brdf_scale"), targets.SEVERAL_VARIABLES),
        "a registered pair": (dict(target="env_brdf"), targets.PAIR),
        "an expression": (dict(expr="atan(x)", name="atan"), targets.ONE_VARIABLE),
        "a TOML file of one variable": (dict(target=str(one)), targets.ONE_VARIABLE),
        "a TOML file of [[variable]] tables": (dict(target=str(box)), targets.SEVERAL_VARIABLES),
        "a CSV table": (dict(table=str(table), x="x", parameter="a"), targets.SEVERAL_VARIABLES),
        "a Target": (dict(target=given), targets.ONE_VARIABLE),
    }
    read = {what: targets.read(**arguments) for what, (arguments, _) in sources.items()}
    assert {what: (type(t), t.shape) for what, t in read.items()} == {
        what: (targets.Target, shape) for what, (_, shape) in sources.items()}
    assert [type(p) for p in read["a registered pair"].parts] == [targets.Target, targets.Target]
    assert read["an expression"].numpy()(np.array([0.5])) == read["a TOML file of one variable"].numpy()(np.array([0.5]))
    assert (read["an expression"].variables, read["an expression"].parameter) == (
        read["a TOML file of one variable"].variables, None)
    assert read["a Target"] is given


def test_the_engines_take_the_target_of_their_shape(monkeypatch):
    """`engines.derive` hands each checked target to the engine of its shape (planted engines record
    what they receive), and no engine or search module calls the targets' readers: a target is read
    once, before the engine."""
    import ast

    from pipeline.approximate import engines
    from pipeline.approximate.engines import one_variable, pairs, several_variables

    received = []
    for module, function in ((one_variable, "derive"), (several_variables, "derive"), (pairs, "derive_pair")):
        monkeypatch.setattr(module, function, lambda target, *args, name=module.__name__, **kwargs:
                            received.append((target.name, name.rsplit(".", 1)[1])) or {})
    for name in ("schlick", "smith_ggx_visibility", "env_brdf"):
        engines.derive(targets.read(name), ["rdna3"], None, None, 4)
    assert received == [("schlick", "one_variable"), ("smith_ggx_visibility", "several_variables"),
                        ("env_brdf", "pairs")]
    readers = {"read", "named", "from_expression", "from_file", "from_csv", "with_range", "check", "registry",
               "one_variable_targets", "several_variable_targets", "pairs"}
    package = Path(engines.__file__).parent.parent
    called = {}
    for room in ("engines", "search"):
        for path in (package / room).glob("*.py"):
            for node in ast.walk(ast.parse(path.read_text())):
                if isinstance(node, ast.ImportFrom) and node.module and node.module.endswith("targets"):
                    for alias in node.names:
                        if alias.name in readers:
                            called.setdefault(path.name, []).append(alias.name)
                if (isinstance(node, ast.Attribute) and node.attr in readers and isinstance(node.value, ast.Name)
                        and node.value.id == "targets"):
                    called.setdefault(path.name, []).append(node.attr)
    assert called == {}


def test_predicted_operations_of_a_form():
    x = sp.Symbol("x", real=True)
    karis = targets.parse("exp2((-5.55473*x - 6.98316)*x)")
    assert forms.operation_counts(karis) == {"exp": 1, "*": 2, "+": 1}
    assert forms.operation_counts(x ** 20) == {"*": 5}           # squarings: x2, x4, x8, x16, x16 x4
    assert forms.operation_counts(sp.exp(2 * x) / (1 + x)) == {"exp": 1, "*": 2, "/": 1, "+": 1}
    assert forms.operation_counts(sp.acos(x)) is None
    assert forms.predicted_cycles(karis, {"exp": 4.0, "*": 1.0, "+": 1.0}) == 7.0


PRINTED = ["exp2((-5.55473*x - 6.98316)*x)", "(1 - x)**5", "(-0.156583*x + pi/2)*sqrt(1 - x)", "exp(3*x - 1)/(1 + x)",
           "Max(9.059*x - 8.059, 0)**2", "1/sqrt(1 + x*x)", "x**1.7 + log(1 + x)", "x**-3 + 2"]


def _validator():
    local = Path(sys.executable).parent / "glslangValidator"
    return str(local) if local.exists() else shutil.which("glslangValidator")


def test_a_form_printed_compiles_and_its_twin_is_its_value(tmp_path):
    """Each form as GLSL (glslang), as HLSL (glslang's HLSL front end) and as Python: the twin's value
    is the form's own (numpy, 1e-12 relative) at points of its domain."""
    x = sp.Symbol("x", real=True)
    points = np.array([0.1, 0.37, 0.5, 0.93])
    for i, text in enumerate(PRINTED):
        expr = targets.parse(text)
        twin = eval(f"lambda x: {forms.python(expr)}", {"math": __import__("math"), "max": max, "min": min})
        value = targets.numpy_function(expr, x)(points)
        np.testing.assert_allclose([twin(float(p)) for p in points], value, rtol=1e-12)
    validator = _validator()
    if validator is None:
        pytest.skip("glslangValidator not found: the printed forms were not compiled")
    glsl = "#version 450\nlayout(location = 0) in float x_in;\nlayout(location = 0) out vec4 color;\n"
    hlsl = ""
    for i, text in enumerate(PRINTED):
        expr = targets.parse(text)
        glsl += f"float f{i}(float x) {{ return {forms.glsl(expr)}; }}\n"
        hlsl += f"float f{i}(float x) {{ return {forms.hlsl(expr)}; }}\n"
    calls = " + ".join(f"f{i}(x_in)" for i in range(len(PRINTED)))
    (tmp_path / "a.frag").write_text(glsl + f"void main() {{ color = vec4({calls}); }}\n")
    (tmp_path / "a.hlsl").write_text(hlsl + f"float4 main(float x_in : TEXCOORD0) : SV_Target {{ return {calls}; }}\n")
    for args in ([str(tmp_path / "a.frag")], ["-D", "-e", "main", "-S", "frag", str(tmp_path / "a.hlsl")]):
        done = subprocess.run([validator, "-V", "-o", str(tmp_path / "out.spv"), *args], capture_output=True, text=True)
        assert done.returncode == 0, done.stdout + done.stderr


def _random_expression(rng, functions: dict, depth: int) -> str:
    """A random text of the parser's whole whitelist: its functions at their arities, + - * / **,
    numbers, x, pi and E."""
    if depth == 0 or rng.random() < 0.25:
        return str(rng.choice(["x", "pi", "E", "0.5", "3", "1.25", "(1 - x)", "(x + 2)"]))
    kind = rng.integers(3)
    if kind == 0:
        name = str(rng.choice(sorted(functions)))
        _, fewest, most = functions[name]
        count = fewest if most is None or most == fewest else int(rng.integers(fewest, most + 1))
        return f"{name}({', '.join(_random_expression(rng, functions, depth - 1) for _ in range(count))})"
    if kind == 1:
        op = str(rng.choice(["+", "-", "*", "/"]))
        return f"({_random_expression(rng, functions, depth - 1)} {op} {_random_expression(rng, functions, depth - 1)})"
    return f"{_random_expression(rng, functions, depth - 1)}**{rng.choice(['2', '0.5', '-1', '3', 'x'])}"


def test_every_expression_the_parser_reads_prints_a_form_that_compiles_or_names_what_is_missing(tmp_path):
    """400 random expressions over the parser's whole whitelist (pi and E inside terms, as
    0.5 (cos(pi x + pi) + 2 x - 1) holds them): each printed in GLSL and in HLSL compiles (glslang,
    one shader of them all per language), or its printer raises NoShaderForm naming a function the
    language lacks (the special functions: erf, gamma, the Bessel functions, ...), or a constant part
    that has no number (erfinv(3)), in one line."""
    from pipeline.engine import expressions

    validator = _validator()
    if validator is None:
        pytest.skip("glslangValidator not found: the printed forms were not compiled")
    functions = expressions._functions()
    rng = np.random.default_rng(3)
    printed = {"glsl": [], "hlsl": []}
    missing = set()
    for _ in range(400):
        text = _random_expression(rng, functions, 3)
        try:
            expr = targets.parse(text)
        except DeriveError:
            continue
        for language, printer in (("glsl", forms.glsl), ("hlsl", forms.hlsl)):
            try:
                printed[language].append(printer(expr))
            except forms.NoShaderForm as e:
                assert len(str(e).splitlines()) == 1
                if "has no number" not in str(e):      # (erfinv(3), asin(3), 1/0: no real number at all)
                    assert f"no {language.upper()} form" in str(e)
                    missing.add(str(e).split()[0])
    assert len(printed["glsl"]) >= 100 and len(printed["hlsl"]) >= 100
    assert missing and missing <= {"erf", "erfc", "erfinv", "erfcinv", "gamma", "loggamma", "polygamma", "Ei", "Si",
                                   "Ci", "li", "elliptic_k", "elliptic_e", "beta", "besselj", "bessely", "besseli",
                                   "besselk", "uppergamma", "lowergamma"}, missing
    glsl = "".join(f"float f{i}(float x) {{ return {text}; }}\n" for i, text in enumerate(printed["glsl"]))
    hlsl = "".join(f"float f{i}(float x) {{ return {text}; }}\n" for i, text in enumerate(printed["hlsl"]))
    calls = {language: " + ".join(f"f{i}(x_in)" for i in range(len(printed[language]))) for language in printed}
    (tmp_path / "a.frag").write_text("#version 450\nlayout(location = 0) in float x_in;\n"
                                     "layout(location = 0) out vec4 color;\n" + glsl
                                     + f"void main() {{ color = vec4({calls['glsl']}); }}\n")
    (tmp_path / "a.hlsl").write_text(hlsl + f"float4 main(float x_in : TEXCOORD0) : SV_Target "
                                            f"{{ return {calls['hlsl']}; }}\n")
    for args in ([str(tmp_path / "a.frag")], ["-D", "-e", "main", "-S", "frag", str(tmp_path / "a.hlsl")]):
        done = subprocess.run([validator, "-V", "-o", str(tmp_path / "out.spv"), *args], capture_output=True, text=True)
        assert done.returncode == 0, (done.stdout + done.stderr)[:2000]


def test_the_best_constant_s_error_is_its_closed_form():
    """abs: half the range; rel: (max - min) / (max + min) of |f|, the floor raising the least; 1 where f
    changes sign (no constant has a relative error below 1 there)."""
    from pipeline.approximate.measures.measure import best_constant_error

    assert best_constant_error([0.0, 0.3, 1.0], "abs") == 0.5
    assert best_constant_error([1.0, 2.0, 3.0], "rel") == 0.5
    assert best_constant_error([0.0, 2.0], "rel", floor=1.0) == pytest.approx(1 / 3, rel=1e-15)
    assert best_constant_error([-1.0, 2.0], "rel") == 1.0
