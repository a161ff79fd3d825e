"""The GL ES text the mobile back ends compile (`pipeline.isa.gles`): read back by an evaluator of
its own (not the operations it was printed from), it computes what the GLSL says; every input it
reads is written out, so the wrapper interpolates what the shader does; and the driver's output is
split at its markers, a refused shader named with the compiler's log."""

import re

import numpy as np
import pytest

from pipeline.isa import gles, lowering, machine_code
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
