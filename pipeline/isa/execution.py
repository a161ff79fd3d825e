"""A form executed as the GPU executes it: its GLSL body run as a compute shader by Mesa's lavapipe
(Vulkan on the CPU: llvmpipe, the `lvp_icd*.json` of Debian's mesa-vulkan-drivers), one invocation
per input, in float32 or float16 (explicit 16-bit types, as a phone's mediump computes), its
outputs read back.

`execute(body, inputs, precision)` compiles the shader here (glslang) and runs the driver in a child
process (`python -m pipeline.isa.execution FOLDER`, the ICD `engine.toolchains` finds), so that a
driver's crash or hang (bounded by a timeout) is one ExecutionError naming the form, never a dead
run. A form reads one variable (an array of inputs) or several (a dict of equal-length arrays, one
buffer each: a parameter per invocation, as a uniform it would be, already rounded to the format);
`execute_sets` runs several sets of forms, each with its own inputs, in one child process. `available()` says why lavapipe
cannot run here, or None; there, `emulate` computes the form per operation in numpy in the format.

What lavapipe computes: + - * / and sqrt correctly rounded per operation in the format (llvmpipe
fuses no multiply-add, not even GLSL's fma), denormals kept; its own functions (acos, asin, atan,
pow, exp2, log2) are Mesa's lowerings, which RADV, ANV, turnip and panfrost share. In float16 every
literal of the body is written as float16_t(the exact value of its nearest float16): glslang
truncates a literal converted to half (float16_t(0.3) is 0.2998, not the nearest 0.30005), and a
bare float literal would promote the arithmetic to float32.
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from ..engine import toolchains

PRECISIONS = {"fp32": ("float", np.float32), "fp16": ("float16_t", np.float16)}
LOCAL_SIZE = 64
MAX_GROUPS = 65535          # work groups per dimension (Vulkan's minimum maxComputeWorkGroupCount)
TIMEOUT = 120.0             # seconds of one form in the child process (compile, dispatch, read back)
_SHADER = """#version 450
{extensions}{prelude}layout(local_size_x = {local}) in;
{buffers}
layout(std430, binding = {out}) writeonly buffer Outputs {{ {t} ys[]; }};
{t} form({arguments})
{{
    return {body};
}}
void main()
{{
    uint i = gl_GlobalInvocationID.y * gl_NumWorkGroups.x * {local} + gl_GlobalInvocationID.x;
    ys[i] = form({values});
}}
"""
_FP16_EXTENSIONS = ("#extension GL_EXT_shader_explicit_arithmetic_types_float16 : require\n"
                    "#extension GL_EXT_shader_16bit_storage : require\n")


class ExecutionError(RuntimeError):
    """A form that lavapipe did not execute (one line: the form and why)."""


def available() -> str | None:
    """None where lavapipe can execute forms here, else why not (one line: `toolchains.find_lavapipe`)."""
    found = toolchains.locate("lavapipe")
    return None if found.found else found.missing


def shader_source(body: str, precision: str = "fp32", variable="x", prelude: str = "") -> str:
    """The compute shader of a form's GLSL expression `body` in `variable` (a name, or several names:
    one input buffer each, in that order) (module docstring), with `prelude` (GLSL declarations the
    body calls: a shader file's functions, its `#extension` lines first) above the form."""
    if precision not in PRECISIONS:
        raise ValueError(f"precision {precision!r}: give one of {', '.join(PRECISIONS)}")
    t, _ = PRECISIONS[precision]
    names = [variable] if isinstance(variable, str) else list(variable)
    extensions = ""
    if precision == "fp16":
        from .shaders import half_literals     # (here: the driver's child process needs no sympy)

        extensions = _FP16_EXTENSIONS
        body = half_literals(body)
    buffers = "\n".join(f"layout(std430, binding = {b}) readonly buffer Input{b} {{ {t} in{b}[]; }};"
                         for b in range(len(names)))
    return _SHADER.format(extensions=extensions, prelude=prelude and prelude.rstrip("\n") + "\n", local=LOCAL_SIZE,
                          t=t, buffers=buffers, out=len(names),
                          arguments=", ".join(f"{t} {n}" for n in names), body=body,
                          values=", ".join(f"in{b}[i]" for b in range(len(names))))


def execute(body: str, inputs, precision: str = "fp32", variable: str = "x", name: str = "form",
            timeout: float = TIMEOUT) -> np.ndarray:
    """The form's values at `inputs` (rounded to the format first) as lavapipe computes them: float32
    or float16, the shape of `inputs`. Raises ExecutionError naming `name` where lavapipe is absent,
    the shader does not compile, or the driver fails, crashes or takes longer than `timeout`."""
    (outcome,) = execute_forms({name: body}, inputs, precision, variable, timeout=timeout).values()
    if isinstance(outcome, ExecutionError):
        raise outcome
    return outcome


def errors(values, inputs, truth, floor: float = 0.0, denominator=None) -> dict:
    """{max_abs_error, max_rel_error, x_abs, x_rel} of `values` (a form's outputs in the format) at
    `inputs` against `truth` (float64 at the same inputs): |value - truth|, and that over
    max(|truth|, floor) (0 where both are equal); inf at the first input where a value is not finite
    and the truth is. `denominator`: max(|truth|, floor), where the caller has it (one per set of
    inputs, for every form executed there)."""
    x = np.asarray(inputs).ravel()
    f = np.asarray(truth, dtype=np.float64).ravel()
    if denominator is None:
        denominator = np.maximum(np.abs(f), floor)
    with np.errstate(all="ignore"):
        diff = np.subtract(np.asarray(values).ravel(), f, dtype=np.float64)
        np.abs(diff, out=diff)
        rel = diff / denominator
        if floor <= 0:
            rel[(denominator == 0) & (diff == 0)] = 0.0
    out = {}
    for key, where, e in (("max_abs_error", "x_abs", diff), ("max_rel_error", "x_rel", rel)):
        k = int(np.argmax(e))                   # (the first largest; the first NaN where there is one)
        if not np.isfinite(e[k]):
            k = int(np.flatnonzero(~np.isfinite(e))[0])
        out[key], out[where] = (float(e[k]) if np.isfinite(e[k]) else math.inf), float(x[k])
    return out


def execute_forms(bodies: dict[str, str], inputs, precision: str = "fp32", variable: str = "x", truth=None,
                  floor: float = 0.0, timeout: float = TIMEOUT, optimized: bool = False) -> dict:
    """Every form of `bodies` ({name: GLSL expression in `variable`, or in the names of `inputs` where
    it is a dict of equal-length arrays; or (prelude, expression), `shader_source`'s, or (prelude,
    expression, "hlsl"), the same compute shader in HLSL, `prelude` an HLSL file's}) executed by
    lavapipe at `inputs` (rounded to the format),
    all in one child process: {name: its values (the format, the shape of the inputs)}, or with
    `truth` (float64 at the inputs) {name: `errors` of its values (at the first variable)}, or an
    ExecutionError (one line naming the form) where it did not compile or the driver failed. A child
    that crashes or passes its time (`timeout` per form) is run again with each unfinished form alone,
    so that one form's failure is that form's only."""
    (out,) = execute_sets([(bodies, inputs, truth, floor)], precision, variable, timeout, optimized)
    return out


def execute_sets(sets, precision: str = "fp32", variable: str = "x", timeout: float = TIMEOUT,
                 optimized: bool = False) -> list[dict]:
    """`execute_forms` of several sets [(bodies, inputs, truth, floor), ...], each with its own inputs,
    in one child process: a list of its results, one dict per set. `optimized`: each shader's SPIR-V
    passed through `spirv-opt -O` first, as an application that optimizes its shaders ships them."""
    from ..optics import glslang

    if precision not in PRECISIONS:
        raise ValueError(f"precision {precision!r}: give one of {', '.join(PRECISIONS)}")
    why = available()
    if why is not None:
        return [{name: ExecutionError(f"{name}: not executed: {why}") for name in bodies} for bodies, *_ in sets]
    _, dtype = PRECISIONS[precision]
    outs: list[dict] = [{} for _ in sets]
    jobs = []                       # (set, name, file stem)
    with tempfile.TemporaryDirectory(prefix="execute_") as folder:
        folder = Path(folder)
        described = []
        for j, (bodies, inputs, truth, floor) in enumerate(sets):
            named = dict(inputs) if isinstance(inputs, dict) else {variable: inputs}
            arrays = [np.asarray(a, dtype=dtype).ravel() for a in named.values()]
            if len({a.size for a in arrays}) != 1:
                raise ValueError("the inputs of a set have different lengths")
            for b, a in enumerate(arrays):
                np.save(folder / f"set{j}_in{b}.npy", a)
            if truth is not None:
                np.save(folder / f"set{j}_truth.npy", np.asarray(truth, dtype=np.float64).ravel())
            described.append(dict(inputs=len(arrays), truth=truth is not None, floor=floor,
                                  shape=list(np.shape(next(iter(named.values()))))))
            for name, body in bodies.items():
                prelude, body, language = (body + ("glsl",))[:3] if isinstance(body, tuple) else ("", body, "glsl")
                try:
                    code = (glslang.spirv(shader_source(body, precision, list(named), prelude), stage="comp")
                            if language == "glsl" else _hlsl_spirv(body, list(named), prelude, precision))
                except glslang.GlslError as e:
                    first = next((line for line in str(e).splitlines() if "ERROR" in line), str(e).strip())
                    outs[j][name] = ExecutionError(f"{name}: the shader does not compile: {first}")
                    continue
                stem = f"set{j}_form{len(jobs)}"
                (folder / f"{stem}.spv").write_bytes(code)
                if optimized:
                    try:
                        _optimize(folder / f"{stem}.spv")
                    except RuntimeError as e:
                        outs[j][name] = ExecutionError(f"{name}: {e}")
                        continue
                jobs.append((j, name, stem))

        def run(indices: list[int]) -> str | None:
            (folder / "job.json").write_text(json.dumps(dict(sets=described, forms=[[jobs[k][0], jobs[k][2]]
                                                                                   for k in indices])))
            env = dict(os.environ, VK_ICD_FILENAMES=toolchains.locate("lavapipe").path,
                       XDG_RUNTIME_DIR=os.environ.get("XDG_RUNTIME_DIR") or tempfile.gettempdir())
            try:
                done = subprocess.run([sys.executable, "-m", "pipeline.isa.execution", str(folder)], env=env,
                                      capture_output=True, text=True, timeout=timeout * len(indices))
            except subprocess.TimeoutExpired:
                return f"lavapipe took longer than {timeout:g} s"
            if done.returncode != 0:
                return "lavapipe failed: " + (done.stderr.strip().splitlines() or [f"exit status {done.returncode}"])[-1]
            return None

        def result(k: int) -> Path:
            j, _, stem = jobs[k]
            return folder / (f"{stem}.errors.json" if described[j]["truth"] else f"{stem}.out.npy")

        failures = {}
        if jobs and run(list(range(len(jobs)))) is not None:
            for k in [k for k in range(len(jobs)) if not result(k).exists()]:
                alone = run([k])
                if alone is not None:
                    failures[k] = alone
        for k, (j, name, _) in enumerate(jobs):
            if k in failures:
                outs[j][name] = ExecutionError(f"{name}: {failures[k]}")
            elif not result(k).exists():
                outs[j][name] = ExecutionError(f"{name}: lavapipe wrote no result")
            elif described[j]["truth"]:
                outs[j][name] = json.loads(result(k).read_text())
            else:
                outs[j][name] = np.load(result(k)).reshape(described[j]["shape"])
    return [{name: out[name] for name in bodies} for out, (bodies, *_) in zip(outs, sets)]


_HLSL_SHADER = """{prelude}
{buffers}
[[vk::binding({out}, 0)]] RWStructuredBuffer<float> ys;
float form({arguments})
{{
    return {body};
}}
[numthreads({local}, 1, 1)]
void main(uint3 id : SV_DispatchThreadID)
{{
    ys[id.x] = form({values});
}}
"""


def _hlsl_spirv(body: str, names: list[str], prelude: str, precision: str) -> bytes:
    """The SPIR-V of `shader_source`'s compute shader written in HLSL (glslang's HLSL front end),
    `prelude` an HLSL file's declarations: float32 only, inputs at most MAX_GROUPS * LOCAL_SIZE (one
    row of work groups: the invocation's index its x). Raises glslang.GlslError with the
    compiler's message."""
    from ..optics import glslang, spirv

    if precision != "fp32":
        raise glslang.GlslError("an HLSL harness executes in float32 only")
    source = _HLSL_SHADER.format(
        prelude=prelude, out=len(names), local=LOCAL_SIZE, body=body,
        buffers="\n".join(f"[[vk::binding({b}, 0)]] StructuredBuffer<float> in{b};" for b in range(len(names))),
        arguments=", ".join(f"float {n}" for n in names), values=", ".join(f"in{b}[id.x]" for b in range(len(names))))
    with tempfile.TemporaryDirectory(prefix="hlsl_") as folder:
        path, out = Path(folder) / "form.hlsl", Path(folder) / "form.spv"
        path.write_text(source)
        done = spirv.run_tool([spirv.tool("glslangValidator"), "-D", "-V", "-S", "comp", "-e", "main", str(path),
                               "-o", str(out)])
        if done.returncode != 0:
            raise glslang.GlslError(done.stdout + done.stderr)
        return out.read_bytes()


def _optimize(path: Path) -> None:
    """The SPIR-V file at `path` replaced by its `spirv-opt -O` (RuntimeError with the tool's message)."""
    from ..optics import spirv

    done = spirv.run_tool([spirv.tool("spirv-opt"), "-O", str(path), "-o", str(path)])
    if done.returncode != 0:
        raise RuntimeError(f"spirv-opt failed on {path.name}: {done.stderr.strip()}")


def emulate(body: str, inputs, precision: str = "fp32", variable: str = "x") -> np.ndarray:
    """The form's values at `inputs` (an array of `variable`, or a dict of arrays by name) by a
    per-operation emulation in the format, where lavapipe cannot run: its fragment shader's
    operations after spirv-opt (`lowering.operations`, what every back end lowers) evaluated in numpy
    float32 or float16 (`lowering.evaluate`), each + - * / and sqrt correctly rounded as lavapipe
    rounds them; the special functions numpy's in the format (not a driver's: acos and pow are not
    those a GPU executes). Literals are the format's nearest, as `shader_source` writes them."""
    from . import lowering

    _, dtype = PRECISIONS[precision]
    named = dict(inputs) if isinstance(inputs, dict) else {variable: inputs}
    ops, result = emulation_program(body, precision, list(named))
    arrays = {name: np.asarray(a, dtype=dtype) for name, a in named.items()}
    shape = next(iter(arrays.values())).shape
    return np.asarray(lowering.evaluate(ops, result, arrays, {}, dtype), dtype=dtype).reshape(shape)


def emulation_program(body: str, precision: str, names: list[str], driver: bool = False) -> tuple[list, str]:
    """(the operations, the result's id) `emulate` evaluates for the form `body` in the inputs
    `names`, in the format (`lowering.operations` of its optimized fragment shader; `driver`: a
    driver's own acos, asin and atan kept as functions, for a bound by their allowances)."""
    from ..optics.spirv import optimized_disassembly
    from . import lowering
    from .shaders import form_shader, LITERAL

    if precision == "fp16":      # (the nearest float16 of each literal, exact in the float32 shader)
        body = LITERAL.sub(lambda m: repr(float(np.float16(float(m.group(1))))), body)
    return lowering.operations(optimized_disassembly(form_shader(names, names, f"return {body};", "")), driver=driver)


# The operations whose emulation (numpy, per operation in the format) equals lavapipe's result bit
# for bit: IEEE's correctly rounded + - * / and sqrt, and those that round nothing.
EXACT_FUNCTIONS = ("Sqrt", "FAbs", "FMax", "FMin", "NMax", "NMin", "FClamp", "NClamp")


def not_exactly_emulated(ops) -> str | None:
    """None where every operation of `ops` is emulated bit for bit (`EXACT_FUNCTIONS`, arithmetic,
    comparisons, selections), else the first that is not (a driver's own function, a fused
    multiply-add), by its SPIR-V name."""
    for op in ops:
        if op.kind == "function" and op.op not in EXACT_FUNCTIONS:
            return op.op
    return None


def _memory_type(vk, physical, bits: int, flags: int) -> int:
    properties = vk.vkGetPhysicalDeviceMemoryProperties(physical)
    for i in range(properties.memoryTypeCount):
        if bits & (1 << i) and (properties.memoryTypes[i].propertyFlags & flags) == flags:
            return i
    raise RuntimeError("no host-visible, host-coherent memory")


def run_folder(folder: Path) -> None:
    """The child process: the forms `folder/job.json` names dispatched one after the other on the
    first lavapipe device, each over its set's inputs (`setJ_inB.npy`, one buffer each), writing
    `STEM.out.npy`, or where its set has a truth its `STEM.errors.json` against `setJ_truth.npy`. The
    format is the inputs' dtype (float32 or float16)."""
    import vulkan as vk

    job = json.loads((folder / "job.json").read_text())
    sets = job["sets"]
    needed = sorted({j for j, _ in job["forms"]})
    inputs = {j: [np.load(folder / f"set{j}_in{b}.npy") for b in range(sets[j]["inputs"])] for j in needed}
    dtype = next(iter(inputs.values()))[0].dtype if inputs else np.float32
    destroy = []                                           # (function, arguments), in the order made
    try:
        app = vk.VkApplicationInfo(pApplicationName="pipeline execution", apiVersion=vk.VK_MAKE_VERSION(1, 2, 0))
        instance = vk.vkCreateInstance(vk.VkInstanceCreateInfo(pApplicationInfo=app), None)
        destroy.append((vk.vkDestroyInstance, (instance, None)))
        physical = next((d for d in vk.vkEnumeratePhysicalDevices(instance)
                         if "llvmpipe" in vk.vkGetPhysicalDeviceProperties(d).deviceName), None)
        if physical is None:
            raise RuntimeError("no lavapipe (llvmpipe) device: VK_ICD_FILENAMES names another driver")
        family = next(i for i, q in enumerate(vk.vkGetPhysicalDeviceQueueFamilyProperties(physical))
                      if q.queueFlags & vk.VK_QUEUE_COMPUTE_BIT)
        # float16 arithmetic and 16-bit storage buffers (the chain's structs must outlive vkCreateDevice)
        float16 = vk.VkPhysicalDeviceShaderFloat16Int8Features(shaderFloat16=vk.VK_TRUE)
        storage16 = vk.VkPhysicalDevice16BitStorageFeatures(pNext=float16, storageBuffer16BitAccess=vk.VK_TRUE)
        features = vk.VkPhysicalDeviceFeatures2(pNext=storage16) if dtype == np.float16 else None
        queue_info = vk.VkDeviceQueueCreateInfo(queueFamilyIndex=family, queueCount=1, pQueuePriorities=[1.0])
        device = vk.vkCreateDevice(physical, vk.VkDeviceCreateInfo(pNext=features, pQueueCreateInfos=[queue_info]),
                                   None)
        destroy.append((vk.vkDestroyDevice, (device, None)))
        queue = vk.vkGetDeviceQueue(device, family, 0)
        commands = vk.vkCreateCommandPool(device, vk.VkCommandPoolCreateInfo(
            queueFamilyIndex=family, flags=vk.VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT), None)
        destroy.append((vk.vkDestroyCommandPool, (device, commands, None)))
        command = vk.vkAllocateCommandBuffers(device, vk.VkCommandBufferAllocateInfo(
            commandPool=commands, level=vk.VK_COMMAND_BUFFER_LEVEL_PRIMARY, commandBufferCount=1))[0]
        fence = vk.vkCreateFence(device, vk.VkFenceCreateInfo(), None)
        destroy.append((vk.vkDestroyFence, (device, fence, None)))
        for j in needed:
            forms = [stem for set_index, stem in job["forms"] if set_index == j]
            _run_set(vk, physical, device, queue, command, fence, folder, forms, inputs[j], sets[j],
                     np.load(folder / f"set{j}_truth.npy") if sets[j]["truth"] else None)
    finally:
        for function, arguments in reversed(destroy):
            function(*arguments)


def _run_set(vk, physical, device, queue, command, fence, folder: Path, forms: list[str], arrays, described, truth):
    """One set's forms over its inputs (`run_folder`): its buffers, layout and pipelines, made and
    destroyed here."""
    values = arrays[0]
    dtype = values.dtype
    denominator = None if truth is None else np.maximum(np.abs(truth), described["floor"])
    groups = max(1, -(-values.size // LOCAL_SIZE))
    width = min(groups, MAX_GROUPS)
    height = -(-groups // width)
    size = width * height * LOCAL_SIZE * values.itemsize   # padded: the shader needs no bounds check
    count = len(arrays) + 1
    destroy = []
    try:
        memories = []
        buffers = []
        for _ in range(count):
            buffer = vk.vkCreateBuffer(device, vk.VkBufferCreateInfo(
                size=size, usage=vk.VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, sharingMode=vk.VK_SHARING_MODE_EXCLUSIVE), None)
            destroy.append((vk.vkDestroyBuffer, (device, buffer, None)))
            needs = vk.vkGetBufferMemoryRequirements(device, buffer)
            memory = vk.vkAllocateMemory(device, vk.VkMemoryAllocateInfo(
                allocationSize=needs.size, memoryTypeIndex=_memory_type(
                    vk, physical, needs.memoryTypeBits,
                    vk.VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | vk.VK_MEMORY_PROPERTY_HOST_COHERENT_BIT)), None)
            destroy.append((vk.vkFreeMemory, (device, memory, None)))
            vk.vkBindBufferMemory(device, buffer, memory, 0)
            buffers.append(buffer)
            memories.append(memory)
        for b, array in enumerate(arrays):
            mapped = vk.vkMapMemory(device, memories[b], 0, size, 0)   # a cffi buffer; numpy views it
            view = np.frombuffer(mapped, dtype=dtype)
            view[:array.size] = array
            view[array.size:] = 0
            del view, mapped                                           # (no view outlives the mapping)
            vk.vkUnmapMemory(device, memories[b])
        bindings = [vk.VkDescriptorSetLayoutBinding(binding=b, descriptorType=vk.VK_DESCRIPTOR_TYPE_STORAGE_BUFFER,
                                                    descriptorCount=1, stageFlags=vk.VK_SHADER_STAGE_COMPUTE_BIT)
                    for b in range(count)]
        set_layout = vk.vkCreateDescriptorSetLayout(device, vk.VkDescriptorSetLayoutCreateInfo(pBindings=bindings), None)
        destroy.append((vk.vkDestroyDescriptorSetLayout, (device, set_layout, None)))
        layout = vk.vkCreatePipelineLayout(device, vk.VkPipelineLayoutCreateInfo(pSetLayouts=[set_layout]), None)
        destroy.append((vk.vkDestroyPipelineLayout, (device, layout, None)))
        pool = vk.vkCreateDescriptorPool(device, vk.VkDescriptorPoolCreateInfo(maxSets=1, pPoolSizes=[
            vk.VkDescriptorPoolSize(type=vk.VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, descriptorCount=count)]), None)
        destroy.append((vk.vkDestroyDescriptorPool, (device, pool, None)))
        descriptors = vk.vkAllocateDescriptorSets(device, vk.VkDescriptorSetAllocateInfo(
            descriptorPool=pool, pSetLayouts=[set_layout]))[0]
        # (the package's VK_WHOLE_SIZE is -1, which cffi refuses: the buffers' size instead)
        vk.vkUpdateDescriptorSets(device, count, [vk.VkWriteDescriptorSet(
            dstSet=descriptors, dstBinding=b, descriptorCount=1, descriptorType=vk.VK_DESCRIPTOR_TYPE_STORAGE_BUFFER,
            pBufferInfo=[vk.VkDescriptorBufferInfo(buffer=buffers[b], offset=0, range=size)]) for b in range(count)],
            0, None)
        for stem in forms:
            code = (folder / f"{stem}.spv").read_bytes()
            module = vk.vkCreateShaderModule(device, vk.VkShaderModuleCreateInfo(codeSize=len(code), pCode=code), None)
            stage = vk.VkPipelineShaderStageCreateInfo(stage=vk.VK_SHADER_STAGE_COMPUTE_BIT, module=module, pName="main")
            pipeline = vk.vkCreateComputePipelines(device, None, 1, [vk.VkComputePipelineCreateInfo(
                stage=stage, layout=layout)], None)[0]
            vk.vkBeginCommandBuffer(command, vk.VkCommandBufferBeginInfo(
                flags=vk.VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT))
            vk.vkCmdBindPipeline(command, vk.VK_PIPELINE_BIND_POINT_COMPUTE, pipeline)
            vk.vkCmdBindDescriptorSets(command, vk.VK_PIPELINE_BIND_POINT_COMPUTE, layout, 0, 1, [descriptors], 0, None)
            vk.vkCmdDispatch(command, width, height, 1)
            vk.vkCmdPipelineBarrier(command, vk.VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, vk.VK_PIPELINE_STAGE_HOST_BIT, 0,
                                    1, [vk.VkMemoryBarrier(srcAccessMask=vk.VK_ACCESS_SHADER_WRITE_BIT,
                                                           dstAccessMask=vk.VK_ACCESS_HOST_READ_BIT)], 0, None, 0, None)
            vk.vkEndCommandBuffer(command)
            vk.vkQueueSubmit(queue, 1, [vk.VkSubmitInfo(pCommandBuffers=[command])], fence)
            vk.vkWaitForFences(device, 1, [fence], vk.VK_TRUE, int(TIMEOUT * 1e9))
            vk.vkResetFences(device, 1, [fence])
            vk.vkResetCommandBuffer(command, 0)
            vk.vkDestroyPipeline(device, pipeline, None)
            vk.vkDestroyShaderModule(device, module, None)
            mapped = vk.vkMapMemory(device, memories[-1], 0, size, 0)
            outputs = np.frombuffer(mapped, dtype=dtype)[:values.size].copy()
            del mapped
            vk.vkUnmapMemory(device, memories[-1])
            if truth is None:
                np.save(folder / f"{stem}.partial.npy", outputs)
                os.replace(folder / f"{stem}.partial.npy", folder / f"{stem}.out.npy")
            else:
                (folder / f"{stem}.errors.json").write_text(json.dumps(errors(outputs, values, truth, described["floor"],
                                                                                         denominator)))
    finally:
        for function, arguments in reversed(destroy):
            function(*arguments)


if __name__ == "__main__":
    try:
        run_folder(Path(sys.argv[1]))
    except Exception as e:      # (the parent reads the last line)
        print(f"{type(e).__name__}: {e}", file=sys.stderr)
        sys.exit(1)
