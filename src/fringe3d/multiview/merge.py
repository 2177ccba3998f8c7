"""The whole multi-view chain: register, fuse, mesh (:func:`merge_views`), and its output folder
(:func:`write_merge`)."""
from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import open3d as o3d

from fringe3d.io.ply_standard import write_standard_ply
from fringe3d.utils.atomic import atomic_path, atomic_write_text

from .fuse import Fused, fuse_views
from .mesh import mesh_figures, poisson_mesh
from .poses import write_poses
from .register import Registration, register_views
from .views import View

MESH_METHODS = ("poisson", "none")


@dataclass
class Merged:
    """What :func:`merge_views` gives: the registration, the fused cloud, the mesh (or None)."""

    names: list[str]
    registration: Registration
    fused: Fused
    mesh: o3d.geometry.TriangleMesh | None
    stage_sigma: tuple[float, float] | None = None

    def summary(self) -> dict:
        r = self.registration
        f = self.fused
        per_view = [{"name": n, "residual_rms_mm": _f(r.residual_rms_mm[i]),
                     "rotation_sigma_mrad": _f(r.rotation_sigma_mrad[i]),
                     "translation_sigma_um": _f(r.translation_sigma_um[i]),
                     "points": int(f.view_points[i]) if i < len(f.view_points) else None,
                     "overlap_share": _f(f.view_overlap[i]) if i < len(f.view_overlap) else None}
                    for i, n in enumerate(self.names)]
        prior = None if self.stage_sigma is None else {"rotation_mrad": self.stage_sigma[0],
                                                       "translation_mm": self.stage_sigma[1]}
        out = {"views": per_view, "stage_prior": prior, "edges": r.edges, "fused_points": len(f.points),
               "fused_overlap_share": _f(f.overlap_share), "fused_sigma_median_mm": _f(np.median(f.sigma))}
        if self.mesh is not None:
            out["mesh"] = mesh_figures(self.mesh)
        return out


def _f(x) -> float | None:
    return float(x) if np.isfinite(x) else None


def merge_views(views: list[View], poses=None, voxel: float = 2.0, fuse_voxel: float | None = None,
                mesh: str = "poisson", seed: int = 0, stage_sigma=None) -> Merged:
    """Register ``views`` (from ``poses`` (V, 4, 4) view → model, or free-hand when None), fuse
    them (σ-weighted voxels of ``fuse_voxel`` mm, default ``voxel / 2``) and mesh them
    (``mesh``: ``poisson`` or ``none``). ``stage_sigma`` (rotation mrad, translation mm at the
    object centre): the stated 1σ of stage ``poses``, which keeps each pose near its stage pose
    by that weight (:func:`fringe3d.multiview.register.register_views`)."""
    if mesh not in MESH_METHODS:
        raise ValueError(f"mesh must be one of {', '.join(MESH_METHODS)}, got {mesh!r}")
    if poses is not None and len(poses) != len(views):
        raise ValueError(f"{len(poses)} poses for {len(views)} views")
    r = register_views(views, poses, voxel=voxel, seed=seed, stage_sigma=stage_sigma)
    fv = fuse_voxel if fuse_voxel is not None else 0.5 * voxel
    fused = fuse_views(views, r.poses, fv)
    m = poisson_mesh(fused.points, fv) if mesh == "poisson" else None
    return Merged([v.name for v in views], r, fused, m,
                  None if stage_sigma is None else (float(stage_sigma[0]), float(stage_sigma[1])))


def write_merge(folder: str | os.PathLike, merged: Merged) -> dict:
    """Write ``fused.ply`` (points mm, ``scalar_sigma_mm``, ``scalar_views``), ``mesh.ply`` (when
    meshed), ``poses.json`` (the registered poses) and ``merge.json`` (the summary) into ``folder``."""
    folder = Path(folder)
    f = merged.fused
    files = {"fused": str(write_standard_ply(
        folder / "fused.ply", f.points, normals=False,
        scalars={"sigma_mm": (f.sigma, "fused point 1-sigma, mm"), "views": (f.views.astype(float), "views merged")},
        comments=["frame: model (view 0 camera frame), mm"]))}
    files["poses"] = str(write_poses(folder / "poses.json", merged.names, merged.registration.poses))
    if merged.mesh is not None:
        with atomic_path(folder / "mesh.ply") as tmp:
            if not o3d.io.write_triangle_mesh(tmp, merged.mesh):
                raise OSError(f"could not write {folder / 'mesh.ply'}")
        files["mesh"] = str(folder / "mesh.ply")
    summary = {**merged.summary(), "files": files}
    atomic_write_text(folder / "merge.json", json.dumps(summary, indent=1))
    return summary
