"""The poses file: one 4×4 rigid transform per view, in millimetres.

``poses.json``::

    {"format": "fringe3d-poses", "version": 1, "unit": "mm",
     "views": [{"name": "view-00", "matrix": [[...4...], ...4 rows...]}, ...]}

``matrix`` maps the view's points (its camera frame, mm) into the common model frame:
``x_model = M @ [x_view, 1]``.
"""
from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np

from fringe3d.utils.atomic import atomic_write_text

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


def write_poses(path: str | os.PathLike, names, matrices) -> Path:
    """Write ``poses.json`` (names: view names; matrices: (V, 4, 4) view → model, mm)."""
    views = [{"name": str(n), "matrix": np.asarray(M, float).tolist()} for n, M in zip(names, matrices)]
    atomic_write_text(path, json.dumps({"format": FORMAT, "version": 1, "unit": "mm", "views": views}, indent=1))
    return Path(path)


def read_poses(path: str | os.PathLike) -> dict[str, np.ndarray]:
    """``{view name: (4, 4) view → model}`` from ``path``; ValueError naming the file and field."""
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"poses file {path} does not exist")
    try:
        doc = json.loads(path.read_text())
    except (json.JSONDecodeError, UnicodeDecodeError) as e:
        raise ValueError(f"poses file {path} is not valid JSON: {e}") from None
    if not isinstance(doc, dict) or doc.get("format") != FORMAT:
        raise ValueError(f"poses file {path}: field 'format' must be {FORMAT!r}")
    if doc.get("unit", "mm") != "mm":
        raise ValueError(f"poses file {path}: field 'unit' must be 'mm', got {doc.get('unit')!r}")
    views = doc.get("views")
    if not isinstance(views, list) or not views:
        raise ValueError(f"poses file {path}: field 'views' must be a non-empty list")
    out: dict[str, np.ndarray] = {}
    for i, v in enumerate(views):
        if not isinstance(v, dict) or not isinstance(v.get("name"), str):
            raise ValueError(f"poses file {path}: field 'views[{i}].name' must be a string")
        if "matrix" not in v:
            raise ValueError(f"poses file {path}: field 'views[{i}].matrix' is missing")
        out[v["name"]] = check_rigid(v["matrix"], f"poses file {path}: field 'views[{i}].matrix'")
    return out


def poses_for(path: str | os.PathLike, names: list[str]) -> list[np.ndarray]:
    """The poses of views ``names`` (in that order) from ``path``; ValueError naming a missing view."""
    poses = read_poses(path)
    missing = [n for n in names if n not in poses]
    if missing:
        raise ValueError(f"poses file {path}: no entry in 'views' for view(s) {', '.join(missing)} "
                         f"(names there: {', '.join(sorted(poses))})")
    return [poses[n] for n in names]
