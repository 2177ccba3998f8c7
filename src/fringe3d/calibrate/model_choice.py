"""Choosing a device's distortion model by held-out reprojection error (``fringe3d calibrate --camera-dist auto``,
``fringe3d calibrate --projector-dist auto``).

A richer Brown model (Eq. 2.14-2.16) always fits the poses it was fitted to at least as well
as a simpler one; whether it describes the lens is shown by poses it was *not* fitted to. The
poses are split into ``k = min(P, MAX_FOLDS)`` folds (pose ``i`` in fold ``i mod k``:
leave-one-pose-out up to :data:`MAX_FOLDS` poses); for each fold the device is calibrated on
the other poses, the held-out poses' board poses are found with the fitted intrinsics
(``cv2.solvePnP``) and their residuals collected. The held-out RMS of a model is the RMS of
all held-out residuals (px).

The models are tried from simple to rich (:data:`CANDIDATES`); a richer model replaces the
one chosen so far only when its held-out RMS is lower by at least :data:`RICHER_MARGIN` of
it *and* by at least :data:`RICHER_MIN_GAIN_PX` (a gain below that is beneath any detector's
precision). With fewer than :data:`MIN_POSES_TO_CHOOSE` poses nothing can be held out and
the fallback model is used.
"""
from __future__ import annotations

import cv2
import numpy as np

from fringe3d.calibrate.serial_opencv import serial_opencv

from .camera import DIST_MODELS, dist_flags

AUTO = "auto"
#: Models tried by ``auto``, simple to rich.
CANDIDATES = DIST_MODELS
MAX_FOLDS = 8
RICHER_MARGIN = 0.10
RICHER_MIN_GAIN_PX = 0.002
MIN_POSES_TO_CHOOSE = 4
#: What ``auto`` falls back to with too few poses: the previous defaults.
FALLBACK = {"camera": "k1k2p", "projector": "none"}


def check_dist_option(value: str, option: str) -> str:
    """``value`` if it is ``auto`` or one of :data:`DIST_MODELS`; ``ValueError`` naming ``option`` otherwise."""
    if value != AUTO and value not in DIST_MODELS:
        raise ValueError(f"{option} must be auto or one of {', '.join(DIST_MODELS)}, got {value!r}")
    return value


def _fit(obj, img, size, model: str):
    crit = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 100, 1e-10)
    with serial_opencv():
        _, K, dist, _, _ = cv2.calibrateCamera(obj, img, size, None, None, flags=dist_flags(model), criteria=crit)
    return np.asarray(K, np.float64), np.asarray(dist, np.float64).ravel()


def _held_out_residuals(obj, img, K, dist) -> np.ndarray:
    ok, rv, tv = cv2.solvePnP(obj, img, K, dist, flags=cv2.SOLVEPNP_ITERATIVE)
    if not ok:
        return np.full((len(obj), 2), np.inf)
    proj, _ = cv2.projectPoints(obj, rv, tv, K, dist)
    return img.reshape(-1, 2).astype(np.float64) - proj.reshape(-1, 2)


def held_out_rms(object_points: list[np.ndarray], image_points: list[np.ndarray], size: tuple[int, int],
                 model: str) -> float:
    """Held-out reprojection RMS (px) of ``model`` over ``k``-fold splits of the poses (module doc).

    ``object_points``: per pose ``(N_i, 3)`` board mm; ``image_points``: per pose ``(N_i, 2)`` px;
    ``size``: (width, height) px. Infinite when a fit or a held-out pose fails."""
    obj = [np.ascontiguousarray(o, np.float32).reshape(-1, 1, 3) for o in object_points]
    img = [np.ascontiguousarray(p, np.float32).reshape(-1, 1, 2) for p in image_points]
    k = min(len(obj), MAX_FOLDS)
    res = []
    wh = (int(size[0]), int(size[1]))
    for fold in range(k):
        test = [i for i in range(len(obj)) if i % k == fold]
        train = [i for i in range(len(obj)) if i % k != fold]
        try:
            K, dist = _fit([obj[i] for i in train], [img[i] for i in train], wh, model)
            res += [_held_out_residuals(obj[i], img[i], K, dist) for i in test]
        except cv2.error:
            return float("inf")
    r = np.concatenate(res)
    value = float(np.sqrt(np.mean(np.sum(r ** 2, axis=1))))
    return value if np.isfinite(value) else float("inf")


def choose_model(object_points: list[np.ndarray], image_points: list[np.ndarray], size: tuple[int, int],
                 device: str) -> tuple[str, dict]:
    """The distortion model of ``device`` ("camera" or "projector") by the module's criterion.

    Returns ``(model, report)``; ``report`` holds ``chosen``, ``held_out_rms_px`` (model ->
    px), ``folds``, ``criterion`` (text) - or ``chosen`` and ``reason`` when there were too few
    poses to hold any out."""
    if len(object_points) < MIN_POSES_TO_CHOOSE:
        chosen = FALLBACK[device]
        return chosen, {"chosen": chosen, "reason": f"{len(object_points)} poses: too few to hold poses out "
                                                    f"(needs {MIN_POSES_TO_CHOOSE}); used {chosen}"}
    errors = {m: held_out_rms(object_points, image_points, size, m) for m in CANDIDATES}
    chosen = CANDIDATES[0]
    for m in CANDIDATES[1:]:
        gain = errors[chosen] - errors[m]
        if gain >= RICHER_MARGIN * errors[chosen] and gain >= RICHER_MIN_GAIN_PX:
            chosen = m
    criterion = (f"held-out reprojection RMS over {min(len(object_points), MAX_FOLDS)} folds of poses; a richer "
                 f"model is taken when it lowers it by >= {100 * RICHER_MARGIN:g} % and >= "
                 f"{RICHER_MIN_GAIN_PX:g} px")
    return chosen, {"chosen": chosen, "held_out_rms_px": errors, "folds": min(len(object_points), MAX_FOLDS),
                    "criterion": criterion}
