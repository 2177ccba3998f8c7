"""Numba building blocks of the Bézier geodesic searches (dissertation ch. 6.4.2, Eq. 6.7–6.8).

Private: shared by the node-by-node search of :mod:`fringe3d.analyze.geodesic` and the per-frame
step table of :mod:`fringe3d.analyze.geodesic_steps`; the public names are re-exported by
:mod:`fringe3d.analyze.geodesic`.

* The marching directions (:func:`_march_offsets`, ``MARCH_OFFSETS``: the 32 offsets
  ``(di, dj)`` of a 7×7 neighbourhood with ``gcd(|di|,|dj|) = 1``), the bilinear stencils of the
  inner Bézier control points (:func:`_control_stencils`) and the angular-neighbour (Farey pair)
  tables of the wavefront update (:func:`_wavefront_tables`).
* The step length P0 → P3 = P0 + (di, dj) (:func:`_step_length`): the arc length
  ``∫₀¹ |B′(t)| dt`` (Eq. 6.8) of the cubic Bézier curve (Eq. 6.7) whose control points are the
  surface points at pixel positions P0 + k·(di, dj)/3, k = 0..3; P1 and P2 are taken by bilinear
  interpolation of the four surrounding grid points (the dissertation "picks two more points" on
  the path without saying how; this is our reading, documented), the integral by 5-point
  Gauss–Legendre quadrature (:func:`_bezier_len`). A step whose points (or the grid points used
  to interpolate them) are not all valid has no length, so holes and borders stop the front.
* The virtual-source wavefront update (:func:`_virtual_source`): the triangle (x, x − a, x − b)
  of two angularly adjacent directions (a unimodular "Farey" pair) unfolded from its three side
  lengths, and the distance from the virtual source at D(x − a), D(x − b) (Novotni & Klein-style).
* An indexed binary min-heap with decrease-key (:func:`_sift_up`, :func:`_sift_down`,
  :func:`_pop`, :func:`_lower`) and the seeding of a sub-pixel source (:func:`_seeds`,
  :func:`_seed_heap`): the nodes within a few pixels start at their chord distance.
* Input checks (:func:`check_point_map`, :func:`_check_radius`) and the validity mask and compact
  node index of a point map (:func:`_valid_index`).
"""
from __future__ import annotations

import math

import numba
import numpy as np


def _march_offsets(radius: int = 3) -> np.ndarray:
    out = []
    for di in range(-radius, radius + 1):
        for dj in range(-radius, radius + 1):
            if (di or dj) and math.gcd(abs(di), abs(dj)) == 1:
                out.append((di, dj))
    return np.array(out, dtype=np.int64)


#: The 32 marching directions (drow, dcol) of a 7×7 neighbourhood (gcd 1, |d| ≤ 3).
MARCH_OFFSETS = _march_offsets(3)
_EIGHT_OFFSETS = _march_offsets(1)

# 5-point Gauss–Legendre nodes/weights mapped to [0, 1]
_gl_x, _gl_w = np.polynomial.legendre.leggauss(5)
_GL_T = 0.5 * (_gl_x + 1.0)
_GL_W = 0.5 * _gl_w


def check_point_map(points: np.ndarray, name: str = "points") -> np.ndarray:
    """Validate an organized point map and return it as C-contiguous float64 ``(H, W, 3)``."""
    a = np.asarray(points)
    if a.ndim != 3 or a.shape[2] != 3:
        raise ValueError(f"{name} must be an organized point map of shape (H, W, 3); got shape {a.shape}")
    if a.shape[0] < 2 or a.shape[1] < 2:
        raise ValueError(f"{name} must be at least 2×2 pixels; got {a.shape[:2]}")
    if not np.issubdtype(a.dtype, np.floating):
        raise ValueError(f"{name} must be a float array (mm, NaN where invalid); got dtype {a.dtype}")
    return np.ascontiguousarray(a, dtype=np.float64)


def _check_radius(radius) -> None:
    if not (isinstance(radius, (int, np.integer)) and 1 <= radius <= 10):
        raise ValueError(f"radius must be an integer in 1..10 (pixels); got {radius!r}")


