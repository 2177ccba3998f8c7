"""Point and map data carried in a report page as base64 typed arrays (little-endian).

A float32 costs 4 bytes (5.3 characters in base64) instead of the 8-12 characters of a JSON
number; point coordinates travel as uint16 quantised over their range (:func:`b64_uint16`,
2 bytes; the step, range / 65535, is ~3 um over 200 mm, far below any measurement's noise), so a
60 000-point cloud costs 0.48 MB and a few 400 x 400 float32 maps keep the page at a few MB. The
page decodes them with :data:`JS_DECODE` (``f32(b64) -> Float32Array``, ``grid(b64, h, w)`` ->
rows, ``u16(b64, lo, step)`` -> values).
"""
from __future__ import annotations

import base64

import numpy as np

JS_DECODE = (
    "function f32(b){const s=atob(b),n=s.length,u=new Uint8Array(n);"
    "for(let i=0;i<n;i++)u[i]=s.charCodeAt(i);return new Float32Array(u.buffer);}"
    "function arr(b){return Array.from(f32(b));}"
    "function u16(b,lo,st){const s=atob(b),n=s.length,u=new Uint8Array(n);"
    "for(let i=0;i<n;i++)u[i]=s.charCodeAt(i);const q=new Uint16Array(u.buffer),o=new Array(q.length);"
    "for(let i=0;i<q.length;i++)o[i]=lo+q[i]*st;return o;}"
    "function grid(b,h,w){const f=f32(b),z=[];for(let i=0;i<h;i++)z.push(Array.from(f.subarray(i*w,(i+1)*w)));"
    "return z;}"
)


def b64_float32(values) -> str:
    """Base64 of ``values`` as contiguous little-endian float32 (NaN kept)."""
    return base64.b64encode(np.ascontiguousarray(values, dtype="<f4").tobytes()).decode("ascii")


def b64_uint16(values) -> tuple[str, float, float]:
    """Finite ``values`` quantised to little-endian uint16 over their range: ``(base64, lo, step)``
    with ``value ~ lo + q * step`` (error at most ``step / 2``, ``step = (max - lo) / 65535``)."""
    v = np.asarray(values, np.float64)
    lo = float(v.min()) if v.size else 0.0
    step = (float(v.max()) - lo) / 65535 if v.size else 0.0
    q = np.zeros(v.shape, "<u2") if step == 0 else np.rint((v - lo) / step).astype("<u2")
    return base64.b64encode(np.ascontiguousarray(q).tobytes()).decode("ascii"), lo, step


def decode_uint16(text: str, lo: float, step: float) -> np.ndarray:
    """Inverse of :func:`b64_uint16` (flat float64 array)."""
    return lo + np.frombuffer(base64.b64decode(text), dtype="<u2").astype(np.float64) * step


def decode_float32(text: str) -> np.ndarray:
    """Inverse of :func:`b64_float32` (flat float32 array)."""
    return np.frombuffer(base64.b64decode(text), dtype="<f4")


def shrink_map(values: np.ndarray, max_side: int = 400) -> np.ndarray:
    """Every k-th row and column of an ``(H, W)`` map so that neither side exceeds ``max_side``."""
    k = max(1, -(-max(values.shape[:2]) // max_side))
    return np.asarray(values)[::k, ::k]


def sample_points(points: np.ndarray, limit: int, seed: int = 0) -> np.ndarray:
    """At most ``limit`` finite points ``(M, 3)`` of a map ``(H, W, 3)`` or list ``(N, 3)``
    (a fixed random subset, so the same folder gives the same page)."""
    p = np.asarray(points, np.float32).reshape(-1, 3)
    p = p[np.isfinite(p).all(axis=1)]
    if len(p) > limit:
        p = p[np.sort(np.random.default_rng(seed).choice(len(p), limit, replace=False))]
    return p
