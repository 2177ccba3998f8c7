"""What a live view draws from one reconstructed cycle: the points with colours, and the mask overlay.

* :func:`display_points`: the valid points of an ``(H, W, 3)`` point map (every ``step``-th
  pixel in both directions), as ``(N, 3)`` float32 mm exactly as the engine computed them, with
  ``(N, 3)`` uint8 colours: by depth (a fixed colour map over a fixed depth range, so colours
  do not flicker from frame to frame) or by texture (grey).
* :func:`mask_overlay`: the texture in grey with every masked pixel tinted by why it was
  masked (:mod:`fringe3d.decode.edges` bits): red where the modulation, saturation or code
  failed (``INVALID``), orange for the edge and mixed-pixel tests.
* :func:`depth_image`: the depth map as an RGB image, by depth on the same colour ramp and range
  as the points, masked pixels in the overlay's colours, with a colour bar labelled in mm
  underneath: a view a browser shows as an ordinary image (no WebGL).
"""
from __future__ import annotations

import numpy as np

import functools

import cv2

from fringe3d.decode.edges import INVALID

from ._display_kernel import colour_depth, gather_points

#: Colourings of the points.
COLOURINGS = ("z", "texture")
#: What the live view shows: the point cloud, or the depth map as an image.
VIEWS = ("cloud", "depth")
#: Colours of masked pixels in :func:`depth_image`: the mask overlay's tints on mid grey
#: (``INVALID`` or no depth: red; the edge and mixed-pixel tests: orange).
MASKED_INVALID = (201, 0, 0)
MASKED_OTHER = (201, 118, 0)
#: Rows of the colour bar under :func:`depth_image` (the ramp, then its range in mm).
BAR_ROWS = 24

# a perceptual blue -> green -> yellow ramp (viridis at 5 stops), interpolated linearly into 256 colours
_RAMP = np.array([[68, 1, 84], [59, 82, 139], [33, 145, 140], [94, 201, 98], [253, 231, 37]], np.float32)
_LUT = np.stack([np.interp(np.linspace(0, len(_RAMP) - 1, 256), np.arange(len(_RAMP)), _RAMP[:, c])
                 for c in range(3)], axis=1).round().astype(np.uint8)


def decimated(points: np.ndarray, step: int) -> np.ndarray:
    """Every ``step``-th pixel of a map in both directions (a view, not a copy).

    Parameters
    ----------
    points : (H, W, ...) ndarray
        A per-pixel map.
    step : int
        Pixel stride (1 keeps every pixel).

    Returns
    -------
    ndarray
        ``points[::step, ::step]``.
    """
    if int(step) < 1:
        raise ValueError(f"step is a pixel stride of at least 1, got {step}")
    return points[::int(step), ::int(step)]


def depth_colours(z: np.ndarray, z_range: tuple[float, float]) -> np.ndarray:
    """Colours of depths on a fixed ramp (near blue, far yellow).

    Parameters
    ----------
    z : (N,) ndarray
        Depths (mm).
    z_range : (float, float)
        Depths (mm) mapped to the ramp's ends; depths outside are clipped.

    Returns
    -------
    (N, 3) uint8 ndarray
        RGB colours (256 steps over ``z_range``).
    """
    z0, z1 = float(z_range[0]), float(z_range[1])
    t = np.asarray(z, np.float32) - np.float32(z0)
    t *= np.float32(255.0 / max(z1 - z0, 1e-6))
    np.clip(t, 0.0, 255.0, out=t)
    return _LUT[(t + np.float32(0.5)).astype(np.uint8)]