@numba.njit(cache=True, inline="always")
def _bezier_len(p0, p1, p2, p3, gt, gw):
    a0 = p1 - p0
    a1 = p2 - p1
    a2 = p3 - p2
    s = 0.0
    for k in range(gt.shape[0]):
        t = gt[k]
        u = 1.0 - t
        c0 = 3.0 * u * u
        c1 = 6.0 * u * t
        c2 = 3.0 * t * t
        dx = c0 * a0[0] + c1 * a1[0] + c2 * a2[0]
        dy = c0 * a0[1] + c1 * a1[1] + c2 * a2[1]
        dz = c0 * a0[2] + c1 * a1[2] + c2 * a2[2]
        s += gw[k] * math.sqrt(dx * dx + dy * dy + dz * dz)
    return s


@numba.njit(cache=True, inline="always")
def _bilinear(pts, valid, r, c, out):
    """Bilinear sample of pts at (r, c); False if any used corner is invalid/outside."""
    h, w = valid.shape
    r0 = int(math.floor(r))
    c0 = int(math.floor(c))
    fr = r - r0
    fc = c - c0
    if fr < 1e-9:
        fr = 0.0
    if fc < 1e-9:
        fc = 0.0
    r1 = r0 + 1 if fr > 0.0 else r0
    c1 = c0 + 1 if fc > 0.0 else c0
    if r0 < 0 or c0 < 0 or r1 >= h or c1 >= w:
        return False
    if not (valid[r0, c0] and valid[r0, c1] and valid[r1, c0] and valid[r1, c1]):
        return False
    for k in range(3):
        top = (1.0 - fc) * pts[r0, c0, k] + fc * pts[r0, c1, k]
        bot = (1.0 - fc) * pts[r1, c0, k] + fc * pts[r1, c1, k]
        out[k] = (1.0 - fr) * top + fr * bot
    return True


# --- indexed binary min-heap (decrease-key) -------------------------------------------------
# heap[i] is a node, hkey[i] its key (kept next to it, so sifting never reads the (H·W) map),
# pos[node] its slot (−1 never queued).
@numba.njit(cache=True, inline="always")
def _sift_up(heap, hkey, pos, i):
    node = heap[i]
    k = hkey[i]
    while i > 0:
        parent = (i - 1) >> 1
        if hkey[parent] <= k:
            break
        pn = heap[parent]
        heap[i] = pn
        hkey[i] = hkey[parent]
        pos[pn] = i
        i = parent
    heap[i] = node
    hkey[i] = k
    pos[node] = i


@numba.njit(cache=True, inline="always")
def _sift_down(heap, hkey, pos, i, n):
    node = heap[i]
    k = hkey[i]
    while True:
        child = 2 * i + 1
        if child >= n:
            break
        if child + 1 < n and hkey[child + 1] < hkey[child]:
            child += 1
        if hkey[child] >= k:
            break
        cn = heap[child]
        heap[i] = cn
        hkey[i] = hkey[child]
        pos[cn] = i
        i = child
    heap[i] = node
    hkey[i] = k
    pos[node] = i


@numba.njit(cache=True, inline="always")
def _pop(heap, hkey, pos, size):
    """Remove the heap's top (the caller has read heap[0]); returns the new size."""
    size -= 1
    if size > 0:
        heap[0] = heap[size]
        hkey[0] = hkey[size]
        pos[heap[0]] = 0
        _sift_down(heap, hkey, pos, 0, size)
    return size


@numba.njit(cache=True, inline="always")
def _step_length(pts, valid, r, c, o, offsets, bezier, gt, gw, cr, cc_, cw, p0, p1, p2, p3):
    """Length (mm) of the step from node (r, c) along ``offsets[o]``: the Bézier arc length
    (Eq. 6.8) or the chord; −1 when the end node or a control-point corner is invalid."""
    h, w = valid.shape
    rr = r + offsets[o, 0]
    cc = c + offsets[o, 1]
    if rr < 0 or cc < 0 or rr >= h or cc >= w or not valid[rr, cc] or not valid[r, c]:
        return -1.0
    if not bezier:
        dx = pts[rr, cc, 0] - pts[r, c, 0]
        dy = pts[rr, cc, 1] - pts[r, c, 1]
        dz = pts[rr, cc, 2] - pts[r, c, 2]
        return math.sqrt(dx * dx + dy * dy + dz * dz)
    for q in range(4):
        if not (valid[r + cr[o, 0, q], c + cc_[o, 0, q]] and valid[r + cr[o, 1, q], c + cc_[o, 1, q]]):
            return -1.0
    for k in range(3):
        p0[k] = pts[r, c, k]
        p3[k] = pts[rr, cc, k]
        a = 0.0
        b = 0.0
        for q in range(4):
            a += cw[o, 0, q] * pts[r + cr[o, 0, q], c + cc_[o, 0, q], k]
            b += cw[o, 1, q] * pts[r + cr[o, 1, q], c + cc_[o, 1, q], k]
        p1[k] = a
        p2[k] = b
    return _bezier_len(p0, p1, p2, p3, gt, gw)


