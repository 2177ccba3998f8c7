"""A calibration session: board poses -> board points -> projector points -> calibrated rig.

A *pose folder* is a capture folder whose manifest is a calibration set (a white frame plus
at least two fringe directions, e.g. ``patterns.sets.calibration``,
``optimal_angle_calibration``, or Gray-code columns and rows such as OpenCV's
``GrayCodePattern`` sequence). A *session folder* holds pose folders (any names, sorted)
and optionally ``session.json`` with the board (``{"board": board.to_dict()}``: a circle
grid, chessboard or ChArUco board, :func:`fringe3d.calibrate.square_boards.board_from_dict`)
and the rig model (``"model": "pinhole" | "telecentric"``). Another tool's session - a
folder per pose of numbered frames, no manifest - is read with a layout
(:func:`find_pose_folders` with ``layout``, e.g. ``"opencv-graycode"``).

The board points are found by :func:`fringe3d.calibrate.corner_detection.locate_board`; the
projector sees them through phase (Eq. 2.30-2.34, :mod:`.phase_mapping`) or, for a Gray-code
set, through local homographies of the decoded projector coordinates (:mod:`.code_mapping`).

:func:`observe_pose` turns one pose's frames into a :class:`PoseObservation`;
:func:`calibrate_observations` runs the pinhole or telecentric calibration and wraps the
result in a :class:`Calibration`. Simulated sessions are rendered by
:func:`fringe3d.sim.calibration_session.simulate_session`.
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from fringe3d.decode import decode
from fringe3d.io.capture import read_capture
from fringe3d.io.importer import ImportLayout, layout_patterns, list_sources, read_frames
from fringe3d.patterns.manifest import MANIFEST_NAME, PatternSet
from fringe3d.patterns.method_registry import method_facts
from fringe3d.utils.console import progress_bar
from fringe3d.utils.warning_types import CalibrationWarning
from fringe3d.utils.jsonfile import read_json
from fringe3d.utils.output_folder import check_complete

from .boards import CircleBoard
from .calibration_file import Calibration
from .code_mapping import DEFAULT_WINDOW, code_projector_points
from .corner_detection import locate_board
from .gates import AcceptanceGateError, Gate, calibration_gates, failed, failure_message
from .model_choice import AUTO, check_dist_option, choose_model
from .outliers import outlier_poses, rule_text as outlier_rule
from .phase_mapping import FringeDirection, projector_points
from .square_boards import CharucoBoard, ChessBoard, board_from_dict, describe_board
from .plots import residual_plot
from .stereo import PoseObservation, calibrate_pinhole_rig
from .session_result import SessionCalibration, SessionFacts
from .session_settings import CalibrationOutput, FitSettings, ObservationSettings
from .telecentric import calibrate_telecentric_rig

SESSION_NAME = "session.json"


@dataclass
class PoseCapture:
    """One board pose in memory: ``frames (F, H, W)`` in the order of ``patterns``."""

    name: str
    frames: np.ndarray
    patterns: PatternSet


@dataclass(frozen=True)
class FramesFolder:
    """A pose of another tool's session: a folder of numbered frames (naturally sorted,
    :func:`fringe3d.io.importer.list_sources`) projected with ``patterns``; read in memory,
    nothing is written."""

    folder: Path
    patterns: PatternSet


# ----------------------------------------------------------------------------- folders
def find_pose_folders(paths, layout: str | None = None,
                      projector_size: tuple[int, int] | None = None) -> tuple[list, dict]:
    """Expand CLI inputs into poses plus session metadata (``session.json``, or {}).

    Each path is a pose folder (holds ``manifest.json``) or a session folder (holds pose
    folders). With ``layout`` (one of :data:`fringe3d.io.importer.LAYOUTS`, e.g.
    ``"opencv-graycode"``, and the ``projector_size`` it needs) a folder without a manifest
    whose sub-folders hold image files is a session of :class:`FramesFolder` poses, and a
    folder of image files is one such pose. Raises ``FileNotFoundError`` for missing paths
    and ``ValueError`` when a folder holds no poses.

    Parameters
    ----------
    paths : iterable of str or Path
        Pose folders and/or session folders.
    layout : str, optional
        Another tool's frame layout (:data:`fringe3d.io.importer.LAYOUTS`); None reads
        fringe3d capture folders.
    projector_size : (width, height), optional
        Projector size in pixels, needed by ``layout``.

    Returns
    -------
    poses : list
        Pose folders (:class:`~pathlib.Path`) or, with ``layout``, :class:`FramesFolder` poses.
    meta : dict
        The merged ``session.json`` contents, or {}.
    """
    if layout is not None:
        return _frame_folders(paths, layout_patterns(ImportLayout(layout, projector_size)))
    out: list[Path] = []
    meta: dict = {}
    for p in map(Path, paths):
        if not p.exists():
            raise FileNotFoundError(f"calibration input {p} does not exist")
        if not p.is_dir():
            raise ValueError(f"calibration input {p} is not a folder; expected a pose (capture) folder "
                             "or a session folder of pose folders")
        check_complete(p, "calibration session")  # an interrupted capture never reaches calibration
        if (p / SESSION_NAME).is_file():
            meta = {**meta, **read_json(p / SESSION_NAME, "calibration session file")}
        if (p / MANIFEST_NAME).is_file():
            out.append(p)
            continue
        subs = sorted(q for q in p.iterdir() if q.is_dir() and (q / MANIFEST_NAME).is_file())
        for q in subs:
            check_complete(q, "calibration pose")
        if not subs:
            raise ValueError(f"{p} holds neither a {MANIFEST_NAME} (pose folder) nor pose folders (session folder)")
        out += subs
    return out, meta


def _has_images(folder: Path) -> bool:
    try:
        list_sources(folder)
    except FileNotFoundError:
        return False
    return True


def _frame_folders(paths, patterns: PatternSet) -> tuple[list, dict]:
    """:func:`find_pose_folders` for another tool's layout: folders of numbered frames."""
    out: list = []
    meta: dict = {}
    for p in map(Path, paths):
        if not p.is_dir():
            raise FileNotFoundError(f"calibration input {p} is not a folder; expected a folder per pose of "
                                    "numbered frames, or a session folder holding them")
        if (p / SESSION_NAME).is_file():
            meta = {**meta, **read_json(p / SESSION_NAME, "calibration session file")}
        subs = sorted((q for q in p.iterdir() if q.is_dir() and _has_images(q)), key=lambda q: q.name)
        if subs:
            out += [FramesFolder(q, patterns) for q in subs]
        elif _has_images(p):
            out.append(FramesFolder(p, patterns))
        else:
            raise ValueError(f"{p} holds no image files and no folders of image files (one folder per pose)")
    return out, meta


