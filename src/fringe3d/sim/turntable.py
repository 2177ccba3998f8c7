"""A virtual turntable: the scene's object turned between views, each view ray-cast with truth.

:class:`VirtualTurntable` implements :class:`fringe3d.devices.stage.Stage` (degrees about an axis
through a point, both in the camera frame, mm). :func:`turntable_views` casts the camera's pixel
rays at the scene turned by the table (equivalently: the rays turned back by ``T⁻¹``), adds depth
noise along each ray with σ = ``sigma`` / max(|cos θ|, 0.3) (θ the incidence angle; grazing
hits below cos θ = 0.2 are dropped, as a real scan loses them), and keeps the noise-free points
and normals in the model frame (view 0's camera frame) as the truth surface.

These views are truth ray-casts plus noise, not rendered fringe images run through decode and
reconstruct: they test registration, fusion and meshing, not the phase chain.
:func:`simulate_turntable` renders the whole chain instead: one full capture folder (fringe
frames, ``truth/``, ``rig.json``) per table angle, the scene turned by :class:`TurnedObject`,
plus ``poses.json`` with what the stage reports (the true poses off by a seeded error of the
stage's stated uncertainty) and the true poses beside them.
"""
from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from fringe3d.devices.stage import rotation_about
from fringe3d.io.images import write_image
from fringe3d.utils.atomic import atomic_write_text

from .catalog import BAR_KINDS, preset_frame, sculpture_scene, sphere_bar_scene  # noqa: F401 (re-exported)
from .hits import Hit, as_rays
from .presets import Preset
from .primitives import Sphere
from .rays import camera_rays
from .scene import Scene
from .scene_object import CullingVolume, SceneObject


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


class VirtualStage(VirtualTurntable):
    """A :class:`VirtualTurntable` under the virtual rig's scene: each move turns the scene the
    virtual camera films (:class:`TurnedObject` by :meth:`transform`), so ``fringe3d capture``
    on the virtual rig sees the object turned, as :func:`simulate_turntable` renders it.

    Parameters
    ----------
    state : fringe3d.sim.virtual_devices.VirtualRigState
        The shared state of the virtual projector and camera (its scene at table angle 0 is the
        home pose).
    axis, point : array_like
        The table axis (unit vector) and a point on it, camera frame, mm.
    """

    def __init__(self, state, axis, point):
        super().__init__(axis, point)
        self._state = state
        self._home = state.scene

    @property
    def home_scene(self) -> Scene:
        """The scene at table angle 0 (the model frame's)."""
        return self._home

    @property
    def rig(self):
        """The virtual rig (what its ``rig.json`` holds)."""
        return self._state.rig

    def move_to(self, position: float) -> None:
        super().move_to(position)
        self._state.set_scene(turned_scene(self._home, self.transform()))

    def describe(self) -> dict:
        return {**super().describe(), "kind": "virtual turntable", "unit": "deg"}

    def close(self) -> None:
        self._state.set_scene(self._home)


def _vec3(options: dict, key: str, default) -> np.ndarray:
    if key not in options:
        return np.asarray(default, float)
    try:
        v = np.array([float(x) for x in str(options[key]).split(",")])
    except ValueError:
        v = np.array([])
    if v.shape != (3,) or not np.all(np.isfinite(v)):
        raise ValueError(f"virtual stage option {key}={options[key]!r}: expected three comma-separated numbers "
                         "(camera frame, mm)")
    return v


