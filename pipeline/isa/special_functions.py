"""The documented accuracy of each GPU's special functions, per architecture and format: Vulkan's
minimum (the specification's "Precision and Operation of SPIR-V Instructions", which every
conformant driver meets) and, where a vendor publishes its own figure for the instruction its
driver emits, that figure with its source.

An `Accuracy` allows, at each input, an absolute error of `ulps` + `ulps_per_x` |x| units in the
last place of the result (the format's spacing there), or `absolute` inside [`lo`, `hi`] of the
argument (log2 near 1; sin and cos) and ULPs outside. `mesa` marks a function that Mesa lowers to
arithmetic for all of its drivers (acos, asin, atan: `nir_lower`'s polynomial times a square root):
the lavapipe that executes the forms is a Mesa driver, so its error is already in the executed one
on the architectures Mesa's drivers compile (AMD through RADV, Adreno through freedreno, Mali
through panfrost), and allows nothing more there.

`allowed(accuracy, argument, value, precision)` is the absolute error allowed at each input.
"""

from __future__ import annotations

import dataclasses

import numpy as np

VULKAN = "Vulkan specification, Precision and Operation of SPIR-V Instructions"
PTX = "NVIDIA PTX ISA, the .approx instructions"
AMD = "AMD RDNA and GCN ISA guides (v_exp, v_log, v_rcp, v_rsq, v_sqrt: 1 ULP)"
LLVM_AMDGPU = "LLVM AMDGPUUsage (exp2: 1 ULP in float, 0.51 ULP in half)"
MESA = "Mesa's lowering (nir: a polynomial times sqrt), the same in lavapipe, which executed it"


@dataclasses.dataclass(frozen=True)
class Accuracy:
    """What a function may err (module docstring), where it comes from, and whether Mesa's shared
    lowering computes it (`mesa`)."""

    function: str
    ulps: float = 0.0
    ulps_per_x: float = 0.0
    absolute: float = 0.0
    lo: float = 0.0
    hi: float = 0.0
    source: str = VULKAN
    mesa: bool = False
    inherited: str = ""         # the expression whose accuracy it inherits (pow: exp2(y log2 x))

    def text(self) -> str:
        if self.mesa:
            return "Mesa's lowering, as executed"
        if self.inherited:
            return f"inherited from {self.inherited}"
        parts = []
        if self.absolute:
            parts.append(f"{self.absolute:.3g} absolute in [{self.lo:g}, {self.hi:g}]")
        if self.ulps or self.ulps_per_x:
            ulp = f"{self.ulps:g}" + (f" + {self.ulps_per_x:g}|x|" if self.ulps_per_x else "") + " ULP"
            parts.append(ulp + (" elsewhere" if self.absolute else ""))
        return ", ".join(parts) or "correctly rounded"