def read_pose(folder) -> PoseCapture:
    """The first pattern cycle of a pose (capture) folder or of a :class:`FramesFolder`
    (``ValueError`` naming the folder when its frame count does not fit the layout)."""
    if isinstance(folder, FramesFolder):
        frames, _, _ = read_frames(list_sources(folder.folder))
        n = len(folder.patterns)
        if len(frames) != n:
            raise ValueError(f"pose folder {folder.folder} has {len(frames)} frames but the layout "
                             f"({folder.patterns.name}) has {n}; expected exactly {n}")
        return PoseCapture(name=folder.folder.name, frames=frames, patterns=folder.patterns)
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


def is_code_set(ps: PatternSet) -> bool:
    """Whether every direction of ``ps`` is a Gray/binary code without phase frames (its
    decoded projector coordinates are stripe centres: mapped by local homographies)."""
    return all(method_facts(p.method).code_only and not ps.groups(direction=p.direction, role="phase")
               for p in ps.plans)


def correspondence_label(ps: PatternSet, window: int) -> str:
    """How the projector sees the board points, as recorded in the calibration file."""
    return (f"gray code, local homographies ({window} px window)" if is_code_set(ps)
            else "phase (Eq. 2.30-2.34)")


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
        uv = uv[np.all(np.isfinite(uv), 1)]
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