def open_virtual_stage(spec, projector) -> VirtualStage:
    """The virtual turntable under ``projector``'s scene (a :class:`~fringe3d.sim.virtual_devices.VirtualProjector`).

    ``spec`` (a :class:`fringe3d.devices.DeviceSpec`): ``virtual[:STEP_DEG][?axis=X,Y,Z&point=X,Y,Z]``;
    the axis and point (camera frame, mm) default to :func:`default_turntable`'s (image-up through
    the centre of the preset's volume). The step is the caller's to read.
    """
    from fringe3d.devices.base import check_unknown_options

    state = getattr(projector, "_state", None)
    if state is None:
        raise ValueError("the virtual stage turns the virtual rig's scene: use the virtual projector and camera")
    check_unknown_options(spec, {"axis", "point", "step"})
    home = default_turntable(state.preset)
    axis = _vec3(spec.options, "axis", home.axis)
    if not np.linalg.norm(axis) > 0:
        raise ValueError("virtual stage option axis: expected a non-zero direction")
    return VirtualStage(state, axis, _vec3(spec.options, "point", home.point))


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
    from fringe3d.multiview.poses import write_poses  # heavy (its package brings open3d, 1.5 s)

    write_poses(folder / "poses.json", names, scan.true_poses)
    np.savez_compressed(folder / "truth.npz", points=scan.truth_points, normals=scan.truth_normals,
                        poses=scan.true_poses, angles_deg=scan.angles_deg)
    return out


def write_spheres(folder, scene: Scene) -> Path | None:
    """Write ``folder/spheres.json``: the static spheres of ``scene`` (at its home pose, the model
    frame) as ``centre_mm`` and ``radius_mm``, the truth of a multi-view ball-bar test
    (:func:`fringe3d.analyze.ball_bar.read_spheres`); None (nothing written) without spheres."""
    spheres = [{"centre_mm": ob.center.tolist(), "radius_mm": ob.radius} for ob in scene.objects
               if isinstance(ob, Sphere) and ob.motion.is_static]
    if not spheres:
        return None
    path = Path(folder) / "spheres.json"
    atomic_write_text(path, json.dumps({"format": "fringe3d-spheres", "version": 1, "unit": "mm",
                                        "frame": "model (view 0 camera frame)", "scene": scene.name,
                                        "spheres": spheres}, indent=1))
    return path


class TurnedObject:
    """``inner`` (a scene object) moved rigidly by ``T`` (4, 4) world → world, mm: what a
    turntable or stage does to the object on it. Rays are cast at the object in its home pose
    (origins and directions moved by ``T⁻¹``) and the hit normals moved back by ``T``; distances
    along the rays are unchanged by a rigid motion. Gloss, albedo and texture are the inner
    object's; extra truth fields (the wing's curvature) are not carried."""

    def __init__(self, inner: SceneObject, T):
        self.inner = inner
        self.T = np.asarray(T, float)
        self._Ti = np.linalg.inv(self.T)

    @property
    def moving(self) -> bool:
        return bool(self.inner.moving)

    @property
    def specular(self) -> float:
        return float(getattr(self.inner, "specular", 0.0))

    @property
    def roughness(self) -> float:
        return float(getattr(self.inner, "roughness", 1.0))

    def _home(self, origins, dirs) -> tuple[np.ndarray, np.ndarray]:
        o, d = as_rays(origins, dirs)
        Ti = self._Ti
        return (np.ascontiguousarray(o @ Ti[:3, :3].T + Ti[:3, 3]), np.ascontiguousarray(d @ Ti[:3, :3].T))

    def intersect(self, origins: np.ndarray, dirs: np.ndarray, time: float = 0.0) -> Hit:
        o, d = self._home(origins, dirs)
        h = self.inner.intersect(o, d, time)
        h.normal = np.ascontiguousarray(h.normal @ self.T[:3, :3].T)
        return h

    def hit_distance(self, origins: np.ndarray, dirs: np.ndarray, time: float = 0.0) -> np.ndarray:
        o, d = self._home(origins, dirs)
        return self.inner.hit_distance(o, d, time)

    def culling_volume(self, time: float = 0.0) -> CullingVolume | None:
        v = self.inner.culling_volume(time)
        if v is None:
            return None
        R = self.T[:3, :3]
        return CullingVolume(R @ v.center + self.T[:3, 3], v.radius, R @ v.R, v.lo, v.hi)

    def bounding_sphere(self, time: float = 0.0) -> tuple[np.ndarray, float]:
        c, r = self.inner.bounding_sphere(time)
        return self.T[:3, :3] @ np.asarray(c, float) + self.T[:3, 3], r

    def describe(self) -> str:
        return f"{self.inner.describe()} on a stage"

    def to_dict(self) -> dict:
        raise ValueError(f"{self.describe()} cannot be saved to a scene file (save the scene at its home pose)")


