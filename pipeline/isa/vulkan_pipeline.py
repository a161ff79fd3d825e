"""A minimal Vulkan program that has the driver compile graphics pipelines and nothing else: run
as `python -P vulkan_pipeline.py`, it reads folders from standard input, a line each, and for each
creates one pipeline per fragment shader `FOLDER/*.frag.spv` (with the vertex shader
`FOLDER/vert.spv`) on the first physical device (created once, for every folder), writing
`@@@ SHADER <name>` to stderr before each and `@@@ END` after the folder's last; it ends at the end
of its input. Under Mesa's RADV with `RADV_DEBUG=shaders` and `ACO_DEBUG=perfinfo` the driver
prints each shader's machine code and its cycle estimate to the same stderr (`pipeline.isa.radv`
reads them).

Nothing is drawn and no memory is allocated: pipelines compile on RADV's null device (no GPU), set
up by `RADV_FORCE_FAMILY`. The `vulkan` package (cffi bindings to libvulkan.so.1) needs no C
compiler. Fragment shaders read push constants (n, k, rate) and two varyings (t, n per pixel).
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

PUSH_CONSTANT_BYTES = 12
VIEWPORT = 64


def _marker(text: str) -> None:
    os.write(2, f"\n@@@ {text}\n".encode())


def main() -> None:
    import vulkan as vk

    app = vk.VkApplicationInfo(pApplicationName="cosquad machine code", apiVersion=vk.VK_MAKE_VERSION(1, 1, 0))
    instance = vk.vkCreateInstance(vk.VkInstanceCreateInfo(pApplicationInfo=app), None)
    devices = vk.vkEnumeratePhysicalDevices(instance)
    if not devices:
        raise SystemExit("no Vulkan device (RADV_FORCE_FAMILY and VK_ICD_FILENAMES select RADV's null device)")
    name = vk.vkGetPhysicalDeviceProperties(devices[0]).deviceName
    queue = vk.VkDeviceQueueCreateInfo(queueFamilyIndex=0, queueCount=1, pQueuePriorities=[1.0])
    device = vk.vkCreateDevice(devices[0], vk.VkDeviceCreateInfo(pQueueCreateInfos=[queue]), None)

    def module(path: Path):
        code = path.read_bytes()
        return vk.vkCreateShaderModule(device, vk.VkShaderModuleCreateInfo(codeSize=len(code), pCode=code), None)

    push = vk.VkPushConstantRange(stageFlags=vk.VK_SHADER_STAGE_FRAGMENT_BIT, offset=0, size=PUSH_CONSTANT_BYTES)
    layout = vk.vkCreatePipelineLayout(device, vk.VkPipelineLayoutCreateInfo(pPushConstantRanges=[push]), None)
    attachment = vk.VkAttachmentDescription(
        format=vk.VK_FORMAT_R32G32B32A32_SFLOAT, samples=vk.VK_SAMPLE_COUNT_1_BIT,
        loadOp=vk.VK_ATTACHMENT_LOAD_OP_DONT_CARE, storeOp=vk.VK_ATTACHMENT_STORE_OP_STORE,
        stencilLoadOp=vk.VK_ATTACHMENT_LOAD_OP_DONT_CARE, stencilStoreOp=vk.VK_ATTACHMENT_STORE_OP_DONT_CARE,
        initialLayout=vk.VK_IMAGE_LAYOUT_UNDEFINED, finalLayout=vk.VK_IMAGE_LAYOUT_GENERAL)
    color = vk.VkAttachmentReference(attachment=0, layout=vk.VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL)
    subpass = vk.VkSubpassDescription(pipelineBindPoint=vk.VK_PIPELINE_BIND_POINT_GRAPHICS, pColorAttachments=[color])
    render_pass = vk.vkCreateRenderPass(device, vk.VkRenderPassCreateInfo(pAttachments=[attachment],
                                                                          pSubpasses=[subpass]), None)
    fixed = dict(
        pVertexInputState=vk.VkPipelineVertexInputStateCreateInfo(),
        pInputAssemblyState=vk.VkPipelineInputAssemblyStateCreateInfo(topology=vk.VK_PRIMITIVE_TOPOLOGY_TRIANGLE_STRIP),
        pViewportState=vk.VkPipelineViewportStateCreateInfo(
            viewportCount=1, pViewports=[vk.VkViewport(0, 0, VIEWPORT, VIEWPORT, 0, 1)], scissorCount=1,
            pScissors=[vk.VkRect2D(vk.VkOffset2D(0, 0), vk.VkExtent2D(VIEWPORT, VIEWPORT))]),
        pRasterizationState=vk.VkPipelineRasterizationStateCreateInfo(
            polygonMode=vk.VK_POLYGON_MODE_FILL, cullMode=vk.VK_CULL_MODE_NONE,
            frontFace=vk.VK_FRONT_FACE_COUNTER_CLOCKWISE, lineWidth=1.0),
        pMultisampleState=vk.VkPipelineMultisampleStateCreateInfo(rasterizationSamples=vk.VK_SAMPLE_COUNT_1_BIT),
        pColorBlendState=vk.VkPipelineColorBlendStateCreateInfo(
            pAttachments=[vk.VkPipelineColorBlendAttachmentState(colorWriteMask=0xF)]),
        layout=layout, renderPass=render_pass, subpass=0)
    for line in sys.stdin:
        _marker(f"DEVICE {name}")
        compile_folder(vk, device, module, fixed, Path(line.rstrip("\n")))


def compile_folder(vk, device, module, fixed: dict, folder: Path) -> None:
    vertex = module(folder / "vert.spv")
    for path in sorted(folder.glob("*.frag.spv")):
        fragment = module(path)
        stages = [vk.VkPipelineShaderStageCreateInfo(stage=vk.VK_SHADER_STAGE_VERTEX_BIT, module=vertex, pName="main"),
                  vk.VkPipelineShaderStageCreateInfo(stage=vk.VK_SHADER_STAGE_FRAGMENT_BIT, module=fragment,
                                                     pName="main")]
        _marker(f"SHADER {path.name[:-len('.frag.spv')]}")
        pipeline = vk.vkCreateGraphicsPipelines(device, None, 1, [vk.VkGraphicsPipelineCreateInfo(
            pStages=stages, **fixed)], None)
        vk.vkDestroyPipeline(device, pipeline[0], None)
        vk.vkDestroyShaderModule(device, fragment, None)
    vk.vkDestroyShaderModule(device, vertex, None)
    _marker("END")


if __name__ == "__main__":
    main()