def observe_pose(pose: PoseCapture, board, min_modulation_share: float = 0.1,
                 directions: list[FringeDirection] | None = None, phase_window=0.0,
                 homography_window: int = DEFAULT_WINDOW) -> PoseObservation | None:
    """Board points in the camera and in the projector.

    The board (circle grid, chessboard or ChArUco; ChArUco corners not seen are NaN rows) is
    found in the white frame. Phase sets: the projector points come through phase
    (Eq. 2.30-2.34); points whose bilinearly sampled modulation is below
    ``min_modulation_share`` times the 95th percentile of the valid modulation are NaN in
    ``projector_uv``; ``phase_window`` (see :func:`phase_window_px`) picks bilinear sampling
    (default, the dissertation's) or a local modulation-weighted fit of the phase around each
    point. Gray-code sets (:func:`is_code_set`): local homographies over
    ``homography_window`` camera px (:mod:`.code_mapping`). Returns None (after a warning
    naming the pose) when the board is not found; ``ValueError`` naming the pose when the
    white frame holds a larger board than ``board`` (a sub-grid would get wrong board points).

    Parameters
    ----------
    pose : PoseCapture
        The pose's frames and pattern set.
    board : CircleBoard or ChessBoard or CharucoBoard
        The calibration board (spacing in mm).
    min_modulation_share : float
        Share of the 95th percentile of the valid modulation below which a point's projector
        coordinates are NaN (phase sets).
    directions : list of FringeDirection, optional
        The pose's decoded fringe directions; default decoded here (:func:`decode_directions`).
    phase_window : float or str
        ``0``/``"bilinear"`` (bilinear phase sampling), a radius in pixels, or ``"auto"``
        (:func:`phase_window_px`).
    homography_window : int
        Side of the local homography window, camera px (Gray-code sets).

    Returns
    -------
    PoseObservation or None
        Board points ``(N, 2)`` in the camera and in the projector, pixels; None when the
        board is not found.
    """
    iw = check_calibration_set(pose.patterns, pose.name)
    try:
        uv, why = locate_board(pose.frames[iw], board)
    except ValueError as e:  # e.g. the image holds a larger board than the one stated
        raise ValueError(f"pose {pose.name}, white frame (frame {iw}): {e}") from None
    if uv is None:
        what = "was not found" if why in ("not found", "the image is flat") else f"is unusable: {why}"
        warnings.warn(f"pose {pose.name}: the {describe_board(board)} {what} in the white frame; "
                      "pose skipped", CalibrationWarning, stacklevel=2)
        return None
    dirs = directions if directions is not None else decode_directions(pose)
    if is_code_set(pose.patterns):
        return PoseObservation(name=pose.name, camera_uv=uv,
                               projector_uv=code_projector_points(dirs, uv, homography_window))
    mods = [d.modulation[np.isfinite(d.phase) & (d.mask if d.mask is not None else True)]
            for d in dirs if d.modulation is not None]
    thr = 0.0
    if mods and all(m.size for m in mods):
        thr = min_modulation_share * min(float(np.percentile(m, 95)) for m in mods)
    puv = projector_points(dirs, uv, min_modulation=thr, window=phase_window_px(phase_window, uv))
    return PoseObservation(name=pose.name, camera_uv=uv, projector_uv=puv)


# ----------------------------------------------------------------------------- whole session
def observe_session(poses, board, min_modulation_share: float = 0.1,
                    progress: bool = True, phase_window=0.0,
                    homography_window: int = DEFAULT_WINDOW) -> tuple[list[PoseObservation], SessionFacts]:
    """Observe every pose (an iterable of :class:`PoseCapture`, :class:`FramesFolder` or
    folders); ``phase_window`` and ``homography_window`` as in :func:`observe_pose`.

    Checks that all poses have the same camera size and projector size. Returns the usable
    observations and the :class:`.session_result.SessionFacts` of the session.

    Parameters
    ----------
    poses : iterable
        :class:`PoseCapture`, :class:`FramesFolder` or pose folders (read by :func:`read_pose`).
    board : CircleBoard or ChessBoard or CharucoBoard
        The calibration board (spacing in mm).
    min_modulation_share : float
        Share of the 95th percentile of the valid modulation below which a point's projector
        coordinates are NaN (phase sets).
    progress : bool
        Show a progress bar.
    phase_window : float or str
        ``0``/``"bilinear"`` (bilinear phase sampling), a radius in pixels, or ``"auto"``
        (:func:`phase_window_px`).
    homography_window : int
        Side of the local homography window, camera px (Gray-code sets).

    Returns
    -------
    observations : list of PoseObservation
        One per pose whose board was found.
    facts : SessionFacts
        Sizes, pose names, skipped poses, fringe periods/angles and the phase sampling.
    """
    sampling = phase_sampling_label(phase_window)  # a bad value fails before any work
    poses = list(poses)
    obs: list[PoseObservation] = []
    facts: SessionFacts | None = None
    with progress_bar("calibration poses", len(poses), enabled=progress) as advance:
        for p in poses:
            pose = read_pose(p) if not isinstance(p, PoseCapture) else p
            facts = _same_sizes(facts, pose, homography_window)
            facts.names.append(pose.name)
            o = observe_pose(pose, board, min_modulation_share, phase_window=phase_window,
                             homography_window=homography_window)
            if o is None:
                facts.skipped.append(pose.name)
            else:
                if not obs:
                    _note_fringes(facts, pose.patterns)
                obs.append(o)
            advance()
    if facts is None:
        raise ValueError("no calibration poses given")
    facts.phase_sampling = sampling
    return obs, facts


