"""A calibration session: board poses -> circle centres -> projector centres -> calibrated rig.

A *pose folder* is a capture folder whose manifest is a calibration set (a white frame plus
at least two fringe directions, e.g. ``patterns.sets.calibration`` or
``optimal_angle_calibration``). A *session folder* holds pose folders (any names, sorted)
and optionally ``session.json`` with the board (``{"board": CircleBoard.to_dict()}``) and
the rig model (``"model": "pinhole" | "telecentric"``).

:func:`observe_pose` turns one pose's frames into a :class:`PoseObservation`;
:func:`calibrate_observations` runs the pinhole or telecentric calibration and wraps the
result in a :class:`Calibration`. Simulated sessions are rendered by
:func:`fringe3d.sim.calibration_session.simulate_session`.
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from fringe3d.decode import decode
from fringe3d.io.capture import read_capture
from fringe3d.patterns.manifest import MANIFEST_NAME, PatternSet
from fringe3d.utils.console import progress_bar
from fringe3d.utils.warning_types import CalibrationWarning
from fringe3d.utils.jsonfile import read_json

from .board_detection import find_board
from .boards import CircleBoard
from .calibration_file import Calibration
from .phase_mapping import FringeDirection, projector_points
from .plots import residual_plot
from .stereo import PoseObservation, calibrate_pinhole_rig
from .telecentric import calibrate_telecentric_rig

SESSION_NAME = "session.json"


@dataclass
class PoseCapture:
    """One board pose in memory: ``frames (F, H, W)`` in the order of ``patterns``."""

    name: str
    frames: np.ndarray
    patterns: PatternSet


# ----------------------------------------------------------------------------- folders
def find_pose_folders(paths) -> tuple[list[Path], dict]:
    """Expand CLI inputs into pose folders plus session metadata (``session.json``, or {}).

    Each path is a pose folder (holds ``manifest.json``) or a session folder (holds pose
    folders). Raises ``FileNotFoundError`` for missing paths and ``ValueError`` when a folder
    holds no pose folders.
    """
    out: list[Path] = []
    meta: dict = {}
    for p in map(Path, paths):
        if not p.exists():
            raise FileNotFoundError(f"calibration input {p} does not exist")
        if not p.is_dir():
            raise ValueError(f"calibration input {p} is not a folder; expected a pose (capture) folder "
                             "or a session folder of pose folders")
        if (p / SESSION_NAME).is_file():
            meta = {**meta, **read_json(p / SESSION_NAME, "calibration session file")}
        if (p / MANIFEST_NAME).is_file():
            out.append(p)
            continue
        subs = sorted(q for q in p.iterdir() if q.is_dir() and (q / MANIFEST_NAME).is_file())
        if not subs:
            raise ValueError(f"{p} holds neither a {MANIFEST_NAME} (pose folder) nor pose folders (session folder)")
        out += subs
    return out, meta


def read_pose(folder: Path) -> PoseCapture:
    """The first pattern cycle of a pose (capture) folder."""
    cap = read_capture(folder, max_cycles=1)
    return PoseCapture(name=Path(folder).name, frames=cap.frames[: len(cap.patterns)], patterns=cap.patterns)


# ----------------------------------------------------------------------------- one pose
def check_calibration_set(ps: PatternSet, where: str) -> int:
    """Index of the white frame; raises unless ``ps`` is a calibration set."""
    white = ps.indices(kind="white")
    if not white:
        raise ValueError(f"{where}: the manifest has no white frame; a calibration pose needs a white "
                         "(board image) frame plus two fringe directions (fringe3d patterns calibration)")
    if len(ps.plans) < 2:
        raise ValueError(f"{where}: the manifest has {len(ps.plans)} fringe direction(s); calibration needs two")
    return white[0]


def decode_directions(pose: PoseCapture) -> list[FringeDirection]:
    """Absolute phase per direction from the decoder (``fringe3d.decode.decode``)."""
    dec = decode(pose.frames, pose.patterns)
    out = []
    for p in pose.patterns.plans:
        d = p.direction
        out.append(FringeDirection(phase=np.asarray(dec.phase[d]), angle=float(dec.angle[d]),
                                   period=float(dec.period[d]), modulation=np.asarray(dec.modulation[d]),
                                   mask=np.asarray(dec.mask[d]), wrapped=np.asarray(dec.wrapped[d])))
    return out


def phase_window_px(window, uv: np.ndarray) -> float:
    """Radius (px) of the local phase fit: 0 = bilinear (Eq. 2.30-2.31), a number = that many
    pixels, ``"auto"`` = half the median distance between neighbouring circle centres."""
    if window == "auto":
        d = np.linalg.norm(uv[:, None] - uv[None], axis=-1)
        np.fill_diagonal(d, np.inf)
        return 0.5 * float(np.median(d.min(1)))
    return _fixed_window_px(window)


def _fixed_window_px(window) -> float:
    """A window other than ``"auto"`` as a radius in px (0 = bilinear); raises on bad values."""
    if window in (None, "bilinear"):
        return 0.0
    try:
        r = float(window)
    except (TypeError, ValueError):
        raise ValueError(f"phase window must be 'auto', 'bilinear' or a radius in pixels, got {window!r}") from None
    if not r >= 0:
        raise ValueError(f"phase window radius must be >= 0 pixels, got {window!r}")
    return r


def phase_sampling_label(window) -> str:
    """How the centres' phase is sampled, as recorded in the calibration file."""
    if window == "auto":
        return "local fit, radius auto"
    r = _fixed_window_px(window)
    return "bilinear" if r == 0 else f"local fit, radius {r:g} px"