def display_points(points: np.ndarray, texture: np.ndarray | None, colouring: str, z_range: tuple[float, float],
                   step: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """The valid points of a point map and their colours, for drawing.

    Parameters
    ----------
    points : (H, W, 3) float32 ndarray
        The point map (mm), NaN where invalid.
    texture : (H, W) float32 ndarray or None
        The texture in [0, 1] (needed for ``colouring="texture"``).
    colouring : str
        ``"z"`` (by depth over ``z_range``) or ``"texture"`` (grey).
    z_range : (float, float)
        Depths (mm) at the colour ramp's ends.
    step : int
        Draw every ``step``-th pixel in both directions.

    Returns
    -------
    points : (N, 3) float32 ndarray
        The valid points (mm), in row-major pixel order, exactly as in ``points``.
    colours : (N, 3) uint8 ndarray
        RGB colour of each point.
    """
    if colouring not in COLOURINGS:
        raise ValueError(f"colouring must be one of {', '.join(COLOURINGS)}, got {colouring!r}")
    if int(step) < 1:
        raise ValueError(f"step is a pixel stride of at least 1, got {step}")
    if points.ndim != 3 or points.shape[2] != 3:
        raise ValueError(f"points must be an (H, W, 3) point map, got shape {points.shape}")
    use_texture = colouring == "texture"
    if use_texture and texture is None:
        raise ValueError("colouring by texture needs the texture (reconstruct with texture)")
    tex = texture if use_texture else np.zeros((1, 1), np.float32)
    z0, z1 = float(z_range[0]), float(z_range[1])
    return gather_points(points, tex, use_texture, int(step), z0, 255.0 / max(z1 - z0, 1e-6), _LUT)


@functools.lru_cache(maxsize=8)
def colour_bar(width: int, z_range: tuple[float, float]) -> np.ndarray:
    """The colour bar under :func:`depth_image`: the ramp over ``z_range``, left to right, and the
    range's ends in mm (black on white).

    Parameters
    ----------
    width : int
        Columns.
    z_range : (float, float)
        Depths (mm) at the ramp's ends.

    Returns
    -------
    (BAR_ROWS, width, 3) uint8 ndarray
        The bar (read-only: it is shared).
    """
    z0, z1 = float(z_range[0]), float(z_range[1])
    bar = np.full((BAR_ROWS, int(width), 3), 255, np.uint8)
    bar[:BAR_ROWS // 2] = depth_colours(np.linspace(z0, z1, int(width)), (z0, z1))[None]
    font, scale = cv2.FONT_HERSHEY_SIMPLEX, 0.35
    right = f"{z1:g} mm"
    (tw, _), _ = cv2.getTextSize(right, font, scale, 1)
    cv2.putText(bar, f"{z0:g} mm", (2, BAR_ROWS - 2), font, scale, (0, 0, 0), 1, cv2.LINE_AA)
    cv2.putText(bar, right, (max(0, int(width) - tw - 2), BAR_ROWS - 2), font, scale, (0, 0, 0), 1, cv2.LINE_AA)
    bar.flags.writeable = False
    return bar


def depth_image(points: np.ndarray, quality: np.ndarray | None, z_range: tuple[float, float],
                step: int = 1) -> np.ndarray:
    """The depth map as an RGB image: by depth on the points' ramp, masked pixels by reason, and a
    colour bar underneath.

    Parameters
    ----------
    points : (H, W, 3) float32 ndarray
        The point map (mm), NaN where invalid.
    quality : (H, W) uint8 ndarray or None
        The quality bits (0 = kept; :mod:`fringe3d.decode.edges`); None: every pixel without a
        depth is ``INVALID``.
    z_range : (float, float)
        Depths (mm) at the ramp's ends (as :func:`depth_colours`; outside: clipped).
    step : int
        Every ``step``-th pixel in both directions.

    Returns
    -------
    (h + BAR_ROWS, w, 3) uint8 ndarray
        Rows ``:h``: the colour of :func:`depth_colours` where the depth is finite,
        :data:`MASKED_OTHER` where the quality bits say edge or mixed pixel,
        :data:`MASKED_INVALID` elsewhere; rows ``h:``: :func:`colour_bar`.
    """
    if points.ndim != 3 or points.shape[2] != 3:
        raise ValueError(f"points must be an (H, W, 3) point map, got shape {points.shape}")
    if int(step) < 1:
        raise ValueError(f"step is a pixel stride of at least 1, got {step}")
    H, W = points.shape[:2]
    h, w = -(-H // int(step)), -(-W // int(step))
    if quality is not None and quality.shape != (H, W):
        raise ValueError(f"quality must be the point map's (H, W) = {(H, W)}, got shape {quality.shape}")
    out = np.empty((h + BAR_ROWS, w, 3), np.uint8)
    z0, z1 = float(z_range[0]), float(z_range[1])
    q = quality if quality is not None else np.full((1, 1), INVALID, np.uint8)
    colour_depth(points, q, int(step), z0, 255.0 / max(z1 - z0, 1e-6), _LUT, np.array(MASKED_INVALID, np.uint8),
                 np.array(MASKED_OTHER, np.uint8), np.uint8(INVALID), out)
    out[h:] = colour_bar(w, (z0, z1))
    return out


def mask_overlay(texture: np.ndarray | None, quality: np.ndarray, width: int | None = None) -> np.ndarray:
    """The texture with masked pixels tinted by reason, as an RGB image.

    Parameters
    ----------
    texture : (H, W) float32 ndarray or None
        The texture in [0, 1]; None draws mid grey.
    quality : (H, W) uint8 ndarray
        The quality bits (0 = kept; :mod:`fringe3d.decode.edges`).
    width : int, optional
        Shrink the image (every k-th pixel) to at most this many columns.

    Returns
    -------
    (h, w, 3) uint8 ndarray
        Kept pixels grey (the texture), ``INVALID`` ones red, other masked ones orange.
    """
    H, W = quality.shape
    k = max(1, int(np.ceil(W / width))) if width else 1
    q = quality[::k, ::k]
    g = (np.full(q.shape, 0.5, np.float32) if texture is None else np.clip(texture[::k, ::k], 0.0, 1.0))
    grey = (g * 255.0 + 0.5).astype(np.uint8)
    img = np.repeat(grey[..., None], 3, axis=2)
    invalid = (q & INVALID) != 0
    other = (q != 0) & ~invalid
    img[invalid] = (grey[invalid, None] * np.array([0.4, 0.0, 0.0]) + np.array([150, 0, 0])).astype(np.uint8)
    img[other] = (grey[other, None] * np.array([0.4, 0.3, 0.0]) + np.array([150, 80, 0])).astype(np.uint8)
    return img
