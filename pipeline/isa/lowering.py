"""One front end for every vendor's back end: a fragment shader's GLSL, compiled by glslang and
optimized by `spirv-opt -O` (`pipeline.optics.spirv`), read back as one list of operations on
scalars, the form each back end lowers to its own instructions (as Mesa's drivers share NIR).

`operations(disassembly)` returns the `Op`s of the shader's `main` in order: inputs (`input`: the
varyings t and n, by name), per-material uniforms (`uniform`: by their place in the push-constant
block, e.g. (0,) for n, (2, 3) for c[3] of a block whose third member is an array), constants, the
GLSL.std.450 functions (by their SPIR-V names: Pow, Exp, FMax, ...), arithmetic (FAdd, FSub, FMul,
FDiv, FNegate), comparisons, selections and conversions between float32 and float16 (`convert`). Each
operation's `width` is its result's: 16 for a float16 value (a shader with explicit 16-bit types),
else 32. A structured branch of one level (a GLSL `?:` or
`if`) becomes a select of both sides, as drivers if-convert short branches. The value written to
the output is `result`. `evaluate(ops, inputs, uniforms)` computes the list in numpy float32 (or
float16; a width-16 operation always in float16), so that each back end's printing is tested against
the same values.
"""

from __future__ import annotations

import dataclasses
import re

import numpy as np

ARITHMETIC = {"OpFAdd": "FAdd", "OpFSub": "FSub", "OpFMul": "FMul", "OpFDiv": "FDiv", "OpFNegate": "FNegate"}
COMPARISONS = {"OpFOrdGreaterThan": "gt", "OpFOrdGreaterThanEqual": "ge", "OpFOrdLessThan": "lt",
               "OpFOrdLessThanEqual": "le", "OpFOrdEqual": "eq", "OpFOrdNotEqual": "ne",
               "OpFUnordGreaterThan": "gt", "OpFUnordLessThan": "lt"}
# GLSL.std.450 functions on floats, and their numpy twins (what each back end must compute).
FUNCTIONS = {
    "Pow": lambda x, y: np.power(x, y), "Exp": np.exp, "Exp2": np.exp2, "Log": np.log, "Log2": np.log2,
    "Sqrt": np.sqrt, "InverseSqrt": lambda x: 1 / np.sqrt(x), "Sin": np.sin, "Cos": np.cos, "FAbs": np.abs,
    "FMax": np.maximum, "FMin": np.minimum, "NMax": np.maximum, "NMin": np.minimum,
    "FClamp": lambda x, lo, hi: np.minimum(np.maximum(x, lo), hi), "NClamp": lambda x, lo, hi: np.minimum(np.maximum(x, lo), hi),
    "Fma": lambda a, b, c: a * b + c,
}
# Functions a driver computes by its own lowering, known to the emulation (numpy's twins, which are not
# any driver's) and to the certification's allowances, not to the back ends (`operations(..., driver=True)`).
DRIVER_FUNCTIONS = {"Acos": np.arccos, "Asin": np.arcsin, "Atan": np.arctan}


class LoweringError(ValueError):
    """The shader uses an operation no back end lowers (its SPIR-V name is in the message)."""


@dataclasses.dataclass(frozen=True)
class Op:
    """One scalar operation: `name` its result's id, `kind` (input, uniform, constant, arithmetic,
    function, compare, select), `op` what it does (FMul, Pow, gt, ...; the input's or uniform's
    place), `args` the ids it reads."""

    name: str
    kind: str
    op: str | tuple
    args: tuple[str, ...] = ()
    value: float = 0.0
    width: int = 32


def _constants(disassembly: str) -> dict[str, float]:
    out = {}
    for m in re.finditer(r"(%\S+) = OpConstant %float (\S+)", disassembly):
        out[m.group(1)] = float(m.group(2))
    for m in re.finditer(r"(%\S+) = OpConstant %int (\S+)", disassembly):
        out[m.group(1)] = int(m.group(2))
    return out


