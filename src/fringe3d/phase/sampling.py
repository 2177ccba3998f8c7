"""Bilinear sampling of an image at sub-pixel points (Eq. 2.30-2.31: the phase at a circle centre,
Eq. 2.30-2.31, "phase sampled by bilinear interpolation at the sub-pixel centre").

Pixel centres sit at integer coordinates: ``image[r, c]`` is the value at ``(u, v) = (c, r)``.
"""
from __future__ import annotations

from typing import Literal

import numpy as np


def sample_bilinear(image, uv, *, outside: Literal["nan", "clamp"] = "nan",
                    combine: Literal["corners", "rows"] = "corners",
                    nonfinite: Literal["propagate", "nan"] = "propagate") -> np.ndarray:
    """Bilinear interpolation of ``image`` at sub-pixel points ``uv = (u, v)`` (column, row).

    With ``(u0, v0)`` the top-left of the 2x2 pixel neighbourhood (``floor``, kept one pixel
    inside the last row/column) and ``(f_u, f_v) = (u - u0, v - v0)``, the sample is
    ``I00 (1-f_u)(1-f_v) + I01 f_u (1-f_v) + I10 (1-f_u) f_v + I11 f_u f_v``.

    Parameters
    ----------
    image : (H, W) or (H, W, C) array_like
        Sampled as float64.
    uv : (N, 2) array_like (any shape ending in 2 is flattened to (N, 2))
        Points ``(u, v)`` in pixels.
    outside : ``"nan"`` or ``"clamp"``
        ``"nan"``: NaN for points outside ``[0, W-1] x [0, H-1]`` or with a non-finite
        coordinate. ``"clamp"``: coordinates are clamped into the image (edge value beyond
        it); a NaN coordinate gives 0.
    combine : ``"corners"`` or ``"rows"``
        Order of the arithmetic: ``"corners"`` sums the four weighted corners as written
        above; ``"rows"`` interpolates along each row first,
        ``(1-f_v)((1-f_u) I00 + f_u I01) + f_v((1-f_u) I10 + f_u I11)``. Equal up to rounding.
    nonfinite : ``"propagate"`` or ``"nan"``
        ``"propagate"``: a NaN (inf) among the used pixels gives NaN (inf, or NaN);
        ``"nan"``: every non-finite sample becomes NaN.

    Returns
    -------
    (N,) or (N, C) float64.

    Examples
    --------
    >>> import numpy as np
    >>> img = np.arange(12.0).reshape(3, 4)  # value = 4 v + u
    >>> sample_bilinear(img, [[1.5, 0.5], [3.0, 2.0], [3.5, 0.0]]).tolist()
    [3.5, 11.0, nan]
    """
    if outside not in ("nan", "clamp"):
        raise ValueError(f"outside must be 'nan' or 'clamp', got {outside!r}")
    if combine not in ("corners", "rows"):
        raise ValueError(f"combine must be 'corners' or 'rows', got {combine!r}")
    if nonfinite not in ("propagate", "nan"):
        raise ValueError(f"nonfinite must be 'propagate' or 'nan', got {nonfinite!r}")
    img = np.asarray(image, dtype=np.float64)
    uv = np.asarray(uv, dtype=np.float64).reshape(-1, 2)
    h, w = img.shape[:2]
    u, v = uv[:, 0], uv[:, 1]
    if outside == "nan":
        ok = (u >= 0) & (v >= 0) & (u <= w - 1) & (v <= h - 1) & np.isfinite(u) & np.isfinite(v)
        uz, vz = np.where(ok, u, 0), np.where(ok, v, 0)
    else:
        ok = ~(np.isnan(u) | np.isnan(v))
        uz, vz = np.where(ok, np.clip(u, 0.0, w - 1.0), 0), np.where(ok, np.clip(v, 0.0, h - 1.0), 0)
    u0 = np.clip(np.floor(uz).astype(int), 0, max(w - 2, 0))
    v0 = np.clip(np.floor(vz).astype(int), 0, max(h - 2, 0))
    fu, fv = uz - u0, vz - v0
    u1, v1 = np.minimum(u0 + 1, w - 1), np.minimum(v0 + 1, h - 1)
    if img.ndim == 3:
        fu, fv, ok = fu[:, None], fv[:, None], ok[:, None]
    with np.errstate(invalid="ignore" if nonfinite == "nan" else None):
        if combine == "corners":
            val = (img[v0, u0] * (1 - fu) * (1 - fv) + img[v0, u1] * fu * (1 - fv)
                   + img[v1, u0] * (1 - fu) * fv + img[v1, u1] * fu * fv)
        else:
            val = ((1 - fv) * ((1 - fu) * img[v0, u0] + fu * img[v0, u1])
                   + fv * ((1 - fu) * img[v1, u0] + fu * img[v1, u1]))
    if nonfinite == "nan":
        val = np.where(np.isfinite(val), val, np.nan)
    return np.where(ok, val, np.nan if outside == "nan" else 0.0)