def _same_sizes(facts: SessionFacts | None, pose: PoseCapture, homography_window: int) -> SessionFacts:
    """The session's facts, started by the first pose; ``ValueError`` when ``pose`` was taken by
    another camera size or projected at another size than the first."""
    cam_size = (pose.frames.shape[2], pose.frames.shape[1])
    prj_size = (pose.patterns.width, pose.patterns.height)
    if facts is None:
        return SessionFacts(camera_size=cam_size, projector_size=prj_size,
                            correspondences=correspondence_label(pose.patterns, homography_window))
    first = facts.names[0]
    if cam_size != facts.camera_size:
        raise ValueError(f"pose {pose.name} has {cam_size[0]}x{cam_size[1]} images but pose {first} has "
                         f"{facts.camera_size[0]}x{facts.camera_size[1]}; all poses must come from one camera")
    if prj_size != facts.projector_size:
        raise ValueError(f"pose {pose.name} was projected at {prj_size[0]}x{prj_size[1]} but pose "
                         f"{first} at {facts.projector_size[0]}x{facts.projector_size[1]}")
    return facts


def _note_fringes(facts: SessionFacts, ps: PatternSet) -> None:
    """Periods, angles and optimal angle of the first usable pose's fringe plans."""
    facts.periods = {pl.direction: float(min(pl.periods)) if pl.periods else float("nan") for pl in ps.plans}
    facts.angles = {pl.direction: float(pl.angle) for pl in ps.plans}
    alpha = [pl.options.get("alpha_opt") for pl in ps.plans if "alpha_opt" in pl.options]
    if alpha:
        facts.alpha_opt = float(alpha[0])


