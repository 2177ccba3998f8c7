"""Packing 1-bit patterns into the bit-planes of 24-bit RGB video frames (kHz binary projection).

A DLP evaluation module in video pattern mode (e.g. TI's DLPC350 / LightCrafter 4500) receives
24-bit RGB frames over HDMI and shows each frame's 24 bit-planes one after another as binary
patterns, with a trigger out per plane: 24 binary patterns per video frame, 1440 patterns/s at
60 Hz. :func:`pack_bitplanes` builds those frames: pattern ``k`` goes to plane ``k % 24`` of
frame ``k // 24``, planes in :data:`PLANE_ORDER` (the DLPC350's: G0..G7, R0..R7, B0..B7, bit 0
the least significant). The pattern folder keeps the unpacked PNGs and the manifest, and gains
``bitplanes/00000.png ...`` (true-RGB PNGs) plus a ``packing`` entry in ``manifest.json``
saying which plane of which file is which pattern (written and read by
:mod:`fringe3d.io.packed_patterns`). A capture of a packed sequence has one
camera frame per pattern, so ``fringe3d decode`` reads it as usual.
"""
from __future__ import annotations

import numpy as np

PLANES_PER_FRAME = 24
CHANNELS = "RGB"
#: (channel index into RGB, bit) of plane 0..23: G0..G7, R0..R7, B0..B7 (TI DLPC350 order).
PLANE_ORDER = tuple([(1, b) for b in range(8)] + [(0, b) for b in range(8)] + [(2, b) for b in range(8)])
PACKING_MODE = "rgb-bitplanes"
PACKED_DIR = "bitplanes"


def _binary(frames: np.ndarray) -> np.ndarray:
    f = np.asarray(frames)
    if f.ndim != 3:
        raise ValueError(f"patterns to pack must be (F, H, W), got shape {f.shape}")
    if f.dtype == bool:
        return f
    vals = np.unique(f)
    if not np.all(np.isin(vals, (0, 1))) and not np.all(np.isin(vals, (0, 255))):
        raise ValueError(f"only 1-bit patterns can be packed into bit-planes; the frames hold the values "
                         f"{vals[:8].tolist()}{'...' if vals.size > 8 else ''} (expected 0/255 or 0/1)")
    return f > 0


def pack_bitplanes(frames: np.ndarray) -> np.ndarray:
    """Pack ``F`` binary patterns (F, H, W) (bool, 0/1 or 0/255) into ``ceil(F / 24)`` RGB frames
    (N, H, W, 3) uint8; unused planes of the last frame are 0."""
    b = _binary(frames)
    n = -(-len(b) // PLANES_PER_FRAME)
    out = np.zeros((n,) + b.shape[1:] + (3,), np.uint8)
    for k in range(len(b)):
        c, bit = PLANE_ORDER[k % PLANES_PER_FRAME]
        out[k // PLANES_PER_FRAME, ..., c] |= (b[k].astype(np.uint8) << bit)
    return out


def unpack_bitplanes(packed: np.ndarray, count: int) -> np.ndarray:
    """The first ``count`` patterns (count, H, W) bool of packed RGB frames (N, H, W, 3) uint8."""
    p = np.asarray(packed)
    if p.ndim != 4 or p.shape[3] != 3 or p.dtype != np.uint8:
        raise ValueError(f"packed frames must be (N, H, W, 3) uint8, got {p.shape} {p.dtype}")
    if not 0 <= count <= PLANES_PER_FRAME * len(p):
        raise ValueError(f"{len(p)} packed frame(s) hold at most {PLANES_PER_FRAME * len(p)} patterns, "
                         f"asked for {count}")
    out = np.empty((count,) + p.shape[1:3], bool)
    for k in range(count):
        c, bit = PLANE_ORDER[k % PLANES_PER_FRAME]
        out[k] = (p[k // PLANES_PER_FRAME, ..., c] >> bit) & 1
    return out


def packing_entry(n_patterns: int, files: list[str]) -> dict:
    """The manifest's ``packing`` entry: per packed file, each plane's channel, bit and pattern."""
    frames = []
    for j, name in enumerate(files):
        planes = []
        for p in range(PLANES_PER_FRAME):
            k = j * PLANES_PER_FRAME + p
            if k >= n_patterns:
                break
            c, bit = PLANE_ORDER[p]
            planes.append({"plane": p, "channel": CHANNELS[c], "bit": bit, "pattern": k})
        frames.append({"file": name, "planes": planes})
    return {"mode": PACKING_MODE, "order": "G0-G7, R0-R7, B0-B7 (TI DLPC350), bit 0 least significant",
            "frames": frames}
