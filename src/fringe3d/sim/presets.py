"""Rig presets mirroring the dissertation's systems.

``get(name) -> Preset`` for

* ``macro``: 1280x1024 camera with an 8 mm lens (4.8 um pixels), 800x600 DLP projector,
  camera-projector angle ~13 deg, working volume ~250 x 150 x 200 mm (x, y, z) at 300-500 mm
  (ch. 2 out-of-focus calibration).
* ``well-designed``: the same devices, projector displaced (almost) purely horizontally so
  horizontal fringes are nearly blind to depth; the baseline is rotated 4 deg out of the
  horizontal so the optimal fringe angle is non-trivial but recoverable (ch. 2.2.5,
  300 x 250 x 500 mm volume).
* ``microscope``: telecentric camera (1280x1024, 0.48x, 12.8 x 10.2 mm field) and a pinhole
  projector with a long focal length, world = projector frame, ~5 mm depth (ch. 3).
* ``high-speed``: binary defocusing at 2,000 Hz (valid range 1,500-5,000 Hz), Gaussian
  projector defocus, 640x512 camera (ch. 5).
* ``tiny``: a 160x128 camera and 256x200 projector for fast tests.

All projectors are 800x600 (SVGA DLP class, square pixels): the diagonal (1000 px) is shorter
than the 1008 px equivalent period of the dissertation's 18/21/144 three-frequency set, so that
set unwraps at every fringe angle (needed by optimal-angle calibration). The LightCrafter 4500's
912x1140 diamond array would not.

Each preset carries a rig, render settings, the working volume (mm, world frame) and the name
of a default scene.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from fringe3d.optics import PinholeDevice, Rig, TelecentricCamera, intrinsics

from .settings import RenderSettings


@dataclass(frozen=True, eq=False)
class Preset:
    """A virtual rig ready to render.

    Attributes
    ----------
    name : str
    rig : Rig
    settings : RenderSettings
    volume : dict
        ``{"x": (min, max), "y": (min, max), "z": (min, max)}`` in mm, world frame.
    scene : str
        Name of the default scene (see :func:`fringe3d.sim.simulate.make_scene`).
    patterns : str
        Name of the default pattern set.
    description : str
    """

    name: str
    rig: Rig
    settings: RenderSettings
    volume: dict
    scene: str = "sphere"
    patterns: str = "three-frequency"
    description: str = ""
    extra: dict = field(default_factory=dict)

    @property
    def z_range(self) -> tuple[float, float]:
        return tuple(self.volume["z"])

    @property
    def center(self) -> np.ndarray:
        """Centre of the working volume (mm, world frame)."""
        return np.array([0.5 * (self.volume[k][0] + self.volume[k][1]) for k in "xyz"])

    @property
    def size(self) -> np.ndarray:
        """Extent of the working volume (mm) along x, y, z."""
        return np.array([self.volume[k][1] - self.volume[k][0] for k in "xyz"])


def look_at(center, target, up=(0.0, -1.0, 0.0)) -> tuple[np.ndarray, np.ndarray]:
    """World-to-device ``(R, t)`` of a device at ``center`` looking at ``target``.

    Device axes: z toward the target, x to the right, y down (image rows), with ``up`` the
    world direction that should map to image-up (default: world -y, i.e. camera convention).
    """
    c = np.asarray(center, float)
    z = np.asarray(target, float) - c
    z /= np.linalg.norm(z)
    x = np.cross(z, -np.asarray(up, float))
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    R = np.stack([x, y, z])
    return R, -R @ c


def _projector(f, width, height, center, target, cy_offset=0.0) -> PinholeDevice:
    R, t = look_at(center, target)
    K = intrinsics(f, f, (width - 1) / 2, (height - 1) / 2 + cy_offset)
    return PinholeDevice(K=K, width=width, height=height, R=R, t=t)


def _baseline_centre(z0: float, direction, angle_deg: float = 13.0) -> np.ndarray:
    """Projector centre (mm) for a camera at the origin looking at ``(0, 0, z0)``: a baseline of
    ``z0 tan(angle)`` scaled by the (x, y) ``direction`` in the camera's x-y plane."""
    b = z0 * np.tan(np.deg2rad(angle_deg))
    return np.array([b * direction[0], b * direction[1], 0.0])


def _camera(f, width, height, dist=(0, 0, 0, 0, 0)) -> PinholeDevice:
    return PinholeDevice(K=intrinsics(f, f, (width - 1) / 2, (height - 1) / 2), width=width,
                         height=height, dist=dist)


def _macro() -> Preset:
    z0 = 450.0
    # baseline mostly horizontal with a small vertical part: both fringe directions see depth
    centre = _baseline_centre(z0, (np.cos(np.deg2rad(20)), -np.sin(np.deg2rad(20))))
    cam = _camera(8.0 / 0.0048, 1280, 1024, dist=(-0.08, 0.1, 0.0, 0.0, 0.0))
    proj = _projector(965.0, 800, 600, centre, (0, 0, z0))
    return Preset("macro", Rig(cam, proj),
                  RenderSettings(defocus="gaussian", defocus_size=1.0, ambient=0.05, brightness=0.8,
                                 frame_rate=120.0, read_noise=0.004, shot_noise=True, bit_depth=8),
                  {"x": (-125.0, 125.0), "y": (-75.0, 75.0), "z": (350.0, 550.0)},
                  scene="sphere", patterns="three-frequency",
                  description="macro rig: 1280x1024 camera, 8 mm lens, 800x600 DLP, ~13 deg, 250x150x200 mm")