def observe_pose(pose: PoseCapture, board: CircleBoard, min_modulation_fraction: float = 0.1,
                 directions: list[FringeDirection] | None = None, phase_window=0.0) -> PoseObservation | None:
    """Circle centres in the camera and, through phase, in the projector (Eq. 2.30-2.34).

    Returns None (after a warning naming the pose) when the board is not found. Centres whose
    bilinearly sampled modulation is below ``min_modulation_fraction`` times the 95th
    percentile of the valid modulation are NaN in ``projector_uv``. ``phase_window`` (see
    :func:`phase_window_px`) picks bilinear sampling (default, the dissertation's) or a local
    modulation-weighted fit of the phase around each centre.
    """
    iw = check_calibration_set(pose.patterns, pose.name)
    uv, why = find_board(pose.frames[iw], board)
    if uv is None:
        what = "was not found" if why in ("not found", "the image is flat") else f"is unusable: {why}"
        warnings.warn(f"pose {pose.name}: the {board.cols}x{board.rows} circle board {what} in the white frame; "
                      "pose skipped", CalibrationWarning, stacklevel=2)
        return None
    dirs = directions if directions is not None else decode_directions(pose)
    mods = [d.modulation[np.isfinite(d.phase) & (d.mask if d.mask is not None else True)]
            for d in dirs if d.modulation is not None]
    thr = 0.0
    if mods and all(m.size for m in mods):
        thr = min_modulation_fraction * min(float(np.percentile(m, 95)) for m in mods)
    puv = projector_points(dirs, uv, min_modulation=thr, window=phase_window_px(phase_window, uv))
    return PoseObservation(name=pose.name, camera_uv=uv, projector_uv=puv)