def calibrate_observations(obs: list[PoseObservation], info: SessionFacts, board, model: str = "pinhole",
                           camera_dist: str = "k1k2p", projector_dist: str = "none", min_poses: int = 3,
                           correct_circle_bias: bool = True,
                           telecentric_refine: bool = True, drop_outliers: bool = True) -> SessionCalibration:
    """Calibrate from observations (``info``: what :func:`observe_session` learnt of the poses).

    Returns a :class:`.session_result.SessionCalibration`, which unpacks as
    ``(Calibration, fit)``.

    ``model`` is ``"pinhole"`` (camera frame = world, ch. 2) or ``"telecentric"`` (projector
    frame = world, ch. 3). Too few usable poses is a ``ValueError`` naming the skipped ones.
    ``camera_dist`` / ``projector_dist``: a model of :data:`.camera.DIST_MODELS` or ``"auto"``
    (chosen by held-out reprojection error, :mod:`.model_choice`).
    ``telecentric_refine`` adds a joint LM refinement to ch. 3's sequential steps
    (``telecentric.refine_jointly``); False gives the dissertation's method exactly.
    ``correct_circle_bias`` applies to circle grids only. A board found in no pose is a
    ``ValueError`` naming the board and the poses. With ``drop_outliers`` the poses that
    :func:`.outliers.outlier_poses` flags are dropped and the rig calibrated once more. The
    result's ``acceptance`` holds the acceptance gates (:func:`.gates.calibration_gates`), the
    dropped poses and the model choice; it is not enforced here
    (:func:`calibrate_to_files` refuses a calibration that fails a gate).

    Parameters
    ----------
    obs : list of PoseObservation
        The usable poses' observations (:func:`observe_session`).
    info : SessionFacts
        What :func:`observe_session` learnt of the poses (sizes, skipped poses).
    board : CircleBoard or ChessBoard or CharucoBoard
        The calibration board (spacing in mm).
    model : ``"pinhole"`` | ``"telecentric"``
        Rig model.
    camera_dist, projector_dist : str
        Distortion model of :data:`.camera.DIST_MODELS` or ``"auto"``.
    min_poses : int
        Fewest usable poses.
    correct_circle_bias : bool
        Remove the perspective bias of circle centres (circle grids, pinhole model).
    telecentric_refine : bool
        Joint LM refinement after ch. 3's sequential steps (telecentric model).
    drop_outliers : bool
        Drop the outlier poses and calibrate once more.

    Returns
    -------
    SessionCalibration
        ``(Calibration, fit)``; ``Calibration.acceptance`` holds the gates, dropped poses and
        model choice.
    """
    skipped = info.skipped
    if not obs and skipped:
        raise ValueError(f"the {describe_board(board)} was not found in any of the {len(skipped)} pose(s) "
                         f"({', '.join(skipped)}); check the board description (kind, cols/rows, spacing"
                         + (", marker, dictionary" if isinstance(board, CharucoBoard) else "") + ")")
    if len(obs) < min_poses:
        raise ValueError(f"only {len(obs)} usable board pose(s); need at least {min_poses}"
                         + (f" (board not found in: {', '.join(skipped)})" if skipped else ""))
    if model not in ("pinhole", "telecentric"):
        raise ValueError(f"unknown rig model {model!r}; expected 'pinhole' or 'telecentric'")
    check_dist_option(camera_dist, "camera distortion model")
    check_dist_option(projector_dist, "projector distortion model")
    args = (info, board, model, camera_dist, projector_dist, min_poses, correct_circle_bias, telecentric_refine)
    cal, res, choice = _calibrate_once(obs, *args)
    dropped = outlier_poses(cal.poses) if drop_outliers else []
    if dropped and len(obs) - len(dropped) >= min_poses:
        names = {d["name"] for d in dropped}
        cal, res, choice = _calibrate_once([o for o in obs if o.name not in names], *args)
    else:
        dropped = []
    gates = calibration_gates(cal, res)
    cal.acceptance = {"passed": not failed(gates), "gates": [g.to_dict() for g in gates],
                      "dropped_poses": dropped, "outlier_rule": outlier_rule(), "model_choice": choice}
    return SessionCalibration(cal, res)


def _choose_projector_model(obs, info: SessionFacts, board) -> tuple[str, dict]:
    """A telecentric rig's ``"auto"`` projector model (:func:`.model_choice.choose_model`)
    from the poses with >= 6 valid projector points."""
    obj = board.object_points()
    keep = [np.all(np.isfinite(o.projector_uv), axis=1) & np.all(np.isfinite(o.camera_uv), axis=1) for o in obs]
    use = [i for i, k in enumerate(keep) if k.sum() >= 6]
    return choose_model([obj[keep[i]] for i in use], [obs[i].projector_uv[keep[i]] for i in use],
                        info.projector_size, "projector")


