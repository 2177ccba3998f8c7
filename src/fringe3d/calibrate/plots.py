"""Residual plots of a calibration (matplotlib, Agg backend, atomic PNG)."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from fringe3d.utils.atomic import atomic_path


def _rms(r: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.sum(r ** 2, 1)))) if len(r) else float("nan")


def _scatter(ax, res: list[np.ndarray], names: list[str], device: str, units: str, cmap) -> None:
    """Residual scatter of one device, one colour per pose (legend when few poses)."""
    allr = np.concatenate(res) if res else np.zeros((0, 2))
    for i, r in enumerate(res):
        ax.plot(r[:, 0], r[:, 1], ".", ms=3, color=cmap(i % 20), label=names[i] if i < len(names) else f"pose {i}")
    lim = max(float(np.abs(allr).max()) if len(allr) else 1e-3, 1e-6) * 1.1
    ax.set_xlim(-lim, lim)
    ax.set_ylim(-lim, lim)
    ax.set_aspect("equal")
    ax.axhline(0, color="0.7", lw=0.5)
    ax.axvline(0, color="0.7", lw=0.5)
    ax.set_title(f"{device}: RMS {_rms(allr):.4g} {units}")
    ax.set_xlabel(f"du ({units})")
    ax.set_ylabel(f"dv ({units})")
    if res:
        ax.legend(fontsize=6, ncol=2 if len(res) > 8 else 1, markerscale=2, title="pose", title_fontsize=7,
                  loc="upper right", framealpha=0.7)


def _residual_map(ax, fig, points: list[np.ndarray], res: list[np.ndarray], image_size, units: str) -> None:
    """Residual magnitude at each detected point over the camera image (u right, v down) with the
    residual vectors drawn exaggerated; a colour bar in ``units``."""
    uv, r = np.concatenate(points), np.concatenate(res)
    mag = np.hypot(r[:, 0], r[:, 1])
    sc = ax.scatter(uv[:, 0], uv[:, 1], c=mag, s=8, cmap="viridis", vmin=0, vmax=float(np.percentile(mag, 99)) or 1)
    gain = 0.04 * max(image_size) / max(float(np.percentile(mag, 95)), 1e-12)
    ax.quiver(uv[:, 0], uv[:, 1], r[:, 0] * gain, r[:, 1] * gain, angles="xy", scale_units="xy", scale=1,
              width=0.003, color="0.3")
    w, h = image_size
    ax.set_xlim(-0.5, w - 0.5)
    ax.set_ylim(h - 0.5, -0.5)
    ax.set_aspect("equal")
    ax.set_xlabel("u (camera px)")
    ax.set_ylabel("v (camera px)")
    ax.set_title(f"camera residuals over the image (vectors ×{gain:.3g})")
    fig.colorbar(sc, ax=ax, label=f"|residual| ({units})", shrink=0.8)


def residual_plot(path, camera_residuals: list[np.ndarray], projector_residuals: list[np.ndarray],
                  pose_names: list[str], title: str = "calibration reprojection residuals",
                  units: str = "px", camera_points: list[np.ndarray] | None = None,
                  image_size: tuple[int, int] | None = None) -> Path:
    """Scatter of reprojection residuals (camera, projector; one colour and legend entry per pose),
    per-pose RMS bars and, given ``camera_points`` and ``image_size``, a map of the camera residuals
    over the image.

    ``*_residuals``: per pose ``(N_i, 2)`` observed minus reprojected (``units``);
    ``camera_points``: per pose ``(N_i, 2)`` detected pixels in the same order (u, v);
    ``image_size``: camera ``(width, height)`` px. The map is left out when the shapes disagree.
    """
    import matplotlib  # heavy: loaded only when a figure is written; Agg must be chosen before pyplot
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    with_map = (camera_points is not None and image_size is not None and len(camera_points) == len(camera_residuals)
                and len(camera_points) > 0
                and all(np.shape(p) == np.shape(r) for p, r in zip(camera_points, camera_residuals)))
    if with_map:  # 2 x 2: readable when a report shows it at 800 px
        fig, grid = plt.subplots(2, 2, figsize=(11, 9.5))
        axes = grid.ravel()
    else:
        fig, axes = plt.subplots(1, 3, figsize=(13, 4.6))
    cmap = plt.get_cmap("tab20")
    _scatter(axes[0], camera_residuals, pose_names, "camera", units, cmap)
    _scatter(axes[1], projector_residuals, pose_names, "projector", units, cmap)
    x = np.arange(len(pose_names))
    cam = [_rms(r) for r in camera_residuals]
    prj = [_rms(r) for r in projector_residuals]
    axes[2].bar(x[: len(cam)] - 0.2, cam, 0.4, label="camera")
    axes[2].bar(x[: len(prj)] + 0.2, prj, 0.4, label="projector")
    axes[2].set_xticks(x, pose_names, rotation=60, fontsize=7)
    axes[2].set_ylabel(f"RMS ({units})")
    axes[2].set_title("per pose")
    axes[2].legend()
    if with_map and camera_points is not None and image_size is not None:
        _residual_map(axes[3], fig, camera_points, camera_residuals, image_size, units)
    fig.suptitle(title)
    fig.tight_layout()
    path = Path(path)
    with atomic_path(path, suffix=".png") as tmp:
        fig.savefig(tmp, dpi=110, format="png")
    plt.close(fig)
    return path
