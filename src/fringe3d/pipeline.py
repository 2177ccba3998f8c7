"""Capture folder -> point cloud in one call: the path ``fringe3d reconstruct`` takes for one
pattern cycle (read the capture, load the rig, decode, triangulate; Eq. 2.37).

>>> import tempfile, fringe3d
>>> cap = tempfile.mkdtemp() + "/cap"
>>> _ = fringe3d.simulate_capture(cap, preset="tiny", seed=0, progress=False)  # a virtual capture
>>> r = fringe3d.reconstruct_capture(cap, cap + "/rig.json")
>>> r.points.shape[-1], r.points.dtype, bool(r.mask.any())
(3, dtype('float32'), True)
"""
from __future__ import annotations

import os
import dataclasses
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from fringe3d.decode import DecodeOptions
from fringe3d.decode.plan_checks import check_plans
from fringe3d.decode.texture import TEXTURE_UNIT
from fringe3d.io.capture import Capture, read_capture
from fringe3d.io.images import write_image
from fringe3d.io.colour_texture import capture_chroma, rgb_texture
from fringe3d.io.ply_standard import write_measurement_ply
from fringe3d.io.vtk_points import write_measurement_vtp
from fringe3d.io.point_attributes import grid_normals
from fringe3d.io.pointcloud import _colors
from fringe3d.optics import Rig
from fringe3d.optics.rig_geometry import RigGeometry
from fringe3d.patterns.manifest import MANIFEST_NAME, PatternSet
from fringe3d.reconstruct.depth import depth_map
from fringe3d.reconstruct.frame import FrameReconstructor, reconstruction_plans
from fringe3d.unwrap.geometric import propose_z_min
from fringe3d.utils.camera_size import check_camera_size
from fringe3d.utils.atomic import atomic_path
from fringe3d.io.arrays import load_array


