"""A function's meaning as the compiler reads it: the optimized SPIR-V (the text of `spirv-dis`) of a
harness's `main`, which loads the function's arguments from inputs (by their `Location`) and stores
its result to one output, read back into a sympy expression in the arguments' symbols, the tree
`engine.expressions` builds (the same functions: exp2 as 2^x, log2 as log(x) / log(2), inversesqrt
as 1 / sqrt(x), clamp as Min(Max(...)), mix as a + (b - a) s).

Kept as operations: + - * /, negation, the GLSL.std.450 functions (min, max, clamp, mix, step,
smoothstep, abs, sign, floor, ceil, fract, fma, sqrt, inversesqrt, exp, exp2, log, log2, pow, the
trigonometric functions), comparisons and the logical operators. A branch (a ternary: OpSelect; an
if/else or an early return: OpPhi after the optimizer, where each incoming value is taken on the
condition that reaches its edge) becomes a Piecewise. Constants are the float32 values the shader
holds. What the reader does not take is `Refused` with one line naming it: a loop left after
optimization, a texture, image or sampler read, derivatives, `discard`, a store other than the
result, an operation it does not know.
"""

from __future__ import annotations

import re

import numpy as np
import sympy as sp


class Refused(ValueError):
    """A function the reader does not take (one line: why)."""


TEXTURE = re.compile(r"^Op(Image|SampledImage|ImageSample|ImageFetch|ImageGather|ImageRead|ImageWrite)")
DERIVATIVES = re.compile(r"^Op(DPdx|DPdy|Fwidth)")
DISCARD = {"OpKill", "OpTerminateInvocation", "OpDemoteToHelperInvocation"}
ARITHMETIC = {"OpFAdd": lambda a, b: a + b, "OpFSub": lambda a, b: a - b, "OpFMul": lambda a, b: a * b,
              "OpFDiv": lambda a, b: a / b}
COMPARISONS = {"LessThan": sp.StrictLessThan, "LessThanEqual": sp.LessThan, "GreaterThan": sp.StrictGreaterThan,
               "GreaterThanEqual": sp.GreaterThan, "Equal": sp.Eq, "NotEqual": sp.Ne}
LOGICAL = {"OpLogicalAnd": sp.And, "OpLogicalOr": sp.Or}


def _clamp(x, lo, hi):
    return sp.Min(sp.Max(x, lo), hi)


def _smoothstep(e0, e1, x):
    t = _clamp((x - e0) / (e1 - e0), 0, 1)
    return t * t * (3 - 2 * t)


FUNCTIONS = {       # GLSL.std.450, as `engine.expressions` builds the same functions
    "FAbs": sp.Abs, "FSign": sp.sign, "Floor": sp.floor, "Ceil": sp.ceiling, "Fract": lambda x: x - sp.floor(x),
    "Sqrt": sp.sqrt, "InverseSqrt": lambda x: 1 / sp.sqrt(x), "Exp": sp.exp, "Exp2": lambda x: sp.Integer(2) ** x,
    "Log": sp.log, "Log2": lambda x: sp.log(x) / sp.log(2), "Pow": lambda x, y: x ** y, "Sin": sp.sin,
    "Cos": sp.cos, "Tan": sp.tan, "Asin": sp.asin, "Acos": sp.acos, "Atan": sp.atan, "Atan2": sp.atan2,
    "Sinh": sp.sinh, "Cosh": sp.cosh, "Tanh": sp.tanh, "FMin": sp.Min, "FMax": sp.Max, "NMin": sp.Min,
    "NMax": sp.Max, "FClamp": _clamp, "NClamp": _clamp, "FMix": lambda a, b, s: a + (b - a) * s,
    "Step": lambda edge, x: sp.Piecewise((sp.Integer(0), x < edge), (sp.Integer(1), True)),
    "SmoothStep": _smoothstep, "Fma": lambda a, b, c: a * b + c,
}


