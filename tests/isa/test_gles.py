"""The GL ES text the mobile back ends compile (`pipeline.isa.gles`): read back by an evaluator of
its own (not the operations it was printed from), it computes what the GLSL says; every input it
reads is written out, so the wrapper interpolates what the shader does; and the driver's output is
split at its markers, a refused shader named with the compiler's log."""

import re

import numpy as np
import pytest

from pipeline.isa import compiler_process, gles, lowering, machine_code
from pipeline.optics import spirv

from .test_nvidia import BODIES, K, N, RATE, T, UNIFORMS  # noqa: F401

GLSL_FUNCTIONS = {"pow": np.power, "exp": np.exp, "exp2": np.exp2, "log": np.log, "log2": np.log2, "sqrt": np.sqrt,
                  "inversesqrt": lambda x: 1 / np.sqrt(x), "sin": np.sin, "cos": np.cos, "abs": np.abs,
                  "max": np.maximum, "min": np.minimum, "clamp": lambda x, lo, hi: np.minimum(np.maximum(x, lo), hi)}
BINARY = {"+": np.add, "-": np.subtract, "*": np.multiply, "/": np.divide, ">": np.greater, ">=": np.greater_equal,
          "<": np.less, "<=": np.less_equal, "==": np.equal, "!=": np.not_equal}


def run_gles(text: str, inputs: dict, uniforms: list[float]) -> np.ndarray:
    """The first output component of a printed GL ES shader, in float32, read from its text."""
    f32 = np.float32
    values = {f"u{i}": f32(u) for i, u in enumerate(uniforms)} | {f"in_{k}": np.asarray(v, f32) for k, v in inputs.items()}

    def arg(word):
        return values[word] if word in values else f32(float(word))

    with np.errstate(all="ignore"):
        for name, expr in re.findall(r"^  (?:highp float|bool) (v\d+) = (.*);$", text, re.M):
            if m := re.fullmatch(r"(\w+) \? (\w+) : (\w+)", expr):
                values[name] = np.where(arg(m[1]), arg(m[2]), arg(m[3]))
            elif m := re.fullmatch(r"(\w+)\((.*)\)", expr):
                values[name] = GLSL_FUNCTIONS[m[1]](*(arg(a.strip()) for a in m[2].split(",")))
            elif m := re.fullmatch(r"(\S+) \* (\S+) \+ (\S+)", expr):          # fma
                values[name] = arg(m[1]) * arg(m[2]) + arg(m[3])
            elif m := re.fullmatch(r"(\S+) (\S+) (\S+)", expr):
                values[name] = BINARY[m[2]](arg(m[1]), arg(m[3]))
            elif expr.startswith("-"):
                values[name] = -arg(expr[1:])
            else:
                assert re.fullmatch(r"[\w.e+-]+", expr), expr
                values[name] = arg(expr)
        out = re.search(r"color = vec4\((\w+)", text)[1]
    return np.asarray(values[out], f32)


@pytest.mark.parametrize("name", BODIES)
def test_the_gles_text_computes_the_glsl(name):
    body, twin = BODIES[name]
    ops, result = lowering.operations(spirv.optimized_disassembly(machine_code.UNIFORM.format(body=body)))
    text = gles.fragment_shader(ops, result)
    places = sorted({op.op for op in ops if op.kind == "uniform"})
    got = run_gles(text, {"t": T}, [UNIFORMS[p] for p in places])
    np.testing.assert_allclose(got, twin(T), rtol=2e-5, atol=1e-6)


def test_the_shader_and_its_wrapper_read_and_write_the_same_inputs():
    lower = gles.lower({"lobe": machine_code.PER_PIXEL.format(body="return pow(t, n);", parameter="n", coef="n + 2.0"),
                        "wrapper": machine_code.WRAPPER_PER_PIXEL})
    for text in lower.values():
        assert "in highp float in_n;" in text and "in highp float in_t;" in text
        assert re.search(r"color = vec4\(\w+, in_n, in_t, 0\.0\);", text), text
    assert "#version 310 es" in lower["lobe"] and "uniform" not in lower["wrapper"]


def test_the_driver_s_output_is_split_at_its_markers():
    output = "\n".join(["noise", f"{gles.MARK} renderer FD630", f"{gles.MARK} begin s0", "a", "b", f"{gles.MARK} end s0 2",
                        f"{gles.MARK} begin s1", "c", f"{gles.MARK} end s1 3", "tail"])
    assert gles.split(output) == {"s0": ["a", "b"], "s1": ["c"]}
    with pytest.raises(ValueError, match="Mesa refused the shader s1: 'error: syntax'"):
        gles.split(output.replace(f"{gles.MARK} end s1 3", f"{gles.MARK} failed s1 'error: syntax'"))


def test_an_operation_without_a_gles_lowering_is_named():
    with pytest.raises(lowering.LoweringError, match="no GL ES lowering for the GLSL.std.450 function Tanh"):
        gles.fragment_shader([lowering.Op("%1", "input", "t"), lowering.Op("%2", "function", "Tanh", ("%1",))], "%2")


