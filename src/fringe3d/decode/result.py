"""The decoder's output: absolute phase, wrapped phase, modulation and mask per direction."""
from __future__ import annotations

import json
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from fringe3d.utils.atomic import atomic_path
from fringe3d.utils.jsonfile import write_json

NPZ_NAME = "decoded.npz"
SUMMARY_NAME = "decoded.json"
_PER_DIRECTION = ("phase", "wrapped", "modulation", "mask")


@dataclass
class Decoded:
    """Decoded phase maps of one pattern cycle.

    Per fringe direction ``d`` (dict keys, e.g. ``"v"``, ``"h"``), each (H, W):
    ``phase[d]`` absolute phase float32 rad (NaN where invalid; ``u_p = phase * period / 2pi``
    for direction ``"v"``), ``wrapped[d]`` wrapped phase float32 in (-pi, pi],
    ``modulation[d]`` float32 (frames' units), ``mask[d]`` bool; ``period[d]`` (px),
    ``angle[d]`` (rad), ``method[d]`` (unwrapping method). Plus ``average`` and ``texture``
    (H, W) float32 and ``info`` (frame checks, warnings).
    """

    phase: dict = field(default_factory=dict)
    wrapped: dict = field(default_factory=dict)
    modulation: dict = field(default_factory=dict)
    mask: dict = field(default_factory=dict)
    period: dict = field(default_factory=dict)
    angle: dict = field(default_factory=dict)
    method: dict = field(default_factory=dict)
    average: np.ndarray | None = None
    texture: np.ndarray | None = None
    info: dict = field(default_factory=dict)

    @property
    def directions(self) -> list[str]:
        return list(self.phase)

    def projector_coordinate(self, direction: str) -> np.ndarray:
        """(H, W) float32 projector fringe coordinate ``w = Phi T / 2 pi`` (px), NaN invalid."""
        return (self.phase[direction] * np.float32(self.period[direction] / (2 * np.pi))).astype(np.float32)

    def summary(self) -> dict:
        """Small JSON-friendly description: per direction period, angle, method, valid fraction."""
        out = {"directions": {}}
        for d in self.directions:
            m = self.mask[d]
            out["directions"][d] = {
                "method": self.method.get(d), "period": float(self.period[d]), "angle": float(self.angle[d]),
                "valid_fraction": float(m.mean()) if m.size else 0.0,
                "phase_min": float(np.nanmin(self.phase[d])) if m.any() else None,
                "phase_max": float(np.nanmax(self.phase[d])) if m.any() else None,
                "median_modulation": float(np.median(self.modulation[d][m])) if m.any() else None,
            }
        out["shape"] = list(self.average.shape) if self.average is not None else None
        out["info"] = self.info
        return out

    def save(self, folder: str | os.PathLike) -> Path:
        """Write ``decoded.npz``, ``decoded.json`` and one 32-bit float TIFF per map
        (``phase_<d>.tif``, ``wrapped_<d>.tif``, ``modulation_<d>.tif``, ``mask_<d>.tif`` as
        0/1, ``average.tif``, ``texture.tif``), each atomically. Returns the folder."""
        import tifffile

        folder = Path(folder)
        folder.mkdir(parents=True, exist_ok=True)
        arrays = {}
        for d in self.directions:
            for name in _PER_DIRECTION:
                arrays[f"{name}_{d}"] = getattr(self, name)[d]
        for name in ("average", "texture"):
            if getattr(self, name) is not None:
                arrays[name] = getattr(self, name)
        meta = {"period": self.period, "angle": self.angle, "method": self.method,
                "directions": self.directions}
        with atomic_path(folder / NPZ_NAME) as tmp:
            with open(tmp, "wb") as fh:
                np.savez(fh, meta=np.array(json.dumps(meta)), **arrays)
        for key, arr in arrays.items():
            with atomic_path(folder / f"{key}.tif") as tmp:
                tifffile.imwrite(tmp, np.asarray(arr, dtype=np.float32))
        write_json(folder / SUMMARY_NAME, self.summary())
        return folder

    @classmethod
    def load(cls, folder: str | os.PathLike) -> "Decoded":
        """Read what :meth:`save` wrote (``decoded.npz`` in ``folder``, or the file itself)."""
        path = Path(folder)
        if path.is_dir():
            path = path / NPZ_NAME
        if not path.exists():
            raise FileNotFoundError(f"no decoded phase file at {path}; expected the output of `fringe3d decode`")
        with np.load(path, allow_pickle=False) as z:
            meta = json.loads(str(z["meta"]))
            out = cls(period={k: float(v) for k, v in meta["period"].items()},
                      angle={k: float(v) for k, v in meta["angle"].items()}, method=dict(meta["method"]))
            for d in meta["directions"]:
                for name in _PER_DIRECTION:
                    getattr(out, name)[d] = z[f"{name}_{d}"]
            out.average = z["average"] if "average" in z else None
            out.texture = z["texture"] if "texture" in z else None
        return out
