"""float32 -> float16 in one numba pass, bit for bit numpy's ``astype(np.float16)`` (private; the
cast of :class:`fringe3d.io.store.PointMapStore`'s sigma_z maps).

numpy's cast of a 1280 x 1024 map costs about 6-7 ms; this pass works on the bit patterns
(``uint32`` in, ``uint16`` out) and vectorises: about 2 ms on one core. Rounding is to
nearest, ties to even; beyond the largest half (65504, from 65520 up) the result is +-inf;
below half the smallest subnormal (2^-25, inclusive: the tie goes to the even zero) +-0; NaN
keeps its sign and the top ten bits of its significand, made non-zero where they are not
(numpy's ``npy_floatbits_to_halfbits``). ``tests/test_float16_cast.py`` checks every float16
value's and midpoint's neighbourhood and a large random sample against numpy; all 2^32 float32
bit patterns were compared once, in chunks of 2^26 (0 mismatches, 15 min on a loaded 2-core
machine: too slow for the suite).

Where the processor converts float32 to float16 itself (x86-64 with F16C, every 64-bit ARM),
the pass is LLVM's ``fptrunc`` to ``half`` (one ``vcvtps2ph`` per 8 values: about 0.2 instead
of 2 ms a map; :data:`HARDWARE`), which rounds as IEEE 754 does, as numpy does; only a
signalling NaN would come out otherwise (quietened), so NaN takes numpy's bits from the same
formula as above. ``tests/test_float16_cast.py`` checks both passes.
"""
from __future__ import annotations

import platform

import numba
import numpy as np
from llvmlite import ir
from numba import types
from numba.extending import intrinsic


def _has_hardware_half() -> bool:
    """Whether the code numba compiles converts float32 to float16 in one instruction: on 64-bit
    ARM always; on x86-64 where the target numba compiles for has F16C (the host's features,
    or ``NUMBA_CPU_FEATURES`` / none at all for another ``NUMBA_CPU_NAME``). Elsewhere LLVM's
    ``fptrunc`` to half is a library call that numba's JIT does not link (with
    ``NUMBA_CPU_NAME=generic`` the process crashed), so the portable pass runs."""
    machine = platform.machine().lower()
    if machine in ("aarch64", "arm64"):
        return True
    if machine not in ("x86_64", "amd64"):
        return False
    try:
        from llvmlite import binding
        from numba.core import config

        cpu_features, cpu_name = getattr(config, "CPU_FEATURES", None), getattr(config, "CPU_NAME", None)
        if cpu_features is not None:
            features = str(cpu_features)
        elif cpu_name in (None, "host"):
            features = str(binding.get_host_cpu_features().flatten())
        else:
            features = ""
        return "+f16c" in features.split(",")
    except Exception:  # noqa: BLE001 - no feature list: the portable pass
        return False


#: float32 -> float16 by the processor's own conversion (:func:`_to_half_hw_kernel`)
HARDWARE = _has_hardware_half()


@intrinsic
def _fptrunc_half_bits(typingctx, x):
    """The bits (uint16) of float32 ``x`` rounded to half by LLVM's ``fptrunc`` (IEEE 754: to
    nearest, ties to even; a signalling NaN is quietened)."""
    if x != types.float32:
        return None

    def codegen(context, builder, signature, args):
        return builder.bitcast(builder.fptrunc(args[0], ir.HalfType()), ir.IntType(16))

    return types.uint16(types.float32), codegen


@numba.njit(inline="always")
def _half_bits(x):  # pragma: no cover - compiled
    """Every case computed, one selected: no branch, so the pixel loop vectorises."""
    u = np.uint32
    a = x & u(0x7FFFFFFF)
    r = a - u(0x38000000)  # normal half (2^-14 and up): rebias, round at bit 13 (a carry may reach inf)
    normal = (r + u(0xFFF) + ((r >> u(13)) & u(1))) >> u(13)
    e = min(max(a >> u(23), u(102)), u(112))  # subnormal half k 2^-24, k = significand >> (126 - e)
    s = u(126) - e
    mant = (a & u(0x007FFFFF)) | u(0x00800000)
    k = mant >> s
    rem = mant & ((u(1) << s) - u(1))
    half = u(1) << (s - u(1))
    sub = k + u((rem > half) | ((rem == half) & ((k & u(1)) == u(1))))
    nan = u(0x7C00) | max((a & u(0x007FFFFF)) >> u(13), u(1))  # NaN: its top ten bits, never zero
    h = (nan if a > u(0x7F800000) else
         u(0x7C00) if a >= u(0x47800000) else  # 2^16 and above: inf
         normal if a >= u(0x38800000) else
         sub if a > u(0x33000000) else u(0))  # up to 2^-25 (the tie rounds to the even zero): 0
    return np.uint16(((x >> u(16)) & u(0x8000)) | h)


@numba.njit(cache=True, nogil=True)
def _to_half_kernel(bits, out):  # pragma: no cover - compiled
    # one thread: the loop vectorises (2 ms a 1280 x 1024 map), and the store's writer runs beside the compute
    for t in range(bits.size):
        out[t] = _half_bits(bits[t])


@numba.njit(cache=True, nogil=True)
def _to_half_hw_kernel(bits, values, out):  # pragma: no cover - compiled
    # the processor's conversion; NaN as numpy makes it (sign, 0x7C00, the top ten significand bits or 1)
    u = np.uint32
    for t in range(bits.size):
        x = bits[t]
        h = _fptrunc_half_bits(values[t])
        nan = np.uint16(((x >> u(16)) & u(0x8000)) | u(0x7C00) | max((x & u(0x007FFFFF)) >> u(13), u(1)))
        out[t] = nan if (x & u(0x7FFFFFFF)) > u(0x7F800000) else h


def to_float16(values: np.ndarray) -> np.ndarray:
    """``values`` (any shape) float32 as float16, equal bit for bit to ``values.astype(np.float16)``;
    other dtypes go through numpy's cast."""
    v = np.asarray(values)
    if v.dtype != np.float32:
        return v.astype(np.float16)
    bits = np.ascontiguousarray(v).reshape(-1).view(np.uint32)
    out = np.empty(bits.size, np.uint16)
    if HARDWARE:
        _to_half_hw_kernel(bits, bits.view(np.float32), out)
    else:
        _to_half_kernel(bits, out)
    return out.view(np.float16).reshape(v.shape)