def _function(disassembly: str) -> list[str]:
    lines = disassembly.splitlines()
    start = next(i for i, line in enumerate(lines) if re.search(r"%main = OpFunction ", line))
    end = next(i for i in range(start, len(lines)) if "OpFunctionEnd" in lines[i])
    return [line.strip() for line in lines[start + 1:end]]


def operations(disassembly: str, driver: bool = False) -> tuple[list[Op], str]:
    """(the operations of `main`, the id of the value written to the output), from the text of
    `spirv-dis` of an optimized fragment shader (`driver`: `DRIVER_FUNCTIONS` too). Raises
    LoweringError naming an operation it does not know."""
    constants = _constants(disassembly)
    halves = set(re.findall(r"(%\S+) = OpTypeFloat 16", disassembly))
    half_constants = {m.group(1): float.fromhex(m.group(3)) if "0x" in m.group(3) else float(m.group(3))
                      for m in re.finditer(r"(%\S+) = OpConstant (%\S+) (\S+)", disassembly) if m.group(2) in halves}
    constants.update(half_constants)
    ops: list[Op] = []
    chains: dict[str, tuple] = {}
    seen_constants: set[str] = set()
    branch, result = None, None

    def use(arg: str) -> str:
        if arg in constants and arg not in seen_constants:
            seen_constants.add(arg)
            ops.append(Op(arg, "constant", "constant", (), float(constants[arg]), 16 if arg in half_constants else 32))
        return arg

    for line in _function(disassembly):
        words = line.split()
        if "=" in words[:2]:
            name, opcode, rest = words[0], words[2], words[3:]
        else:
            name, opcode, rest = None, words[0], words[1:]
        width = 16 if rest and rest[0] in halves else 32
        if opcode in ("OpLabel", "OpSelectionMerge", "OpBranch", "OpReturn"):
            pass
        elif opcode == "OpBranchConditional":
            if branch is not None:
                raise LoweringError("a nested branch in the shader: only one level of ?: or if is lowered")
            branch = (rest[0], rest[1], rest[2])
        elif opcode == "OpAccessChain":
            chains[name] = tuple(int(constants[a]) for a in rest[2:])
        elif opcode == "OpLoad":
            source = rest[1]
            if source in chains:
                ops.append(Op(name, "uniform", chains[source]))
            else:
                ops.append(Op(name, "input", source.lstrip("%").removesuffix("_in")))
        elif opcode in ARITHMETIC:
            ops.append(Op(name, "arithmetic", ARITHMETIC[opcode], tuple(use(a) for a in rest[1:]), width=width))
        elif opcode == "OpExtInst":
            function = rest[2]
            if function not in FUNCTIONS and not (driver and function in DRIVER_FUNCTIONS):
                raise LoweringError(f"no lowering for the GLSL.std.450 function {function}")
            ops.append(Op(name, "function", function, tuple(use(a) for a in rest[3:]), width=width))
        elif opcode in COMPARISONS:
            ops.append(Op(name, "compare", COMPARISONS[opcode], tuple(use(a) for a in rest[1:])))
        elif opcode == "OpSelect":
            ops.append(Op(name, "select", "select", tuple(use(a) for a in rest[1:]), width=width))
        elif opcode == "OpPhi":
            if branch is None:
                raise LoweringError("a phi without a branch")
            incoming = dict(zip(rest[2::2], rest[1::2]))        # label -> value
            condition, true_label, false_label = branch
            ops.append(Op(name, "select", "select", (condition, use(incoming[true_label]), use(incoming[false_label])),
                          width=width))
            branch = None
        elif opcode == "OpFConvert":
            ops.append(Op(name, "convert", "FConvert", (use(rest[1]),), width=width))
        elif opcode == "OpCompositeConstruct":
            result = use(rest[1])
        elif opcode == "OpStore":
            pass
        else:
            raise LoweringError(f"no lowering for the SPIR-V operation {opcode}")
    if result is None:
        raise LoweringError("the shader writes no output")
    return ops, result