def _number(text: str) -> float:
    value = float.fromhex(text) if "0x" in text.lower() else float(text)
    return float(np.float32(value))


def _instructions(disassembly: str) -> list[tuple[str | None, str, list[str]]]:
    out = []
    for line in disassembly.splitlines():
        line = line.split(";", 1)[0].strip()
        if not line:
            continue
        words = re.findall(r'"[^"]*"|\S+', line)
        if len(words) >= 3 and words[1] == "=":
            out.append((words[0], words[2], words[3:]))
        else:
            out.append((None, words[0], words[1:]))
    return out


def read_both(disassembly: str, arguments: list[str], transliterate: bool = True) -> tuple[sp.Expr, str]:
    """(the value `main` stores to its output, a sympy expression in the real symbols `arguments`
    (the input at Location i is argument i); that reading transliterated into the GLSL body of a
    function of a0, a1, ...: one statement per SPIR-V operation, in the optimized shader's order,
    with its own GLSL function, constant and branch condition, so that it computes what the shader
    computes to the last bit, which `round_trip` executes beside the user's function). Without
    `transliterate` (a function of vectors: `lanes`), an argument of N lanes reads as N symbols
    NAME__0, NAME__1, ..., a vector result as a tuple of its lanes, and the text is None. Raises
    Refused naming what the reader does not take."""
    instructions = _instructions(disassembly)
    symbols = [sp.Symbol(a, real=True) for a in arguments]
    types, storage, locations, constants, declared = {}, {}, {}, {}, {}
    for result, opcode, rest in instructions:
        if opcode == "OpDecorate" and len(rest) >= 3 and rest[1] == "Location":
            locations[rest[0]] = int(rest[2])
        elif opcode.startswith("OpType") and result:
            types[result] = (opcode, rest)
        elif opcode == "OpVariable" and result:
            storage[result] = rest[1]
            declared[result] = rest[0]
        elif opcode == "OpConstant" and result:
            kind = types.get(rest[0], ("", []))
            if kind[0] == "OpTypeFloat":
                constants[result] = sp.Float(_number(rest[1]))
            elif kind[0] == "OpTypeInt":
                constants[result] = sp.Integer(int(rest[1]))
        elif opcode == "OpConstantTrue":
            constants[result] = sp.true
        elif opcode == "OpConstantFalse":
            constants[result] = sp.false
        elif opcode == "OpConstantComposite" and result:
            constants[result] = tuple(constants.get(a, a) for a in rest[1:])
    body = _main(instructions)
    for _, opcode, _ in body:
        if opcode == "OpLoopMerge":
            raise Refused("a loop left after optimization")
        if TEXTURE.match(opcode):
            raise Refused("a texture, image or sampler read")
        if DERIVATIVES.match(opcode):
            raise Refused("derivatives (dFdx, dFdy, fwidth)")
        if opcode in DISCARD:
            raise Refused("discard")
    blocks, order = _blocks(body)
    code = _Transliteration(constants) if transliterate else _Silent()
    values: dict = dict(constants)
    reach: dict[str, object] = {order[0]: sp.true}
    edges: dict[tuple[str, str], object] = {}
    stored = []
    for label in order:
        if label not in reach:
            reach[label] = sp.Or(*(sp.And(reach[p], c) for (p, b), c in edges.items() if b == label))
        code.enter(label)
        for result, opcode, rest in blocks[label]:
            if opcode in ("OpLabel", "OpSelectionMerge", "OpReturn", "OpUnreachable", "OpNop", "OpLine",
                          "OpNoLine"):
                continue
            if opcode == "OpLoad":
                pointer = rest[1]
                if storage.get(pointer) != "Input" or pointer not in locations:
                    raise Refused(f"a read of something other than an argument ({pointer})")
                if locations[pointer] >= len(symbols):
                    raise Refused(f"an input at location {locations[pointer]} beyond the arguments")
                pointee = types.get(declared.get(pointer), ("", ["", ""]))[1][-1]
                kind, operands = types.get(pointee, ("", []))
                if kind == "OpTypeVector":
                    if transliterate:
                        raise Refused("a vector argument")
                    name = symbols[locations[pointer]].name
                    values[result] = tuple(sp.Symbol(f"{name}__{k}", real=True) for k in range(int(operands[1])))
                else:
                    values[result] = symbols[locations[pointer]]
                code.names[result] = f"a{locations[pointer]}"
            elif opcode == "OpStore":
                if storage.get(rest[0]) != "Output":
                    raise Refused("a store other than the result (an out or inout parameter, a global)")
                stored.append((label, _value(values, rest[1])))
                code.stored = code.use(rest[1])
            elif opcode == "OpBranch":
                edges[(label, rest[0])] = sp.true
                code.edge(label, rest[0], "true")
            elif opcode == "OpBranchConditional":
                condition = _value(values, rest[0])
                if rest[1] == rest[2]:
                    edges[(label, rest[1])] = sp.true
                    code.edge(label, rest[1], "true")
                else:
                    edges[(label, rest[1])] = condition
                    edges[(label, rest[2])] = sp.Not(condition)
                    code.edge(label, rest[1], code.use(rest[0]))
                    code.edge(label, rest[2], f"!{code.use(rest[0])}")
            elif opcode == "OpSwitch":
                selector = values.get(rest[0])
                if not isinstance(selector, sp.Integer):
                    raise Refused("a switch on a value of the arguments")
                cases = dict(zip(rest[2::2], rest[3::2]))
                edges[(label, cases.get(str(int(selector)), rest[1]))] = sp.true
                code.edge(label, cases.get(str(int(selector)), rest[1]), "true")
            elif opcode == "OpPhi":
                pieces = [(_value(values, v), sp.And(reach[p], edges.get((p, label), sp.false)))
                          for v, p in zip(rest[1::2], rest[2::2]) if p in reach]
                values[result] = _piecewise(pieces)
                code.phi(result, [(v, p) for v, p in zip(rest[1::2], rest[2::2]) if p in reach], label)
            else:
                values[result] = _operation(opcode, rest, values)
                code.operation(result, opcode, rest, values[result])
    if len(stored) != 1:
        raise Refused("the result is written more than once" if stored else "no result is written")
    value = stored[0][1]
    if isinstance(value, tuple) and transliterate:
        raise Refused("a vector result")
    return value, code.text() if transliterate else None