# ----------------------------------------------------------------------------- whole session
def observe_session(poses, board: CircleBoard, min_modulation_fraction: float = 0.1,
                    progress: bool = True, phase_window=0.0) -> tuple[list[PoseObservation], dict]:
    """Observe every pose (an iterable of :class:`PoseCapture` or folders); ``phase_window``
    as in :func:`observe_pose`.

    Checks that all poses have the same camera size and projector size. Returns the usable
    observations and ``{"camera_size", "projector_size", "periods", "angles", "skipped"}``.
    """
    sampling = phase_sampling_label(phase_window)  # a bad value fails before any work
    poses = list(poses)
    obs: list[PoseObservation] = []
    info: dict = {"skipped": []}
    with progress_bar("calibration poses", len(poses), enabled=progress) as advance:
        for p in poses:
            pose = read_pose(p) if not isinstance(p, PoseCapture) else p
            cam_size = (pose.frames.shape[2], pose.frames.shape[1])
            prj_size = (pose.patterns.width, pose.patterns.height)
            if "camera_size" not in info:
                info.update(camera_size=cam_size, projector_size=prj_size, first=pose.name)
            elif cam_size != info["camera_size"]:
                raise ValueError(f"pose {pose.name} has {cam_size[0]}x{cam_size[1]} images "
                                 f"but pose {info['first']} has "
                                 f"{info['camera_size'][0]}x{info['camera_size'][1]}; "
                                 "all poses must come from one camera")
            elif prj_size != info["projector_size"]:
                raise ValueError(f"pose {pose.name} was projected at {prj_size[0]}x{prj_size[1]} but pose "
                                 f"{info['first']} at {info['projector_size'][0]}x{info['projector_size'][1]}")
            o = observe_pose(pose, board, min_modulation_fraction, phase_window=phase_window)
            if o is None:
                info["skipped"].append(pose.name)
            else:
                obs.append(o)
                if "periods" not in info:
                    info["periods"] = {pl.direction: float(min(pl.periods)) if pl.periods else float("nan")
                                       for pl in pose.patterns.plans}
                    info["angles"] = {pl.direction: float(pl.angle) for pl in pose.patterns.plans}
                    alpha = [pl.options.get("alpha_opt") for pl in pose.patterns.plans if "alpha_opt" in pl.options]
                    if alpha:
                        info["alpha_opt"] = float(alpha[0])
            advance()
    if not poses:
        raise ValueError("no calibration poses given")
    info["phase_sampling"] = sampling
    return obs, info


def calibrate_observations(obs: list[PoseObservation], info: dict, board: CircleBoard, model: str = "pinhole",
                           camera_dist: str = "k1k2p", projector_dist: str = "none", min_poses: int = 3,
                           correct_circle_bias: bool = True,
                           telecentric_refine: bool = True) -> tuple[Calibration, object]:
    """Calibrate from observations; returns ``(Calibration, raw result)``.

    ``model`` is ``"pinhole"`` (camera frame = world, ch. 2) or ``"telecentric"`` (projector
    frame = world, ch. 3). Too few usable poses is a ``ValueError`` naming the skipped ones.
    ``telecentric_refine`` adds a joint LM refinement to ch. 3's sequential steps
    (``telecentric.refine_jointly``); False gives the dissertation's method exactly.
    """
    if len(obs) < min_poses:
        skipped = info.get("skipped", [])
        raise ValueError(f"only {len(obs)} usable board pose(s); need at least {min_poses}"
                         + (f" (board not found in: {', '.join(skipped)})" if skipped else ""))
    cam_size, prj_size = info["camera_size"], info["projector_size"]
    if model == "pinhole":
        res = calibrate_pinhole_rig(board, obs, cam_size, prj_size, camera_dist, projector_dist,
                                    correct_circle_bias=correct_circle_bias, min_poses=min_poses)
        prj_rms = {res.pose_names[i]: float(r) for i, r in zip(res.projector_poses, res.projector.per_pose_rms)}
        poses = [{"name": n, "camera_rms_px": float(res.camera.per_pose_rms[i]),
                  "projector_rms_px": prj_rms.get(n, float("nan")), "points": int(res.used_points[i].sum())}
                 for i, n in enumerate(res.pose_names)]
        rms = {"camera_px": res.camera.rms, "projector_px": res.projector.rms, "stereo_px": res.stereo_rms}
        cam_d = {"width": cam_size[0], "height": cam_size[1], "dist_model": camera_dist, "rms_px": res.camera.rms,
                 "per_pose_rms_px": list(map(float, res.camera.per_pose_rms))}
        extra = {"circle_bias_corrected": bool(correct_circle_bias)}
    elif model == "telecentric":
        res = calibrate_telecentric_rig(board, obs, cam_size, prj_size, projector_dist, min_poses=min_poses,
                                        refine=telecentric_refine)
        poses = [{"name": n, "camera_rms_px": float(c), "projector_rms_px": float(p), "points": int(u.sum())}
                 for n, c, p, u in zip(res.pose_names, res.camera_per_pose_rms, res.projector.per_pose_rms,
                                       res.used_points)]
        rms = {"camera_px": res.camera_rms, "projector_px": res.projector.rms,
               "camera_um": 1000 * res.camera_rms / res.camera_scale}
        cam_d = {"width": cam_size[0], "height": cam_size[1], "dist_model": "affine", "rms_px": res.camera_rms,
                 "per_pose_rms_px": list(map(float, res.camera_per_pose_rms))}
        extra = {"camera_pixels_per_mm": res.camera_scale, "joint_refinement": bool(telecentric_refine)}
    else:
        raise ValueError(f"unknown rig model {model!r}; expected 'pinhole' or 'telecentric'")
    prj_d = {"width": prj_size[0], "height": prj_size[1], "dist_model": projector_dist, "rms_px": res.projector.rms,
             "per_pose_rms_px": list(map(float, res.projector.per_pose_rms))}
    if "alpha_opt" in info:
        extra["alpha_opt"] = info["alpha_opt"]
    extra["skipped_poses"] = list(info.get("skipped", []))
    extra["phase_sampling"] = info.get("phase_sampling", "bilinear")
    cal = Calibration(model=model, rig=res.rig, camera=cam_d, projector=prj_d, board=board.to_dict(),
                      periods=info.get("periods", {}), angles=info.get("angles", {}), poses=poses, rms=rms,
                      extra=extra)
    return cal, res


