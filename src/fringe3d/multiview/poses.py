"""The poses file: one 4×4 rigid transform per view, in millimetres.

``poses.json``::

    {"format": "fringe3d-poses", "version": 1, "unit": "mm",
     "views": [{"name": "view-00", "matrix": [[...4...], ...4 rows...]}, ...]}

``matrix`` maps the view's points (its camera frame, mm) into the common model frame:
``x_model = M @ [x_view, 1]``.

Poses from a stage may say how well the stage knows them (what registration's stage prior
weighs them by, :func:`read_stage_sigma`), and a simulated sequence keeps the truth beside them::

    {..., "stage": {"kind": "virtual turntable", ..., "sigma_rotation_mrad": 2.0,
                    "sigma_translation_mm": 0.2},
     "views": [{"name": "view-00", "matrix": ..., "true_matrix": ..., "angle_deg": 0.0}, ...]}

``sigma_rotation_mrad`` is the 1σ rotation error per axis, ``sigma_translation_mm`` the 1σ
translation error per axis at the object's centre (the centroid of the view's points).
"""
from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np

from fringe3d.utils.atomic import atomic_write_text
from fringe3d.utils.jsonfile import read_format_json

FORMAT = "fringe3d-poses"


def check_rigid(M, where: str, tol: float = 1e-4) -> np.ndarray:
    """``M`` as a (4, 4) float rigid transform, or ValueError naming ``where``."""
    try:
        A = np.asarray(M, float)
    except (TypeError, ValueError):
        raise ValueError(f"{where}: expected a 4x4 list of numbers") from None
    if A.shape != (4, 4) or not np.all(np.isfinite(A)):
        raise ValueError(f"{where}: expected a 4x4 matrix of finite numbers, got shape {A.shape}")
    R = A[:3, :3]
    if np.abs(R.T @ R - np.eye(3)).max() > tol or abs(np.linalg.det(R) - 1) > tol or \
            np.abs(A[3] - [0, 0, 0, 1]).max() > tol:
        raise ValueError(f"{where}: not a rigid transform (rotation not orthonormal or last row not 0 0 0 1)")
    return A


def write_poses(path: str | os.PathLike, names, matrices, extra=None, stage: dict | None = None) -> Path:
    """Write ``poses.json``.

    Parameters
    ----------
    path : path
        The file.
    names : sequence of str
        View names.
    matrices : (V, 4, 4) array_like or None
        View → model transforms, mm; None writes the views without ``matrix`` (a stage's
        positions recorded before its axis is calibrated: not yet a poses file to merge with).
    extra : sequence of dict, optional
        More fields per view (e.g. ``true_matrix``, ``angle_deg``).
    stage : dict, optional
        The ``stage`` entry (:func:`stage_entry`).

    Returns
    -------
    Path
        ``path``.
    """
    views: list[dict] = [{"name": str(n)} for n in names]
    if matrices is not None:
        for v, M in zip(views, matrices):
            v["matrix"] = np.asarray(M, float).tolist()
    for v, e in zip(views, extra or []):
        v.update(e)
    doc: dict = {"format": FORMAT, "version": 1, "unit": "mm"}
    if stage is not None:
        doc["stage"] = stage
    doc["views"] = views
    atomic_write_text(path, json.dumps(doc, indent=1))
    return Path(path)


def stage_entry(description: dict, sigma_rotation_mrad: float, sigma_translation_mm: float) -> dict:
    """The ``stage`` entry of a poses file: ``description`` (kind, axis, ...) and the stage's
    stated 1σ rotation (mrad) and translation at the object centre (mm)."""
    return {**description, "sigma_rotation_mrad": float(sigma_rotation_mrad),
            "sigma_translation_mm": float(sigma_translation_mm)}


def _load(path: Path) -> dict:
    return read_format_json(path, "poses file", FORMAT)


def read_stage_sigma(path: str | os.PathLike) -> tuple[float, float] | None:
    """The stage's stated 1σ ``(rotation mrad, translation mm)`` from ``path``'s ``stage`` entry,
    or None when the file states none; ValueError naming the field when it is not two numbers ≥ 0."""
    path = Path(path)
    stage = _load(path).get("stage")
    if stage is None:
        return None
    out = []
    for key in ("sigma_rotation_mrad", "sigma_translation_mm"):
        v = stage.get(key) if isinstance(stage, dict) else None
        if v is None:
            return None
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not np.isfinite(v) or v < 0:
            raise ValueError(f"poses file {path}: field 'stage.{key}' must be a number >= 0, got {v!r}")
        out.append(float(v))
    return out[0], out[1]


def read_poses(path: str | os.PathLike) -> dict[str, np.ndarray]:
    """``{view name: (4, 4) view → model}`` from ``path``; ValueError naming the file and field."""
    return _read(path, "matrix")


def read_true_poses(path: str | os.PathLike) -> dict[str, np.ndarray]:
    """``{view name: (4, 4) true view → model}`` from the ``true_matrix`` fields a simulated
    sequence writes (:func:`fringe3d.sim.turntable.simulate_turntable`)."""
    return _read(path, "true_matrix")


def _read(path, key: str) -> dict[str, np.ndarray]:
    path = Path(path)
    doc = _load(path)
    if doc.get("unit", "mm") != "mm":
        raise ValueError(f"poses file {path}: field 'unit' must be 'mm', got {doc.get('unit')!r}")
    views = doc.get("views")
    if not isinstance(views, list) or not views:
        raise ValueError(f"poses file {path}: field 'views' must be a non-empty list")
    out: dict[str, np.ndarray] = {}
    for i, v in enumerate(views):
        if not isinstance(v, dict) or not isinstance(v.get("name"), str):
            raise ValueError(f"poses file {path}: field 'views[{i}].name' must be a string")
        if key not in v:
            why = (" (the stage's positions were recorded without a turntable axis: calibrate the axis and "
                   "capture with it, or register without poses)" if "angle_deg" in v and key == "matrix" else "")
            raise ValueError(f"poses file {path}: field 'views[{i}].{key}' is missing{why}")
        out[v["name"]] = check_rigid(v[key], f"poses file {path}: field 'views[{i}].{key}'")
    return out


def poses_for(path: str | os.PathLike, names: list[str]) -> list[np.ndarray]:
    """The poses of views ``names`` (in that order) from ``path``; ValueError naming a missing view."""
    poses = read_poses(path)
    missing = [n for n in names if n not in poses]
    if missing:
        raise ValueError(f"poses file {path}: no entry in 'views' for view(s) {', '.join(missing)} "
                         f"(names there: {', '.join(sorted(poses))})")
    return [poses[n] for n in names]
