"""Residual plots of a calibration (matplotlib, Agg backend, atomic PNG)."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from fringe3d.utils.atomic import atomic_path


def residual_plot(path, camera_residuals: list[np.ndarray], projector_residuals: list[np.ndarray],
                  pose_names: list[str], title: str = "calibration reprojection residuals",
                  units: str = "px") -> Path:
    """Scatter of reprojection residuals (camera left, projector right) plus per-pose RMS bars.

    ``*_residuals``: per pose ``(N_i, 2)`` observed minus reprojected (``units``).
    """
    import matplotlib  # heavy: loaded only when a figure is written; Agg must be chosen before pyplot
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 3, figsize=(13, 4.2))
    cmap = plt.get_cmap("tab20")
    for ax, res, name in ((axes[0], camera_residuals, "camera"), (axes[1], projector_residuals, "projector")):
        allr = np.concatenate(res) if res else np.zeros((0, 2))
        for i, r in enumerate(res):
            ax.plot(r[:, 0], r[:, 1], ".", ms=3, color=cmap(i % 20))
        rms = float(np.sqrt(np.mean(np.sum(allr ** 2, 1)))) if len(allr) else float("nan")
        lim = max(float(np.abs(allr).max()) if len(allr) else 1e-3, 1e-6) * 1.1
        ax.set_xlim(-lim, lim)
        ax.set_ylim(-lim, lim)
        ax.set_aspect("equal")
        ax.axhline(0, color="0.7", lw=0.5)
        ax.axvline(0, color="0.7", lw=0.5)
        ax.set_title(f"{name}: RMS {rms:.4g} {units}")
        ax.set_xlabel(f"du ({units})")
        ax.set_ylabel(f"dv ({units})")
    x = np.arange(len(pose_names))
    cam = [np.sqrt(np.mean(np.sum(r ** 2, 1))) for r in camera_residuals]
    prj = [np.sqrt(np.mean(np.sum(r ** 2, 1))) for r in projector_residuals]
    axes[2].bar(x[: len(cam)] - 0.2, cam, 0.4, label="camera")
    axes[2].bar(x[: len(prj)] + 0.2, prj, 0.4, label="projector")
    axes[2].set_xticks(x, pose_names, rotation=60, fontsize=7)
    axes[2].set_ylabel(f"RMS ({units})")
    axes[2].set_title("per pose")
    axes[2].legend()
    fig.suptitle(title)
    fig.tight_layout()
    path = Path(path)
    with atomic_path(path, suffix=".png") as tmp:
        fig.savefig(tmp, dpi=110, format="png")
    plt.close(fig)
    return path