# Vulkan's minimum per format (the 32-bit and 16-bit columns); pow is inherited from exp2(y log2 x),
# sqrt from 1 / inversesqrt(x) (2 + 2.5 ULP), acos and asin from atan2 (4096 ULP).
MINIMUM = {
    "fp32": {"exp2": Accuracy("exp2", 3, 2), "log2": Accuracy("log2", 3, absolute=2.0 ** -21, lo=0.5, hi=2.0),
             "inversesqrt": Accuracy("inversesqrt", 2), "sqrt": Accuracy("sqrt", 4.5), "division": Accuracy("division", 2.5),
             "sin": Accuracy("sin", 0, absolute=2.0 ** -11, lo=-np.pi, hi=np.pi),
             "cos": Accuracy("cos", 0, absolute=2.0 ** -11, lo=-np.pi, hi=np.pi),
             "acos": Accuracy("acos", 4096), "asin": Accuracy("asin", 4096), "atan": Accuracy("atan", 4096),
             "pow": Accuracy("pow", inherited="exp2(y log2 x)")},
    "fp16": {"exp2": Accuracy("exp2", 1, 2), "log2": Accuracy("log2", 3, absolute=2.0 ** -7, lo=0.5, hi=2.0),
             "inversesqrt": Accuracy("inversesqrt", 2), "sqrt": Accuracy("sqrt", 4.5), "division": Accuracy("division", 2.5),
             "sin": Accuracy("sin", 0, absolute=2.0 ** -7, lo=-np.pi, hi=np.pi),
             "cos": Accuracy("cos", 0, absolute=2.0 ** -7, lo=-np.pi, hi=np.pi),
             "acos": Accuracy("acos", 4096), "asin": Accuracy("asin", 4096), "atan": Accuracy("atan", 4096),
             "pow": Accuracy("pow", inherited="exp2(y log2 x)")},
}
# The vendors' own figures, where published, for the instructions their drivers emit.
VENDOR = {
    ("nvidia", "fp32"): {"exp2": Accuracy("exp2", 2, source=PTX + " (ex2.approx.f32: 2 ULP)"),
                         "log2": Accuracy("log2", 3, absolute=2.0 ** -22, lo=0.5, hi=2.0,
                                          source=PTX + " (lg2.approx.f32: 2^-22 absolute in (0.5, 2))"),
                         "division": Accuracy("division", 1 + 0.5, source=PTX + " (rcp.approx.f32: 1 ULP, and the multiply)"),
                         "inversesqrt": Accuracy("inversesqrt", 2.0 ** -22.9 / 2.0 ** -23,
                                                 source=PTX + " (rsqrt.approx.f32: 2^-22.9 relative)")},
    ("nvidia", "fp16"): {"exp2": Accuracy("exp2", 2.0 ** -9.9 / 2.0 ** -10,
                                          source=PTX + " (ex2.approx.f16: 2^-9.9 relative)")},
    ("amd", "fp32"): {name: Accuracy(name, 1, source=AMD) for name in ("exp2", "log2", "inversesqrt", "sqrt")}
    | {"division": Accuracy("division", 1.5, source=AMD + " (v_rcp and the multiply)")},
    ("amd", "fp16"): {"exp2": Accuracy("exp2", 0.51, source=LLVM_AMDGPU)},
}
MESA_VENDORS = ("amd", "qualcomm", "arm")          # costed here by Mesa's drivers (RADV, freedreno, panfrost)
MESA_LOWERED = ("acos", "asin", "atan")


def accuracy(function: str, vendor: str, precision: str) -> Accuracy:
    """The accuracy of `function` on `vendor`'s architectures in `precision` (module docstring)."""
    if function in MESA_LOWERED and vendor in MESA_VENDORS:
        return Accuracy(function, source=MESA, mesa=True)
    return VENDOR.get((vendor, precision), {}).get(function) or MINIMUM[precision][function]


def spacing(value, precision: str) -> np.ndarray:
    """The format's ULP at each value (the spacing of its representable numbers there)."""
    dtype = np.float32 if precision == "fp32" else np.float16
    with np.errstate(all="ignore"):
        return np.abs(np.spacing(np.abs(np.asarray(value, dtype=np.float64)).astype(dtype))).astype(np.float64)


def allowed(a: Accuracy, argument, value, precision: str) -> np.ndarray:
    """The absolute error `a` allows at each input (its argument and its exact value); pow's,
    inherited, is computed from exp2's and log2's (`approximate.measures.bounds`)."""
    if a.inherited:
        raise ValueError(f"{a.function}: its accuracy is inherited from {a.inherited}")
    argument = np.asarray(argument, dtype=np.float64)
    value = np.asarray(value, dtype=np.float64)
    if a.mesa:
        return np.zeros(np.broadcast(argument, value).shape)
    ulp = (a.ulps + a.ulps_per_x * np.abs(argument)) * spacing(value, precision)
    if a.absolute:
        return np.where((argument >= a.lo) & (argument <= a.hi), a.absolute, ulp)
    return np.broadcast_to(ulp, np.broadcast(argument, value).shape)
