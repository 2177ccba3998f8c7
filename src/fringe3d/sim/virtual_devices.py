"""The virtual projector and camera: the simulator rendering whatever the projector shows.

:func:`open_virtual_rig` builds a :class:`VirtualProjector` and a :class:`VirtualCamera` on a
preset rig (:mod:`fringe3d.sim.presets`) and a scene; they implement the
:class:`fringe3d.devices.Projector` and :class:`fringe3d.devices.Camera` protocols, so the capture
loop of :mod:`fringe3d.devices.acquire` runs unchanged without hardware.

Semantics (chosen so that ``fringe3d capture`` on the virtual rig writes the very frames
``fringe3d simulate`` writes for the same preset, scene, pattern set and seed):

* A shared clock: every camera exposure happens at ``t = k / frame_rate`` (s) where ``k``
  counts the projector frames since the rig was opened (software trigger: one per trigger;
  hardware trigger: one per projector frame or bit-plane, exposed or missed). Frame ``k`` draws
  its noise from :func:`fringe3d.sim.noise.frame_rng` with index = the camera's frame id (frames
  delivered since the rig was opened), exactly like :func:`fringe3d.sim.render`.
* Shown images: an image equal to a frame of the pattern set the projector was given
  (``patterns=``, 8-bit rendering) is shown as the simulator's model of that frame (the
  continuous pattern of :func:`fringe3d.sim.render.projector_image`, defocus included); any
  other image (grey ramp, flashes, gamma-compensated or packed frames) as its 8-bit values
  / 255 through the same defocus. The projector gamma is ``RenderSettings.gamma``.
* Bit-plane mode (``bitplanes=True``): a shown (H, W, 3) RGB frame is displayed as its 24
  bit-planes in :data:`fringe3d.patterns.bitplanes.PLANE_ORDER`, each a 0/255 binary image, with
  one hardware trigger per plane (like a DLP evaluation module in video pattern mode).
* Faults for tests: ``drop=[k, ...]`` makes the camera miss triggers number ``k`` (counting
  all triggers since opening); ``repeat=[k, ...]`` delivers the frame of trigger ``k`` twice;
  ``interrupt=k`` raises ``KeyboardInterrupt`` (Ctrl-C) at its ``k``-th frame; ``unplug=k`` makes it fail
  with :class:`DeviceError` at its ``k``-th frame.
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from fringe3d.devices.base import (
    DeviceError,
    DeviceSpec,
    Frame,
    check_image_fits,
    check_pixel_format,
    check_trigger_mode,
    check_unknown_options,
    option,
)
from fringe3d.optics.defocus import blur_pattern
from fringe3d.patterns.bitplanes import PLANES_PER_FRAME, unpack_bitplanes
from fringe3d.patterns.manifest import PatternSet
from fringe3d.patterns.render import render_set

from . import presets as _presets
from .board import BoardLook, BoardTarget
from .calibration_session import default_board, sample_board_poses
from .geometry import cast, crop
from .hits import Hit
from .noise import blur_margin, sense
from .projector_sampling import PatternSampler
from .radiometry import irradiance, motion_subtimes
from .rays import camera_rays
from .render import check_visible
from .scene import Scene, as_scene
from .settings import RenderSettings
from .simulate import make_scene
from .validate import check_scene

PROJECTOR_OPTIONS = {"gamma", "defocus", "brightness", "bitplanes", "latency"}
CAMERA_OPTIONS = {"scene", "seed", "noise", "frame_rate", "bit_depth", "ideal", "drop", "unplug", "exposure", "repeat",
                  "interrupt", "poses", "hold", "move"}


class HandHeldBoard:
    """A circle board held still at a sequence of poses, moved between them (calibration capture).

    Pose ``j`` (board -> world ``(R_j, t_j)``, :func:`fringe3d.calibrate.simulated_session.sample_board_poses`)
    is held for ``hold`` s (default 1.6) from ``j * (hold + move)``; during the next ``move`` s (0.2) the board slides
    to pose ``j + 1`` (translation interpolated, rotation switching half-way). After the last
    pose the board leaves the view. Poses are drawn in the near 60% of the preset's depth range. Boards are rendered
    like the simulated sessions' (grey circles of albedo 0.35 on 0.9, a two-pixel anti-aliasing ramp).
    """

    moving = True
    ambient = 0.0
    name = "handheld-board"

    def __init__(self, preset, poses: int = 4, hold: float = 1.6, move: float = 0.2, seed: int = 0):
        self.rig = preset.rig
        self.board = default_board(self.rig, preset.volume)
        z0, z1 = preset.volume["z"]  # the near 60% of the depth range: the board stays large enough to find
        near = {**preset.volume, "z": (z0, z0 + 0.6 * (z1 - z0))}
        self.poses = sample_board_poses(self.rig, near, self.board, int(poses), np.random.default_rng(seed))
        self.hold, self.move = float(hold), float(move)
        self._boards: dict = {}

    def _scene_board(self, R, t):
        b = self.board
        px_mm = self.rig.camera.to_device(t)[2] / self.rig.camera.K[0, 0]
        edge = min(2.0 * px_mm, 0.9 * b.radius)
        return BoardTarget(b, R=R, t=t, look=BoardLook(white=0.9, dark=0.35, edge_width=edge))

    def board_at(self, time: float):
        """The scene board at ``time`` (s), or None once every pose has been shown."""
        period = self.hold + self.move
        j = int(np.floor(time / period))
        if j >= len(self.poses):
            return None
        f = (time - j * period - self.hold) / self.move if self.move > 0 else 0.0
        if f <= 0 or j + 1 >= len(self.poses):
            if j not in self._boards:
                self._boards[j] = self._scene_board(*self.poses[j])
            return self._boards[j] if f <= 0 else None
        (R0, t0), (R1, t1) = self.poses[j], self.poses[j + 1]
        return self._scene_board(R0 if f < 0.5 else R1, (1 - f) * np.asarray(t0) + f * np.asarray(t1))

    def intersect(self, origins, dirs, time: float = 0.0):
        b = self.board_at(time)
        if b is None:
            return Hit.miss(np.asarray(dirs).reshape(-1, 3).shape[0])
        return b.intersect(origins, dirs, time=0.0)

    def hit_distance(self, origins, dirs, time: float = 0.0) -> np.ndarray:
        """Ray parameter of the first hit (inf on a miss or once the board has left)."""
        b = self.board_at(time)
        if b is None:
            return np.full(np.asarray(dirs).reshape(-1, 3).shape[0], np.inf)
        return b.hit_distance(origins, dirs, time=0.0)

    def culling_volume(self, time: float = 0.0):
        """No culling volume: the board moves between poses."""
        return None

    def bounding_sphere(self, time: float = 0.0) -> tuple[np.ndarray, float]:
        b = self.board_at(time)
        return (np.zeros(3), 0.0) if b is None else b.bounding_sphere(0.0)

    def describe(self) -> str:
        return f"hand-held circle board, {len(self.poses)} poses ({self.hold:g} s still, {self.move:g} s moving)"

    def to_dict(self) -> dict:
        return {"type": self.name, "poses": len(self.poses), "hold": self.hold, "move": self.move}


@dataclass(frozen=True)
class _Shown:
    """An arbitrary 8-bit image on the virtual projector (hashable key for the sampler's cache)."""

    key: int
    kind: str = "image"


class _ImageSampler(PatternSampler):
    """:class:`PatternSampler` that also samples arbitrary shown images (values / 255)."""

    def __init__(self, patterns, settings, images: dict):
        super().__init__(patterns, settings)
        self._images = images

    def _image(self, spec, size: float):
        if not isinstance(spec, _Shown):
            return super()._image(spec, size)
        key = (spec, round(float(size), 6))
        if key not in self._cache:
            img = self._images[spec.key].astype(np.float64) / 255.0
            if self.settings.defocus != "none" and size > 0:
                img = blur_pattern(img, self.settings.defocus, size)
            if len(self._cache) > 64:
                self._cache.clear()
            self._cache[key] = img
        return self._cache[key]

    def values(self, spec, geo):
        if isinstance(spec, _Shown) and self.settings.ideal:
            s, self.settings = self.settings, self.settings.replace(ideal=False)
            try:
                return super().values(spec, geo)
            finally:
                self.settings = s
        return super().values(spec, geo)


class VirtualRigState:
    """What the virtual projector and camera share: rig, scene, settings, clock, shown frame."""

    def __init__(self, preset, scene, settings: RenderSettings, patterns=None):
        self.preset = preset
        self.rig = preset.rig
        self.scene = scene
        self.settings = settings
        self.tick = 0                  # projector frames (exposure opportunities) since opening
        self.current = None            # FrameSpec or _Shown
        self.images: dict = {}         # _Shown.key -> uint8 image
        self.lookup: dict = {}         # bytes of a pattern frame's 8-bit rendering -> FrameSpec
        self.patterns = patterns
        if patterns is not None:
            self.register(patterns)
        self._empty = PatternSet(self.rig.projector.width, self.rig.projector.height, frames=())
        self.sampler = _ImageSampler(patterns if patterns is not None else self._empty, settings, self.images)
        self.margin = blur_margin(self.settings)  # rendered beyond the sensor for the camera blur
        self.origins, self.dirs, self.off = camera_rays(self.rig.camera, self.margin)
        self.static = not scene.moving
        self._geo0 = None

    def set_scene(self, scene) -> None:
        """Film ``scene`` from now on (a stage moved the object): the cached static cast is dropped."""
        self.scene = scene
        self.static = not scene.moving
        self._geo0 = None

    def register(self, patterns) -> None:
        """Remember the 8-bit rendering of each frame of ``patterns`` (see the module docstring)."""
        self.patterns = patterns
        for spec, img in zip(patterns.frames, render_set(patterns)):
            self.lookup.setdefault(img.tobytes(), spec)
        if hasattr(self, "sampler"):
            self.sampler.patterns = patterns

    def set_image(self, img: np.ndarray) -> None:
        proj = self.rig.projector
        if img.shape != (proj.height, proj.width):
            full = np.zeros((proj.height, proj.width), np.uint8)
            full[:img.shape[0], :img.shape[1]] = img
            img = full
        spec = self.lookup.get(img.tobytes())
        if spec is None:
            key = hash(img.tobytes())
            if key not in self.images:
                if len(self.images) > 256:
                    self.images.clear()
                    self.sampler._cache.clear()
                self.images[key] = img.copy()
            spec = _Shown(key)
        self.current = spec

    def exposure_image(self, t: float, index: int) -> np.ndarray:
        """The camera frame for the shown pattern at time ``t`` with noise index ``index``."""
        s = self.settings
        if blur_margin(s) != self.margin:  # the settings' camera blur changed: new rays, new cast
            self.margin = blur_margin(s)
            self.origins, self.dirs, self.off = camera_rays(self.rig.camera, self.margin)
            self._geo0 = None
        m = self.margin
        H, W = self.rig.camera.height + 2 * m, self.rig.camera.width + 2 * m
        spec = self.current
        amb = float(getattr(self.scene, "ambient", 0.0) or 0.0)
        if spec is None:
            raise DeviceError("the virtual camera was triggered before the virtual projector showed anything")
        if self.static:
            if self._geo0 is None:
                self._geo0 = cast(self.scene, self.rig, self.origins, self.dirs, self.off, 0.0, s.shadows)
                check_visible(crop(self._geo0, (H, W), m))
            img = irradiance(self._geo0, self.sampler.values(spec, self._geo0), s, amb)
        else:
            sub = motion_subtimes(float(t), s)
            img = np.zeros(H * W)
            for ts in sub:
                g = cast(self.scene, self.rig, self.origins, self.dirs, self.off, ts, s.shadows)
                img += irradiance(g, self.sampler.values(spec, g), s, amb) / len(sub)
        return sense(img.reshape(H, W), s, index, m)


class VirtualProjector:
    """The preset's projector as a device (see the module docstring)."""

    def __init__(self, state: VirtualRigState, bitplanes: bool = False, latency: float = 0.0):
        self._state = state
        proj = state.rig.projector
        self.width, self.height = int(proj.width), int(proj.height)
        self.bitplanes = bool(bitplanes)
        # bit-plane mode: 24 planes per video frame, one plane per camera frame period
        self.refresh_rate = float(state.settings.frame_rate) / (24 if self.bitplanes else 1)
        self.latency = float(latency)
        self.plane_counts: list[int] = []  # patterns per packed frame (the DLP's pattern sequence)
        self._packed_shown = 0
        self.camera = None  # the VirtualCamera, set by open_virtual_rig (hardware trigger wiring)

    def show(self, image: np.ndarray) -> float:
        img = check_image_fits(image, self.width, self.height, "virtual projector")
        if img.ndim == 3:
            if not self.bitplanes:
                raise ValueError("the virtual projector shows grey images; for packed RGB bit-plane frames open it "
                                 "as virtual:PRESET?bitplanes=1")
            counts = self.plane_counts or [PLANES_PER_FRAME]
            planes = unpack_bitplanes(img[None], counts[self._packed_shown % len(counts)])
            self._packed_shown += 1
            for p in planes:
                self._frame(np.where(p, 255, 0).astype(np.uint8))
        else:
            self._frame(img)
        return time.monotonic()

    def _frame(self, img: np.ndarray) -> None:
        st = self._state
        st.set_image(img)
        cam = self.camera
        if cam is not None and cam.armed and cam.trigger_mode == "hardware":
            cam._expose()  # the projector's trigger output fires the camera
        elif cam is None or cam.trigger_mode != "software":
            st.tick += 1

    def configure_bitplanes(self, counts: list[int]) -> None:
        """Patterns (planes) shown per packed video frame, in order (a DLP's pattern sequence)."""
        self.plane_counts = [int(c) for c in counts]
        self._packed_shown = 0

    def describe(self) -> dict:
        s = self._state.settings
        return {"backend": "virtual", "preset": self._state.preset.name, "width": self.width, "height": self.height,
                "refresh_rate": self.refresh_rate, "gamma": s.gamma, "defocus": s.defocus,
                "defocus_size": s.defocus_size, "bitplanes": self.bitplanes, "latency": self.latency}

    def close(self) -> None:
        pass


class VirtualCamera:
    """The preset's camera as a device (see the module docstring)."""

    def __init__(self, state: VirtualRigState, drop=(), unplug: int | None = None, repeat=(),
                 interrupt: int | None = None):
        self._state = state
        self.interrupt = interrupt
        self.drop = set(int(k) for k in drop)
        self.repeat = set(int(k) for k in repeat)
        self.unplug = unplug
        self._trigger_mode = "off"
        self.armed = False
        self._queue: list[Frame] = []
        self._frames = 0               # frames delivered (the frame id)
        self._triggers = 0             # triggers received (software or hardware)
        cam = state.rig.camera
        self._roi = (0, 0, int(cam.width), int(cam.height))

    # settings mapped onto the renderer
    @property
    def exposure(self) -> float:
        s = self._state.settings
        return s.exposure if s.exposure is not None else 1.0 / s.frame_rate

    @exposure.setter
    def exposure(self, seconds: float) -> None:
        self._state.settings = self._state.settings.replace(exposure=float(seconds))
        self._state.sampler.settings = self._state.settings

    @property
    def gain(self) -> float:
        return 20.0 * float(np.log10(self._state.settings.gain))

    @gain.setter
    def gain(self, db: float) -> None:
        self._state.settings = self._state.settings.replace(gain=float(10 ** (float(db) / 20.0)))
        self._state.sampler.settings = self._state.settings

    @property
    def pixel_format(self) -> str:
        bd = self._state.settings.bit_depth
        return f"Mono{bd}" if bd in (8, 10, 12) else f"Mono{bd}"

    @pixel_format.setter
    def pixel_format(self, fmt: str) -> None:
        self._state.settings = self._state.settings.replace(bit_depth=check_pixel_format(fmt))
        self._state.sampler.settings = self._state.settings

    @property
    def roi(self):
        return self._roi

    @roi.setter
    def roi(self, roi) -> None:
        cam = self._state.rig.camera
        x, y, w, h = (int(v) for v in roi)
        if x < 0 or y < 0 or w < 1 or h < 1 or x + w > cam.width or y + h > cam.height:
            raise ValueError(f"ROI {x},{y},{w},{h} does not fit the {cam.width}x{cam.height} virtual camera")
        self._roi = (x, y, w, h)

    @property
    def trigger_mode(self) -> str:
        return self._trigger_mode

    @trigger_mode.setter
    def trigger_mode(self, mode: str) -> None:
        self._trigger_mode = check_trigger_mode(mode)

    @property
    def frame_rate(self) -> float:
        return float(self._state.settings.frame_rate)

    def start(self) -> None:
        self.armed = True

    def stop(self) -> None:
        self.armed = False

    def trigger(self) -> None:
        if self._trigger_mode != "software":
            raise DeviceError("the virtual camera is not in software trigger mode")
        self._expose()

    def _expose(self) -> None:
        st = self._state
        k = self._triggers
        self._triggers += 1
        t = st.tick / st.settings.frame_rate
        st.tick += 1
        if k in self.drop:
            return  # the camera missed this trigger: no exposure, no frame id consumed
        if self.interrupt is not None and self._frames >= self.interrupt:
            raise KeyboardInterrupt  # as if the user pressed Ctrl-C here
        if self.unplug is not None and self._frames >= self.unplug:
            raise DeviceError(f"virtual camera unplugged at its frame {self._frames}")
        img = st.exposure_image(t, self._frames)
        x, y, w, h = self._roi
        fr = Frame(image=img[y:y + h, x:x + w], frame_id=self._frames, timestamp=t, host_time=time.monotonic())
        self._queue.append(fr)
        if k in self.repeat:
            self._queue.append(fr)  # delivered twice (e.g. a transport resend)
        self._frames += 1

    def check_sequence(self, n_frames: int) -> None:
        """Reject a scene that leaves the view during the next ``n_frames`` frames (as simulate does)."""
        st = self._state
        if isinstance(st.scene, HandHeldBoard) or st.static:
            return
        t0 = st.tick / st.settings.frame_rate
        check_scene(st.scene, st.rig, times=sorted({t0, t0 + (n_frames - 1) / st.settings.frame_rate}))

    def grab(self, timeout: float) -> Frame:
        if not self.armed:
            raise DeviceError("the virtual camera is not acquiring (call start())")
        if self._trigger_mode == "off" and not self._queue:
            self._expose()  # free run: expose now
        if not self._queue:
            raise TimeoutError(f"virtual camera delivered no frame within {timeout:g} s")
        return self._queue.pop(0)

    def describe(self) -> dict:
        st = self._state
        return {"backend": "virtual", "model": f"fringe3d virtual camera ({st.preset.name} preset)",
                "serial": "virtual", "exposure": self.exposure, "gain": self.gain, "pixel_format": self.pixel_format,
                "roi": list(self._roi), "trigger_mode": self._trigger_mode,
                "scene": getattr(st.scene, "name", ""), "seed": st.settings.seed,
                "render_settings": st.settings.to_dict()}

    def close(self) -> None:
        self.armed = False


def _ints(text: str) -> list[int]:
    try:
        return [int(x) for x in str(text).replace(";", ",").split(",") if x.strip()]
    except ValueError:
        raise ValueError(f"expected comma-separated integers, got {text!r}") from None


def open_virtual_rig(projector_spec, camera_spec=None, patterns=None, scene=None):
    """(VirtualProjector, VirtualCamera | None) from device specs.

    ``projector_spec``: ``virtual[:PRESET][?gamma=G&defocus=SIGMA&brightness=B&bitplanes=1&latency=S]``;
    ``camera_spec``: ``virtual[:PRESET][?scene=NAME&seed=N&noise=SIGMA&frame_rate=HZ&bit_depth=B&ideal=1
    &drop=K,..&repeat=K,..&unplug=K]`` (the preset must be the projector's). ``scene`` (a Scene object) overrides
    the camera's ``scene`` option. Render settings start from the preset's, with ``seed`` 0 as
    ``fringe3d simulate``'s default.
    """
    ps = projector_spec if isinstance(projector_spec, DeviceSpec) else DeviceSpec.parse(projector_spec)
    check_unknown_options(ps, PROJECTOR_OPTIONS)
    preset_name = ps.ident or "tiny"
    cs = None
    if camera_spec is not None:
        cs = camera_spec if isinstance(camera_spec, DeviceSpec) else DeviceSpec.parse(camera_spec)
        if cs.backend != "virtual":
            cs = None
        else:
            check_unknown_options(cs, CAMERA_OPTIONS)
            if cs.ident and cs.ident != preset_name:
                raise ValueError(f"the virtual camera ({cs.ident}) and projector ({preset_name}) must use the same "
                                 f"preset rig")
    p = _presets.get(preset_name)
    s = p.settings.replace(seed=0)
    po, co = ps.options, (cs.options if cs else {})
    changes = {}
    if "gamma" in po:
        changes["gamma"] = option(po, "gamma", 1.0, float)
    if "defocus" in po:
        changes["defocus_size"] = option(po, "defocus", 0.0, float)
        if s.defocus == "none":
            changes["defocus"] = "gaussian"
    if "brightness" in po:
        changes["brightness"] = option(po, "brightness", 0.8, float)
    for key, name, cast_ in (("seed", "seed", int), ("noise", "read_noise", float), ("frame_rate", "frame_rate", float),
                             ("bit_depth", "bit_depth", int), ("ideal", "ideal", bool),
                             ("exposure", "exposure", float)):
        if key in co:
            changes[name] = option(co, key, None, cast_)
    s = s.replace(**changes)
    if scene is None and co.get("scene") == "handheld-board":
        scene = HandHeldBoard(p, poses=option(co, "poses", 4, int), hold=option(co, "hold", 1.6, float),
                              move=option(co, "move", 0.2, float), seed=s.seed)
    elif any(k in co for k in ("poses", "hold", "move")):
        raise ValueError("the virtual camera's poses/hold/move options belong to scene=handheld-board")
    sc = scene if scene is not None else make_scene(co.get("scene") or None, p)
    if not isinstance(sc, HandHeldBoard):
        check_scene(sc, p.rig, times=[0.0])  # as fringe3d simulate does (it also checks the last frame's time)
    state = VirtualRigState(p, as_scene(sc) if not isinstance(sc, HandHeldBoard) else
                            Scene([sc], ambient=sc.ambient, name=sc.name), s, patterns)
    proj = VirtualProjector(state, bitplanes=option(po, "bitplanes", False, bool),
                            latency=option(po, "latency", 0.0, float))
    cam = None
    if cs is not None:
        unplug = option(co, "unplug", None, int)
        cam = VirtualCamera(state, drop=_ints(co.get("drop", "")), unplug=unplug, repeat=_ints(co.get("repeat", "")),
                            interrupt=option(co, "interrupt", None, int))
        proj.camera = cam
    return proj, cam
