"""Acceptance gates: whether a calibration is plausible enough to be used.

A calibration that converged is not necessarily a good one: too few or near-parallel board
poses leave the intrinsics undetermined (Zhang's method needs at least three board
orientations that are not parallel), an outlier pose or a wrong board description shows as
large reprojection residuals, and a distortion model fitted to too few poses can bend the
image corners by tens of percent. Each gate below is one such check, with a named,
documented limit; :func:`evaluate_gates` runs them all on a calibration's figures and
returns one :class:`Gate` per check (passed or failed, with its value and limit).

Limits (module constants):

* :data:`MIN_POSES` usable poses.
* :data:`MIN_ORIENTATIONS` distinct board orientations: board normals (in the camera frame,
  or the projector frame for a telecentric rig) counted greedily, a normal counting when it is
  more than :data:`ORIENTATION_STEP_DEG` from every normal counted before.
* Reprojection RMS (camera, projector, and the stereo fit of a pinhole rig) at most
  :data:`MAX_RMS_PX`, and every pose's at most :data:`MAX_POSE_RMS_PX`.
* Focal lengths ``fx``, ``fy`` between :data:`FOCAL_RANGE` times the device width (a
  horizontal field of view between 127 and 2.3 deg), and ``|fx/fy - 1| <=``
  :data:`MAX_ASPECT_DEVIATION` (square pixels).
* Principal point inside the image (camera); for a projector, whose lens is usually offset,
  inside the image grown by :data:`PROJECTOR_PP_MARGIN` of its size on every side.
* Distortion: the Brown model's displacement of the image corners and edge midpoints at most
  :data:`MAX_DISTORTION_SHARE` of their distance from the principal point, and the radial
  mapping ``r -> r (1 + k1 r^2 + k2 r^4 + k3 r^6)`` (Eq. 2.14) increasing out to the farthest
  corner (a mapping that turns back folds the image onto itself).
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass

import cv2
import numpy as np

from fringe3d.optics.distortion import distort
from fringe3d.utils.warning_types import RenamedFieldWarning

MIN_POSES = 5
MIN_ORIENTATIONS = 3
ORIENTATION_STEP_DEG = 10.0
MAX_RMS_PX = 1.0
MAX_POSE_RMS_PX = 2.0
FOCAL_RANGE = (0.25, 25.0)
MAX_ASPECT_DEVIATION = 0.05
PROJECTOR_PP_MARGIN = 0.5
MAX_DISTORTION_SHARE = 0.2


class AcceptanceGateError(ValueError):
    """A calibration failed an acceptance gate; ``summary`` is what the calibration gave (the
    command prints it before the error)."""

    def __init__(self, message: str, summary: dict | None = None):
        super().__init__(message)
        self.summary = summary or {}


@dataclass(frozen=True)
class Gate:
    """One acceptance check: ``name``, ``passed``, the measured ``value`` and the ``limit`` it
    was held to (both as text with units), and ``advice`` (what to do when it fails)."""

    name: str
    passed: bool
    value: str
    limit: str
    advice: str = ""

    def to_dict(self) -> dict:
        return {"name": self.name, "passed": bool(self.passed), "value": self.value, "limit": self.limit,
                "advice": self.advice}


_MORE_POSES = ("capture more board poses (10 or more), tilted up to ~35 deg in different directions and "
               "spread through the measurement volume")


def pose_count_gate(n: int) -> Gate:
    """At least :data:`MIN_POSES` usable poses."""
    return Gate("poses", n >= MIN_POSES, f"{n} poses", f">= {MIN_POSES} poses", _MORE_POSES)


def distinct_orientations(normals: np.ndarray, step_deg: float = ORIENTATION_STEP_DEG) -> int:
    """How many of the unit board normals ``(P, 3)`` differ by more than ``step_deg`` from
    every normal counted before them (greedy, in pose order; a normal and its opposite are
    one orientation)."""
    kept: list[np.ndarray] = []
    cos_step = np.cos(np.deg2rad(step_deg))
    for n in np.asarray(normals, np.float64):
        if all(abs(float(n @ k)) < cos_step for k in kept):
            kept.append(n)
    return len(kept)


def board_normals(rvecs: np.ndarray) -> np.ndarray:
    """Board normals ``(P, 3)`` (the third column of each board-to-device rotation) from
    Rodrigues vectors ``(P, 3)``."""
    return np.array([cv2.Rodrigues(np.asarray(r, np.float64))[0][:, 2] for r in rvecs]).reshape(-1, 3)


def orientation_gate(rvecs: np.ndarray) -> Gate:
    """At least :data:`MIN_ORIENTATIONS` board orientations :data:`ORIENTATION_STEP_DEG` apart."""
    normals = board_normals(rvecs)
    k = distinct_orientations(normals)
    spread = 0.0
    if len(normals) > 1:
        spread = float(np.degrees(np.arccos(np.clip(np.abs(normals @ normals.T), 0, 1))).max())
    return Gate("orientations", k >= MIN_ORIENTATIONS,
                f"{k} (board normals up to {spread:.1f} deg apart)",
                f">= {MIN_ORIENTATIONS} orientations {ORIENTATION_STEP_DEG:g} deg apart",
                "the poses are (nearly) parallel, which leaves the focal length undetermined: tilt the board "
                "by 15-35 deg in different directions between poses")


def rms_gates(device: str, rms: float, per_pose: dict[str, float]) -> list[Gate]:
    """Overall RMS at most :data:`MAX_RMS_PX`; every pose's at most :data:`MAX_POSE_RMS_PX`."""
    finite = {k: v for k, v in per_pose.items() if np.isfinite(v)}
    worst = max(finite, key=lambda k: finite[k]) if finite else None
    advice = ("check the board description (kind, cols/rows, spacing), the focus and exposure of the "
              "board images, and remove poses where the board is blurred or partly shadowed")
    out = [Gate(f"{device}_rms", bool(rms <= MAX_RMS_PX), f"{rms:.3g} px", f"<= {MAX_RMS_PX:g} px", advice)]
    if worst is not None:
        out.append(Gate(f"{device}_pose_rms", bool(finite[worst] <= MAX_POSE_RMS_PX),
                        f"{finite[worst]:.3g} px (worst pose: {worst})", f"<= {MAX_POSE_RMS_PX:g} px every pose",
                        advice))
    return out


