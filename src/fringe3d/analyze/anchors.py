"""Anchor dots: find them in the texture image, check them against the point map, and turn
them into geodesic distance maps (dissertation ch. 6.2: two black anchor dots per wing).

Dark, compact blobs inside the bright (valid) surface are labelled with scikit-image; their
intensity-weighted centroids are the sub-pixel anchor positions (u column, v row).
"""
from __future__ import annotations

import numpy as np
from scipy import ndimage
from skimage import measure

from fringe3d.analyze.geodesic import check_point_map, grid_geodesic, step_table, table_geodesics
from fringe3d.io.point_sequence import PointSequence

__all__ = ["dark_dots", "fill_dot_holes", "find_anchor_dots", "check_anchor", "distance_maps", "pair_anchors",
           "parse_anchors", "follow_anchors", "auto_anchors", "query_grid"]


def dark_dots(texture: np.ndarray, min_area: float = 4.0, max_area: float = 2000.0, darkness: float = 0.5,
              surface: np.ndarray | None = None) -> np.ndarray:
    """All dark dots on the surface: (K, 3) rows (u, v, area px), largest first.

    texture : (H, W) intensity image (any dtype). A dot is a connected set of pixels darker
    than ``darkness`` × the median surface brightness, not touching the image border, with
    ``min_area ≤ area ≤ max_area`` pixels, enclosed by surface pixels. Centroids are
    darkness-weighted (sub-pixel). surface : optional (H, W) bool of surface pixels (default:
    pixels brighter than 25 % of the 99th percentile, holes filled so the dots count as surface).
    """
    img = np.asarray(texture, dtype=np.float64)
    if img.ndim != 2:
        raise ValueError(f"texture must be a 2D image; got shape {img.shape}")
    if not np.isfinite(img).any():
        raise ValueError("texture image has no finite pixels")
    img = np.nan_to_num(img, nan=0.0)
    if surface is None:
        surface = ndimage.binary_fill_holes(img > 0.25 * np.percentile(img, 99))
    else:
        surface = ndimage.binary_fill_holes(np.asarray(surface, bool))
    if not surface.any():
        raise ValueError("no surface found in the texture image (all dark?); expected a lit wing")
    level = darkness * np.median(img[surface])
    lab = measure.label((img < level) & surface, connectivity=2)
    h, w = img.shape
    blobs = []
    for reg in measure.regionprops(lab, intensity_image=level - img):
        r0, c0, r1, c1 = reg.bbox
        if r0 == 0 or c0 == 0 or r1 == h or c1 == w or not (min_area <= reg.area <= max_area):
            continue
        cy, cx = reg.centroid_weighted
        blobs.append((cx, cy, reg.area))
    blobs.sort(key=lambda b: -b[2])
    return np.array(blobs, dtype=np.float64).reshape(-1, 3)


def find_anchor_dots(texture: np.ndarray, count: int = 2, min_area: float = 4.0, max_area: float = 2000.0,
                     darkness: float = 0.5, surface: np.ndarray | None = None) -> np.ndarray:
    """Centroids (count, 2) (u, v) of the ``count`` largest dark dots (:func:`dark_dots`).

    Raises ``ValueError`` if fewer than ``count`` dots are found. Rows are ordered by u, then v.

    Parameters
    ----------
    texture : (H, W) array
        Intensity image (any dtype).
    count : int
        Number of dots wanted (the largest by area).
    min_area, max_area : float
        Accepted dot area, pixels.
    darkness : float
        A dot pixel is darker than ``darkness`` x the median surface brightness.
    surface : (H, W) bool array, optional
        Surface pixels; default pixels brighter than 25 % of the 99th percentile (holes filled).

    Returns
    -------
    (count, 2) ndarray (float64)
        Dot centroids (u column, v row), pixels, sub-pixel.
    """
    blobs = dark_dots(texture, min_area, max_area, darkness, surface)
    if len(blobs) < count:
        raise ValueError(f"found {len(blobs)} anchor dot(s) in the texture image; expected {count} dark dots "
                         f"of {min_area:g}–{max_area:g} px on the surface (pass `anchors` u1,v1,u2,v2 instead)")
    pts = blobs[:count, :2]
    return pts[np.lexsort((pts[:, 1], pts[:, 0]))]


