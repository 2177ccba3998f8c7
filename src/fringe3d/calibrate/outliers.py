"""Outlier board poses: which poses a calibration drops before it is fitted again.

Rule: a pose whose camera or projector reprojection RMS exceeds
``max(OUTLIER_FACTOR x median of that device's per-pose RMS, OUTLIER_FLOOR_PX)`` is an
outlier. :func:`fringe3d.calibrate.session.calibrate_observations` drops the outliers and
calibrates once more (only when at least ``min_poses`` poses remain), and records which poses
it dropped and why. The floor keeps a session of uniformly tiny residuals (a good one) from
losing poses to noise.
"""
from __future__ import annotations

import numpy as np

OUTLIER_FACTOR = 3.0
OUTLIER_FLOOR_PX = 0.5


def outlier_poses(poses: list[dict]) -> list[dict]:
    """The outliers among ``poses`` (the calibration file's ``poses`` entries: ``name``,
    ``camera_rms_px``, ``projector_rms_px``; NaN = the device did not use that pose).

    Returns one dict per outlier: ``name``, ``camera_rms_px``, ``projector_rms_px`` and
    ``limit_px`` (``{"camera": ..., "projector": ...}``, the rule's limits)."""
    limits = {}
    for dev in ("camera", "projector"):
        v = np.array([p[f"{dev}_rms_px"] for p in poses], np.float64)
        v = v[np.isfinite(v)]
        limits[dev] = max(OUTLIER_FACTOR * float(np.median(v)), OUTLIER_FLOOR_PX) if v.size else np.inf
    out = []
    for p in poses:
        if any(np.isfinite(p[f"{d}_rms_px"]) and p[f"{d}_rms_px"] > limits[d] for d in limits):
            out.append({"name": p["name"], "camera_rms_px": p["camera_rms_px"],
                        "projector_rms_px": p["projector_rms_px"], "limit_px": dict(limits)})
    return out


def rule_text() -> str:
    """The rule, as recorded in the calibration file."""
    return (f"per-pose RMS > max({OUTLIER_FACTOR:g} x median, {OUTLIER_FLOOR_PX:g} px) in the camera or the "
            "projector: dropped, calibrated once more")
