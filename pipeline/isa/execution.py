"""A form executed as the GPU executes it: its GLSL body run as a compute shader by Mesa's lavapipe
(Vulkan on the CPU: llvmpipe, the `lvp_icd*.json` of Debian's mesa-vulkan-drivers), one invocation
per input, in float32 or float16 (explicit 16-bit types, as a phone's mediump computes), its
outputs read back.

`execute(body, inputs, precision)` compiles the shader here (glslang) and runs the driver in a child
process (`python -m pipeline.isa.execution FOLDER`, the ICD `engine.toolchains` finds), so that a driver's crash or hang (bounded by a
timeout) is one ExecutionError naming the form, never a dead run. `available()` says why lavapipe
cannot run here, or None; there, `emulate` computes the form per operation in numpy in the format.

What lavapipe computes: + - * / and sqrt correctly rounded per operation in the format (llvmpipe
fuses no multiply-add, not even GLSL's fma), denormals kept; its own functions (acos, asin, atan,
pow, exp2, log2) are Mesa's lowerings, which RADV, ANV, turnip and panfrost share. In float16 every
literal of the body is written as float16_t(the exact value of its nearest float16): glslang
truncates a literal converted to half (float16_t(0.3) is 0.2998, not the nearest 0.30005), and a
bare float literal would promote the arithmetic to float32.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from ..engine import toolchains

PRECISIONS = {"fp32": ("float", np.float32), "fp16": ("float16_t", np.float16)}
LOCAL_SIZE = 64
TIMEOUT = 120.0             # seconds of one child process (compile, dispatch, read back)
_SHADER = """#version 450
{extensions}layout(local_size_x = {local}) in;
layout(std430, binding = 0) readonly buffer Inputs {{ {t} xs[]; }};
layout(std430, binding = 1) writeonly buffer Outputs {{ {t} ys[]; }};
{t} form({t} {variable})
{{
    return {body};
}}
void main() {{ uint i = gl_GlobalInvocationID.x; ys[i] = form(xs[i]); }}
"""
_FP16_EXTENSIONS = ("#extension GL_EXT_shader_explicit_arithmetic_types_float16 : require\n"
                    "#extension GL_EXT_shader_16bit_storage : require\n")
# a numeric literal, not part of a name (x2, vec3)
_LITERAL = re.compile(r"(?<![\w.])(\d+\.\d*(?:[eE][+-]?\d+)?|\.\d+(?:[eE][+-]?\d+)?|\d+[eE][+-]?\d+|\d+)(?![\w.])")


class ExecutionError(RuntimeError):
    """A form that lavapipe did not execute (one line: the form and why)."""


def available() -> str | None:
    """None where lavapipe can execute forms here, else why not (one line: `toolchains.find_lavapipe`)."""
    found = toolchains.locate("lavapipe")
    return None if found.found else found.missing


def shader_source(body: str, precision: str = "fp32", variable: str = "x") -> str:
    """The compute shader of a form's GLSL expression `body` in `variable` (module docstring)."""
    if precision not in PRECISIONS:
        raise ValueError(f"precision {precision!r}: give one of {', '.join(PRECISIONS)}")
    t, _ = PRECISIONS[precision]
    extensions = ""
    if precision == "fp16":
        extensions = _FP16_EXTENSIONS
        body = _LITERAL.sub(lambda m: f"float16_t({float(np.float16(float(m.group(1))))!r})", body)
    return _SHADER.format(extensions=extensions, local=LOCAL_SIZE, t=t, variable=variable, body=body)


