"""Simulated calibration sessions: a board at random poses, rendered by the simulator.

:func:`simulate_session` picks board poses inside a preset's working volume (board fully
visible to the camera and lit by the projector, facing both; optionally some poses only
partly in the camera's view), renders the calibration pattern set for each pose with
:func:`fringe3d.sim.render`, and returns the poses in memory (optionally also writing a
session folder of capture folders plus ``session.json``) for
:func:`fringe3d.calibrate.observe_session` / :func:`fringe3d.calibrate.calibrate_session`.
The board is a circle grid (default), a chessboard or a ChArUco board
(:mod:`fringe3d.sim.square_board`); the patterns are the phase calibration set or Gray-code
columns and rows with inverses (:func:`gray_code_patterns`).
:func:`render_and_decode` measures a test scene with the same simulator.
"""
from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

import cv2
import numpy as np

from fringe3d.calibrate.boards import CircleBoard
from fringe3d.calibrate.square_boards import CharucoBoard, ChessBoard
from fringe3d.calibrate.evaluation import directions_of
from fringe3d.calibrate.phase_mapping import FringeDirection
from fringe3d.calibrate.session import SESSION_NAME, PoseCapture
from fringe3d.decode import decode
from fringe3d.io.capture import write_capture
from fringe3d.optics import Rig, TelecentricCamera
from fringe3d.patterns import sets
from fringe3d.patterns.layouts import opencv_graycode
from fringe3d.patterns.manifest import FrameSpec, PatternSet
from fringe3d.utils.console import progress_bar
from fringe3d.utils.jsonfile import write_json

from . import presets
from .projector_sampling import images_held
from .render import render
from .scene import Scene
from .square_board import board_target


@dataclass
class SimulatedSession:
    poses: list[PoseCapture]
    board: CircleBoard | ChessBoard | CharucoBoard
    rig: Rig                       # the true rig
    board_poses: list[tuple[np.ndarray, np.ndarray]]  # true board -> world (R, t)
    model: str
    folder: Path | None = None
    settings: object = None        # the RenderSettings used


def scaled_camera(rig: Rig, factor: float) -> Rig:
    """The rig with a camera of ``factor`` times the resolution (same field of view); used
    by quick variants to render small images."""
    if factor == 1:
        return rig
    cam = rig.camera
    w, h = max(8, int(round(cam.width * factor))), max(8, int(round(cam.height * factor)))
    sx, sy = w / cam.width, h / cam.height
    if isinstance(cam, TelecentricCamera):
        M = cam.M.copy()
        M[0] *= sx
        M[1] *= sy
        M[0, 3] += 0.5 * sx - 0.5
        M[1, 3] += 0.5 * sy - 0.5
        return Rig(TelecentricCamera(M=M, width=w, height=h), rig.projector)
    K = cam.K.copy()
    K[0] *= sx
    K[1] *= sy
    K[0, 2] += 0.5 * sx - 0.5
    K[1, 2] += 0.5 * sy - 0.5
    return Rig(replace(cam, K=K, width=w, height=h), rig.projector)


def default_board(rig: Rig, volume: dict, fraction: float = 0.5, cols: int = 9, rows: int = 9,
                  kind: str = "circles"):
    """A board whose grid spans ``fraction`` of the smaller field of view (camera or
    projector) at the near end of the working volume; spacing rounded to 0.1 mm.

    ``kind`` ``"circles"`` (a ``cols`` x ``rows`` :class:`CircleBoard`), ``"chessboard"`` or
    ``"charuco"`` (``cols`` x ``rows`` squares spanning ``fraction``; ChArUco
    markers 0.7 squares, ``DICT_4X4_50``)."""
    z = float(volume["z"][0]) if not rig.telecentric else float(np.mean(volume["z"]))
    fovs = []
    for dev in (rig.camera, rig.projector):
        if isinstance(dev, TelecentricCamera):
            s = float(np.mean(np.linalg.norm(dev.M[:, :3], axis=1)))
            fovs.append(min(dev.width, dev.height) / s)
        else:
            depth = z if dev is rig.camera or rig.telecentric else z
            fovs.append(min(dev.width / dev.K[0, 0], dev.height / dev.K[1, 1]) * depth)
    fov = min(fovs)
    if kind == "circles":
        spacing = max(round(fraction * fov / (max(cols, rows) - 1), 1), 0.1)
        return CircleBoard(cols=cols, rows=rows, spacing=spacing, radius=0.25 * spacing)
    spacing = float(max(round(fraction * fov / max(cols, rows), 1), 0.1))
    if kind == "chessboard":
        return ChessBoard(cols=cols, rows=rows, spacing=spacing)
    if kind == "charuco":
        return CharucoBoard(cols=cols, rows=rows, spacing=spacing, marker=round(0.7 * spacing, 2))
    raise ValueError(f"unknown board kind {kind!r}; expected circles, chessboard or charuco")