def pair_anchors(anchors: np.ndarray, points: np.ndarray) -> list[np.ndarray]:
    """Group anchor dots into pairs lying on the same connected surface region (one per wing).

    Raises ``ValueError`` if a region does not hold exactly two anchors.

    Parameters
    ----------
    anchors : (2k, 2) array
        Anchor dots (u column, v row), pixels.
    points : (H, W, 3) float array
        Organized point map, mm, NaN where invalid.

    Returns
    -------
    list of (2, 2) ndarray
        One pair of anchors (u, v) per surface region, regions ordered by their smallest u.
    """
    valid = np.isfinite(check_point_map(points)).all(axis=2)
    lab = measure.label(ndimage.binary_closing(valid, iterations=3), connectivity=1)
    groups: dict[int, list] = {}
    for a in anchors:
        u, v = int(round(a[0])), int(round(a[1]))
        groups.setdefault(int(lab[v, u]), []).append(a)
    if 0 in groups:
        raise ValueError("an anchor dot lies outside every reconstructed surface region")
    pairs = []
    for key in sorted(groups, key=lambda k: min(p[0] for p in groups[k])):
        g = groups[key]
        if len(g) != 2:
            raise ValueError(f"a surface region holds {len(g)} anchor dots; expected exactly two per wing")
        pairs.append(np.array(g))
    return pairs


def check_anchor(points: np.ndarray, uv, radius: int = 1) -> None:
    """Raise ``ValueError`` unless the pixel cell around ``uv`` lies on valid points.

    Parameters
    ----------
    points : (H, W, 3) float array
        Organized point map, mm, NaN where invalid.
    uv : (u, v)
        Anchor position (column, row), pixels, sub-pixel allowed; must lie inside the frame.
    radius : int
        Half-size of the pixel block checked: rows ``floor(v) - radius + 1 .. floor(v) + radius``
        (and likewise columns); 1 checks the 2x2 cell around ``uv``.
    """
    pts = check_point_map(points)
    h, w, _ = pts.shape
    u, v = float(uv[0]), float(uv[1])
    if not (0 <= u <= w - 1 and 0 <= v <= h - 1):
        raise ValueError(f"anchor (u={u:.1f}, v={v:.1f}) is outside the {w}×{h} frame")
    r0, c0 = int(np.floor(v)), int(np.floor(u))
    cell = pts[max(r0 - radius + 1, 0):r0 + radius + 1, max(c0 - radius + 1, 0):c0 + radius + 1]
    if not np.isfinite(cell).all():
        raise ValueError(f"anchor (u={u:.1f}, v={v:.1f}) lies on invalid (unreconstructed) pixels; "
                         "expected anchors on the measured surface")