def turned_scene(scene: Scene, T) -> Scene:
    """``scene`` with every object moved by ``T`` (4, 4) world → world (:class:`TurnedObject`)."""
    return Scene([TurnedObject(ob, T) for ob in scene.objects], ambient=scene.ambient, name=scene.name)


def stage_errors(true_poses, centres, sigma_rotation_mrad: float, sigma_translation_mm: float,
                 seed: int = 0) -> np.ndarray:
    """What a stage of stated 1σ uncertainty reports: each true pose (V, 4, 4) view → model
    followed by a random error ``E`` in its view frame, a rotation of N(0, σ_rot) per axis about
    the view's object centre ``centres[k]`` (mm) and a shift of N(0, σ_trans) per axis. View 0
    defines the model frame and is exact. Seeded: the same seed gives the same errors."""
    rng = np.random.default_rng(seed)
    out = [np.asarray(true_poses[0], float)]
    for P, c in zip(true_poses[1:], centres[1:]):
        w = rng.normal(scale=1e-3 * sigma_rotation_mrad, size=3)
        ang = float(np.linalg.norm(w))
        E = rotation_about(w if ang > 0 else (0.0, 0.0, 1.0), ang, c)
        E[:3, 3] += rng.normal(scale=sigma_translation_mm, size=3)
        out.append(np.asarray(P, float) @ E)
    return np.stack(out)


def simulate_turntable(folder, preset="tiny", scene=None, patterns=None, *, views: int, step_deg: float,
                       stage_sigma: tuple[float, float] = (0.0, 0.0), progress: bool = True,
                       **capture) -> dict:
    """Render a turntable sequence: one capture folder per table angle and its poses.

    Writes ``folder/view-NN/`` (a full :func:`fringe3d.sim.simulate.simulate_capture` folder of
    the scene turned by ``NN × step_deg`` about :func:`default_turntable`'s axis) and
    ``folder/poses.json``: per view its ``matrix`` (what the stage reports: the true view → model
    pose off by :func:`stage_errors`), ``true_matrix`` (the truth) and ``angle_deg``, plus a
    ``stage`` entry (axis, point, step, the stated 1σ ``sigma_rotation_mrad`` and
    ``sigma_translation_mm`` at the object centre). The model frame is view 0's camera frame.
    A scene with spheres also gets ``folder/spheres.json`` (their true centres and radii in the
    model frame, mm): the truth of a multi-view ball-bar test (``fringe3d evaluate --ball-bar``).

    Parameters
    ----------
    folder : path
        Output folder (the view folders and ``poses.json`` are written inside it).
    preset, scene, patterns
        As :func:`fringe3d.sim.simulate.simulate_capture` (a scene at its home pose, table angle 0).
    views : int
        Number of views (≥ 2).
    step_deg : float
        Table turn between consecutive views (degrees).
    stage_sigma : (float, float)
        The stage's stated 1σ uncertainty: rotation (mrad) and translation at the object centre
        (mm); the reported poses carry a seeded error of that size.
    progress : bool
        Show progress bars.
    **capture
        Any other keyword of ``simulate_capture`` (``seed`` also seeds the stage error; view
        ``k`` renders with ``seed + k``).

    Returns
    -------
    dict
        Summary: folder, views (their folders), angles, the ``poses`` file and each view's summary.
    """
    from . import presets as _presets
    from .simulate import make_scene, simulate_capture

    if views < 2:
        raise ValueError(f"views must be >= 2, got {views}")
    if not np.isfinite(step_deg) or step_deg == 0:
        raise ValueError(f"step_deg must be a finite non-zero angle in degrees, got {step_deg}")
    if min(stage_sigma) < 0:
        raise ValueError(f"stage_sigma must be >= 0 (mrad, mm), got {stage_sigma}")
    p = _presets.get(preset)
    sc = make_scene(scene, p)
    table = default_turntable(p)
    folder = Path(folder)
    seed = int(capture.pop("seed", None) or 0)
    angles = step_deg * np.arange(views)
    names = [f"view-{k:02d}" for k in range(views)]
    true, centres, summaries = [], [], []
    for k, (name, a) in enumerate(zip(names, angles)):
        table.move_to(float(a))
        T = table.transform()
        true.append(np.linalg.inv(T))  # view k -> model (view 0: angle 0, the home pose)
        centres.append(T[:3, :3] @ table.point + T[:3, 3])
        summaries.append(simulate_capture(folder / name, p, turned_scene(sc, T), patterns, seed=seed + k,
                                          progress=progress, **capture))
    stage = stage_errors(np.stack(true), centres, stage_sigma[0], stage_sigma[1], seed)
    write_spheres(folder, sc)
    desc = {**table.describe(), "step_deg": float(step_deg), "angles_deg": angles.tolist()}
    from fringe3d.multiview.poses import stage_entry, write_poses  # heavy (its package brings open3d)

    poses = write_poses(folder / "poses.json", names, stage,
                        extra=[{"true_matrix": t.tolist(), "angle_deg": float(a)} for t, a in zip(true, angles)],
                        stage=stage_entry(desc, *stage_sigma))
    return {"folder": str(folder), "views": [str(folder / n) for n in names], "angles_deg": angles.tolist(),
            "poses": str(poses), "stage_sigma": {"rotation_mrad": stage_sigma[0], "translation_mm": stage_sigma[1]},
            "captures": summaries}