def _device_view(dev, X):
    """Pixels of world points and whether the points are in front (pinhole)."""
    uv = dev.project(X)
    if isinstance(dev, TelecentricCamera):
        return uv, np.ones(len(X), bool)
    return uv, dev.to_device(X)[:, 2] > 0


def _inside(dev, uv, front, margin):
    return bool(np.all(front) and np.all(uv[:, 0] > margin * dev.width)
                and np.all(uv[:, 0] < (1 - margin) * dev.width - 1)
                and np.all(uv[:, 1] > margin * dev.height) and np.all(uv[:, 1] < (1 - margin) * dev.height - 1))


def board_outline(board) -> np.ndarray:
    """``(4, 3)`` corners (board mm) of the printed board: the points (circle grid) or the
    squares (chessboard, ChArUco) plus a one-spacing border."""
    s = board.spacing
    if isinstance(board, CircleBoard):
        obj = board.object_points()
        x0, x1, y0, y1 = obj[:, 0].min(), obj[:, 0].max(), obj[:, 1].min(), obj[:, 1].max()
    else:
        x0, x1, y0, y1 = board.squares_extent()
    return np.array([[x0 - s, y0 - s, 0], [x1 + s, y0 - s, 0], [x1 + s, y1 + s, 0], [x0 - s, y1 + s, 0]])


def _partly_seen(rig: Rig, obj_world: np.ndarray, margin: float, seen: tuple[float, float]) -> bool:
    """Whether the share of board points inside the camera image lies in ``seen`` (min, max)
    and at least 80 % of them are inside the projector image."""
    uv, front = _device_view(rig.camera, obj_world)
    cam = rig.camera
    inside = (front & (uv[:, 0] > margin * cam.width) & (uv[:, 0] < (1 - margin) * cam.width - 1)
              & (uv[:, 1] > margin * cam.height) & (uv[:, 1] < (1 - margin) * cam.height - 1))
    if not seen[0] <= inside.mean() <= seen[1]:
        return False
    puv, pfront = _device_view(rig.projector, obj_world[inside])
    lit = pfront & (puv[:, 0] > 0) & (puv[:, 0] < rig.projector.width - 1) & (puv[:, 1] > 0) & \
        (puv[:, 1] < rig.projector.height - 1)
    return bool(lit.mean() >= 0.8)


@dataclass(frozen=True)
class PoseRanges:
    """The ranges :func:`sample_board_poses` draws board poses from.

    Attributes
    ----------
    max_tilt_deg : float
        Largest tilt of the board normal (degrees); a few degrees gives a degenerate session of
        near-parallel poses (the calibration's orientation gate, :mod:`fringe3d.calibrate.gates`).
    spin_deg : float
        In-plane spin drawn from ``[-spin_deg, spin_deg]`` (degrees).
    margin : float
        Border of each device's image the whole board stays out of (fraction of its width and
        height).
    max_tries : int
        Poses drawn at most before giving up.
    partial : int
        The last ``partial`` poses show only part of the board to the camera (pinhole cameras).
    partial_seen : (float, float)
        Share (min, max) of the board points a partial view shows to the camera.
    """

    max_tilt_deg: float = 35.0
    spin_deg: float = 15.0
    margin: float = 0.04
    max_tries: int = 20000
    partial: int = 0
    partial_seen: tuple[float, float] = (0.6, 0.85)


