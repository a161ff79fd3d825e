"""The one reader of expression text (`engine.expressions`): what it refuses (before anything runs,
in one line naming the token and its column), the work it bounds (each planted case timed by the
test: under a second), the same sympy tree as sympy's own reading for every expression of the
registries, the caches' text read back exactly, and a property run over random texts."""

import ast
import time
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

from pipeline.engine import expressions
from pipeline.engine.expressions import ExpressionError

PACKAGE = Path(expressions.__file__).parent.parent


def marker_text(marker: Path) -> str:
    return f"__import__('pathlib').Path({str(marker)!r}).write_text('owned')"


# (text with MARKER where an attack writes the marker file, the message's words, the column named)
REFUSED = [
    ("x + 0*len(MARKER)", "unknown function 'len'", 7),
    ("MARKER", "the attribute '.write_text'", None),
    ("x.real", "the attribute '.real'", 2),
    ("().__class__.__bases__[0].__subclasses__()", "the attribute '.__subclasses__'", 26),
    ("x[0]", "a subscript", 1),
    ("(lambda: MARKER)()", "a lambda", 2),
    ("__import__('os')", "unknown function '__import__'", 1),
    ("[MARKER for i in (1,)]", "a comprehension", 1),
    ("'x'", "a string is not a number", 1),
    ("x + f'{x}'", "a string", 5),
    ("sin(x, key=MARKER)", "the keyword argument 'key' of sin", 8),
    ("sin(*x)", "a starred argument of sin", 1),
    ("x < 1", "a comparison", 1),
    ("x if x else 1", "a conditional", 1),
    ("x and 1", "a logical operator", 1),
    ("(y := 2) * x", "an assignment", 2),
    ("y * x", "unknown name 'y'", 1),
    ("exp", "the function 'exp' without its arguments", 1),
    ("x % 2", "the operator '%'", 1),
    ("x // 2", "the operator '//'", 1),
    ("~x", "the operator '~'", 1),
    ("x @ x", "the operator '@'", 1),
    ("1j * x", "the constant 1j is not a number", 1),
    ("True * x", "the constant True is not a number", 1),
    ("sin(x", "does not parse", 4),
    ("x;MARKER", "does not parse", 2),
    ("clamp(x, 0)", "clamp takes 3 arguments, given 2", 1),
    ("x\x00", "the control character", 2),
    ("", "an empty expression", None),
]


@pytest.mark.parametrize("text, words, column", REFUSED)
def test_every_kind_outside_the_grammar_is_refused_in_one_line_and_nothing_runs(text, words, column, tmp_path):
    marker = tmp_path / "marker.txt"
    text = text.replace("MARKER", marker_text(marker))
    with pytest.raises(ExpressionError) as refused:
        expressions.parse(text, "x")
    message = str(refused.value)
    assert words in message and len(message.splitlines()) == 1
    assert f"at column {column}" in message if column else ("at column" in message) == (text != "")
    assert not marker.exists()


@pytest.mark.parametrize("text, words", [
    ("x*9**9**9", "the exponent 387420489 is beyond 10000"),
    ("x**(10**100)", "the exponent of 101 digits is beyond 10000"),
    ("2**3000 * 5**3000", "more than 1000"),
    ("2**1200 * 5**1200", "an exact number of more than 1000 digits"),
    ("9**1100", "a number of about 1.05e+03 digits"),
    ("sqrt(2)**20000", "the exponent 20000 is beyond 10000"),
    ("-50**-5^-52", "the exponent's denominator of 37 digits is beyond 10000"),
    ("x**1e300", "the exponent 1e+300 is beyond 10000"),
    ("gamma(10**100)", "the exact argument of gamma is beyond 100"),
    ("gamma(1000000)", "the exact argument of gamma is beyond 100"),
    ("uppergamma(5000, x)", "the exact argument of uppergamma is beyond 100"),
    ("sin(10**7)", "the exact argument of sin is beyond 1e"),
    ("1" * 1001 + "*x", "an integer of more than 1000 digits"),
    ("8888888888888E88888888888888*x", "a power of ten beyond 1000"),
    ("222222e222222222222222222222*x", "a power of ten beyond 1000"),
    ("(" * 101 + "x" + ")" * 101, "parentheses nested deeper than 100"),
    ("-" * 101 + "x", "nested deeper than 100"),
    ("x**" * 101 + "x", "nested deeper than 100"),
    ("sin(" * 101 + "x" + ")" * 101, "parentheses nested deeper than 100"),
    ("-" * 3900 + "x", "does not parse|nested deeper than 100"),
    ("x+" * 2001 + "x", "characters, more than 4000"),
])
def test_work_beyond_the_bounds_is_refused_within_a_second(text, words):
    started = time.perf_counter()
    with pytest.raises(ExpressionError, match=words.replace("(", r"\(").replace("+", r"\+").replace("*", r"\*")) as refused:
        expressions.parse(text, "x")
    assert time.perf_counter() - started < 1.0
    assert len(str(refused.value).splitlines()) == 1 and len(str(refused.value)) < 250