def calibrate_session(paths, board: CircleBoard | None = None, model: str | None = None, progress: bool = True,
                      **kw) -> tuple[Calibration, object]:
    """Folders in, :class:`Calibration` out (``board``/``model`` default to session.json)."""
    folders, meta = find_pose_folders(paths)
    if board is None:
        if "board" not in meta:
            raise ValueError("no board description: pass the board (cols, rows, spacing, radius) or put "
                             f"{{\"board\": {{...}}}} in the session folder's {SESSION_NAME}")
        board = CircleBoard.from_dict(meta["board"])
    model = model or meta.get("model", "pinhole")
    mmf = kw.pop("min_modulation_fraction", 0.1)
    obs, info = observe_session(folders, board, mmf, progress, phase_window=kw.pop("phase_window", 0.0))
    return calibrate_observations(obs, info, board, model, **kw)


def board_from_options(cols: int, rows: int, spacing: float | None, radius: float | None, asymmetric: bool,
                       bright: bool) -> CircleBoard | None:
    """The board the command line describes (radius default ``spacing / 4``), or None without a spacing."""
    if spacing is None:
        return None
    return CircleBoard(cols=cols, rows=rows, spacing=spacing, radius=radius if radius else 0.25 * spacing,
                       asymmetric=asymmetric, dark_circles=not bright)


def calibrate_to_files(inputs, output: Path, board=None, model=None, camera_dist="k1k2p", projector_dist="none",
                       plot: Path | None = None, yaml: Path | None = None, min_modulation: float = 0.1,
                       progress: bool = True, refine: bool = True, phase_window="bilinear") -> dict:
    """Calibrate from pose/session folders (:func:`calibrate_session`); write the calibration JSON
    (+ optional residual PNG plot / OpenCV YAML).

    Returns a JSON-friendly summary. Nothing is written unless the calibration succeeds.
    """
    cal, res = calibrate_session(inputs, board=board, model=model, progress=progress, camera_dist=camera_dist,
                                 projector_dist=projector_dist, min_modulation_fraction=min_modulation,
                                 telecentric_refine=refine, phase_window=phase_window)
    cal.save(output)
    written = {"calibration": str(output)}
    if plot is not None:
        if cal.model == "pinhole":
            cam_r = res.camera.residuals
            names = res.pose_names
            prj_r = res.projector.residuals
        else:
            cam_r, prj_r, names = res.camera_residuals, res.projector.residuals, res.pose_names
        residual_plot(plot, cam_r, prj_r, names, title=f"{output.name}: reprojection residuals")
        written["plot"] = str(plot)
    if yaml is not None:
        cal.export_opencv_yaml(yaml)
        written["yaml"] = str(yaml)
    rig = cal.rig
    summary = {"model": cal.model, "rms": cal.rms, "poses": cal.poses, "written": written,
               "skipped_poses": cal.extra.get("skipped_poses", []), "periods": cal.periods,
               "phase_sampling": cal.extra.get("phase_sampling", "bilinear"),
               "camera": rig.camera.to_dict(), "projector": rig.projector.to_dict()}
    return summary