def sample_board_poses(rig: Rig, volume: dict, board, n: int, rng: np.random.Generator,
                       ranges: PoseRanges = PoseRanges()) -> list[tuple[np.ndarray, np.ndarray]]:
    """``n`` board -> world poses with the whole board (incl. a one-spacing border,
    :func:`board_outline`) inside both devices' images, facing both, centres spread over the
    working volume (tilt, spin and image margin as ``ranges``, :class:`PoseRanges`). The last
    ``ranges.partial`` poses instead show only a share ``ranges.partial_seen`` (min, max) of the
    board points to the camera (a ChArUco board's partial views), 80 % of them lit by the projector."""
    max_tilt_deg, spin_deg, margin = ranges.max_tilt_deg, ranges.spin_deg, ranges.margin
    max_tries, partial, partial_seen = ranges.max_tries, ranges.partial, ranges.partial_seen
    if not 0 <= partial <= n:
        raise ValueError(f"partial views must be between 0 and the {n} poses, got {partial}")
    if partial and rig.telecentric:
        raise ValueError("partial board views are simulated for pinhole cameras only")
    obj = board.object_points()
    ext = board_outline(board)
    mid = obj.mean(0)
    vx, vy, vz = (np.asarray(volume[k], float) for k in "xyz")
    poses = []
    for _ in range(max_tries):
        if len(poses) == n:
            break
        k = len(poses)
        part = k >= n - partial
        # stratify depth over the volume so the poses span it
        z = vz[0] + (k + rng.uniform(0.1, 0.9)) / n * (vz[1] - vz[0])
        c = np.array([rng.uniform(*(0.5 * vx)), rng.uniform(*(0.5 * vy)), z])
        if part:  # centred near the camera image's border: partly out of view
            cam = rig.camera
            side = rng.integers(4)
            along, a = rng.uniform(0.2, 0.8), rng.uniform(0.02, 0.15)  # along the side, inset
            edge = [(along * cam.width, a * cam.height), (along * cam.width, (1 - a) * cam.height),
                    (a * cam.width, along * cam.height), ((1 - a) * cam.width, along * cam.height)][side]
            o, d = cam.rays(np.asarray(edge, float))
            c = o + d * (z - o[2]) / d[2]
        tilt = np.deg2rad(max_tilt_deg) * np.sqrt(rng.uniform(0.15, 1.0))
        az = rng.uniform(0, 2 * np.pi)
        rv = np.array([np.cos(az) * tilt, np.sin(az) * tilt, np.deg2rad(rng.uniform(-spin_deg, spin_deg))])
        R, _ = cv2.Rodrigues(rv)
        t = c - R @ mid
        X = ext @ R.T + t
        ok = True
        normal = R[:, 2]
        if part and not _partly_seen(rig, obj @ R.T + t, 0.01, partial_seen):
            continue
        for dev in (rig.camera, rig.projector):
            uv, front = _device_view(dev, X)
            if not part and not _inside(dev, uv, front, margin):
                ok = False
                break
            if isinstance(dev, TelecentricCamera):
                cosang = abs(normal @ dev.view_direction)
            else:
                v = dev.center - c
                cosang = abs(normal @ v) / np.linalg.norm(v)
            if cosang < np.cos(np.deg2rad(60)):
                ok = False
                break
        if ok:
            poses.append((R, t))
    if len(poses) < n:
        raise ValueError(f"could place only {len(poses)} of {n} board poses inside the working volume; "
                         "use a smaller board or fewer poses")
    return poses


def render_board_poses(rig: Rig, settings, board, board_poses, patterns, seed: int = 0,
                       dark_albedo: float = 0.35, edge_pixels: float = 2.0, progress: bool = True,
                       names: list[str] | None = None) -> list[PoseCapture]:
    """Render the board (any kind, :func:`fringe3d.sim.square_board.board_target`) at each
    ``(R, t)`` (board -> world) with ``patterns``; one :class:`PoseCapture` per pose (noise
    seeded by ``seed`` and the pose index). ``dark_albedo``: the circles' or black squares'
    albedo (the board is 0.9); ``edge_pixels``: width of the anti-aliasing albedo ramp, in
    camera pixels at the board."""
    out = []
    with progress_bar("rendering board poses", len(board_poses), enabled=progress) as advance, \
            images_held(len(patterns.frames)):  # the same images at every pose: rendered once
        for k, (R, t) in enumerate(board_poses):
            if rig.telecentric:
                px_mm = 1.0 / float(np.mean(np.linalg.norm(rig.camera.M[:, :3], axis=1)))
            else:
                px_mm = rig.camera.to_device(t)[2] / rig.camera.K[0, 0]
            sb = board_target(board, R, t, white=0.9, dark=dark_albedo, edge_width=edge_pixels * px_mm)
            frames, _ = render(Scene([sb]), rig, patterns, settings.replace(seed=seed * 1000 + k), progress=False)
            out.append(PoseCapture(name=names[k] if names else f"pose_{k:02d}", frames=frames, patterns=patterns))
            advance()
    return out


#: Pattern kinds :func:`simulate_session` renders by name.
PATTERN_KINDS = ("phase", "gray-code")