def test_work_within_the_bounds_is_read_within_a_second():
    """A sum of 2,000 terms (a flat chain, one level deep) and of 280 distinct ones (near the 4,000
    characters' bound), a power of 10,000, a 1,000-digit number."""
    x = sp.Symbol("x", real=True)
    for text, expected in (("+".join(["x"] * 2000), 2000 * x), ("+".join(f"{i}.5*x**{i % 40}" for i in range(280)), None), ("x**10000", x ** 10000),
                           ("10**998 - 10**998 + x", x), ("(1 - x)^5", (1 - x) ** 5)):
        started = time.perf_counter()
        read = expressions.parse(text, "x")
        assert expected is None or read == expected
        assert time.perf_counter() - started < 1.0


def sympy_reading(text: str, names) -> sp.Expr:
    """sympy's own reading of trusted text (the registries' own): the oracle of the same tree."""
    functions = {"exp2": lambda a: sp.Integer(2) ** a, "log2": lambda a: sp.log(a) / sp.log(2),
                 "rsqrt": lambda a: 1 / sp.sqrt(a), "saturate": lambda a: sp.Min(sp.Max(a, 0), 1),
                 "clamp": lambda a, lo, hi: sp.Min(sp.Max(a, lo), hi), "max": sp.Max, "min": sp.Min, "pow": sp.Pow}
    symbols = {n: sp.Symbol(n, real=True) for n in names}
    return sp.sympify(text, locals={**symbols, **functions}, convert_xor=True)


def registry_texts() -> list[tuple[str, tuple]]:
    """Every expression the registries hold: targets, anchors, moving range ends, the lobe families'
    and the paper's lobes', with their names."""
    from pipeline.approximate import targets
    from pipeline.optics import lobe_families

    out = []
    for t in targets.one_variable_targets().values():
        out += [(t.expression, (t.variable,))] + [(a.expression, (t.variable,)) for a in t.anchors]
    for t in list(targets.several_variable_targets().values()) + [p for pair in targets.pairs().values()
                                                      for p in (pair.scale, pair.bias)]:
        if t.table is None:
            out.append((t.expression, t.names))
        out += [(a.expression, t.names) for a in t.anchors]
        out += [(a.lo_of, (t.parameter.name,)) for a in t.variables if isinstance(a.lo_of, str) and a.lo_of]
    out += [(a.expression, ("t", "n")) for a in targets.paper_lobes()]
    out += [(f.python, ("A", "B", "C", "t")) for f in lobe_families.FAMILIES.values()]
    return out