def _calibrate_once(obs, info: SessionFacts, board, model, camera_dist, projector_dist, min_poses, correct_circle_bias,
                    telecentric_refine) -> tuple[Calibration, object, dict]:
    """One calibration of ``obs`` (see :func:`calibrate_observations`); also returns the model
    choice (``{device: report}`` for the ``"auto"`` models)."""
    choice: dict = {}
    cam_size, prj_size = info.camera_size, info.projector_size
    if model == "pinhole":
        circles = isinstance(board, CircleBoard)
        res = calibrate_pinhole_rig(board, obs, cam_size, prj_size, camera_dist, projector_dist,
                                    correct_circle_bias=correct_circle_bias and circles, min_poses=min_poses)
        prj_rms = {res.pose_names[i]: float(r) for i, r in zip(res.projector_poses, res.projector.per_pose_rms)}
        poses = [{"name": n, "camera_rms_px": float(res.camera.per_pose_rms[i]),
                  "projector_rms_px": prj_rms.get(n, float("nan")), "points": int(res.used_points[i].sum())}
                 for i, n in enumerate(res.pose_names)]
        rms = {"camera_px": res.camera.rms, "projector_px": res.projector.rms, "stereo_px": res.stereo_rms}
        choice = res.model_choice
        cam_d = {"width": cam_size[0], "height": cam_size[1], "dist_model": res.camera.dist_model,
                 "rms_px": res.camera.rms,
                 "per_pose_rms_px": list(map(float, res.camera.per_pose_rms))}
        extra = {"circle_bias_corrected": bool(correct_circle_bias and circles)}
    else:
        partial = [o.name for o in obs if not np.all(np.isfinite(o.camera_uv))]
        if partial:
            raise ValueError(f"telecentric calibration needs the whole board in every pose; pose(s) "
                             f"{', '.join(partial)} show only part of the {describe_board(board)}")
        if projector_dist == AUTO:
            projector_dist, choice["projector"] = _choose_projector_model(obs, info, board)
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
    prj_d = {"width": prj_size[0], "height": prj_size[1], "dist_model": res.projector.dist_model,
             "rms_px": res.projector.rms,
             "per_pose_rms_px": list(map(float, res.projector.per_pose_rms))}
    if info.alpha_opt is not None:
        extra["alpha_opt"] = info.alpha_opt
    extra["skipped_poses"] = list(info.skipped)
    extra["phase_sampling"] = info.phase_sampling
    extra["correspondences"] = info.correspondences
    cal = Calibration(model=model, rig=res.rig, camera=cam_d, projector=prj_d, board=board.to_dict(),
                      periods=dict(info.periods), angles=dict(info.angles), poses=poses, rms=rms,
                      extra=extra)
    return cal, res, choice


def calibrate_session(paths, board=None, model: str | None = None, progress: bool = True,
                      layout: str | None = None, projector_size: tuple[int, int] | None = None, *,
                      observe: ObservationSettings = ObservationSettings(), fit: FitSettings = FitSettings(),
                      min_modulation_fraction: float | None = None) -> SessionCalibration:
    """Calibrate a rig from pose folders or a session folder.

    Parameters
    ----------
    paths : path or list of paths
        A session folder, or pose folders (:func:`find_pose_folders`).
    board : board, optional
        The board; default the session folder's ``session.json``.
    model : str, optional
        ``"pinhole"`` or ``"telecentric"``; default ``session.json``'s, else pinhole.
    progress : bool
        Show a progress bar over the poses.
    layout : str, optional
        Another tool's session layout (:func:`find_pose_folders`), e.g. ``"opencv-graycode"``.
    projector_size : (int, int), optional
        The projector's ``(width, height)`` for a ``layout``.
    observe : ObservationSettings
        How the board points are observed: the modulation share (:func:`observe_pose`), the
        phase sampling (:func:`phase_window_px`) and the Gray-code homography window (camera px).
    fit : FitSettings
        Distortion models, or ``"auto"`` (:func:`calibrate_observations`), and the telecentric
        refinement.
    min_modulation_fraction : float, optional
        Deprecated spelling of ``observe.min_modulation_share``.

    Returns
    -------
    SessionCalibration
        The calibration and the fit (unpacks as ``(Calibration, fit)``).
    """
    if min_modulation_fraction is not None:
        warnings.warn("the parameter min_modulation_fraction is deprecated; pass `min_modulation_share`",
                      DeprecationWarning, stacklevel=2)
        observe = replace(observe, min_modulation_share=min_modulation_fraction)
    folders, meta = find_pose_folders(paths, layout, projector_size)
    if board is None:
        if "board" not in meta:
            raise ValueError("no board description: pass the board (`board` KIND, `cols`, `rows`, `spacing` ...) "
                             f"or put {{\"board\": {{...}}}} in the session folder's {SESSION_NAME}")
        board = board_from_dict(meta["board"])
    model = model or meta.get("model", "pinhole")
    obs, facts = observe_session(folders, board, observe.min_modulation_share, progress,
                                 phase_window=observe.phase_window, homography_window=observe.homography_window)
    return calibrate_observations(obs, facts, board, model, camera_dist=fit.camera_dist,
                                  projector_dist=fit.projector_dist, telecentric_refine=fit.telecentric_refine)


