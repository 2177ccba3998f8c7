"""Strain figures as DIC users expect: per-frame maps with a colour bar and units, an animation.

Matplotlib's Agg backend (no display needed); every file written atomically.
"""
from __future__ import annotations

import os
from typing import Sequence

import numpy as np

from fringe3d.utils.atomic import atomic_path

__all__ = ["strain_map_png", "strain_animation", "scatter_to_image"]


def _mpl():
    import matplotlib  # optional heavy dependency: loaded only when a figure is drawn
    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt
    return plt


def scatter_to_image(uv: np.ndarray, values: np.ndarray, shape: tuple[int, int], radius: int = 1) -> np.ndarray:
    """Paint per-point ``values`` at pixel positions ``uv`` (N,2) into an (H, W) float image
    (NaN elsewhere); each point covers a (2·radius+1)² square so subsampled grids stay dense."""
    img = np.full(shape, np.nan)
    uv = np.asarray(uv, float)
    good = np.isfinite(uv).all(axis=1) & np.isfinite(values)
    u = np.round(uv[good, 0]).astype(int)
    v = np.round(uv[good, 1]).astype(int)
    val = np.asarray(values)[good]
    for dv in range(-radius, radius + 1):
        for du in range(-radius, radius + 1):
            uu, vv = u + du, v + dv
            m = (uu >= 0) & (vv >= 0) & (uu < shape[1]) & (vv < shape[0])
            img[vv[m], uu[m]] = val[m]
    return img


def _draw(ax, image, vmax, title, background=None):
    if background is not None:
        ax.imshow(background, cmap="gray")
    im = ax.imshow(image * 1e6, cmap="RdBu_r", vmin=-vmax * 1e6, vmax=vmax * 1e6, interpolation="nearest")
    ax.set_title(title)
    ax.set_xlabel("u (px)")
    ax.set_ylabel("v (px)")
    return im


def strain_map_png(path: str | os.PathLike, image: np.ndarray, title: str = "dominant bending strain",
                   vmax: float | None = None, background: np.ndarray | None = None) -> None:
    """One strain map (H, W) (dimensionless, NaN = no data) as PNG, colour bar in µε."""
    plt = _mpl()
    if vmax is None:
        finite = np.abs(image[np.isfinite(image)])
        vmax = float(np.percentile(finite, 99)) if finite.size else 1e-6
    vmax = max(vmax, 1e-12)
    fig, ax = plt.subplots(figsize=(6.4, 4.8), dpi=100)
    im = _draw(ax, image, vmax, title, background)
    fig.colorbar(im, ax=ax, label="strain E (µε = 10⁻⁶)")
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png")
    plt.close(fig)


def strain_animation(path: str | os.PathLike, images: Sequence[np.ndarray], titles: list[str] | None = None,
                     vmax: float | None = None, fps: float = 10.0) -> None:
    """Animated GIF of strain maps (one per frame) with a fixed colour scale (µε), via Pillow."""
    plt = _mpl()
    from matplotlib.animation import FuncAnimation, PillowWriter  # optional heavy dependency (see _mpl)

    if not images:
        raise ValueError("no strain maps to animate; expected at least one frame")
    if vmax is None:
        allv = np.concatenate([np.abs(im[np.isfinite(im)]) for im in images])
        vmax = float(np.percentile(allv, 99)) if allv.size else 1e-6
    vmax = max(vmax, 1e-12)
    titles = titles or [f"frame {i}" for i in range(len(images))]
    fig, ax = plt.subplots(figsize=(6.4, 4.8), dpi=80)
    im = _draw(ax, images[0], vmax, titles[0])
    fig.colorbar(im, ax=ax, label="strain E (µε = 10⁻⁶)")
    fig.tight_layout()

    def update(i):
        im.set_data(images[i] * 1e6)
        ax.set_title(titles[i])
        return (im,)

    anim = FuncAnimation(fig, update, frames=len(images), blit=False)
    with atomic_path(path, suffix=".gif") as tmp:
        anim.save(str(tmp), writer=PillowWriter(fps=fps))  # type: ignore[arg-type]  # matplotlib stubs say int; a float rate works
    plt.close(fig)