def evaluate(ops: list[Op], result: str, inputs: dict[str, np.ndarray], uniforms: dict[tuple, float],
             dtype=np.float32) -> np.ndarray:
    """The shader's output computed in numpy from its operations, each rounded to `dtype` (float32, or
    float16: numpy's + - * / and sqrt are correctly rounded per operation in either): `inputs` by
    name (t, n), `uniforms` by place."""
    values: dict[str, np.ndarray] = {}
    with np.errstate(all="ignore"):
        for op in ops:
            f32 = np.float16 if op.width == 16 else dtype
            a = [values[x] for x in op.args]
            if op.kind == "input":
                values[op.name] = np.asarray(inputs[op.op], f32)
            elif op.kind == "uniform":
                values[op.name] = f32(uniforms[op.op])
            elif op.kind == "constant":
                values[op.name] = f32(op.value)
            elif op.kind == "convert":
                values[op.name] = np.asarray(a[0], f32)
            elif op.kind == "arithmetic":
                values[op.name] = {"FAdd": lambda: a[0] + a[1], "FSub": lambda: a[0] - a[1], "FMul": lambda: a[0] * a[1],
                                   "FDiv": lambda: a[0] / a[1], "FNegate": lambda: -a[0]}[op.op]()
            elif op.kind == "function":
                values[op.name] = (FUNCTIONS | DRIVER_FUNCTIONS)[op.op](*a)
            elif op.kind == "compare":
                values[op.name] = {"gt": np.greater, "ge": np.greater_equal, "lt": np.less, "le": np.less_equal,
                                   "eq": np.equal, "ne": np.not_equal}[op.op](a[0], a[1])
            elif op.kind == "select":
                values[op.name] = np.where(a[0], a[1], a[2])
            values[op.name] = np.asarray(values[op.name], bool if op.kind == "compare" else f32)
    return values[result]


INFIX = {"FAdd": "+", "FSub": "-", "FMul": "*", "gt": ">", "ge": ">=", "lt": "<", "le": "<=", "eq": "==", "ne": "!="}


def c_statements(ops: list[Op], *, input_expr, uniform_expr, constant, function, divide, float_type: str,
                 bool_type: str, half_type: str | None = None) -> tuple[list[str], dict[str, str]]:
    """The operations as C-like statements, one variable each (`v0`, `v1`, ...), for the back ends
    that print a C-family language (OpenCL C, GL ES): the language's own words come from the
    callables (an input's, a uniform's by its index among the sorted uniforms, a constant's, a
    function's, a division's); a width-16 value is declared `half_type` (a conversion is the
    assignment). Returns (the statements, {op id: its variable}). Raises LoweringError for a width-16
    value where the language has no `half_type`."""
    uniforms = sorted({op.op for op in ops if op.kind == "uniform"})
    names: dict[str, str] = {}
    body = []
    for index, op in enumerate(ops):
        a = [names[x] for x in op.args]
        if op.kind == "input":
            expr = input_expr(op.op)
        elif op.kind == "uniform":
            expr = uniform_expr(uniforms.index(op.op))
        elif op.kind == "constant":
            expr = constant(op.value)
        elif op.kind == "arithmetic":
            expr = divide(*a) if op.op == "FDiv" else f"-{a[0]}" if op.op == "FNegate" else f"{a[0]} {INFIX[op.op]} {a[1]}"
        elif op.kind == "function":
            expr = function(op.op, a)
        elif op.kind == "compare":
            expr = f"{a[0]} {INFIX[op.op]} {a[1]}"
        elif op.kind == "convert":
            expr = a[0]
        else:
            expr = f"{a[0]} ? {a[1]} : {a[2]}"
        if op.width == 16 and half_type is None:
            raise LoweringError("no 16-bit float type in this back end's language")
        names[op.name] = f"v{index}"
        kind = bool_type if op.kind == "compare" else half_type if op.width == 16 else float_type
        body.append(f"  {kind} v{index} = {expr};")
    return body, names