def read_turntable_truth(folder, names: list[str]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The truth of a simulated multi-view sequence for the views ``names``: their true view →
    model poses (V, 4, 4) and the true visible surface, points and unit normals (M, 3) in the
    model frame (mm).

    ``folder`` is what :func:`write_turntable` wrote (``truth.npz``: poses in view order
    ``view-00``, ``view-01``, ...) or :func:`simulate_turntable` (``poses.json``'s ``true_matrix``
    and each ``view-NN/truth/``, whose valid pixels are placed by the view's true pose).
    ValueError naming the file when a view has no truth there."""
    from fringe3d.multiview.poses import read_true_poses

    from .truth import Truth

    folder = Path(folder)
    npz = folder / "truth.npz"
    if npz.is_file():
        with np.load(npz) as z:
            poses, points, normals = z["poses"], z["points"], z["normals"]
        order = {f"view-{i:02d}": i for i in range(len(poses))}
        missing = [n for n in names if n not in order]
        if missing:
            raise ValueError(f"{npz}: no true pose for view(s) {', '.join(missing)} (it holds {len(poses)} views, "
                             "named view-00, view-01, ... in order)")
        return np.stack([poses[order[n]] for n in names]), points, normals
    if not (folder / "poses.json").is_file():
        raise ValueError(f"{folder}: expected a simulated multi-view sequence (truth.npz, or poses.json with "
                         "true_matrix and view-NN/truth/)")
    true = read_true_poses(folder / "poses.json")
    missing = [n for n in names if n not in true]
    if missing:
        raise ValueError(f"{folder / 'poses.json'}: no true_matrix for view(s) {', '.join(missing)}")
    pts, nrm = [], []
    for name in names:
        t = Truth.load(folder / name)
        xyz, normal, mask = (np.asarray(a) for a in (t.xyz, t.normal, t.mask))
        if xyz.ndim == 4:  # a sequence: its first frame
            xyz, normal, mask = xyz[0], normal[0], mask[0]
        keep = mask.astype(bool) & np.isfinite(xyz).all(-1)
        R, c = true[name][:3, :3], true[name][:3, 3]
        pts.append(xyz[keep] @ R.T + c)
        nrm.append(normal[keep] @ R.T)
    return np.stack([true[n] for n in names]), np.concatenate(pts), np.concatenate(nrm)