def lanes(disassembly: str, arguments: list[str], vectors: list[str]) -> sp.Expr:
    """The one scalar function every lane of a vector result computes of its own lane of each vector
    argument (`vectors`: their names) and of the scalar ones (a colour's Fresnel), in the arguments'
    names. Raises Refused where a lane reads another lane or computes another function."""
    value, _ = read_both(disassembly, arguments, transliterate=False)
    if not isinstance(value, tuple):
        raise Refused("a vector function whose result is not a vector")
    plain = {a: sp.Symbol(a, real=True) for a in arguments}
    out = []
    for k, lane in enumerate(value):
        own = {sp.Symbol(f"{a}__{k}", real=True): plain[a] for a in vectors}
        scalar = lane.xreplace(own)
        if not scalar.free_symbols <= set(plain.values()):
            raise Refused("a vector result whose lanes are not one scalar function of their own lane (lane "
                          f"{k} reads another lane)")
        out.append(scalar)
    if any(o != out[0] for o in out[1:]):
        raise Refused("a vector result whose lanes are not one scalar function of their own lane")
    return out[0]


class _Silent:
    """No transliteration (a reading of vectors)."""

    def __init__(self):
        self.names: dict = {}
        self.stored = None

    def use(self, name):
        return name

    def __getattr__(self, name):
        return lambda *args, **kwargs: None


