"""Calibration parameters as report tables: intrinsics ``K``, distortion, pose, baseline and the
per-pose residuals, from a ``fringe3d-calibration`` or ``fringe3d-rig`` JSON.

Baseline: distance between the two optical centres, ``|C_p - C_c|`` with ``C = -R^T t`` for each
device's world-to-device pose ``x_dev = R x + t`` (mm).
"""
from __future__ import annotations

import numpy as np


def _centre(dev: dict) -> np.ndarray | None:
    try:
        R, t = np.asarray(dev["R"], float), np.asarray(dev["t"], float)
    except (KeyError, TypeError, ValueError):
        return None
    return -R.T @ t if R.shape == (3, 3) and t.shape == (3,) else None


def device_rows(rig: dict) -> tuple[list[str], list[list]]:
    """Header and one row per device (camera, projector): size, fx, fy, cx, cy, distortion."""
    rows = []
    for name in ("camera", "projector"):
        d = rig.get(name)
        if not isinstance(d, dict):
            continue
        K = np.asarray(d.get("K", np.full((3, 3), np.nan)), float)
        dist = d.get("dist")
        size = f"{d.get('width', '?')} x {d.get('height', '?')}"
        rows.append([name, d.get("kind", ""), size, K[0, 0], K[1, 1], K[0, 2], K[1, 2],
                     ", ".join(f"{float(v):.4g}" for v in (dist or [])) or "—"])
    return ["device", "model", "pixels", "fx (px)", "fy (px)", "cx (px)", "cy (px)", "distortion"], rows


def baseline_mm(rig: dict) -> float | None:
    """Camera-projector baseline (mm), or None when a pose is missing (e.g. telecentric rigs)."""
    cc, cp = _centre(rig.get("camera") or {}), _centre(rig.get("projector") or {})
    return None if cc is None or cp is None else float(np.linalg.norm(cp - cc))


def calibration_tables(cal: dict) -> list[tuple[str, list[str], list[list]]]:
    """``(title, header, rows)`` tables for a calibration or rig dict."""
    rig = cal.get("rig", cal)
    out = [("Devices (intrinsics K and distortion)", *device_rows(rig))]
    summary = [["format", cal.get("format", "")], ["model", cal.get("model", rig.get("camera", {}).get("kind", ""))]]
    b = baseline_mm(rig)
    if b is not None:
        summary.append(["baseline |C_p - C_c| (mm)", b])
    for k, v in (cal.get("rms") or {}).items():
        summary.append([f"RMS {k}", v])
    out.append(("Summary", ["quantity", "value"], summary))
    poses = cal.get("poses") or []
    if poses and isinstance(poses[0], dict):
        keys = [k for k in poses[0] if not isinstance(poses[0][k], (list, dict))]
        out.append(("Per-pose residuals", keys, [[p.get(k) for k in keys] for p in poses]))
    return out