def test_a_branch_reads_as_a_piecewise_and_prints_back():
    """`a if x <= c else b` (a shader's ?: or if, as the shader reader writes it): a Piecewise, its
    test one comparison or and, or, not of them; `text` prints it back to the same tree; a test that
    is no comparison, a chained one, a comparison outside a conditional are refused."""
    x = sp.Symbol("x", real=True)
    decode = expressions.parse("x/12.92 if x <= 0.04045 else ((x + 0.055)/1.055)**2.4", ("x",))
    assert decode == sp.Piecewise((x / sp.Float("12.92"), x <= sp.Float("0.04045")),
                                  (((x + sp.Float("0.055")) / sp.Float("1.055")) ** sp.Float("2.4"), True))
    nested = expressions.parse("1 if x > 0.1 and x < 0.5 else (2 if not x < 0.9 else 3)", ("x",))
    for tree in (decode, nested):
        assert sp.srepr(expressions.parse(expressions.text(tree, {"x": x}), ("x",), float64=True)) == sp.srepr(tree)
    for text, message in (("x < 1", "a comparison"), ("x if x else 1", "a conditional whose test 'x'"),
                          ("1 if 0 < x < 1 else 2", "is not one comparison"), ("1 if x == 0 else 2", "x == 0")):
        with pytest.raises(ExpressionError, match=message):
            expressions.parse(text, ("x",))


def test_every_expression_of_the_registries_reads_to_sympys_tree():
    texts = registry_texts()
    assert len(texts) >= 30
    for text, names in texts:
        assert sp.srepr(expressions.parse(text, names)) == sp.srepr(sympy_reading(text, names)), text


def test_the_expressions_of_the_tests_read_to_sympys_tree():
    texts = ["erf(t)", "atan(x)", "x * (0.97 - 0.19 * x * x)", "exp(x)", "0.9 + 1.9*x", "1 + 2*x",
             "1.5707963267948966 - 0.15658276442180141*x", "log2(1 + x) * rsqrt(x + 1)", "saturate(2*x - 0.5)",
             "clamp(x, 0.1, 0.9)**2.5", "pow(x, 3) - x^2/3", "2/3*x - 1/7", "-x**-0.5 + E**x*pi"]
    for text in texts:
        name = "t" if "(t)" in text else "x"
        assert sp.srepr(expressions.parse(text, (name,))) == sp.srepr(sympy_reading(text, (name,))), text


def test_printed_text_reads_back_to_the_same_tree():
    """`text` writes what `parse(..., float64=True)` reads back exactly (the caches' format): float64
    constants to the last bit, rationals, functions, Floats of other precisions."""
    x, c0 = sp.Symbol("x", real=True), sp.Symbol("c0", real=True)
    rng = np.random.default_rng(5)
    symbols = {"x": x, "c0": c0}
    for _ in range(200):
        a, b, c = (sp.Float(float(v)) for v in rng.normal(size=3) * 10.0 ** rng.integers(-12, 12, size=3))
        expr = (a * x + b) / (sp.sqrt(x) + c) + sp.Max(0, c0 * x) ** sp.Float(float(rng.uniform(0.5, 4))) \
            + sp.Rational(1, 3) * sp.exp(-b * x) + 2 ** (c * x) - sp.acos(x) * sp.pi
        assert sp.srepr(expressions.parse(expressions.text(expr, symbols), symbols, float64=True)) == sp.srepr(expr)
    finer = sp.Float("0.1", 30) * x - sp.Float(1 / 3, 17) * sp.exp(sp.Float(-0.2, 24) * x)
    printed = expressions.text(finer, symbols)
    assert "Float(" in printed and sp.srepr(expressions.parse(printed, symbols, float64=True)) == sp.srepr(finer)
    with pytest.raises(ExpressionError, match="unknown function 'Float'"):
        expressions.parse(printed, symbols)        # (outside text has no Float: only the caches' reading)
    for bad in ("Float(1e88888888888888, 60)", "Float(0.1, 1e9)", "Float(0.1, precision=60)", "Float(x, 60)"):
        with pytest.raises(ExpressionError, match="power of ten|Float takes"):
            expressions.parse(bad, symbols, float64=True)
    # a tree sympy would not build from its text (held unevaluated) is refused, not kept altered
    with pytest.raises(ExpressionError, match="does not read back"):
        expressions.text(sp.Mul(2, x + 1, evaluate=False), symbols)


@pytest.mark.parametrize("name, allowed", [("x", True), ("NoV", True), ("alpha_2", True), ("lambda", False),
                                           ("exp", False), ("pi", False), ("numpy", False), ("_x", False),
                                           ("x y", False), ("\u00e9", False), ("2x", False)])