def gray_code_patterns(width: int, height: int, stripe: float = 1.0) -> PatternSet:
    """Gray-code calibration set: column codes then row codes, each bit followed by its
    inverse, then a white and a black frame; plans ``gray_code_only``. ``stripe`` is the
    narrowest stripe (projector px); with 1 px it is OpenCV's ``GrayCodePattern`` sequence
    (:func:`fringe3d.patterns.layouts.opencv_graycode`)."""
    if stripe == 1:
        return opencv_graycode(width, height)
    if not stripe >= 1:
        raise ValueError(f"Gray-code stripe width must be >= 1 projector px, got {stripe}")
    cols = sets.gray_code(float(stripe), "v", width=width, height=height)
    rows = sets.gray_code(float(stripe), "h", width=width, height=height)
    ps = cols.concat(rows, name=f"gray-code-calibration-T{stripe:g}-{width}x{height}")
    plans = tuple(replace(pl, method="gray_code_only") for pl in ps.plans)
    frames = ps.frames + (FrameSpec(kind="white", role="texture"), FrameSpec(kind="black", role="reference"))
    return replace(ps, frames=frames, plans=plans)


def calibration_patterns(kind, width: int, height: int, stripe: float | None = None, defocus: float = 0.0):
    """The pattern set a session projects: a ``PatternSet`` as it is, ``"phase"``
    (``patterns.sets.calibration``) or ``"gray-code"`` (:func:`gray_code_patterns`; stripe
    default the smallest power of two >= 2 x the defocus size, so the finest bit keeps contrast)."""
    if isinstance(kind, PatternSet):
        return kind
    if kind in (None, "phase"):
        return sets.calibration(width=width, height=height)
    if kind == "gray-code":
        if stripe is None:
            stripe = float(2 ** int(np.ceil(np.log2(max(1.0, 2.0 * float(defocus))))))
        return gray_code_patterns(width, height, stripe)
    raise ValueError(f"unknown calibration patterns {kind!r}; expected one of {', '.join(PATTERN_KINDS)} or a "
                     "PatternSet")


@dataclass(frozen=True)
class SessionOptics:
    """The simulated rig of a session: the preset's, changed so.

    Attributes
    ----------
    camera_scale : float
        Render with a camera of this fraction of the preset's resolution (same field of view).
    defocus : float | None
        Projector defocus size (projector px, the preset's defocus model; Gaussian when the preset
        has none); ``None`` = the preset's.
    projector_dist : sequence of float | None
        Brown coefficients ``(k1, k2, p1, p2, k3)`` of the true projector lens (the presets'
        projectors have none); the renderer maps through them (Eq. 2.14-2.16).
    """

    camera_scale: float = 1.0
    defocus: float | None = None
    projector_dist: tuple[float, ...] | None = None


@dataclass(frozen=True)
class SessionImaging:
    """What a session's images show besides the rig: noise, the printed board, the Gray-code stripe.

    Attributes
    ----------
    noise : bool
        False renders noise-free frames (no shot / read noise; 16-bit quantisation).
    settings_overrides : dict | None
        Other ``RenderSettings`` fields.
    dark_albedo : float
        Albedo of the board's circles or black squares (the board is 0.9); a grey circle keeps
        enough fringe modulation at the circle centres for phase mapping.
    edge_pixels : float | None
        Width of the circles' or squares' anti-aliasing albedo ramp, in camera pixels at the
        board (the renderer casts one ray per pixel); ``None``: 4 for chessboards (a lens blurs a
        printed edge over a few pixels; a narrower ramp aliases: the rendered corners' error is
        0.036 / 0.026 / 0.015 px for ramps of 1 / 2 / 4 px on the macro rig at half resolution),
        2 for circle grids and ChArUco boards (a wider blur erases the markers' bits).
    stripe : float | None
        Gray-code patterns: the narrowest stripe (projector px); ``None`` = the smallest power of
        two >= 2 x the defocus size (:func:`calibration_patterns`).
    """

    noise: bool = True
    settings_overrides: dict | None = None
    dark_albedo: float = 0.35
    edge_pixels: float | None = None
    stripe: float | None = None