def _well_designed() -> Preset:
    z0 = 750.0
    tilt = np.deg2rad(4.0)  # baseline rotated 4 deg out of the horizontal
    centre = _baseline_centre(z0, (np.cos(tilt), -np.sin(tilt)))
    cam = _camera(8.0 / 0.0048, 1280, 1024)
    proj = _projector(1100.0, 800, 600, centre, (0, 0, z0))
    return Preset("well-designed", Rig(cam, proj),
                  RenderSettings(defocus="gaussian", defocus_size=1.0, ambient=0.05, brightness=0.8,
                                 frame_rate=120.0, read_noise=0.004, shot_noise=True, bit_depth=8),
                  {"x": (-150.0, 150.0), "y": (-125.0, 125.0), "z": (500.0, 1000.0)},
                  scene="sphere", patterns="three-frequency",
                  description="well-designed rig: horizontal baseline (4 deg tilt), "
                              "horizontal fringes nearly depth-blind",
                  extra={"baseline_tilt_deg": 4.0})


def _microscope() -> Preset:
    # world = projector frame; the projector looks along +z at a scene ~100 mm away
    z0 = 100.0
    proj = PinholeDevice(K=intrinsics(6700.0, 6700.0, 399.5, 299.5), width=800, height=600)
    tilt = np.deg2rad(-25.0)  # camera axis tilted about y, looking at (0, 0, z0)
    Ry = np.array([[np.cos(tilt), 0, np.sin(tilt)], [0, 1, 0], [-np.sin(tilt), 0, np.cos(tilt)]])
    R = Ry.T  # world-to-camera
    pixel = 0.0048
    mag = 0.48
    W, H = 1280, 1024
    s = mag / pixel
    # principal offset so that the volume centre lands on the image centre
    uv0 = s * (R[:2] @ np.array([0, 0, z0]))
    cam = TelecentricCamera.from_pose(mag, R, np.zeros(3), (W - 1) / 2 - uv0[0], (H - 1) / 2 - uv0[1],
                                      W, H, pixel_size=pixel)
    # sensor noise: 4,000 e- full well + 0.64 % read noise, chosen so that the dissertation's
    # own projector mapping (bilinear phase at the circle centres, periods 18/36) gives its
    # projector reprojection RMS, 1.2 um = 0.16 px of a 7.6 um DMD (ch. 3.4, Fig. 3.4)
    return Preset("microscope", Rig(cam, proj),
                  RenderSettings(defocus="gaussian", defocus_size=1.5, ambient=0.05, brightness=0.8,
                                 frame_rate=100.0, read_noise=0.0064, shot_noise=True, full_well=4000.0, bit_depth=8),
                  {"x": (-5.0, 5.0), "y": (-4.0, 4.0), "z": (z0 - 2.5, z0 + 2.5)},
                  scene="plane", patterns="three-frequency",
                  description="microscope: telecentric camera (0.48x), long-focal-length pinhole projector, 10x8x5 mm")


def _high_speed() -> Preset:
    z0 = 400.0
    centre = _baseline_centre(z0, (1.0, -0.15))
    cam = _camera(1000.0, 640, 512)
    proj = _projector(1150.0, 800, 600, centre, (0, 0, z0))
    return Preset("high-speed", Rig(cam, proj),
                  RenderSettings(defocus="gaussian", defocus_size=3.5, ambient=0.05, brightness=0.8,
                                 frame_rate=2000.0, read_noise=0.006, shot_noise=True, bit_depth=8),
                  {"x": (-90.0, 90.0), "y": (-65.0, 65.0), "z": (300.0, 500.0)},
                  scene="falling-balls", patterns="two-frequency-binary",
                  description="high-speed rig: binary defocusing at 2,000 Hz (1,500-5,000 Hz), 640x512 camera",
                  extra={"frame_rate_range": (1500.0, 5000.0)})


def _tiny() -> Preset:
    z0 = 400.0
    centre = _baseline_centre(z0, (1.0, -0.2))
    cam = _camera(200.0, 160, 128)
    proj = _projector(290.0, 256, 200, centre, (0, 0, z0))
    return Preset("tiny", Rig(cam, proj),
                  RenderSettings(defocus="none", ambient=0.05, brightness=0.8, frame_rate=100.0,
                                 bit_depth=8),
                  {"x": (-100.0, 100.0), "y": (-80.0, 80.0), "z": (300.0, 500.0)},
                  scene="sphere", patterns="three-frequency",
                  description="tiny rig for fast tests: 160x128 camera, 256x200 projector")


_BUILDERS = {"macro": _macro, "well-designed": _well_designed, "microscope": _microscope,
             "high-speed": _high_speed, "tiny": _tiny}

NAMES = tuple(_BUILDERS)


def get(name: str) -> Preset:
    """The preset called ``name`` (one of :data:`NAMES`); raises ``ValueError`` otherwise."""
    if isinstance(name, Preset):
        return name
    try:
        return _BUILDERS[name]()
    except KeyError:
        raise ValueError(f"unknown preset {name!r}; valid presets: {', '.join(NAMES)}") from None