def test_a_declared_name_is_an_ascii_identifier_the_grammar_does_not_own(name, allowed):
    assert (expressions.name_fault(name) is None) == allowed


def test_a_derive_target_file_that_attacks_runs_nothing_and_exits_2(tmp_path, capsys):
    """The planted target files (the expression, an anchor) and --expr texts: exit 2, one line, no
    marker, no output folder."""
    from pipeline.cli import main

    marker = tmp_path / "marker.txt"
    attack = marker_text(marker)
    files = {"expression": f'[target]\nname = "evil"\nexpression = "x + 0*len({attack})"\n',
             "anchor": f'[target]\nname = "evil"\nexpression = "x"\n[[anchor]]\nname = "a"\nexpression = "{attack}"\n',
             "parametric": ('[target]\nname = "evil"\nexpression = "x*a"\n[[variable]]\nname = "x"\nrange = [0, 1]\n'
                            f'[parameter]\nname = "a"\nrange = [1, 2]\n[[anchor]]\nname = "b"\nexpression = "{attack}"\n')}
    for label, text in files.items():
        path = tmp_path / f"{label}.toml"
        path.write_text(text)
        code = main(["derive", "--target", str(path), "--out", str(tmp_path / "out")])
        err = capsys.readouterr().err.strip()
        assert code == 2 and len(err.splitlines()) == 1 and "at column" in err, (label, err)
    for text in (f"x + {attack}", "x*9**9**9", "x**(10**100)"):
        started = time.perf_counter()
        assert main(["derive", "--expr", text, "--out", str(tmp_path / "out")]) == 2
        assert time.perf_counter() - started < 1.0
        assert len(capsys.readouterr().err.strip().splitlines()) == 1
    assert not marker.exists() and not (tmp_path / "out").exists()


# The package's source reads no outside text by sympify, parse_expr, eval or exec; the one exec left
# runs text the program printed itself from a parsed tree (a member's Python twin, `api.twin`).
ALLOWED = {("approximate/api.py", "exec")}


def test_no_sympify_parse_expr_eval_or_exec_in_the_package():
    found = set()
    for path in PACKAGE.rglob("*.py"):
        where = path.relative_to(PACKAGE).as_posix()
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom) and any(a.name in ("sympify", "parse_expr", "S") for a in node.names):
                found.add((where, "import"))
            if not isinstance(node, ast.Call):
                continue
            function = node.func
            name = function.id if isinstance(function, ast.Name) else getattr(function, "attr", None)
            on = function.value.id if isinstance(function, ast.Attribute) and isinstance(function.value, ast.Name) else None
            # sympy's readers however they are reached; Python's eval and exec as builtins (a method
            # named eval, such as a Mitsuba BSDF's, is not Python's)
            if name in ("sympify", "parse_expr", "S") or (name in ("eval", "exec") and on in (None, "builtins")):
                found.add((where, name))
    assert found == ALLOWED



# ---- properties over random texts (Hypothesis; derandomized, so that every run tries the same) ----

from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

LEAVES = st.sampled_from(["x", "pi", "E", "2", "3", "0.5", "0.448", "1.5707963267948966", "7", "1e-3", "0.099",
                          "12.25", "(1 - x)"])
UNARY = ["sin", "cos", "exp", "sqrt", "log", "acos", "atan", "Abs", "exp2", "log2", "rsqrt", "saturate", "erf"]


def _combine(children):
    binary = st.tuples(children, st.sampled_from(["+", "-", "*", "/"]), children).map(lambda t: f"({t[0]} {t[1]} {t[2]})")
    power = st.tuples(children, st.sampled_from(["2", "3", "-1", "0.5", "-0.5", "x"])).map(lambda t: f"{t[0]}**{t[1]}")
    call = st.tuples(st.sampled_from(UNARY), children).map(lambda t: f"{t[0]}({t[1]})")
    pair = st.tuples(st.sampled_from(["Max", "Min", "pow"]), children, children).map(lambda t: f"{t[0]}({t[1]}, {t[2]})")
    return st.one_of(binary, power, call, pair, children.map(lambda t: f"-{t}"),
                     st.tuples(children, children, children).map(lambda t: f"{t[0]} - {t[1]}*{t[2]}/3 + {t[0]}"))