def simulate_session(preset="macro", n_poses: int = 12, seed: int = 0, patterns=None, board=None, folder=None,
                     progress: bool = True, optics: SessionOptics = SessionOptics(),
                     imaging: SessionImaging = SessionImaging(),
                     pose_ranges: PoseRanges = PoseRanges()) -> SimulatedSession:
    """Render a calibration session with the simulator.

    Parameters
    ----------
    preset : preset name or ``fringe3d.sim.presets.Preset``
    n_poses : number of board poses (>= 3; the dissertation's figures use >= 10)
    seed : seeds the board poses and the sensor noise
    patterns : PatternSet, or ``"phase"`` (default: ``patterns.sets.calibration`` at the
        projector's size) or ``"gray-code"`` (:func:`calibration_patterns`, stripe ``imaging.stripe``)
    board : CircleBoard, ChessBoard or CharucoBoard, or a kind (``"circles"``,
        ``"chessboard"``, ``"charuco"``) or ``(kind, cols, rows)`` for :func:`default_board`;
        default circles
    folder : if given, write ``folder/pose_XX`` capture folders and ``folder/session.json``
    progress : show a progress bar while the poses are rendered
    optics : SessionOptics
        Camera scale, projector defocus (px) and projector lens distortion of the true rig.
    imaging : SessionImaging
        Noise, other render settings, the board's albedo and edge ramp (px), the Gray-code stripe (px).
    pose_ranges : PoseRanges
        Tilt and spin (deg), image margins and partial views of the board poses
        (:func:`sample_board_poses`; partial views for ChArUco boards).

    Returns
    -------
    SimulatedSession
        The rendered poses (:class:`~fringe3d.calibrate.session.PoseCapture`), the board, the
        true rig and board poses (board -> world, mm), the rig model, the folder written (or
        None) and the render settings used.
    """
    defocus, projector_dist = optics.defocus, optics.projector_dist
    p = presets.get(preset)
    rig = scaled_camera(p.rig, optics.camera_scale)
    if projector_dist is not None:
        rig = Rig(rig.camera, replace(rig.projector, dist=np.asarray(projector_dist, np.float64)))
    model = "telecentric" if rig.telecentric else "pinhole"
    if board is None or isinstance(board, (str, tuple)):
        kind, *cols_rows = (board,) if isinstance(board, str) else board or ("circles",)
        board = default_board(rig, p.volume, kind=kind, **dict(zip(("cols", "rows"), cols_rows)))
    s = p.settings
    blur = (defocus if defocus is not None else s.defocus_size if s.defocus != "none" else 0.0)
    patterns = calibration_patterns(patterns, rig.projector.width, rig.projector.height, imaging.stripe, blur)
    if (patterns.width, patterns.height) != (rig.projector.width, rig.projector.height):
        raise ValueError(f"pattern set is {patterns.width}x{patterns.height} but the projector is "
                         f"{rig.projector.width}x{rig.projector.height}")
    rng = np.random.default_rng(seed)
    board_poses = sample_board_poses(rig, p.volume, board, n_poses, rng, pose_ranges)
    over = dict(imaging.settings_overrides or {})
    if defocus is not None:
        over.setdefault("defocus", s.defocus if s.defocus != "none" else "gaussian")
        over["defocus_size"] = float(defocus)
    if not imaging.noise:
        over.update(shot_noise=False, read_noise=0.0, bit_depth=16)
    s = s.replace(**over)
    folder = Path(folder) if folder is not None else None
    edge_pixels = imaging.edge_pixels
    if edge_pixels is None:
        edge_pixels = 4.0 if isinstance(board, ChessBoard) else 2.0
    poses = render_board_poses(rig, s, board, board_poses, patterns, seed=seed, dark_albedo=imaging.dark_albedo,
                               edge_pixels=edge_pixels, progress=progress)
    if folder is not None:
        for pose, (R, t) in zip(poses, board_poses):
            write_capture(folder / pose.name, pose.frames, patterns,
                          meta={"simulated": True, "preset": p.name, "board_R": R, "board_t": t})
    if folder is not None:
        meta = {"board": board.to_dict(), "model": model, "preset": p.name, "seed": seed,
                "truth": {"rig": rig.to_dict(), "board_poses": [{"R": R, "t": t} for R, t in board_poses]}}
        write_json(folder / SESSION_NAME, meta, units={"length": "mm", "spacing": "mm", "t": "mm"})
    return SimulatedSession(poses=poses, board=board, rig=rig, board_poses=board_poses, model=model, folder=folder,
                            settings=s)


def render_and_decode(scene, rig: Rig, patterns, settings) -> tuple[np.ndarray, object, list[FringeDirection]]:
    """Render ``scene`` through the true ``rig`` and decode: returns (frames, truth, directions)."""
    frames, truth = render(scene, rig, patterns, settings, progress=False)
    dec = decode(frames, patterns)
    return frames, truth, directions_of(dec, patterns)