def distance_maps(points: np.ndarray, anchors_uv: np.ndarray, method: str = "bezier",
                  radius: int = 3, stop_distance=None) -> tuple[np.ndarray, np.ndarray]:
    """Geodesic distance maps (D1, D2), each (H, W) mm, from the two anchors (2, 2) (u, v).

    method "bezier" (Eq. 6.7–6.8, marching window (2·radius+1)², 7×7 by default, with the
    virtual-source wavefront update), "bezier-edges" (the dissertation's edge-only scheme) or
    "grid" (8-neighbour Dijkstra). For the Bézier methods the step lengths are computed once
    (:func:`fringe3d.analyze.geodesic.step_table`) and shared by both anchors, whose searches run
    at once on two threads (:func:`fringe3d.analyze.geodesic.table_geodesics`; same maps as one
    after the other).
    stop_distance : None (whole map), a distance (mm) or one per anchor (2,): each search stops
    beyond it (:func:`fringe3d.analyze.geodesic.bezier_geodesic`), nodes farther are ``inf``;
    ignored by "grid".

    Parameters
    ----------
    points : (H, W, 3) float array
        Organized point map, mm, NaN where invalid.
    anchors_uv : (2, 2) array
        The two anchors (u column, v row), pixels; each must lie on valid points
        (:func:`check_anchor`).
    method : ``"bezier"`` | ``"bezier-edges"`` | ``"grid"``
        Geodesic scheme (above).
    radius : int
        Half-size of the Bézier marching window, pixels; ignored by "grid".
    stop_distance : float or (2,) array_like, optional
        Search limit, mm (above); None searches the whole map.

    Returns
    -------
    D1, D2 : (H, W) ndarray (float64)
        Geodesic distance from the first and the second anchor, mm; ``inf`` where invalid,
        unreachable or beyond ``stop_distance``.
    """
    if method not in ("bezier", "bezier-edges", "grid"):
        raise ValueError(f"unknown geodesic method {method!r}; expected 'bezier', 'bezier-edges' or 'grid'")
    for a in anchors_uv:
        check_anchor(points, a)
    if method in ("bezier", "bezier-edges"):
        wave = method == "bezier"
        steps = step_table(points, radius)
        stops = np.broadcast_to(np.asarray(np.inf if stop_distance is None else stop_distance, float), (2,))
        d1, d2 = table_geodesics(steps, anchors_uv[:2], stops, wavefront=wave)
        return d1, d2
    return grid_geodesic(points, anchors_uv[0]), grid_geodesic(points, anchors_uv[1])


def fill_dot_holes(points: np.ndarray, anchors_uv: np.ndarray, max_radius: int = 8, ring: int = 5) -> np.ndarray:
    """Fill the reconstruction holes left by dark anchor dots (low fringe modulation).

    For each anchor, invalid pixels within ``max_radius`` px of it are filled with a quadratic
    polynomial in (u, v) per coordinate, least-squares fitted to the valid pixels within
    ``max_radius + ring`` px (the smooth membrane around the dot). Pixels already valid are not
    touched. Raises ``ValueError`` if an anchor is outside the frame or the surrounding ring has
    too few valid pixels (the anchor is not on the measured surface). Returns a float64 copy.

    Parameters
    ----------
    points : (H, W, 3) float array
        Organized point map, mm, NaN where invalid.
    anchors_uv : (K, 2) or (2,) array
        Anchor positions (u column, v row), pixels.
    max_radius : int
        Radius around each anchor within which invalid pixels are filled, pixels.
    ring : int
        Width of the ring of valid pixels beyond ``max_radius`` used for the fit, pixels.

    Returns
    -------
    (H, W, 3) ndarray (float64)
        A copy of ``points`` with the dot holes filled, mm.
    """
    pts = check_point_map(points).copy()
    h, w, _ = pts.shape
    valid = np.isfinite(pts).all(axis=2)
    R = max_radius + ring
    for a in np.atleast_2d(anchors_uv):
        u0, v0 = float(a[0]), float(a[1])
        if not (0 <= u0 <= w - 1 and 0 <= v0 <= h - 1):
            raise ValueError(f"anchor (u={u0:.1f}, v={v0:.1f}) is outside the {w}×{h} frame")
        r0, r1 = max(int(v0) - R, 0), min(int(v0) + R + 2, h)
        c0, c1 = max(int(u0) - R, 0), min(int(u0) + R + 2, w)
        vv, uu = np.mgrid[r0:r1, c0:c1]
        dist = np.hypot(uu - u0, vv - v0)
        hole = (~valid[r0:r1, c0:c1]) & (dist <= max_radius)
        if not hole.any():
            continue
        support = valid[r0:r1, c0:c1] & (dist <= R)
        if support.sum() < 0.5 * np.pi * R * R * 0.5:
            raise ValueError(f"anchor (u={u0:.1f}, v={v0:.1f}) lies on invalid (unreconstructed) pixels with too "
                             "little measured surface around it; expected anchors on the measured surface")
        x, y = (uu - u0) / R, (vv - v0) / R
        A = np.stack([np.ones_like(x), x, y, x * x, x * y, y * y], axis=-1).astype(float)
        coef, *_ = np.linalg.lstsq(A[support], pts[r0:r1, c0:c1][support], rcond=None)
        block = pts[r0:r1, c0:c1]
        block[hole] = A[hole] @ coef
    return pts