@numba.njit(cache=True, inline="always")
def _virtual_source(la, lb, lc, da, db, best):
    """Distance to x through the triangle (x, A, B) unfolded in the plane from its side lengths
    la = |Ax|, lb = |Bx|, lc = |AB| (mm): the virtual source S lies at da from A and db from B
    on the far side of AB; returns |Sx| if the segment S→x crosses AB, else inf.

    Also inf, without a division or square root, when |Sx| cannot be below ``best`` (mm, ≥ da):
    with x = (xx, xy), S = (sx, −|sy|) in the frame of A → B, |Sx|² = (xx − sx)² + (xy + |sy|)²
    ≥ (xx − sx)² + xy² + sy² = la² + da² − 2·xx·sx, i.e. 2lc²(la² + da²) − X·Y for X = 2lc·xx,
    Y = 2lc·sx; the test keeps a 1e-9 relative margin (the roundings are ~1e-15 of best²), so a
    candidate that would have won is never dropped and the distances do not change."""
    if lc <= 0.0:
        return np.inf
    la2 = la * la
    da2 = da * da
    lc2 = lc * lc
    if 2.0 * lc2 * (la2 + da2) - (la2 - lb * lb + lc2) * (da2 - db * db + lc2) > 2.0 * lc2 * best * best * (1.0 + 1e-9):
        return np.inf
    xx = (la * la - lb * lb + lc * lc) / (2.0 * lc)
    xy2 = la * la - xx * xx
    sx = (da * da - db * db + lc * lc) / (2.0 * lc)
    sy2 = da * da - sx * sx
    if xy2 <= 0.0 or sy2 < 0.0:
        return np.inf
    xy = math.sqrt(xy2)
    sy = -math.sqrt(sy2)
    tx = sx + (xx - sx) * (-sy) / (xy - sy)
    if tx < 0.0 or tx > lc:
        return np.inf
    return math.sqrt((xx - sx) ** 2 + (xy - sy) ** 2)


@numba.njit(cache=True, inline="always")
def _lower(heap, hkey, pos, dist, i, d, size):
    """Set ``dist[i] = d`` (smaller than before), queueing ``i`` if it is new; returns the heap size."""
    dist[i] = d
    if pos[i] < 0:
        heap[size] = i
        pos[i] = size
        size += 1
    hkey[pos[i]] = d
    _sift_up(heap, hkey, pos, pos[i])
    return size


@numba.njit(cache=True, inline="always")
def _seed_heap(heap, hkey, pos, dist, seed_idx, seed_dist):
    """Queue the seeds (pixel index, start distance) in an empty heap; returns the heap size."""
    size = 0
    for s in range(seed_idx.shape[0]):
        i = seed_idx[s]
        if seed_dist[s] < dist[i]:
            size = _lower(heap, hkey, pos, dist, i, seed_dist[s], size)
    return size


@numba.njit(cache=True, nogil=True)
def _valid_index(pts):
    """Validity (H, W) bool (all three coordinates finite), compact node index (H, W) int64
    (row-major, −1 invalid), node count and bounding box (r_lo, r_hi, c_lo, c_hi) of the valid
    nodes (half-open; empty box when none) of a point map (H, W, 3)."""
    h, w, _ = pts.shape
    valid = np.empty((h, w), dtype=np.bool_)
    index = np.empty((h, w), dtype=np.int64)
    nv = 0
    r_lo, r_hi, c_lo, c_hi = h, 0, w, 0
    for r in range(h):
        for c in range(w):
            ok = np.isfinite(pts[r, c, 0]) and np.isfinite(pts[r, c, 1]) and np.isfinite(pts[r, c, 2])
            valid[r, c] = ok
            index[r, c] = nv if ok else -1
            if ok:
                nv += 1
                r_lo = min(r_lo, r)
                r_hi = max(r_hi, r + 1)
                c_lo = min(c_lo, c)
                c_hi = max(c_hi, c + 1)
    return valid, index, nv, (r_lo, r_hi, c_lo, c_hi)