def board_from_options(cols: int, rows: int, spacing: float | None, radius: float | None, asymmetric: bool,
                       bright: bool, kind: str = "circles", marker: float | None = None,
                       dictionary: str = "DICT_4X4_50"):
    """The board the command line describes, or None without a spacing: a circle grid
    (radius default ``spacing / 4``), a chessboard or a ChArUco board (``cols`` x ``rows``
    squares of side ``spacing``; marker default ``0.7 spacing``)."""
    if spacing is None:
        return None
    if kind == "circles":
        return CircleBoard(cols=cols, rows=rows, spacing=spacing, radius=radius if radius else 0.25 * spacing,
                           asymmetric=asymmetric, dark_circles=not bright)
    if kind == "chessboard":
        return ChessBoard(cols=cols, rows=rows, spacing=spacing)
    if kind == "charuco":
        return CharucoBoard(cols=cols, rows=rows, spacing=spacing, marker=marker if marker else 0.7 * spacing,
                            dictionary=dictionary)
    raise ValueError(f"`board` must be circles, chessboard or charuco, got {kind!r}")


def calibrate_to_files(inputs, output: Path, board=None, model=None, progress: bool = True,
                       layout: str | None = None, projector_size: tuple[int, int] | None = None,
                       observe: ObservationSettings = ObservationSettings(phase_window="bilinear"),
                       fit: FitSettings = FitSettings(camera_dist="auto", projector_dist="auto"),
                       files: CalibrationOutput = CalibrationOutput()) -> dict:
    """Calibrate from pose/session folders (:func:`calibrate_session`, with ``observe`` and ``fit``:
    by default bilinear phase sampling and automatic distortion models); write the calibration
    JSON (+ optional residual PNG plot / OpenCV YAML, ``files``).

    Returns a JSON-friendly summary. Nothing is written unless the calibration succeeds and
    passes its acceptance gates (:mod:`.gates`): a failed gate raises :class:`.gates.AcceptanceGateError`
    (its ``summary`` is this function's summary with nothing written) - unless ``files.accept_poor``,
    which writes the files, records ``acceptance.accepted_poor`` and warns.
    """
    plot, yaml = files.plot, files.yaml
    session = calibrate_session(inputs, board=board, model=model, progress=progress, layout=layout,
                                projector_size=projector_size, observe=observe, fit=fit)
    cal = session.calibration
    gates = [Gate(**g) for g in cal.acceptance["gates"]]
    if failed(gates):
        if not files.accept_poor:
            raise AcceptanceGateError(failure_message(gates) + "\nnothing was written; `accept_poor=True` writes "
                                      "the calibration anyway and records the failed gates in it", _summary(cal, {}))
        cal.acceptance["accepted_poor"] = True
        warnings.warn(failure_message(gates) + "\nwritten anyway (`accept_poor=True`); the file records the failed "
                      "gates", CalibrationWarning, stacklevel=2)
    cal.save(output)
    written = {"calibration": str(output)}
    if plot is not None:
        pinhole = cal.model == "pinhole"  # detected points over the image: the pinhole fit keeps them
        residual_plot(plot, session.camera_residuals, session.projector_residuals, session.pose_names,
                      title=f"{output.name}: reprojection residuals",
                      camera_points=getattr(session.fit, "camera_points", None) if pinhole else None,
                      image_size=(cal.rig.camera.width, cal.rig.camera.height) if pinhole else None)
        written["plot"] = str(plot)
    if yaml is not None:
        cal.export_opencv_yaml(yaml)
        written["yaml"] = str(yaml)
    return _summary(cal, written)


def _summary(cal: Calibration, written: dict) -> dict:
    """The JSON-friendly summary :func:`calibrate_to_files` returns."""
    rig = cal.rig
    return {"model": cal.model, "rms": cal.rms, "poses": cal.poses, "written": written,
            "skipped_poses": cal.extra.get("skipped_poses", []), "periods": cal.periods,
            "phase_sampling": cal.extra.get("phase_sampling", "bilinear"),
            "correspondences": cal.extra.get("correspondences"), "board": cal.board,
            "dist_models": {"camera": cal.camera["dist_model"], "projector": cal.projector["dist_model"]},
            "acceptance": cal.acceptance, "camera": rig.camera.to_dict(), "projector": rig.projector.to_dict()}