def intrinsics_gates(device: str, K: np.ndarray, width: int, height: int) -> list[Gate]:
    """Focal lengths within :data:`FOCAL_RANGE` of the width, square pixels, principal point
    inside the image (grown by :data:`PROJECTOR_PP_MARGIN` for a projector)."""
    fx, fy, cx, cy = float(K[0, 0]), float(K[1, 1]), float(K[0, 2]), float(K[1, 2])
    lo, hi = FOCAL_RANGE
    ok_f = lo * width <= min(fx, fy) and max(fx, fy) <= hi * width and abs(fx / fy - 1) <= MAX_ASPECT_DEVIATION
    advice = ("the intrinsics are implausible: check the board description and that the poses are tilted in "
              "different directions; " + _MORE_POSES)
    m = PROJECTOR_PP_MARGIN if device == "projector" else 0.0
    ok_c = -m * width <= cx <= (1 + m) * width - 1 and -m * height <= cy <= (1 + m) * height - 1
    where = "the image" if m == 0 else f"the image +/- {100 * m:g} % of its size"
    return [Gate(f"{device}_focal", bool(ok_f), f"fx {fx:.1f} px, fy {fy:.1f} px ({fx / width:.3g} x width)",
                 f"{lo:g}-{hi:g} x width, |fx/fy - 1| <= {MAX_ASPECT_DEVIATION:g}", advice),
            Gate(f"{device}_principal_point", bool(ok_c), f"({cx:.1f}, {cy:.1f}) px",
                 f"inside {where} ({width}x{height} px)", advice)]


def distortion_share(K: np.ndarray, dist: np.ndarray, width: int, height: int) -> float:
    """Largest displacement the distortion model gives the image corners and edge midpoints,
    as a share of their distance from the principal point (the points taken as undistorted
    pixels, mapped through Eq. 2.14-2.16)."""
    u = np.array([0, width / 2, width - 1, 0, width - 1, 0, width / 2, width - 1], np.float64)
    v = np.array([0, 0, 0, height / 2, height / 2, height - 1, height - 1, height - 1], np.float64)
    fx, fy, cx, cy = K[0, 0], K[1, 1], K[0, 2], K[1, 2]
    xy = np.stack([(u - cx) / fx, (v - cy) / fy], -1)
    moved = distort(xy, dist)
    shift = np.hypot((moved[:, 0] - xy[:, 0]) * fx, (moved[:, 1] - xy[:, 1]) * fy)
    dist_px = np.maximum(np.hypot(u - cx, v - cy), 1.0)
    return float(np.max(shift / dist_px))


