"""The decode output's files: ``decoded.npz`` (every map + the plan facts), one TIFF per map and
``decoded.json`` (the summary), each written atomically (docs/file-formats.md)."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from fringe3d.io.images import write_tiff
from fringe3d.utils.atomic import atomic_path
from fringe3d.utils.jsonfile import write_json

NPZ_NAME = "decoded.npz"
SUMMARY_NAME = "decoded.json"
#: Unit of each saved map (the TIFFs' descriptions). The texture is the scene under full projector
#: illumination as a fraction of the camera's full scale (:mod:`fringe3d.decode.texture`).
MAP_UNITS = {"phase": "rad", "wrapped": "rad", "modulation": "camera counts", "mask": "1 valid, 0 invalid",
             "quality": "bit flags (fringe3d.decode.edges)", "phase_sigma": "rad", "average": "camera counts",
             "texture": "fraction of full scale"}
#: Units of decoded.json's fields.
SUMMARY_UNITS = {"period": "projector px", "angle": "rad", "phase_min": "rad", "phase_max": "rad",
                 "median_modulation": "camera counts", "valid_fraction": "1", "shape": "px (rows, columns)",
                 "order_inconsistent": "1 (share of the method's valid pixels)",
                 "edge_margin": "projector px", "blur": "projector px", "min_modulation": "camera counts"}


def write_decoded_files(folder: Path, arrays: dict[str, np.ndarray], meta: dict, summary: dict) -> Path:
    """Write a decode output folder.

    Parameters
    ----------
    folder : Path
        The folder (created when missing).
    arrays : dict of str to ndarray
        The maps, keyed ``QUANTITY_DIRECTION`` (``phase_v``, ``mask_v`` ...) or ``average`` /
        ``texture``; every direction of a phase map has its ``mask_<d>``.
    meta : dict
        ``period``, ``angle``, ``method`` (per direction) and ``directions``, stored in the npz.
    summary : dict
        The JSON-friendly summary, written last (its presence marks the folder complete).

    Returns
    -------
    Path
        ``folder``.
    """
    folder.mkdir(parents=True, exist_ok=True)
    with atomic_path(folder / NPZ_NAME) as tmp:
        with open(tmp, "wb") as fh:
            np.savez(fh, meta=np.array(json.dumps(meta)), **arrays)  # type: ignore[arg-type]
    for key, arr in arrays.items():
        quantity = key.rsplit("_", 1)[0] if key not in MAP_UNITS else key
        write_tiff(folder / f"{key}.tif", _tiff_map(arrays, quantity, key, arr), key, MAP_UNITS[quantity])
    write_json(folder / SUMMARY_NAME, summary, units=SUMMARY_UNITS)
    return folder


def _tiff_map(arrays: dict[str, np.ndarray], quantity: str, key: str, arr: np.ndarray) -> np.ndarray:
    """A map as its TIFF holds it: ``quality`` and ``mask`` as uint8, ``phase`` and
    ``phase_sigma`` float32 with NaN outside the direction's mask (no inf or huge
    placeholder there), the others float32 as computed."""
    if quantity in ("quality", "mask"):
        return np.asarray(arr, np.uint8)
    out = np.asarray(arr, np.float32)
    if quantity in ("phase", "phase_sigma"):
        valid = np.asarray(arrays[f"mask_{key[len(quantity) + 1:]}"], bool) & np.isfinite(out)
        out = np.where(valid, out, np.float32(np.nan))
    return out


def read_decoded_npz(path: Path) -> tuple[dict, dict[str, np.ndarray]]:
    """Read ``decoded.npz``.

    Parameters
    ----------
    path : Path
        The file.

    Returns
    -------
    meta : dict
        As given to :func:`write_decoded_files`.
    arrays : dict of str to ndarray
        Every map in the file.
    """
    with np.load(path, allow_pickle=False) as z:
        meta = json.loads(str(z["meta"]))
        arrays = {k: z[k] for k in z.files if k != "meta"}
    return meta, arrays
