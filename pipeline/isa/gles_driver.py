"""Runs under an arm64 Python beside Mesa's GL ES driver on a drm-shim null device (qemu-user):
reads batches of fragment shaders from standard input, one JSON object ({name: GLSL ES source})
per line, compiles each shader as a separable program and writes a marker line before and after
each to standard error, where Mesa prints its listings, and one after the batch; it ends at the
end of its input. Standard library only: it imports nothing of the pipeline."""
import ctypes
import json
import os
import sys

EGL_PLATFORM_SURFACELESS_MESA = 0x31DD
EGL_OPENGL_ES_API = 0x30A0
EGL_NONE = 0x3038
GL_FRAGMENT_SHADER = 0x8B30
GL_LINK_STATUS = 0x8B82
MARK = "@@pipeline-shader"


LIBC = ctypes.CDLL(None)


def say(text):
    """A marker line on standard error, after whatever Mesa has buffered on either stream."""
    LIBC.fflush(None)
    os.write(2, (text + "\n").encode())


def main():
    egl = ctypes.CDLL("libEGL.so.1")
    gl = ctypes.CDLL("libGLESv2.so.2")
    vp = ctypes.c_void_p
    egl.eglGetProcAddress.restype = vp
    egl.eglGetProcAddress.argtypes = [ctypes.c_char_p]
    platform_display = ctypes.CFUNCTYPE(vp, ctypes.c_uint, vp, vp)(egl.eglGetProcAddress(b"eglGetPlatformDisplayEXT"))
    display = platform_display(EGL_PLATFORM_SURFACELESS_MESA, None, None)
    egl.eglInitialize.argtypes = [vp, vp, vp]
    if not display or not egl.eglInitialize(display, None, None):
        raise SystemExit("EGL could not open Mesa's surfaceless display")
    egl.eglBindAPI(EGL_OPENGL_ES_API)
    egl.eglCreateContext.restype = vp
    egl.eglCreateContext.argtypes = [vp, vp, vp, vp]
    attributes = (ctypes.c_int * 5)(0x3098, 3, 0x30FB, 1, EGL_NONE)        # ES 3.1
    context = egl.eglCreateContext(display, None, None, attributes)
    egl.eglMakeCurrent.argtypes = [vp, vp, vp, vp]
    if not context or not egl.eglMakeCurrent(display, None, None, context):
        raise SystemExit(f"no GL ES 3.1 context (EGL error {egl.eglGetError():#x})")
    gl.glGetString.restype = ctypes.c_char_p
    say(f"{MARK} renderer {gl.glGetString(0x1F01).decode()} | {gl.glGetString(0x1F02).decode()}")
    gl.glCreateShaderProgramv.restype = ctypes.c_uint
    gl.glCreateShaderProgramv.argtypes = [ctypes.c_uint, ctypes.c_int, ctypes.POINTER(ctypes.c_char_p)]
    for line in sys.stdin:
        compile_batch(gl, json.loads(line))
        say(f"{MARK} batch-end")


def compile_batch(gl, sources):
    for name, source in sources.items():
        say(f"{MARK} begin {name}")
        text = (ctypes.c_char_p * 1)(source.encode())
        program = gl.glCreateShaderProgramv(GL_FRAGMENT_SHADER, 1, text)
        status = ctypes.c_int(0)
        gl.glGetProgramiv(program, GL_LINK_STATUS, ctypes.byref(status))
        if not status.value:
            log = ctypes.create_string_buffer(8192)
            gl.glGetProgramInfoLog(program, 8192, None, log)
            say(f"{MARK} failed {name} {log.value.decode(errors='replace')!r}")
        gl.glFinish()
        say(f"{MARK} end {name} {program}")
        gl.glDeleteProgram(program)


if __name__ == "__main__":
    main()