def radial_is_monotonic(K: np.ndarray, dist: np.ndarray, width: int, height: int, samples: int = 512) -> bool:
    """Whether ``r (1 + k1 r^2 + k2 r^4 + k3 r^6)`` increases from 0 to the farthest image
    corner's normalised radius (taken as undistorted)."""
    d = np.asarray(dist, np.float64).ravel()
    k1, k2 = d[0], d[1]
    k3 = d[4] if d.size > 4 else 0.0
    cx, cy = K[0, 2], K[1, 2]
    corners = np.array([[0, 0], [width - 1, 0], [0, height - 1], [width - 1, height - 1]], np.float64)
    r_max = float(np.max(np.hypot((corners[:, 0] - cx) / K[0, 0], (corners[:, 1] - cy) / K[1, 1])))
    r = np.linspace(0, r_max, samples)
    slope = 1 + 3 * k1 * r ** 2 + 5 * k2 * r ** 4 + 7 * k3 * r ** 6  # d/dr of r L(r)
    return bool(np.all(slope > 0))


def distortion_gate(device: str, K: np.ndarray, dist: np.ndarray, width: int, height: int) -> Gate:
    """Distortion bounded over the image (:data:`MAX_DISTORTION_SHARE`) and monotonic."""
    share = distortion_share(K, dist, width, height)
    mono = radial_is_monotonic(K, dist, width, height)
    d = np.asarray(dist, np.float64).ravel()
    terms = ", ".join(f"{n} {x:.3g}" for n, x in zip(("k1", "k2", "p1", "p2", "k3"), d[:5]) if x != 0) or "none"
    return Gate(f"{device}_distortion", bool(share <= MAX_DISTORTION_SHARE and mono),
                f"{100 * share:.1f} % at the border, {'monotonic' if mono else 'folds back'} ({terms})",
                f"<= {100 * MAX_DISTORTION_SHARE:g} % and monotonic",
                f"the {device} distortion terms are not supported by the poses: use a simpler model "
                f"(--{device}-dist auto, k1k2 or none) or " + _MORE_POSES + ", covering the image corners")


def calibration_gates(cal, res) -> list[Gate]:
    """Every gate for a :class:`~fringe3d.calibrate.calibration_file.Calibration` ``cal`` and its
    raw result ``res`` (:class:`~fringe3d.calibrate.stereo.RigCalibration` for a pinhole rig,
    :class:`~fringe3d.calibrate.telecentric.TelecentricCalibration` for a telecentric one)."""
    pinhole = cal.model == "pinhole"
    rvecs = res.camera.rvecs if pinhole else res.projector.rvecs
    gates = [pose_count_gate(len(cal.poses)), orientation_gate(rvecs)]
    for dev in ("camera", "projector"):
        gates += rms_gates(dev, float(cal.rms[f"{dev}_px"]), {p["name"]: p[f"{dev}_rms_px"] for p in cal.poses})
    if pinhole:
        stereo = float(cal.rms["stereo_px"])
        gates.append(Gate("stereo_rms", bool(stereo <= MAX_RMS_PX), f"{stereo:.3g} px", f"<= {MAX_RMS_PX:g} px",
                          "camera and projector disagree on the board poses: check the projector size and "
                          "the pattern layout (fringe periods, Gray-code order) given to calibrate"))
    devices = (("camera", cal.rig.camera), ("projector", cal.rig.projector)) if pinhole \
        else (("projector", cal.rig.projector),)
    for name, dev in devices:
        gates += intrinsics_gates(name, dev.K, dev.width, dev.height)
        gates.append(distortion_gate(name, dev.K, dev.dist, dev.width, dev.height))
    return gates


def failed(gates: list[Gate]) -> list[Gate]:
    """The gates that did not pass."""
    return [g for g in gates if not g.passed]


def failure_message(gates: list[Gate]) -> str:
    """One paragraph naming each failed gate, its value, its limit and what to do."""
    lines = [f"{g.name}: {g.value}, needs {g.limit} - {g.advice}" for g in failed(gates)]
    return "calibration failed its acceptance gates:\n  " + "\n  ".join(lines)


def __getattr__(name: str):
    """``QualityGateError``: the old name of :class:`AcceptanceGateError` (warns)."""
    if name == "QualityGateError":
        warnings.warn("fringe3d.calibrate.gates.QualityGateError is renamed AcceptanceGateError ('quality' "
                      "means the mask reason bits in fringe3d)", RenamedFieldWarning, stacklevel=2)
        return AcceptanceGateError
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
