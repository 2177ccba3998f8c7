"""Packed (bit-plane) pattern folders on disk: ``bitplanes/NNNNN.png`` RGB frames plus the
``packing`` entry of ``manifest.json`` (see :mod:`fringe3d.patterns.bitplanes`)."""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from fringe3d.io.images import read_image, write_image
from fringe3d.patterns.bitplanes import (CHANNELS, PACKED_DIR, PACKING_MODE, PLANE_ORDER, pack_bitplanes,
                                         packing_entry)
from fringe3d.patterns.manifest import MANIFEST_NAME, MANIFEST_UNITS, PatternSet
from fringe3d.utils.jsonfile import read_json, write_json
from fringe3d.utils.write_guard import guard_write


def write_packed(folder: str | os.PathLike, ps: PatternSet, images: np.ndarray) -> list[Path]:
    """Write ``folder/bitplanes/NNNNN.png`` (RGB) for the 1-bit ``images`` of ``ps`` and add the
    ``packing`` entry to ``folder/manifest.json`` (atomic writes)."""
    if ps.bit_depth != 1:
        raise ValueError(f"pattern set {ps.name!r} is {ps.bit_depth}-bit; only 1-bit sets can be packed into "
                         f"bit-planes (use a binary `kind` such as square or bayer, or a Gray code)")
    folder = Path(folder)
    packed = pack_bitplanes(images)
    pdir = folder / PACKED_DIR
    pdir.mkdir(parents=True, exist_ok=True)
    for stale in pdir.glob("*.png"):
        guard_write(stale).unlink()
    paths = [write_image(pdir / f"{j:05d}.png", np.ascontiguousarray(f[..., ::-1])) for j, f in enumerate(packed)]
    d = ps.to_dict()
    d["packing"] = packing_entry(len(ps), [f"{PACKED_DIR}/{p.name}" for p in paths])
    write_json(folder / MANIFEST_NAME, d, units=MANIFEST_UNITS)
    return paths


def read_packed(folder: str | os.PathLike) -> tuple[list[np.ndarray], list[int]] | None:
    """(RGB frames, patterns per frame) of a packed pattern folder, or None when it is not packed.

    Checks that the planes list the patterns in projection order, one plane each.
    """
    folder = Path(folder)
    d = read_json(folder / MANIFEST_NAME, "pattern manifest")
    pk = d.get("packing")
    if pk is None:
        return None
    if pk.get("mode") != PACKING_MODE:
        raise ValueError(f"{folder / MANIFEST_NAME}: packing mode {pk.get('mode')!r} is not {PACKING_MODE!r}")
    frames, counts, k = [], [], 0
    for entry in pk["frames"]:
        for pl in entry["planes"]:
            c, bit = PLANE_ORDER[pl["plane"]]
            if pl["pattern"] != k or CHANNELS[c] != pl["channel"] or bit != pl["bit"]:
                raise ValueError(f"{folder / MANIFEST_NAME}: packing plane {pl} is not pattern {k} in plane order")
            k += 1
        img = read_image(folder / entry["file"], grey=False)
        if img.ndim != 3 or img.shape[2] != 3:
            raise ValueError(f"{folder / entry['file']} is not an RGB image")
        frames.append(np.ascontiguousarray(img[..., ::-1]))
        counts.append(len(entry["planes"]))
    if k != len(d["frames"]):
        raise ValueError(f"{folder / MANIFEST_NAME}: the packing covers {k} patterns but the manifest lists "
                         f"{len(d['frames'])}")
    return frames, counts