@dataclass
class Reconstruction:
    """One pattern cycle reconstructed.

    Attributes
    ----------
    points : (H, W, 3) float32
        Camera-frame points (mm), NaN where invalid.
    texture : (H, W) float32 or None
        Texture: the scene under full projector light as a fraction of the camera's full scale,
        in [0, 1] (:mod:`fringe3d.decode.texture`; the same as ``decode``'s).
    mask : (H, W) bool
        Valid points (``isfinite(points[..., 0])``).
    patterns : PatternSet
        The manifest as decoded (after any method override).
    path : str
        Which code path reconstructed it (fused kernel or decode + triangulate).
    quality : (H, W) uint8 or None
        Why a pixel has no point, one bit per reason (OR over the fringe directions): 1 invalid
        (modulation, saturation, code), 2 projector-edge band, 4 multi-frequency disagreement,
        8 phase-gradient jump, 16 modulation drop (:mod:`fringe3d.decode.edges`); 0 = kept.
    sigma_xyz : (H, W, 3) float32 or None
        Predicted standard deviation of each coordinate (mm) from the phase noise
        (:mod:`fringe3d.reconstruct.uncertainty`); NaN where invalid.
    texture_rgb : (H, W, 3) float32 or None
        The texture in colour when the frames came from a colour camera
        (:mod:`fringe3d.io.colour_texture`: luma = ``texture``); the PLY's colours then.
    """

    points: np.ndarray
    texture: np.ndarray | None
    mask: np.ndarray
    patterns: PatternSet
    path: str
    quality: np.ndarray | None = None
    sigma_xyz: np.ndarray | None = None
    texture_rgb: np.ndarray | None = None

    @property
    def sigma_z(self) -> np.ndarray | None:
        """(H, W) float32 predicted depth standard deviation (mm), NaN where invalid."""
        return None if self.sigma_xyz is None else np.ascontiguousarray(self.sigma_xyz[..., 2])

    def save_ply(self, path: str | os.PathLike) -> Path:
        """Write the valid points as the measurement PLY every path writes
        (:func:`fringe3d.io.ply_standard.write_measurement_ply`: normals, texture colour,
        ``scalar_sigma_z_mm`` (when known), ``scalar_roughness_mm``, units and provenance); returns the path."""
        return write_measurement_ply(Path(path), self.points, self.colour, mask=self.mask, sigma_z=self.sigma_z)

    @property
    def colour(self) -> np.ndarray | None:
        """The PLY's colours: ``texture_rgb`` when the camera is colour, else the grey ``texture``."""
        return self.texture_rgb if self.texture_rgb is not None else self.texture

    def _valid(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Valid points ``(N, 3)`` float64, their unit normals ``(N, 3)`` (the PLY's rule,
        :func:`fringe3d.io.point_attributes.grid_normals`: finite everywhere) and RGB colours
        ``(N, 3)`` float64 in [0, 1] (grey texture; mid-grey without one)."""
        m = self.mask & np.isfinite(self.points).all(axis=-1)
        pts = np.asarray(self.points, np.float64)[m]
        P = np.where(m[..., None], self.points, np.nan)
        normals = grid_normals(P)[m].astype(np.float64)
        if self.texture is None:
            colors = np.full_like(pts, 0.5)
        else:
            colors = _colors(self.texture, self.mask.shape)[m].astype(np.float64) / 255.0
        return pts, normals, colors

    def to_open3d(self):
        """The valid points as an ``open3d.geometry.PointCloud`` (mm, camera frame).

        Returns
        -------
        open3d.geometry.PointCloud
            Points, colours from the texture (RGB in [0, 1]) and unit normals from the organized
            grid (oriented towards the camera; one-sided at borders, the line of sight for a lone
            point, as in the PLY).

        Raises
        ------
        ImportError
            When open3d is not installed (``pip install "fringe3d[open3d]"``).
        """
        o3d = _optional("open3d", "to_open3d")
        pts, normals, colors = self._valid()
        pcd = o3d.geometry.PointCloud()
        pcd.points = o3d.utility.Vector3dVector(pts)
        pcd.colors = o3d.utility.Vector3dVector(colors)
        pcd.normals = o3d.utility.Vector3dVector(normals)
        return pcd

    def to_pyvista(self):
        """The valid points as a ``pyvista.PolyData`` (mm, camera frame; one vertex cell per point).

        Returns
        -------
        pyvista.PolyData
            Point data ``rgb`` (uint8 colours from the texture), ``normals`` (unit, as in the PLY),
            ``quality`` (uint8 bits, :attr:`quality`) and ``sigma_z`` (float32 mm,
            :attr:`sigma_z`) where those are known.

        Raises
        ------
        ImportError
            When pyvista is not installed (``pip install "fringe3d[pyvista]"``).
        """
        pv = _optional("pyvista", "to_pyvista")
        m = self.mask & np.isfinite(self.points).all(axis=-1)
        pts, normals, colors = self._valid()
        cloud = pv.PolyData(pts)
        cloud.point_data["rgb"] = np.round(colors * 255.0).astype(np.uint8)
        cloud.point_data["normals"] = normals
        if self.quality is not None:
            cloud.point_data["quality"] = np.asarray(self.quality, np.uint8)[m]
        sigma_z = self.sigma_z
        if sigma_z is not None:
            cloud.point_data["sigma_z"] = np.asarray(sigma_z, np.float32)[m]
        return cloud

    def save(self, out: str | os.PathLike, ply: bool = False, mesh: bool = False) -> dict:
        """Write ``points.npy``, ``depth.tif``, ``texture.tif``, ``quality.tif`` (uint8 bits),
        ``sigma_z.tif`` (float32 mm) (+ ``points.ply``, with faces when ``mesh``, and
        ``points.vtp``) into ``out``; see :func:`write_point_maps`."""
        files = write_point_maps(Path(out), self.points, self.texture, ply, mesh, colour=self.texture_rgb,
                                 sigma_z=self.sigma_z)
        if self.quality is not None:
            files["quality"] = str(write_image(Path(out) / "quality.tif", self.quality.astype(np.uint8),
                                                       "quality", "bit flags (fringe3d.decode.edges)"))
        if self.sigma_z is not None:
            files["sigma_z"] = str(write_image(Path(out) / "sigma_z.tif", self.sigma_z.astype(np.float32),
                                                       "sigma_z (predicted depth standard deviation)", "mm"))
        return files

    def summary(self) -> dict:
        """Valid share / count and depth range; see :func:`point_summary`."""
        return point_summary(self.points)


def _optional(module: str, method: str):
    """The optional library ``module`` (also the name of its extra), or an ImportError saying how
    to install it for ``Reconstruction.<method>``."""
    try:
        return __import__(module)  # a top-level package name: the module itself
    except ImportError as e:
        raise ImportError(f"Reconstruction.{method} needs {module}: pip install \"fringe3d[{module}]\" "
                          f"(or pip install {module}) ({e})") from e


def check_sizes(rig: Rig, frames: np.ndarray, calibration, patterns: PatternSet | None = None) -> None:
    """ValueError when the calibration's camera and the captured frames ``(F, H, W)`` differ in size,
    or its projector and the pattern manifest ``patterns`` (projector pixels) do."""
    if patterns is not None and (rig.projector.width, rig.projector.height) != (patterns.width, patterns.height):
        raise ValueError(f"the calibration {calibration} describes a {rig.projector.width}x{rig.projector.height} "
                         f"projector but the capture's pattern manifest is {patterns.width}x{patterns.height}: "
                         "calibration and patterns disagree (expected the calibration of the projector that showed "
                         "these patterns)")
    check_camera_size(frames.shape[1:], (rig.camera.height, rig.camera.width), what="the capture's frames",
                      hint=f" (expected the calibration {calibration} of the camera that recorded this capture)")


@dataclass(frozen=True)
class CycleSettings:
    """How :func:`reconstruct_cycle` reconstructs one pattern cycle; every field has a default.

    Attributes
    ----------
    options : DecodeOptions
        The decoder's options (:class:`fringe3d.decode.DecodeOptions`): among them ``z_min``
        (nearest scene depth, mm, for the geometric methods), ``min_modulation`` (camera counts;
        default from the bit depth), ``edge_mask`` and ``edge_margin`` (edge and mixed pixels;
        projector px, default 2 px + twice the estimated blur), ``compensate`` and ``response``
        (projector-nonlinearity compensation). Its ``bit_depth``, when not set, is the capture's.
        Default ``DecodeOptions()``.
    method : str, optional
        Unwrapping method for every direction (default None: the manifest's plans).
    triangulation : {"auto", "fast", "lsq"}
        Closed form or least squares (Eq. 2.37); default ``"auto"``.
    backend : {"cpu", "cuda"}
        Where the per-pixel kernels run (:class:`fringe3d.reconstruct.frame.FrameReconstructor`);
        default ``"cpu"``.
    allow_relative : bool
        Triangulate a wrapped or relative phase (method ``none`` or ``spatial``) anyway, with a
        warning; its 3D is off by an unknown number of fringe periods in depth. Default False.

    Examples
    --------
    >>> s = CycleSettings(method="geometric", options=DecodeOptions(z_min=350.0))
    >>> s.options.z_min, s.triangulation, s.backend
    (350.0, 'auto', 'cpu')
    """

    options: DecodeOptions = field(default_factory=DecodeOptions)
    method: str | None = None
    triangulation: str = "auto"
    backend: str = "cpu"
    allow_relative: bool = False


def reconstruct_cycle(cap: Capture, rig: Rig | RigGeometry, settings: CycleSettings | None = None) -> Reconstruction:
    """Reconstruct the first pattern cycle of a capture in memory.

    Parameters
    ----------
    cap : Capture
        From :func:`fringe3d.io.capture.read_capture` (frames in manifest order).
    rig : Rig or RigGeometry
        Calibrated rig whose camera recorded ``cap``, or its
        :class:`~fringe3d.optics.rig_geometry.RigGeometry` (the maps that the caller's own plan
        checks computed are then reused, not computed again).
    settings : CycleSettings, optional
        The decoder's options, unwrapping method, triangulation, backend and whether a relative
        phase may be triangulated (default ``CycleSettings()``: the manifest's plans, closed form
        where it applies, on the CPU).

    Returns
    -------
    Reconstruction
        ``points`` (H, W, 3) float32 mm (NaN where invalid), ``texture``, ``mask``, ``quality``,
        ``sigma_xyz`` / ``sigma_z``, the manifest as decoded and the code path taken.

    Raises
    ------
    fringe3d.decode.plan_checks.RelativePhaseError
        A direction's phase is wrapped or relative (and not ``allow_relative``); the message names
        the absolute methods the manifest can feed.
    fringe3d.decode.plan_checks.MissingGeometryError
        A geometric-constraint method without ``z_min``.

    Examples
    --------
    >>> import tempfile, fringe3d
    >>> cap = tempfile.mkdtemp() + "/cap"
    >>> _ = fringe3d.simulate_capture(cap, preset="tiny", seed=0, progress=False)  # a virtual capture
    >>> settings = CycleSettings(triangulation="lsq", options=DecodeOptions(edge_margin=4.0))
    >>> r = reconstruct_cycle(read_capture(cap, max_cycles=1), Rig.load(cap + "/rig.json"), settings)
    >>> r.points.shape[-1], bool(r.mask.any())
    (3, True)
    """
    s = settings if settings is not None else CycleSettings()
    geometry = rig if isinstance(rig, RigGeometry) else RigGeometry(rig)  # one for the checks and the engine
    ps = reconstruction_plans(cap.patterns, s.method)
    source = f"{cap.folder / MANIFEST_NAME}" if cap.folder is not None else "the manifest"
    check_plans(ps, geometry.rig, s.options.z_min, original=cap.patterns, source=source,
                allow_relative=s.allow_relative, geometry=geometry)
    options = s.options
    if options.bit_depth is None:
        options = dataclasses.replace(options, bit_depth=cap.meta.get("bit_depth"))
    rec = FrameReconstructor(ps, geometry.rig, options, triangulation=s.triangulation, backend=s.backend,
                             allow_relative=s.allow_relative, geometry=geometry)
    c = rec.reconstruct(np.ascontiguousarray(cap.frames))
    texture_rgb = None
    if cap.folder is not None and c.texture is not None:
        chroma = capture_chroma(cap.folder, len(ps))
        texture_rgb = None if chroma is None else rgb_texture(c.texture, chroma)
    return Reconstruction(points=c.points, texture=c.texture, mask=np.isfinite(c.points[..., 0]), patterns=ps,
                          path=rec.path, quality=c.quality, sigma_xyz=c.sigma_xyz, texture_rgb=texture_rgb)


def reconstruct_capture(folder: str | os.PathLike, calibration: str | os.PathLike | Rig, method: str | None = None,
                        z_min: float | None = None, triangulation: str = "auto",
                        min_modulation: float | None = None, edge_mask: bool = True,
                        edge_margin: float | None = None, allow_relative: bool = False) -> Reconstruction:
    """A capture folder's first pattern cycle as a point map.

    Parameters
    ----------
    folder : path
        Capture folder (``manifest.json`` + frames).
    calibration : path or Rig
        Calibration JSON (with a ``rig`` entry) or rig JSON, or a :class:`Rig`.
    method, z_min, triangulation, min_modulation, edge_mask, edge_margin, allow_relative
        As in :func:`reconstruct_cycle`: the unwrapping method overriding the manifest's plan,
        the nearest depth for the geometric constraint (mm), closed form or least squares, the
        modulation threshold (camera counts), the edge / mixed-pixel masking and whether a
        wrapped or relative phase may be triangulated (``RelativePhaseError`` otherwise).

    Returns
    -------
    Reconstruction
        ``points`` (H, W, 3) float32 mm (NaN where invalid), ``texture``, ``mask``, ``quality``,
        ``sigma_xyz`` / ``sigma_z``.
    """
    rig = calibration if isinstance(calibration, Rig) else Rig.load(calibration)
    cap = read_capture(folder, max_cycles=1)
    check_sizes(rig, cap.frames, calibration, cap.patterns)
    options = DecodeOptions(z_min=z_min, min_modulation=min_modulation, edge_mask=edge_mask, edge_margin=edge_margin)
    return reconstruct_cycle(cap, rig, CycleSettings(options, method, triangulation, allow_relative=allow_relative))


def write_point_maps(out: Path, points: np.ndarray, texture: np.ndarray | None, ply: bool,
                     mesh: bool = False, colour: np.ndarray | None = None,
                     sigma_z: np.ndarray | None = None) -> dict:
    """points.npy, depth.tif (float32 mm, NaN invalid), texture.tif and optionally points.ply
    and points.vtp, all written atomically; returns ``{kind: path}``.

    The PLY (:func:`fringe3d.io.ply_standard.write_measurement_ply`) carries normals from the
    grid, the texture as colour, the fields ``scalar_sigma_z_mm`` (``sigma_z``, when given) and
    ``scalar_roughness_mm`` (local roughness), units and provenance in its header and, with
    ``mesh``, the grid's triangles; ``colour`` (H, W, 3), a colour camera's texture, replaces the
    grey texture as the PLY's colours. ``points.vtp`` (:func:`fringe3d.io.vtk_points.
    write_measurement_vtp`) holds the same points and fields for ParaView and PyVista, whose PLY
    reader drops scalar fields."""
    out.mkdir(parents=True, exist_ok=True)
    with atomic_path(out / "points.npy") as tmp:
        with open(tmp, "wb") as f:
            np.save(f, points)
    files = {"points": str(out / "points.npy"), "depth": str(write_image(out / "depth.tif", depth_map(points),
                                                                                 "depth (camera-frame z)", "mm"))}
    if texture is not None:
        files["texture"] = str(write_image(out / "texture.tif", texture.astype(np.float32), "texture",
                                                   TEXTURE_UNIT))
    if ply or mesh:
        colours = colour if colour is not None else texture
        files["ply"] = str(write_measurement_ply(out / "points.ply", points, colours, faces=mesh, sigma_z=sigma_z))
        files["vtp"] = str(write_measurement_vtp(out / "points.vtp", points, colours, sigma_z=sigma_z))
    return files


def point_summary(points: np.ndarray) -> dict:
    """Share and count of valid points and their depth range (mm; None when no point is valid)."""
    ok = np.isfinite(points[..., 0])
    z = points[..., 2][ok]
    return {"valid_share": float(ok.mean()), "valid_points": int(ok.sum()),
            "depth_min": float(z.min()) if z.size else None, "depth_max": float(z.max()) if z.size else None}


def reference_z_min(path: Path, margin: float) -> float:
    """z_min proposed from a reference point map (``.npy`` or a folder holding ``points.npy``)."""
    path = Path(path)
    f = path / "points.npy" if path.is_dir() else path
    if not f.exists():
        raise FileNotFoundError(f"no reference point map at {f} (expected a .npy point map or a reconstruct folder)")
    return propose_z_min(load_array(f, "reference point map"), margin=margin)