EXPRESSIONS = st.recursive(LEAVES, _combine, max_leaves=12)
PROPERTY = settings(max_examples=250, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow])


@PROPERTY
@given(EXPRESSIONS)
def test_a_random_expression_reads_to_sympys_tree(text):
    assert sp.srepr(expressions.parse(text, "x")) == sp.srepr(sympy_reading(text, ("x",)))


@PROPERTY
@given(st.one_of(st.text(max_size=60), st.text(alphabet="x0123456789.+-*/^()[]{},:;'\"_ ealmbdsqrtpi\\@%<=!~&|",
                                                  max_size=60),
                 st.tuples(EXPRESSIONS, st.integers(0, 80), st.text(max_size=4)).map(
                     lambda t: t[0][:t[1]] + t[2] + t[0][t[1]:])))
def test_any_text_is_an_expression_or_one_clean_refusal(text):
    try:
        expr = expressions.parse(text, "x")
    except ExpressionError as e:
        assert len(str(e).splitlines()) == 1
    else:
        assert isinstance(expr, sp.Expr) and expr.free_symbols <= {sp.Symbol("x", real=True)}


def test_a_kept_entry_changed_or_holding_code_is_recomputed_with_one_line(tmp_path, monkeypatch):
    """`pipeline derive`'s kept entries (`approximate.kept`): read back to the same trees (a float64
    constant, one of 17 digits, a push constant c0); an entry whose body changed after it was written
    (its hash), or whose expression is code (with a valid hash), is computed again with one line
    saying why; nothing in it runs."""
    import hashlib
    import json

    from pipeline.approximate import targets
    from pipeline.approximate.search import box_search as parametric_search, kept
    from pipeline.symbolic.budgets import Budget
    from pipeline.engine import paths

    monkeypatch.setattr(paths, "DERIVE_CACHE", tmp_path / "derive")
    monkeypatch.setattr(parametric_search, "worker_count", lambda parts: 0)       # (the planted search: here)
    target = targets.several_variable_targets()["smith_ggx_visibility"]
    nov, nol, alpha = target.symbols()
    c0 = sp.Symbol("c0", real=True)
    expr = sp.Float(1 / 3, 17) / (nov * nol * sp.Float(0.25) + alpha * c0) + sp.Max(0, nov - nol) ** 2
    calls, lines = [], []

    class Planted(parametric_search.Search):
        def compute(self, part, f, log):          # (the planted form is the families' part; the others find none)
            calls.extend([1] * (part == "families"))
            return [dict(name="planted", expression=expr)] * (part == "families"), dict(seconds=1.0)

    def run():
        ((found, _),) = parametric_search.searched([Planted(target, Budget(1.0), 2)], [None], [lines.append], lines.append)
        return found[0]["expression"]

    assert run() == expr and len(calls) == 1
    assert sp.srepr(run()) == sp.srepr(expr) and len(calls) == 1 and "families' fits of an earlier run" in lines[-3]
    (path,) = [p for p in (tmp_path / "derive").glob("*.json") if "planted" in p.read_text()]
    entry = json.loads(path.read_text())
    path.write_text(json.dumps(dict(entry, body=entry["body"].replace("0.25", "0.5"))))
    lines.clear()
    assert run() == expr and len(calls) == 2
    assert [line for line in lines if "kept entry" in line] == [f"the kept entry {path.name} was changed after it "
                                                                "was written (its hash): computed again"]
    marker = tmp_path / "marker.txt"
    body = json.loads(json.loads(path.read_text())["body"])
    body["found"][0]["expression"] = f"NoV + 0*len({marker_text(marker)})"
    text = json.dumps(body, sort_keys=True)
    path.write_text(json.dumps(dict(sha256=hashlib.sha256(text.encode()).hexdigest(), body=text)))
    lines.clear()
    assert run() == expr and len(calls) == 3 and not marker.exists()
    (line,) = [line for line in lines if "families' fits" in line]
    assert "is not used" in line and "unknown function 'len'" in line and "computed again" in line
    assert kept.read(tmp_path / "none.json", lines.append) is None