def _wavefront_tables(offsets: np.ndarray):
    """Angular neighbours ``(n, 2)`` of every marching direction (consecutive directions of a
    primitive stencil form unimodular "Farey" pairs, so the triangle (x, x − a, x − b) holds no
    other grid node) and a lookup ``(2R+1, 2R+1)`` from an offset to its index (−1 if none)."""
    n = offsets.shape[0]
    order = np.argsort(np.arctan2(offsets[:, 0], offsets[:, 1]))
    rank = np.empty(n, np.int64)
    rank[order] = np.arange(n)
    nbr = np.stack([order[(rank - 1) % n], order[(rank + 1) % n]], axis=1).astype(np.int64)
    R = int(np.abs(offsets).max())
    lut = np.full((2 * R + 1, 2 * R + 1), -1, np.int64)
    lut[offsets[:, 0] + R, offsets[:, 1] + R] = np.arange(n)
    return nbr, lut


def _control_stencils(offsets: np.ndarray):
    """Bilinear stencils of the inner control points P1, P2 at offset·k/3 (k = 1, 2).

    Returns corner row/col offsets ``(n, 2, 4)`` int64 and weights ``(n, 2, 4)`` float64;
    zero-weight corners repeat the base corner so validity tests never look outside the
    step's bounding box.
    """
    n = offsets.shape[0]
    cr = np.zeros((n, 2, 4), np.int64)
    cc = np.zeros((n, 2, 4), np.int64)
    cw = np.zeros((n, 2, 4), np.float64)
    for o, (dr, dc) in enumerate(offsets):
        for s, k in enumerate((1, 2)):
            fr, fc = dr * k / 3.0, dc * k / 3.0
            r0, c0 = math.floor(fr + 1e-12), math.floor(fc + 1e-12)
            ar, ac = fr - r0, fc - c0
            ar = 0.0 if ar < 1e-9 else ar
            ac = 0.0 if ac < 1e-9 else ac
            corners = [(r0, c0, (1 - ar) * (1 - ac)), (r0 + (ar > 0), c0, ar * (1 - ac)),
                       (r0, c0 + (ac > 0), (1 - ar) * ac), (r0 + (ar > 0), c0 + (ac > 0), ar * ac)]
            for q, (a, b, wgt) in enumerate(corners):
                cr[o, s, q], cc[o, s, q], cw[o, s, q] = a, b, wgt
    return cr, cc, cw


def _seeds(pts, valid, uv, radius):
    """:func:`fringe3d.analyze.geodesic.seeds_from_pixel` on a checked map and its validity mask (H, W) bool."""
    h, w, _ = pts.shape
    u, v = float(uv[0]), float(uv[1])
    if not (0.0 <= u <= w - 1 and 0.0 <= v <= h - 1):
        raise ValueError(f"source pixel (u={u:.2f}, v={v:.2f}) is outside the {w}×{h} point map")
    src = np.empty(3)
    if not _bilinear(pts, valid, v, u, src):
        raise ValueError(f"source pixel (u={u:.2f}, v={v:.2f}) lies on invalid (NaN) pixels of the point map; "
                         "expected a pixel inside the reconstructed surface")
    r0, c0 = int(math.floor(v)), int(math.floor(u))
    rad = max(float(radius), 0.0)
    k = int(math.ceil(rad)) + 1
    idx, d = [], []
    for r in range(max(r0 - k, 0), min(r0 + k + 2, h)):
        for c in range(max(c0 - k, 0), min(c0 + k + 2, w)):
            corner = r in (r0, r0 + 1) and c in (c0, c0 + 1)
            if valid[r, c] and (corner or math.hypot(r - v, c - u) <= rad):
                idx.append(r * w + c)
                d.append(float(np.linalg.norm(pts[r, c] - src)))
    return np.array(idx, dtype=np.int64), np.array(d, dtype=np.float64)