GLSL_FUNCTIONS = {
    "FAbs": "abs", "FSign": "sign", "Floor": "floor", "Ceil": "ceil", "Fract": "fract", "Sqrt": "sqrt",
    "InverseSqrt": "inversesqrt", "Exp": "exp", "Exp2": "exp2", "Log": "log", "Log2": "log2", "Pow": "pow",
    "Sin": "sin", "Cos": "cos", "Tan": "tan", "Asin": "asin", "Acos": "acos", "Atan": "atan", "Atan2": "atan",
    "Sinh": "sinh", "Cosh": "cosh", "Tanh": "tanh", "FMin": "min", "FMax": "max", "NMin": "min", "NMax": "max",
    "FClamp": "clamp", "NClamp": "clamp", "FMix": "mix", "Step": "step", "SmoothStep": "smoothstep", "Fma": "fma",
}
GLSL_COMPARISONS = {"LessThan": "<", "LessThanEqual": "<=", "GreaterThan": ">", "GreaterThanEqual": ">=",
                    "Equal": "==", "NotEqual": "!="}
UNORDERED = {"LessThan": ">=", "LessThanEqual": ">", "GreaterThan": "<=", "GreaterThanEqual": "<", "Equal": "!="}
GLSL_ARITHMETIC = {"OpFAdd": "+", "OpFSub": "-", "OpFMul": "*", "OpFDiv": "/"}


class _Transliteration:
    """The optimized shader's `main` as GLSL statements (`read_both`): a float or bool local per
    SPIR-V value, a bool per block that holds where the block is reached, a phi a chain of `?:` over
    its incoming edges' conditions."""

    def __init__(self, constants: dict):
        self.names: dict[str, str] = {}
        self.constants = constants
        self.lines: list[str] = []
        self.edges: dict[tuple[str, str], str] = {}
        self.stored: str | None = None
        self.count = 0

    def use(self, name: str):
        """A value's GLSL text, or a vector's list of its lanes' texts."""
        if name in self.names:
            return self.names[name]
        value = self.constants.get(name)
        if isinstance(value, tuple):
            return [self.use(v) if isinstance(v, str) else self._number(v) for v in value]
        return self._number(value, name)

    def _number(self, value, name: str = "") -> str:
        if value is sp.true or value is sp.false:
            return "true" if value is sp.true else "false"
        if isinstance(value, sp.Float):
            text = format(float(value), ".9g")
            return text if any(c in text for c in ".eEn") else text + ".0"
        raise Refused(f"a value the transliteration does not know ({name})")

    def _local(self, result: str, kind: str, text: str) -> None:
        self.count += 1
        self.names[result] = f"v{self.count}"
        self.lines.append(f"{kind} v{self.count} = {text};")

    def enter(self, label: str) -> None:
        incoming = [f"({self.names[f'reach{p}']} && {c})" for (p, b), c in self.edges.items() if b == label]
        self.lines.append(f"bool r{len(self.lines)} = {' || '.join(incoming) or 'true'};")
        self.names[f"reach{label}"] = f"r{len(self.lines) - 1}"

    def edge(self, source: str, target: str, condition: str) -> None:
        self.edges[(source, target)] = condition

    def phi(self, result: str, incoming: list[tuple[str, str]], label: str) -> None:
        pieces = [(self.use(v), f"({self.names[f'reach{p}']} && {self.edges.get((p, label), 'false')})")
                  for v, p in incoming]
        if any(isinstance(v, list) for v, _ in pieces):
            raise Refused("a branch between vectors")
        text = pieces[-1][0]
        for value, condition in reversed(pieces[:-1]):
            text = f"({condition} ? {value} : {text})"
        self._local(result, "float", text)

    def operation(self, result: str, opcode: str, rest: list[str], value) -> None:
        if opcode == "OpCompositeExtract":         # (a vector's lanes: one text each)
            vector = self.use(rest[1])
            self.names[result] = vector[int(rest[2])] if isinstance(vector, list) else vector
            return
        if opcode == "OpVectorShuffle":
            both = list(self.use(rest[1])) + list(self.use(rest[2]))
            self.names[result] = [both[int(i)] for i in rest[3:]]
            return
        args = [self.use(a) for a in rest[1:]] if opcode != "OpExtInst" else [self.use(a) for a in rest[3:]]
        if opcode == "OpCompositeConstruct":
            self.names[result] = [lane for a in args for lane in (a if isinstance(a, list) else [a])]
            return
        if opcode == "OpVectorTimesScalar":
            opcode, args = "OpFMul", args
        if isinstance(value, tuple):                # (lane by lane: GLSL computes a vector's lanes apart)
            names = []
            for k in range(len(value)):
                lane = [a[k] if isinstance(a, list) else a for a in args]
                self._scalar(f"{result}[{k}]", opcode, rest, lane)
                names.append(self.names.pop(f"{result}[{k}]"))
            self.names[result] = names
            return
        self._scalar(result, opcode, rest, args)

    def _scalar(self, result: str, opcode: str, rest: list[str], args: list[str]) -> None:
        comparison = re.fullmatch(r"OpF(Ord|Unord)(\w+)", opcode)
        if opcode in GLSL_ARITHMETIC:
            self._local(result, "float", f"({args[0]} {GLSL_ARITHMETIC[opcode]} {args[1]})")
        elif opcode == "OpFNegate":
            self._local(result, "float", f"(-{args[0]})")
        elif opcode == "OpExtInst":
            self._local(result, "float", f"{GLSL_FUNCTIONS[rest[2]]}({', '.join(args)})")
        elif comparison:
            kind = comparison.group(2)
            text = (f"({args[0]} {GLSL_COMPARISONS[kind]} {args[1]})" if comparison.group(1) == "Ord" or kind == "NotEqual"
                    else f"!({args[0]} {UNORDERED[kind]} {args[1]})")
            if comparison.group(1) == "Ord" and kind == "NotEqual":
                text = f"(({args[0]} < {args[1]}) || ({args[0]} > {args[1]}))"
            self._local(result, "bool", text)
        elif opcode in ("OpLogicalAnd", "OpLogicalOr"):
            self._local(result, "bool", f"({args[0]} {'&&' if opcode == 'OpLogicalAnd' else '||'} {args[1]})")
        elif opcode == "OpLogicalNot":
            self._local(result, "bool", f"(!{args[0]})")
        elif opcode == "OpSelect":
            self._local(result, "float", f"({args[0]} ? {args[1]} : {args[2]})")
        else:
            raise Refused(f"an operation the transliteration does not know ({opcode})")

    def text(self) -> str:
        return "\n".join(self.lines + [f"return {self.stored};"])