def parse_anchors(text: str) -> list[np.ndarray] | None:
    """``"auto"`` → None; ``"u1,v1,u2,v2[;u3,v3,u4,v4]"`` → list of (2, 2) arrays (one per wing)."""
    if text.strip().lower() == "auto":
        return None
    wings = []
    for part in text.split(";"):
        try:
            vals = [float(x) for x in part.split(",")]
        except ValueError:
            raise ValueError(f"cannot read anchors {part!r}; expected 'u1,v1,u2,v2' (pixels) or 'auto'") from None
        if len(vals) != 4:
            raise ValueError(f"anchors {part!r} has {len(vals)} numbers; expected 4: u1,v1,u2,v2")
        wings.append(np.array(vals).reshape(2, 2))
    return wings


def follow_anchors(texture, n_frames: int, start: list[np.ndarray], search: float = 40.0) -> np.ndarray:
    """Anchor positions (F, wings, 2, 2) from the reference positions ``start``.

    ``texture``: callable ``i -> (H, W)`` image, or None. With textures, each frame's anchor is
    the dark dot nearest its constant-velocity prediction (within ``search`` px, else the
    prediction); without, the given positions hold for every frame (anchors near the wing root
    barely move).

    Parameters
    ----------
    texture : callable or None
        ``i -> (H, W)`` texture image of frame ``i``; None keeps the ``start`` positions.
    n_frames : int
        Number of frames ``F``.
    start : list of (2, 2) ndarray
        Reference anchor pair (u, v) per wing, pixels (frame 0).
    search : float
        Largest distance from the prediction to an accepted dot, pixels.

    Returns
    -------
    (F, wings, 2, 2) ndarray
        Anchor positions (u, v) per frame, wing and anchor, pixels.
    """
    out = np.repeat(np.stack(start)[None], n_frames, axis=0)
    if texture is None:
        return out
    for f in range(1, n_frames):
        try:
            dots = dark_dots(texture(f))[:, :2]
        except ValueError:
            dots = np.empty((0, 2))
        for w in range(len(start)):
            for a in range(2):
                pred = out[f - 1, w, a] + ((out[f - 1, w, a] - out[f - 2, w, a]) if f >= 2 else 0.0)
                out[f, w, a] = pred
                if len(dots):
                    d = np.linalg.norm(dots - pred, axis=1)
                    j = int(np.argmin(d))
                    if d[j] <= search:
                        out[f, w, a] = dots[j]
    return out


def auto_anchors(seq: PointSequence, wings: int) -> list[np.ndarray]:
    """Detect 2 × ``wings`` dark dots in the reference texture and pair them per wing."""
    if not seq.has_texture:
        raise ValueError(f"`anchors` auto needs texture images in {seq.source} (texture_00000.npy/.png or a "
                         "'texture' array); none found. Pass `anchors` u1,v1,u2,v2 instead")
    dots = find_anchor_dots(seq.texture(0), count=2 * wings)
    return pair_anchors(dots, seq[0]) if wings > 1 else [dots]


def query_grid(points: np.ndarray, anchors: np.ndarray, step: int, margin: int) -> np.ndarray:
    """Reference pixels (N, 2) every ``step`` px on the surface region that holds the anchors,
    at least ``margin`` px inside its valid area."""
    valid = np.isfinite(points).all(axis=2)
    lab = measure.label(valid, connectivity=1)
    region = lab == lab[int(round(anchors[0, 1])), int(round(anchors[0, 0]))]
    if margin > 0:
        region = ndimage.binary_erosion(region, iterations=margin)
    v, u = np.mgrid[0:valid.shape[0]:step, 0:valid.shape[1]:step]
    keep = region[v, u]
    return np.stack([u[keep], v[keep]], axis=1).astype(float)
