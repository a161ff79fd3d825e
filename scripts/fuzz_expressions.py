"""A coverage-guided fuzz run of the one reader of expression text (`pipeline.engine.expressions`)
with atheris (libFuzzer for Python): every input, as text, must come back as a sympy expression in
the declared names or as one `ExpressionError` of one line, within a second; anything else (another
exception, a second line, a slow input, a file written, memory beyond libFuzzer's 2 GB) is a
finding, and the run stops on it with the input saved by libFuzzer in outputs/fuzz/.

    python scripts/fuzz_expressions.py [--record docs/measured/fuzz.json] [libFuzzer flags ...]

`make fuzz` runs it for FUZZ_SECONDS (600 by default) from a corpus seeded with expressions of the
registries and the planted attacks of the tests; `--record` writes a run's numbers (inputs tried,
time, the corpus, the parser's statements its corpus reaches) as a measured record the
documentation reads, where the run has no finding.
"""

from __future__ import annotations

import ast
import json
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import atheris

with atheris.instrument_imports(include=["pipeline.engine.expressions"]):
    from pipeline.engine import expressions

import sympy as sp

NAMES = ("x", "NoV", "alpha")
SYMBOLS = {n: sp.Symbol(n, real=True) for n in NAMES}
SLOW = 1.0                  # seconds: an input the parser takes longer on is a finding
MARKER = Path(tempfile.gettempdir()) / "fuzz_expressions_marker.txt"
SEEDS = ["(1 - x)**5", "exp2((-5.55473*x - 6.98316)*x)", "acos(x)", "(1.5707963267948966 - 0.15658276442180141*x)*sqrt(1 - x)",
         "0.5/(NoL*sqrt(NoV**2*(1 - alpha**2) + alpha**2) + NoV*sqrt(NoL**2*(1 - alpha**2) + alpha**2))",
         "min((1 - alpha)**2, exp2(-9.28*NoV))", "clamp(x, 0, 1)^2.5", "x*9**9**9", "x**(10**100)", "gamma(10**100)",
         f"x + 0*len(__import__('pathlib').Path('{MARKER}').write_text('owned'))", "().__class__.__bases__[0]",
         "(lambda: 1)()", "[i for i in (1,)]", "x if x else 1", "x < 1", "sin(x, key=1)", "Float(0.1, 60)"]
tried = [0]


def one_input(data: bytes) -> None:
    text = atheris.FuzzedDataProvider(data).ConsumeUnicodeNoSurrogates(400)
    tried[0] += 1
    started = time.perf_counter()
    try:
        expr = expressions.parse(text, SYMBOLS, float64=len(data) % 2 == 1)
    except expressions.ExpressionError as e:
        if len(str(e).splitlines()) != 1:
            raise AssertionError(f"a refusal of more than one line: {str(e)!r}") from None
    else:
        if not isinstance(expr, sp.Expr) or not expr.free_symbols <= set(SYMBOLS.values()):
            raise AssertionError(f"{text!r} read as {expr!r}")
    if time.perf_counter() - started > SLOW:
        raise AssertionError(f"{text!r} took {time.perf_counter() - started:.2f} s")
    if MARKER.exists():
        raise AssertionError(f"{text!r} wrote {MARKER}")


def fuzz(corpus: str, flags: list[str]) -> None:
    """The fuzzer itself (libFuzzer exits the process when it stops)."""
    atheris.Setup([sys.argv[0], *flags, corpus], one_input)
    atheris.Fuzz()


def main() -> int:
    args = sys.argv[1:]
    if os.environ.get("FUZZ_EXPRESSIONS_CORPUS"):
        fuzz(os.environ["FUZZ_EXPRESSIONS_CORPUS"], args)
        return 0
    record = None
    if "--record" in args:
        i = args.index("--record")
        record = Path(args[i + 1])
        del args[i:i + 2]
    findings = Path("outputs/fuzz")
    if not any(a.startswith("-artifact_prefix=") for a in args):
        findings.mkdir(parents=True, exist_ok=True)
        args.append(f"-artifact_prefix={findings}/")
    corpus = Path(tempfile.mkdtemp(prefix="fuzz_expressions_"))
    for i, seed in enumerate(SEEDS):
        (corpus / f"seed{i}").write_text(seed, encoding="utf-8")
    MARKER.unlink(missing_ok=True)
    started = time.perf_counter()
    done = subprocess.run([sys.executable, __file__, *args], env=dict(os.environ, FUZZ_EXPRESSIONS_CORPUS=str(corpus)),
                          stderr=subprocess.PIPE, text=True)
    seconds = time.perf_counter() - started
    runs = [int(m) for m in re.findall(r"Done (\d+) runs", done.stderr)] or \
        [int(m) for m in re.findall(r"^#(\d+)", done.stderr, re.M)]
    inputs = sorted(corpus.iterdir())
    lines, covered = coverage(inputs)
    summary = dict(date=time.strftime("%Y-%m-%d"), inputs_tried=runs[-1] if runs else None, seconds=round(seconds, 1),
                   corpus=len(inputs), parser_statements=lines, parser_statements_reached=covered,
                   python=sys.version.split()[0], command="make fuzz")
    print(done.stderr[-3000:] if done.returncode else done.stderr.strip().splitlines()[-1], file=sys.stderr)
    print(f"fuzz_expressions: {summary['inputs_tried']} inputs in {summary['seconds']} s, a corpus of {len(inputs)}, "
          f"{covered} of the parser's {lines} statements reached; "
          + (f"a finding: libFuzzer saved its input in {findings}/ (above: which)" if done.returncode else "no finding"))
    if record is not None and not done.returncode:
        record.write_text(json.dumps(summary, indent=1) + "\n")
    return 1 if done.returncode else 0


def coverage(inputs) -> tuple[int, int]:
    """(the parser module's lines of code, those the corpus reaches): the corpus the run kept replayed
    under Python's own tracing."""
    import trace

    source = Path(expressions.__file__).resolve()
    tree = ast.parse(source.read_text())
    code_lines = {node.lineno for node in ast.walk(tree) if isinstance(node, ast.stmt)
                  and not (isinstance(node, ast.Expr) and isinstance(node.value, ast.Constant))}
    tracer = trace.Trace(count=1, trace=0)
    for path in inputs:
        data = path.read_bytes()
        text = atheris.FuzzedDataProvider(data).ConsumeUnicodeNoSurrogates(400)
        tracer.runfunc(_quiet, text, len(data) % 2 == 1)
    hit = {n for (f, n), c in tracer.results().counts.items() if Path(f).resolve() == source}
    return len(code_lines), len(code_lines & hit)


def _quiet(text, float64):
    try:
        expressions.parse(text, SYMBOLS, float64=float64)
    except expressions.ExpressionError:
        pass


if __name__ == "__main__":
    sys.exit(main())