def _main(instructions) -> list:
    names = {rest[0]: rest[1].strip('"') for _, opcode, rest in instructions if opcode == "OpName"}
    for opcode_at, (result, opcode, rest) in enumerate(instructions):
        if opcode == "OpEntryPoint":
            entry = rest[1]
            break
    else:
        raise Refused("no entry point")
    start = next(i for i, (result, opcode, _) in enumerate(instructions) if opcode == "OpFunction" and result == entry)
    end = next(i for i in range(start, len(instructions)) if instructions[i][1] == "OpFunctionEnd")
    body = instructions[start + 1:end]
    calls = [rest[1] for _, opcode, rest in body if opcode == "OpFunctionCall"]
    if calls:
        raise Refused(f"a call the optimizer left ({names.get(calls[0], calls[0])})")
    return body


def _blocks(body) -> tuple[dict, list[str]]:
    """({label: its instructions}, the labels in an order where each comes after its predecessors).
    Raises Refused for a cycle (a loop)."""
    blocks: dict[str, list] = {}
    label = None
    for instruction in body:
        result, opcode, rest = instruction
        if opcode == "OpLabel":
            label = result
            blocks[label] = []
        elif label is not None:
            blocks[label].append(instruction)
    successors = {}
    for label, lines in blocks.items():
        result, opcode, rest = lines[-1]
        successors[label] = ([rest[0]] if opcode == "OpBranch" else rest[1:3] if opcode == "OpBranchConditional"
                             else [rest[1]] + rest[3::2] if opcode == "OpSwitch" else [])
    entry = next(iter(blocks))
    seen, stack, reachable = set(), [entry], []
    while stack:
        b = stack.pop()
        if b not in seen:
            seen.add(b)
            reachable.append(b)
            stack.extend(successors[b])
    incoming = {b: 0 for b in reachable}
    for b in reachable:
        for s in set(successors[b]):
            incoming[s] += 1
    order, ready = [], [entry]
    while ready:
        b = ready.pop()
        order.append(b)
        for s in set(successors[b]):
            incoming[s] -= 1
            if incoming[s] == 0:
                ready.append(s)
    if len(order) != len(reachable):
        raise Refused("a loop left after optimization")
    return blocks, order


