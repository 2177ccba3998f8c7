"""A virtual turntable: the scene's object turned between views, each view ray-cast with truth.

:class:`VirtualTurntable` implements :class:`fringe3d.devices.stage.Stage` (degrees about an axis
through a point, both in the camera frame, mm). :func:`turntable_views` casts the camera's pixel
rays at the scene turned by the table (equivalently: the rays turned back by ``T⁻¹``), adds depth
noise along each ray with σ = ``sigma`` / max(|cos θ|, 0.3) (θ the incidence angle; grazing
hits below cos θ = 0.2 are dropped, as a real scan loses them), and keeps the noise-free points
and normals in the model frame (view 0's camera frame) as the truth surface.

These views are truth ray-casts plus noise, not rendered fringe images run through decode and
reconstruct: they test registration, fusion and meshing, not the phase chain.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from fringe3d.devices.stage import rotation_about
from fringe3d.io.images import write_image
from fringe3d.multiview.poses import write_poses

from .catalog import preset_frame, sculpture_scene
from .presets import Preset
from .primitives import Box, Sphere
from .rays import camera_rays
from .scene import Scene


class VirtualTurntable:
    """A turntable about ``axis`` through ``point`` (camera frame, mm); ``position`` in degrees."""

    def __init__(self, axis, point):
        self.axis = np.asarray(axis, float) / np.linalg.norm(axis)
        self.point = np.asarray(point, float)
        self._position = 0.0

    def move_to(self, position: float) -> None:
        if not np.isfinite(position):
            raise ValueError(f"turntable position must be a finite angle in degrees, got {position}")
        self._position = float(position)

    @property
    def position(self) -> float:
        return self._position

    def transform(self) -> np.ndarray:
        return rotation_about(self.axis, np.deg2rad(self._position), self.point)

    def describe(self) -> dict:
        return {"kind": "virtual turntable", "axis": self.axis.tolist(), "point_mm": self.point.tolist()}

    def close(self) -> None:
        pass


@dataclass
class TurntableScan:
    """Views of a turntable sequence: ``points`` (V, H, W, 3) mm camera frame (NaN: no point),
    ``sigma`` (V, H, W) mm, ``true_poses`` (V, 4, 4) view → model (view 0's camera frame),
    ``truth_points`` / ``truth_normals`` (M, 3) the noise-free visible surface in the model frame."""

    points: np.ndarray
    sigma: np.ndarray
    true_poses: np.ndarray
    truth_points: np.ndarray
    truth_normals: np.ndarray
    angles_deg: np.ndarray


def default_turntable(preset: Preset) -> VirtualTurntable:
    """A table turning about image-up through the centre of the preset's volume."""
    c, _, _, down = preset_frame(preset)
    return VirtualTurntable(-down, c)


def turntable_views(scene: Scene, preset: Preset, angles_deg, sigma: float = 0.05,
                    seed: int = 0, table: VirtualTurntable | None = None) -> TurntableScan:
    """Cast ``scene`` on ``table`` (default :func:`default_turntable`) at each angle."""
    table = table or default_turntable(preset)
    cam = preset.rig.camera
    o, d, _ = camera_rays(cam)
    rng = np.random.default_rng(seed)
    H, W = cam.height, cam.width
    pts, sig, poses, tp, tn = [], [], [], [], []
    table.move_to(float(angles_deg[0]))
    T0 = table.transform()
    for a in angles_deg:
        table.move_to(float(a))
        T = table.transform()
        Ti = np.linalg.inv(T)
        o_b = np.broadcast_to(o, d.shape) @ Ti[:3, :3].T + Ti[:3, 3]
        hit = scene.intersect(np.ascontiguousarray(o_b), np.ascontiguousarray(d @ Ti[:3, :3].T))
        ok = np.isfinite(hit.t)
        n_cam = hit.normal @ T[:3, :3].T
        cos = np.abs(np.einsum("ij,ij->i", n_cam, d))
        ok &= cos >= 0.2
        s = sigma / np.maximum(cos, 0.3)
        X = np.broadcast_to(o, d.shape) + d * hit.t[:, None]
        noisy = X + d * (rng.standard_normal(len(d)) * s)[:, None]
        pose = T0 @ Ti
        pts.append(np.where(ok[:, None], noisy, np.nan).reshape(H, W, 3))
        sig.append(np.where(ok, s, np.nan).reshape(H, W))
        poses.append(pose)
        tp.append(X[ok] @ pose[:3, :3].T + pose[:3, 3])
        tn.append(n_cam[ok] @ pose[:3, :3].T)
    return TurntableScan(np.stack(pts), np.stack(sig), np.stack(poses), np.concatenate(tp),
                         np.concatenate(tn), np.asarray(angles_deg, float))


def sphere_bar_scene(preset: Preset, spacing: float | None = None, radius: float | None = None):
    """A ball bar for VDI/VDE 2634-3: two spheres ``spacing`` mm apart (default 45 % of the volume
    width) joined by a square bar, and a smaller knob sphere on the bar (it breaks the bar's
    symmetry so free-hand registration has a unique answer). Returns ``(scene, centres (2, 3),
    radius)`` in the camera frame at table angle 0."""
    c, size, view, down = preset_frame(preset)
    L = 0.45 * size[0] if spacing is None else float(spacing)
    r = 0.08 * size[0] if radius is None else float(radius)
    right = np.cross(down, view)
    right /= np.linalg.norm(right)
    ca, cb = c - 0.5 * L * right, c + 0.5 * L * right
    R = np.column_stack([right, -down, -view])
    bar = Box(c, (L - r, 0.5 * r, 0.5 * r), R=R)
    knob = Sphere(c + 0.2 * L * right - 0.6 * r * down, 0.5 * r)
    return Scene([Sphere(ca, r), Sphere(cb, r), bar, knob], name="sphere-bar"), np.stack([ca, cb]), r


def sculpture_turntable(preset: Preset, seed: int = 0) -> Scene:
    """The seeded sculpture relief of :func:`fringe3d.sim.catalog.sculpture_scene`."""
    return sculpture_scene(preset, seed)


def write_turntable(folder, scan: TurntableScan) -> list[Path]:
    """Write ``scan`` as one reconstruct-like folder per view (``view-NN/points.npy`` float32 mm,
    ``view-NN/sigma_z.tif`` mm) plus ``poses.json`` (the true view → model poses, what a
    calibrated turntable gives) and ``truth.npz`` (``points``, ``normals``, ``poses``,
    ``angles_deg``) in ``folder``; returns the view folders."""
    folder = Path(folder)
    names = [f"view-{i:02d}" for i in range(len(scan.points))]
    out = []
    for name, P, s in zip(names, scan.points, scan.sigma):
        (folder / name).mkdir(parents=True, exist_ok=True)
        np.save(folder / name / "points.npy", P.astype(np.float32))
        write_image(folder / name / "sigma_z.tif", s.astype(np.float32), "depth uncertainty", "mm")
        out.append(folder / name)
    write_poses(folder / "poses.json", names, scan.true_poses)
    np.savez_compressed(folder / "truth.npz", points=scan.truth_points, normals=scan.truth_normals,
                        poses=scan.true_poses, angles_deg=scan.angles_deg)
    return out