def execute(body: str, inputs, precision: str = "fp32", variable: str = "x", name: str = "form",
            timeout: float = TIMEOUT) -> np.ndarray:
    """The form's values at `inputs` (rounded to the format first) as lavapipe computes them: float32
    or float16, the shape of `inputs`. Raises ExecutionError naming `name` where lavapipe is absent,
    the shader does not compile, or the driver fails, crashes or takes longer than `timeout`."""
    from ..optics import glslang

    why = available()
    if why is not None:
        raise ExecutionError(f"{name}: not executed: {why}")
    _, dtype = PRECISIONS[precision] if precision in PRECISIONS else (None, None)
    source = shader_source(body, precision, variable)
    try:
        code = glslang.spirv(source, stage="comp")
    except glslang.GlslError as e:
        first = next((line for line in str(e).splitlines() if "ERROR" in line), str(e).strip())
        raise ExecutionError(f"{name}: the shader does not compile: {first}") from None
    values = np.asarray(inputs, dtype=dtype)
    with tempfile.TemporaryDirectory(prefix="execute_") as folder:
        folder = Path(folder)
        (folder / "form.spv").write_bytes(code)
        np.save(folder / "inputs.npy", values.ravel())
        env = dict(os.environ, VK_ICD_FILENAMES=toolchains.locate("lavapipe").path,
                   XDG_RUNTIME_DIR=os.environ.get("XDG_RUNTIME_DIR") or tempfile.gettempdir())
        try:
            done = subprocess.run([sys.executable, "-m", "pipeline.isa.execution", str(folder)], env=env,
                                  capture_output=True, text=True, timeout=timeout)
        except subprocess.TimeoutExpired:
            raise ExecutionError(f"{name}: lavapipe took longer than {timeout:g} s") from None
        if done.returncode != 0 or not (folder / "outputs.npy").exists():
            last = (done.stderr.strip().splitlines() or [f"exit status {done.returncode}"])[-1]
            raise ExecutionError(f"{name}: lavapipe failed: {last}")
        return np.load(folder / "outputs.npy").reshape(values.shape)


def emulate(body: str, inputs, precision: str = "fp32", variable: str = "x") -> np.ndarray:
    """The form's values at `inputs` by a per-operation emulation in the format, where lavapipe
    cannot run: its fragment shader's operations after spirv-opt (`lowering.operations`, what every
    back end lowers) evaluated in numpy float32 or float16 (`lowering.evaluate`), each + - * / and
    sqrt correctly rounded as lavapipe rounds them; the special functions numpy's in the format (not
    a driver's: acos and pow are not those a GPU executes). Literals are the format's nearest, as
    `shader_source` writes them."""
    from ..optics.spirv import optimized_disassembly
    from . import lowering
    from .shaders import UNIFORM

    _, dtype = PRECISIONS[precision]
    if precision == "fp16":      # (the nearest float16 of each literal, exact in the float32 shader)
        body = _LITERAL.sub(lambda m: repr(float(np.float16(float(m.group(1))))), body)
    head = "" if variable == "t" else f"float {variable} = t; "
    ops, result = lowering.operations(optimized_disassembly(UNIFORM.format(body=f"{head}return {body};")))
    values = np.asarray(inputs, dtype=dtype)
    return np.asarray(lowering.evaluate(ops, result, {"t": values}, {}, dtype), dtype=dtype).reshape(values.shape)


def _memory_type(vk, physical, bits: int, flags: int) -> int:
    properties = vk.vkGetPhysicalDeviceMemoryProperties(physical)
    for i in range(properties.memoryTypeCount):
        if bits & (1 << i) and (properties.memoryTypes[i].propertyFlags & flags) == flags:
            return i
    raise RuntimeError("no host-visible, host-coherent memory")