def _value(values: dict, name: str):
    if name not in values:
        raise Refused(f"a value the reader does not know ({name})")
    return values[name]


def _piecewise(pieces: list) -> sp.Expr:
    pieces = [(v, c) for v, c in pieces if c is not sp.false]
    if len(pieces) == 1:
        return pieces[0][0]
    if any(isinstance(v, tuple) for v, _ in pieces):
        raise Refused("a branch between vectors")
    return sp.Piecewise(*pieces[:-1], (pieces[-1][0], True))


def _operation(opcode: str, rest: list[str], values: dict):
    """The value of one instruction (its type is rest[0], its operands after)."""
    args = rest[1:]
    if opcode in ARITHMETIC:
        return _lanes(ARITHMETIC[opcode], [_value(values, a) for a in args])
    if opcode == "OpFNegate":
        return _lanes(lambda a: -a, [_value(values, args[0])])
    if opcode == "OpExtInst":
        function = args[1]
        if function not in FUNCTIONS:
            raise Refused(f"an operation the reader does not know (GLSL.std.450 {function})")
        return _lanes(FUNCTIONS[function], [_value(values, a) for a in args[2:]])
    comparison = re.fullmatch(r"OpF(Ord|Unord)(\w+)", opcode)
    if comparison and comparison.group(2) in COMPARISONS:
        a, b = (_value(values, x) for x in args)
        return COMPARISONS[comparison.group(2)](a, b)
    if opcode in LOGICAL:
        return LOGICAL[opcode](*(_value(values, a) for a in args))
    if opcode == "OpLogicalNot":
        return sp.Not(_value(values, args[0]))
    if opcode == "OpSelect":
        condition, a, b = (_value(values, x) for x in args)
        return _lanes(lambda x, y: _piecewise([(x, condition), (y, sp.Not(condition))]), [a, b])
    if opcode == "OpCompositeConstruct":
        return tuple(_value(values, a) for a in args)
    if opcode == "OpCompositeExtract":
        value = _value(values, args[0])
        return value[int(args[1])] if isinstance(value, tuple) else value
    if opcode == "OpVectorShuffle":
        first, second = _value(values, args[0]), _value(values, args[1])
        lanes = tuple(first) + tuple(second)
        return tuple(lanes[int(i)] for i in args[2:])
    if opcode == "OpVectorTimesScalar":
        vector, scalar = _value(values, args[0]), _value(values, args[1])
        return tuple(v * scalar for v in vector)
    if opcode == "OpDot":
        a, b = _value(values, args[0]), _value(values, args[1])
        return sp.Add(*(x * y for x, y in zip(a, b)))
    raise Refused(f"an operation the reader does not know ({opcode})")


def _lanes(function, operands: list):
    """`function` of scalar operands, or lane by lane where one is a vector (a scalar operand
    repeated)."""
    width = max((len(o) for o in operands if isinstance(o, tuple)), default=0)
    if not width:
        return function(*operands)
    return tuple(function(*(o[i] if isinstance(o, tuple) else o for o in operands)) for i in range(width))