def _shader(k: int) -> str:
    return ("#version 310 es\nprecision highp float;\nin highp float in_t;\nuniform highp float u0;\n"
            "layout(location = 0) out highp vec4 color;\nvoid main()\n{\n"
            f"  color = vec4(in_t * in_t * u0 + {k}.5, in_t, 0.0, 0.0);\n}}\n")


@pytest.fixture()
def adreno_driver(monkeypatch):
    """(compile, the driver's variables) for Adreno 740, the test's drivers apart from the session's
    (none running before, all ended after)."""
    from pipeline.isa import adreno

    try:
        gles.tools()
    except gles.CompilerMissing as e:
        pytest.skip(f"Mesa's mobile drivers do not run here: {e}")
    environment = dict(adreno.ENVIRONMENT, FD_GPU_ID="740")
    monkeypatch.setattr(compiler_process, "_RUNNING", {})
    yield (lambda sources: gles.compile_all(sources, "a740", environment, adreno.SHIM)[0]), environment
    compiler_process.close_all()


def _counts(listings):
    from pipeline.isa import adreno

    return {name: {k: v for k, v in adreno.parse(lines).items() if k != "listing"}
            for name, lines in listings.items()}


def test_a_running_driver_compiles_a_later_batch_as_a_fresh_one_does(adreno_driver):
    """The second batch goes to the same process, and its counts are a fresh process's (only Mesa's
    running numbers of its programs differ in the listings)."""
    compile_batch, _ = adreno_driver
    batch = {f"a{k}": _shader(k) for k in range(6)}
    first = compile_batch(batch)
    (running,) = compiler_process._RUNNING.values()
    compile_batch({f"b{k}": _shader(k + 50) for k in range(4)})
    again = compile_batch(batch)
    assert list(compiler_process._RUNNING.values()) == [running] and running.alive()
    compiler_process.close_all()
    assert not running.alive() and not compiler_process._RUNNING
    fresh = compile_batch(batch)
    assert _counts(first) == _counts(again) == _counts(fresh)
    assert _counts(fresh)["a0"]["alu"] > 0


def test_a_driver_that_ended_is_started_again_and_one_that_fails_is_named(adreno_driver):
    from pipeline.isa import adreno

    compile_batch, _ = adreno_driver
    compile_batch({"a": _shader(1)})
    (running,) = compiler_process._RUNNING.values()
    running.process.kill()
    running.process.wait()
    assert _counts(compile_batch({"a": _shader(1)}))["a"]["alu"] > 0
    (again,) = compiler_process._RUNNING.values()
    assert again is not running and again.alive()
    # a chip Mesa does not know: the driver ends before its first batch's end, with Mesa's words
    unknown = r"Mesa's compiler \(a999\) under qemu failed \(exit -?\d+\): FD_GPU_ID unrecognized"
    with pytest.raises(RuntimeError, match=unknown):
        gles.compile_all({"a": _shader(1)}, "a999", dict(adreno.ENVIRONMENT, FD_GPU_ID="999"), adreno.SHIM)
    assert again.alive() and _counts(compile_batch({"a": _shader(2)}))["a"]["alu"] > 0


def test_a_refused_shader_leaves_the_driver_running(adreno_driver):
    compile_batch, _ = adreno_driver
    with pytest.raises(ValueError, match="Mesa refused the shader s1"):
        compile_batch({"good": _shader(1), "bad": "#version 310 es\nvoid main() { undefined_name; }\n"})
    (running,) = compiler_process._RUNNING.values()
    assert running.alive() and _counts(compile_batch({"a": _shader(2)}))["a"]["alu"] > 0
    assert list(compiler_process._RUNNING.values()) == [running]


def test_a_driver_ends_with_the_process_that_started_it(tmp_path):
    """A process that is killed (no exit handler runs) leaves no driver behind: the driver reads the
    end of its input and ends."""
    import os
    import signal
    import subprocess
    import sys
    import time

    try:
        gles.tools()
    except gles.CompilerMissing as e:
        pytest.skip(f"Mesa's mobile drivers do not run here: {e}")
    script = ("import os, sys\nfrom pipeline.isa import adreno, compiler_process, gles\n"
              "gles.compile_all({'a': sys.argv[1]}, 'a740', dict(adreno.ENVIRONMENT, FD_GPU_ID='740'),\n"
              "                 adreno.SHIM)\n"
              "(d,) = compiler_process._RUNNING.values()\nprint(d.process.pid, flush=True)\nos.kill(os.getpid(), 9)\n")
    done = subprocess.run([sys.executable, "-c", script, _shader(1)], capture_output=True, text=True,
                          timeout=120)
    assert done.returncode == -signal.SIGKILL, done.stderr
    pid = int(done.stdout.split()[0])
    for _ in range(100):
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            return
        time.sleep(0.1)
    raise AssertionError(f"the driver {pid} still runs 10 s after its parent was killed")
