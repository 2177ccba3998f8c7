"""Segmentation of spatially isolated objects and their frame-to-frame motion (ch. 5.2.5).

The hybrid FTP + PSP framework (Fig. 5.4) first separates the isolated objects of a scene,
unwraps each one spatially, and compensates each object's motion between frames by the
shift of its bounding-box centre. This module holds those three small steps:

* :func:`modulation_mask` keeps the pixels whose fringes are well modulated relative to the
  scene's robust modulation level (never a cut on average brightness, so a dark but
  well-modulated surface stays);
* :func:`segment_objects` labels the connected valid regions of a mask
  (``skimage.measure.label``) and drops the tiny ones;
* :func:`box_centres` gives each label's bounding-box centre ``(u, v)`` in pixels;
* :func:`match_objects` pairs the objects of two label maps (nearest centres, one to one)
  and returns the displacement ``(du, dv)`` of Eq. (5.13).

Pixel (0, 0) is the centre of the top-left pixel; ``u`` is the column, ``v`` the row.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


def _check_mask(mask, name: str = "mask") -> np.ndarray:
    mask = np.asarray(mask)
    if mask.ndim != 2:
        raise ValueError(f"{name} must be a 2-D (H, W) array, got shape {mask.shape}")
    return mask.astype(bool, copy=False)


def foreground_mask(average: np.ndarray, modulation: np.ndarray | None = None,
                    min_ratio: float = 0.15) -> np.ndarray:
    """Pixels lit by the projector on an object, from the average intensity and modulation.

    Otsu's threshold (``skimage.filters.threshold_otsu``) on the average intensity ``I'``
    separates the objects from the dark background; with ``modulation`` the pixel must also
    have ``I'' >= min_ratio * I'`` (fringes visible, not just ambient light).

    Parameters
    ----------
    average, modulation : (H, W) float
        ``I'`` and ``I''`` in the frames' units (e.g. ``PhaseResult.average / .modulation``).
    min_ratio : float
        Smallest accepted fringe contrast ``I''/I'``.

    Returns
    -------
    (H, W) bool
    """

    average = np.asarray(average, np.float64)
    if average.ndim != 2:
        raise ValueError(f"average intensity must be a 2-D (H, W) array, got shape {average.shape}")
    finite = np.isfinite(average)
    if not finite.any() or np.ptp(average[finite]) <= 0:
        raise ValueError("the average intensity is constant (all-dark or saturated frames?); "
                         "cannot separate objects from the background")
    from skimage.filters import threshold_otsu  # heavy (brings scipy.ndimage): loaded with the first Otsu mask

    mask = finite & (average > threshold_otsu(average[finite]))
    if modulation is not None:
        modulation = np.asarray(modulation, np.float64)
        if modulation.shape != average.shape:
            raise ValueError(f"modulation shape {modulation.shape} differs from average shape {average.shape}")
        with np.errstate(invalid="ignore"):
            mask &= modulation >= min_ratio * average
    return mask


#: :func:`modulation_mask` defaults: keep ``B >= MODULATION_FRACTION * percentile_99(B)``.
MODULATION_FRACTION = 0.05
MODULATION_PERCENTILE = 99.0


def modulation_mask(modulation: np.ndarray, valid: np.ndarray | None = None,
                    fraction: float = MODULATION_FRACTION, percentile: float = MODULATION_PERCENTILE) -> np.ndarray:
    """Pixels whose fringe modulation is a usable share of the scene's best: the object mask of
    the per-object (spatial) unwrapper.

    The N-step phase noise is ``sigma_phi = sqrt(2 / N) sigma_I / B`` (Eq. 2.3-2.4 with additive
    noise ``sigma_I``), so the modulation ``B`` alone says how good a pixel's phase is, whatever its
    albedo. A pixel is kept when ``B >= fraction * level`` with ``level`` the ``percentile`` of
    ``B`` over the ``valid`` finite pixels (a robust "well lit" modulation: one hot pixel does not
    move it): with the defaults its phase noise is at most 20 times that of the scene's
    best-modulated pixels. Average brightness plays no part: a dark surface (albedo 0.1 beside
    0.9) has a tenth of the modulation and stays, while the background (no fringes, ``B`` at the
    noise floor) goes. The absolute floor (the decoder's ``min_modulation``, saturation) is the
    ``valid`` mask's job.

    Parameters
    ----------
    modulation : (H, W) float
        ``B`` in the frames' units (``PhaseResult.modulation``).
    valid : (H, W) bool, optional
        Pixels that may be kept (e.g. the decoder's validity mask); default all finite ones.
    fraction : float
        Share of the robust level a pixel needs, in (0, 1].
    percentile : float
        Percentile of the valid modulation taken as the robust level, in (0, 100].

    Returns
    -------
    (H, W) bool
        All False when no pixel is valid.

    Examples
    --------
    >>> import numpy as np
    >>> B = np.array([[60.0, 6.0], [0.5, 55.0]])   # bright, dark (albedo 0.1), background, bright
    >>> modulation_mask(B)
    array([[ True,  True],
           [False,  True]])
    """
    modulation = np.asarray(modulation, np.float64)
    if modulation.ndim != 2:
        raise ValueError(f"modulation must be a 2-D (H, W) array, got shape {modulation.shape}")
    if not 0 < fraction <= 1 or not 0 < percentile <= 100:
        raise ValueError(f"fraction must be in (0, 1] and percentile in (0, 100], got {fraction}, {percentile}")
    ok = np.isfinite(modulation)
    if valid is not None:
        ok &= _check_mask(valid, "valid")
    if not ok.any():
        return ok
    level = float(np.percentile(modulation[ok], percentile))
    return ok & (modulation >= fraction * level) & (modulation > 0)


def segment_objects(mask: np.ndarray, min_size: int = 64, connectivity: int = 1,
                    erode: int = 0) -> np.ndarray:
    """Label the connected valid regions of ``mask``; regions under ``min_size`` pixels are dropped.

    Parameters
    ----------
    mask : (H, W) bool
        Valid pixels (e.g. modulation above a threshold).
    min_size : int
        Smallest object kept, in pixels (after erosion).
    connectivity : int
        1 = 4-connected, 2 = 8-connected (as ``skimage.measure.label``).
    erode : int
        Optional binary erosion radius in pixels applied before labelling, to cut thin bridges
        between touching objects and the unreliable rim pixels.

    Returns
    -------
    labels : (H, W) int32
        0 = background, 1..n = objects, numbered in raster order of their first pixel.
    """
    mask = _check_mask(mask)
    if min_size < 1:
        raise ValueError(f"min_size must be >= 1 pixel, got {min_size}")
    if erode > 0:
        from scipy import ndimage  # heavy (0.25 s with scipy.special): loaded when a mask is eroded

        mask = ndimage.binary_erosion(mask, structure=np.ones((2 * erode + 1,) * 2, bool))
    from skimage.measure import label as sk_label  # heavy (brings scipy.ndimage): loaded with the first labels

    labels = sk_label(mask, connectivity=connectivity).astype(np.int32)
    if labels.max() == 0:
        return labels
    sizes = np.bincount(labels.ravel())
    keep = sizes >= min_size
    keep[0] = False
    new_id = np.zeros(sizes.size, np.int32)
    new_id[keep] = np.arange(1, int(keep.sum()) + 1, dtype=np.int32)
    return new_id[labels]


def box_centres(labels: np.ndarray) -> dict[int, tuple[float, float]]:
    """Bounding-box centre ``(u, v)`` (pixels) of every label > 0.

    The centre of a box spanning columns ``u0..u1`` and rows ``v0..v1`` (inclusive pixel
    centres) is ``((u0 + u1)/2, (v0 + v1)/2)``.
    """
    from scipy import ndimage  # heavy (0.25 s with scipy.special): loaded when boxes are measured

    labels = np.asarray(labels)
    out: dict[int, tuple[float, float]] = {}
    for i, sl in enumerate(ndimage.find_objects(labels), start=1):
        if sl is None:
            continue
        rows, cols = sl
        out[i] = ((cols.start + cols.stop - 1) / 2.0, (rows.start + rows.stop - 1) / 2.0)
    return out


@dataclass(frozen=True)
class ObjectMatch:
    """One object seen in two frames: label in frame a, label in frame b and the shift a -> b."""

    label_a: int
    label_b: int
    du: float
    dv: float


def match_objects(labels_a: np.ndarray, labels_b: np.ndarray,
                  max_shift: float | None = None) -> list[ObjectMatch]:
    """Pair the objects of two label maps by their bounding-box centres (one to one).

    The pairing minimises the summed centre distance (Hungarian assignment,
    ``scipy.optimize.linear_sum_assignment``). The shift ``(du, dv) = centre_b - centre_a``
    is the motion compensation ``(Δu, Δv)`` of Eq. (5.13).

    Parameters
    ----------
    labels_a, labels_b : (H, W) int
        Label maps from :func:`segment_objects`.
    max_shift : float, optional
        Pairs whose centres are further apart than this (pixels) are left unmatched.

    Returns
    -------
    list of :class:`ObjectMatch`, sorted by ``label_a``.
    """
    ca, cb = box_centres(labels_a), box_centres(labels_b)
    if np.shape(labels_a) != np.shape(labels_b):
        raise ValueError(f"label maps differ in shape: {np.shape(labels_a)} vs {np.shape(labels_b)}")
    if not ca or not cb:
        return []
    ka, kb = list(ca), list(cb)
    pa = np.array([ca[k] for k in ka])
    pb = np.array([cb[k] for k in kb])
    dist = np.linalg.norm(pa[:, None, :] - pb[None, :, :], axis=-1)
    from scipy.optimize import linear_sum_assignment  # heavy (0.5 s): loaded when segments are matched

    rows, cols = linear_sum_assignment(dist)
    out = []
    for r, c in zip(rows, cols):
        if max_shift is not None and dist[r, c] > max_shift:
            continue
        out.append(ObjectMatch(ka[r], kb[c], float(pb[c, 0] - pa[r, 0]), float(pb[c, 1] - pa[r, 1])))
    return sorted(out, key=lambda m: m.label_a)


def shift_image(image: np.ndarray, du: float, dv: float, fill=np.nan) -> np.ndarray:
    """``out(u, v) = image(u + du, v + dv)`` with the shift rounded to whole pixels.

    Pixels whose source falls outside the image get ``fill``. Whole-pixel shifts keep phase
    values intact (no blending across 2π jumps or object edges), as the bounding-box motion
    estimate of Eq. (5.13) is itself only pixel-accurate.

    Parameters
    ----------
    image : (H, W, ...) array_like
        The image.
    du, dv : float
        Shift along columns and rows (px), rounded to whole pixels.
    fill : scalar
        Value of pixels whose source is outside the image (default NaN).

    Returns
    -------
    ndarray
        The shifted image, shape of ``image``, dtype that holds both ``image`` and ``fill``.
    """
    image = np.asarray(image)
    su, sv = int(round(du)), int(round(dv))
    out = np.full(image.shape, fill, dtype=np.result_type(image.dtype, np.asarray(fill).dtype))
    h, w = image.shape[:2]
    # destination rows v take source rows v + sv
    v0, v1 = max(0, -sv), min(h, h - sv)
    u0, u1 = max(0, -su), min(w, w - su)
    if v1 > v0 and u1 > u0:
        out[v0:v1, u0:u1] = image[v0 + sv:v1 + sv, u0 + su:u1 + su]
    return out