def run_folder(folder: Path) -> None:
    """The child process: `folder/form.spv` dispatched over `folder/inputs.npy` on the first lavapipe
    device, `folder/outputs.npy` written. The format is the inputs' dtype (float32 or float16)."""
    import vulkan as vk

    code = (folder / "form.spv").read_bytes()
    values = np.load(folder / "inputs.npy")
    dtype = values.dtype
    groups = max(1, -(-values.size // LOCAL_SIZE))
    size = groups * LOCAL_SIZE * values.itemsize          # padded: the shader needs no bounds check
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
        buffers, memories = [], []
        for _ in range(2):
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
        mapped = vk.vkMapMemory(device, memories[0], 0, size, 0)       # a cffi buffer; numpy views it
        view = np.frombuffer(mapped, dtype=dtype)
        view[:values.size] = values
        view[values.size:] = 0
        del view, mapped                                                # (no view outlives the mapping)
        vk.vkUnmapMemory(device, memories[0])
        bindings = [vk.VkDescriptorSetLayoutBinding(binding=b, descriptorType=vk.VK_DESCRIPTOR_TYPE_STORAGE_BUFFER,
                                                    descriptorCount=1, stageFlags=vk.VK_SHADER_STAGE_COMPUTE_BIT)
                    for b in range(2)]
        set_layout = vk.vkCreateDescriptorSetLayout(device, vk.VkDescriptorSetLayoutCreateInfo(pBindings=bindings), None)
        destroy.append((vk.vkDestroyDescriptorSetLayout, (device, set_layout, None)))
        layout = vk.vkCreatePipelineLayout(device, vk.VkPipelineLayoutCreateInfo(pSetLayouts=[set_layout]), None)
        destroy.append((vk.vkDestroyPipelineLayout, (device, layout, None)))
        module = vk.vkCreateShaderModule(device, vk.VkShaderModuleCreateInfo(codeSize=len(code), pCode=code), None)
        destroy.append((vk.vkDestroyShaderModule, (device, module, None)))
        stage = vk.VkPipelineShaderStageCreateInfo(stage=vk.VK_SHADER_STAGE_COMPUTE_BIT, module=module, pName="main")
        pipeline = vk.vkCreateComputePipelines(device, None, 1, [vk.VkComputePipelineCreateInfo(
            stage=stage, layout=layout)], None)[0]
        destroy.append((vk.vkDestroyPipeline, (device, pipeline, None)))
        pool = vk.vkCreateDescriptorPool(device, vk.VkDescriptorPoolCreateInfo(maxSets=1, pPoolSizes=[
            vk.VkDescriptorPoolSize(type=vk.VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, descriptorCount=2)]), None)
        destroy.append((vk.vkDestroyDescriptorPool, (device, pool, None)))
        descriptors = vk.vkAllocateDescriptorSets(device, vk.VkDescriptorSetAllocateInfo(
            descriptorPool=pool, pSetLayouts=[set_layout]))[0]
        # (the package's VK_WHOLE_SIZE is -1, which cffi refuses: the buffers' size instead)
        vk.vkUpdateDescriptorSets(device, 2, [vk.VkWriteDescriptorSet(
            dstSet=descriptors, dstBinding=b, descriptorCount=1, descriptorType=vk.VK_DESCRIPTOR_TYPE_STORAGE_BUFFER,
            pBufferInfo=[vk.VkDescriptorBufferInfo(buffer=buffers[b], offset=0, range=size)]) for b in range(2)],
            0, None)
        commands = vk.vkCreateCommandPool(device, vk.VkCommandPoolCreateInfo(queueFamilyIndex=family), None)
        destroy.append((vk.vkDestroyCommandPool, (device, commands, None)))
        command = vk.vkAllocateCommandBuffers(device, vk.VkCommandBufferAllocateInfo(
            commandPool=commands, level=vk.VK_COMMAND_BUFFER_LEVEL_PRIMARY, commandBufferCount=1))[0]
        vk.vkBeginCommandBuffer(command, vk.VkCommandBufferBeginInfo(flags=vk.VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT))
        vk.vkCmdBindPipeline(command, vk.VK_PIPELINE_BIND_POINT_COMPUTE, pipeline)
        vk.vkCmdBindDescriptorSets(command, vk.VK_PIPELINE_BIND_POINT_COMPUTE, layout, 0, 1, [descriptors], 0, None)
        vk.vkCmdDispatch(command, groups, 1, 1)
        vk.vkCmdPipelineBarrier(command, vk.VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, vk.VK_PIPELINE_STAGE_HOST_BIT, 0,
                                1, [vk.VkMemoryBarrier(srcAccessMask=vk.VK_ACCESS_SHADER_WRITE_BIT,
                                                       dstAccessMask=vk.VK_ACCESS_HOST_READ_BIT)], 0, None, 0, None)
        vk.vkEndCommandBuffer(command)
        fence = vk.vkCreateFence(device, vk.VkFenceCreateInfo(), None)
        destroy.append((vk.vkDestroyFence, (device, fence, None)))
        vk.vkQueueSubmit(queue, 1, [vk.VkSubmitInfo(pCommandBuffers=[command])], fence)
        vk.vkWaitForFences(device, 1, [fence], vk.VK_TRUE, int(TIMEOUT * 1e9))
        mapped = vk.vkMapMemory(device, memories[1], 0, size, 0)
        outputs = np.frombuffer(mapped, dtype=dtype)[:values.size].copy()
        del mapped
        vk.vkUnmapMemory(device, memories[1])
    finally:
        for function, arguments in reversed(destroy):
            function(*arguments)
    np.save(folder / "outputs.npy", outputs)


if __name__ == "__main__":
    try:
        run_folder(Path(sys.argv[1]))
    except Exception as e:      # (the parent reads the last line)
        print(f"{type(e).__name__}: {e}", file=sys.stderr)
        sys.exit(1)
