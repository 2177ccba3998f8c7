"""Per-frame step table of a point map and the geodesic searches on it (dissertation ch. 6.4.2,
Eq. 6.7–6.8).

:func:`step_table` computes every Bézier step length (Eq. 6.8) of a frame once (a step and its
reverse share their control points, so half the offsets suffice) into an ``(n_valid, 32)`` table
that the searches of all sources on that frame read instead of recomputing 32 + 64 lengths per
settled node; :func:`fringe3d.analyze.geodesic.bezier_geodesic` ``(..., steps=table,
stop_distance=d)`` runs on it and stops once every node within ``d`` mm is settled (same values
there as the full search). The table kernel runs row by row on x/y/z planes of the valid bounding
box without branches (an invalid point's NaN marks the step invalid), so it vectorises, and on two
threads over two row ranges; :func:`table_geodesics` runs several sources' searches on one table
at once on threads. Both give the same bits as their one-thread, node-by-node forms.

The public names are re-exported by :mod:`fringe3d.analyze.geodesic`.
"""
from __future__ import annotations

import math
import threading
from dataclasses import dataclass, field

import numba
import numpy as np

from fringe3d.analyze._geodesic_kernels import (_GL_T, _GL_W, MARCH_OFFSETS, _check_radius, _control_stencils,
                                                _lower, _march_offsets, _pop, _seed_heap, _seeds, _valid_index,
                                                _virtual_source, _wavefront_tables, check_point_map)

__all__ = ["StepTable", "step_table", "table_geodesics"]


@numba.njit(cache=True, nogil=True)
def _planes(pts, valid, box):
    """The points of the bounding box as x, y, z planes (3, bh, bw), NaN at invalid nodes."""
    r_lo, r_hi, c_lo, c_hi = box
    out = np.empty((3, max(r_hi - r_lo, 0), max(c_hi - c_lo, 0)))
    for k in range(3):
        for r in range(r_lo, r_hi):
            for c in range(c_lo, c_hi):
                out[k, r - r_lo, c - c_lo] = pts[r, c, k] if valid[r, c] else np.nan
    return out


@numba.njit(cache=True, inline="always")
def _control_row(xk, r, c0, n, sr, sc, sw, s, out):
    """out[j] = Σ_q sw[s, q]·xk[r + sr[s, q], c0 + j + sc[s, q]] (summed from 0 in q order),
    j < n: one coordinate of the bilinear control point P1 (s = 0) or P2 (s = 1) along a row."""
    v0 = xk[r + sr[s, 0], c0 + sc[s, 0]:c0 + sc[s, 0] + n]
    v1 = xk[r + sr[s, 1], c0 + sc[s, 1]:c0 + sc[s, 1] + n]
    v2 = xk[r + sr[s, 2], c0 + sc[s, 2]:c0 + sc[s, 2] + n]
    v3 = xk[r + sr[s, 3], c0 + sc[s, 3]:c0 + sc[s, 3] + n]
    w0 = sw[s, 0]
    w1 = sw[s, 1]
    w2 = sw[s, 2]
    w3 = sw[s, 3]
    for j in range(n):
        out[j] = 0.0 + w0 * v0[j] + w1 * v1[j] + w2 * v2[j] + w3 * v3[j]


@numba.njit(cache=True, inline="always")
def _row_lengths(pl, r, c0, c1, dr, dc, sr, sc, sw, bezier, work, out):
    """Step lengths (mm) from (r, c) to (r + dr, c + dc), c0 ≤ c < c1, of one row of the planes
    ``pl`` (3, bh, bw), into out[0 : c1 − c0]: the Bézier arc length (Eq. 6.7–6.8, 5-point
    Gauss–Legendre) with inner control points P1, P2 = Σ_q sw[s, q]·P[r + sr[s, q], c + sc[s, q]]
    (s = 0, 1), or the chord. Branch-free loops (vectorised): NaN when a point read is invalid.
    ``work`` (11, ≥ n) scratch: the differences P1−P0, P2−P1, P3−P2 (rows 0–8) and P1, P2."""
    n = c1 - c0
    for k in range(3):
        xk = pl[k]
        p1 = work[9]
        p2 = work[10]
        _control_row(xk, r, c0, n, sr, sc, sw, 0, p1)
        _control_row(xk, r, c0, n, sr, sc, sw, 1, p2)
        p0 = xk[r, c0:c1]
        p3 = xk[r + dr, c0 + dc:c1 + dc]
        a0 = work[k]
        a1 = work[3 + k]
        a2 = work[6 + k]
        for j in range(n):
            a2[j] = p3[j] - p2[j]
            a1[j] = p2[j] - p1[j]
            a0[j] = p1[j] - p0[j]
            if not bezier:
                a0[j] = p3[j] - p0[j] + 0.0 * (a0[j] + a1[j] + a2[j])   # chord, NaN where the curve is
    if not bezier:
        for j in range(n):
            out[j] = math.sqrt(work[0, j] * work[0, j] + work[1, j] * work[1, j] + work[2, j] * work[2, j])
        return
    for j in range(n):
        ln = 0.0
        for g in range(5):
            t = _GL_T[g]
            u = 1.0 - t
            k0 = 3.0 * u * u
            k1 = 6.0 * u * t
            k2 = 3.0 * t * t
            dx = k0 * work[0, j] + k1 * work[3, j] + k2 * work[6, j]
            dy = k0 * work[1, j] + k1 * work[4, j] + k2 * work[7, j]
            dz = k0 * work[2, j] + k1 * work[5, j] + k2 * work[8, j]
            ln += _GL_W[g] * math.sqrt(dx * dx + dy * dy + dz * dz)
        out[j] = ln


@numba.njit(cache=True, nogil=True)  # frames run on threads (fringe3d strain --workers)
def _step_table_kernel(planes, index, box, table, offsets, opposite, bezier, cr, cc_, cw, first, last):
    """Fill ``table`` (n_valid, n_offsets) with the step lengths (mm; −1 where the end node or a
    control-point corner is invalid or outside) of the valid nodes of ``index`` (H, W).

    A step and its reverse x + o → x share their four control points in reverse order (P1 of
    the reverse is P2 of the step), hence the arc length (the Gauss–Legendre nodes are
    symmetric): only the offsets with ``opposite[o] > o`` are evaluated, and each value is also
    written as the far node's reverse step. Works on blocks of two image rows (all offsets),
    so the table rows being written stay in cache; a block's rows are set to −1 first, and the
    evaluated steps of :func:`_march_offsets` point up or left, so every reverse lands in a row
    already set. ``planes`` from :func:`_planes`; the values equal the node-by-node evaluation
    bit for bit (same operations in the same order, no fast-math).

    Only the box rows [first, last) are filled, and their reverses that land above ``first``
    are left to :func:`_boundary_reverses`, so disjoint row ranges can run on threads at once."""
    r_lo, r_hi, c_lo, c_hi = box
    _, bh, bw = planes.shape
    nofs = offsets.shape[0]
    buf = np.empty(bw)
    work = np.empty((11, bw))
    for b0 in range(first, last, 2):
        b1 = min(b0 + 2, last)
        for r in range(b0, b1):   # this block's rows start invalid
            for c in range(bw):
                k = index[r + r_lo, c + c_lo]
                if k >= 0:
                    table[k, :] = -1.0
        for o in range(nofs):
            if opposite[o] < o:
                continue
            dr = offsets[o, 0]
            dc = offsets[o, 1]
            ob = opposite[o]
            sr = cr[o]
            sc = cc_[o]
            sw = cw[o]
            c0 = max(0, -dc)
            c1 = min(bw, bw - dc)
            for r in range(max(b0, -dr), min(b1, bh - dr)):
                _row_lengths(planes, r, c0, c1, dr, dc, sr, sc, sw, bezier, work, buf)
                for c in range(c0, c1):
                    k = index[r + r_lo, c + c_lo]
                    ln = buf[c - c0]
                    if k >= 0 and ln == ln:
                        table[k, o] = ln
                        if r + dr >= first:
                            table[index[r + r_lo + dr, c + c_lo + dc], ob] = ln


@numba.njit(cache=True, nogil=True)
def _boundary_reverses(index, box, table, offsets, opposite, first):
    """The reverses :func:`_step_table_kernel` left out for a range starting at box row
    ``first``: the evaluated steps of its first rows that end above it, copied to their end nodes."""
    r_lo, r_hi, c_lo, c_hi = box
    bh = r_hi - r_lo
    bw = c_hi - c_lo
    for o in range(offsets.shape[0]):
        if opposite[o] < o:
            continue
        dr = offsets[o, 0]
        dc = offsets[o, 1]
        for r in range(first, min(first - dr, bh)):
            if r + dr < 0:
                continue
            for c in range(max(0, -dc), min(bw, bw - dc)):
                k = index[r + r_lo, c + c_lo]
                if k >= 0 and table[k, o] >= 0.0:
                    table[index[r + r_lo + dr, c + c_lo + dc], opposite[o]] = table[k, o]


@numba.njit(cache=True, nogil=True)  # anchors and frames run on threads (fringe3d strain --workers)
def _dijkstra_table(index, rows, table, seed_idx, seed_dist, step_flat, tri_side, nbr, wavefront, stop,
                    dist, done, pos, heap, hkey):
    """:func:`fringe3d.analyze.geodesic._dijkstra` on precomputed step lengths (``index`` (H, W), ``table`` of
    :func:`_step_table_kernel`), stopping once the smallest open distance exceeds ``stop`` (mm).

    A step o of a settled node is followed only where ``table[k, o] ≥ 0``, which already means
    that its end node is inside the map and valid, so the end is ``node + step_flat[o]`` (flat
    index) with no bounds test; likewise the triangle side A → B of the wavefront update
    (offset ``tri_side[o, e]``, −1 if none). Same relaxations in the same order as
    :func:`fringe3d.analyze.geodesic._dijkstra`, so the same distances. ``dist``, ``done``, ``pos``, ``heap``, ``hkey``
    (n = H·W) are caller-owned work arrays, reset here. Returns (H, W) mm, ``inf`` unsettled."""
    h, w = index.shape
    lo = rows[0] * w   # every valid node lies in the rows [rows[0], rows[1]): only they are reset
    hi = rows[1] * w
    dist[lo:hi] = np.inf
    done[lo:hi] = False
    pos[lo:hi] = -1
    size = _seed_heap(heap, hkey, pos, dist, seed_idx, seed_dist)
    nofs = step_flat.shape[0]
    while size > 0:
        node = heap[0]
        d0 = hkey[0]
        if d0 > stop:
            break
        size = _pop(heap, hkey, pos, size)
        done[node] = True
        kn = index.flat[node]
        for o in range(nofs):
            la = table[kn, o]
            if la < 0.0:
                continue
            nb = node + step_flat[o]
            if done[nb]:
                continue
            best = dist[nb]
            if d0 + la < best:
                best = d0 + la
            if wavefront:
                # triangles (x, A, B) with B = x − b, b the angular neighbours of a (Farey pairs)
                for e in range(2):
                    oc = tri_side[o, e]
                    if oc < 0:
                        continue
                    lcc = table[kn, oc]
                    if lcc < 0.0:
                        continue
                    nbb = node + step_flat[oc]
                    if not done[nbb]:
                        continue
                    lb = table[index.flat[nbb], nbr[o, e]]
                    if lb < 0.0:
                        continue
                    vs = _virtual_source(la, lb, lcc, d0, dist[nbb], best)
                    if vs < best:
                        best = vs
            if best < dist[nb]:
                size = _lower(heap, hkey, pos, dist, nb, best, size)
    out = np.full(h * w, np.inf)
    for i in range(lo, hi):
        if done[i]:
            out[i] = dist[i]
    return out.reshape(h, w)


@dataclass
class StepTable:
    """Per-frame step lengths of one point map, shared by every source on that frame.

    ``index`` (H, W) int64 compact node id (−1 invalid); ``lengths`` (n_valid, n_offsets) float64
    mm, the Bézier arc length (Eq. 6.8) or chord of every marching step (−1 invalid);
    ``offsets`` (n_offsets, 2) the marching directions; ``bezier`` whether Bézier lengths;
    ``rows`` (2,) int64 the half-open range of image rows holding the valid nodes.
    ``work``: the Dijkstra work arrays (n = H·W), one set per concurrent search, allocated on
    first use (:func:`_work`) and reused by every later search on the table.
    """
    points: np.ndarray
    valid: np.ndarray
    index: np.ndarray
    lengths: np.ndarray
    offsets: np.ndarray
    bezier: bool
    rows: np.ndarray
    work: list = field(default_factory=list)


def _work(steps: StepTable, count: int) -> list:
    """The first ``count`` work-array sets (dist, done, pos, heap, heap keys) of ``steps``."""
    n = steps.valid.size
    while len(steps.work) < count:
        steps.work.append((np.empty(n), np.empty(n, np.bool_), np.empty(n, np.int64), np.empty(n, np.int64),
                           np.empty(n)))
    return steps.work[:count]


def step_table(points: np.ndarray, radius: int = 3, bezier: bool = True) -> StepTable:
    """Compute every marching step length of ``points`` once (Eq. 6.7–6.8), for
    :func:`~fringe3d.analyze.geodesic.bezier_geodesic` ``steps=`` (two anchors on one frame then share the work).

    Parameters
    ----------
    points : (H, W, 3) float, mm, NaN where invalid.
    radius : marching window half-size (3 = 7×7, 32 directions); 1 with ``bezier=False`` is the
        8-neighbour grid of :func:`~fringe3d.analyze.geodesic.grid_geodesic`.
    bezier : Bézier arc lengths (True) or chords.

    Returns
    -------
    StepTable ; memory 8·32 B per valid pixel for the 7×7 window (plus 25 B per pixel of work
    arrays; while computing, 24 B per pixel of the valid nodes' bounding box for the x, y, z
    planes the vectorised kernel reads).
    """
    _check_radius(radius)
    pts = check_point_map(points)
    valid, index, nv, box = _valid_index(pts)
    offsets = MARCH_OFFSETS if radius == 3 else _march_offsets(int(radius))
    cr, cc, cw = _control_stencils(offsets)
    lut = _wavefront_tables(offsets)[1]
    R = (lut.shape[0] - 1) // 2
    opposite = lut[R - offsets[:, 0], R - offsets[:, 1]]
    lengths = np.empty((nv, len(offsets)))
    planes = _planes(pts, valid, box)
    bh = planes.shape[1]
    mid = 2 * (bh // 4) if bh >= 64 else bh      # two row ranges on two threads (blocks of two rows)
    args = (planes, index, box, lengths, offsets, opposite, bool(bezier), cr, cc, cw)
    _on_threads([lambda: _step_table_kernel(*args, 0, mid), lambda: _step_table_kernel(*args, mid, bh)])
    _boundary_reverses(index, box, lengths, offsets, opposite, mid)
    rows = np.array([box[0], max(box[1], box[0])], np.int64)
    return StepTable(pts, valid, index, lengths, offsets, bool(bezier), rows)


def table_geodesics(steps: StepTable, sources, stop_distances=None, wavefront: bool = True,
                    seed_radius: float = 3.0) -> list[np.ndarray]:
    """Geodesic distance maps from several sources on one :func:`step_table`, the searches run at
    once on threads (the kernel releases the GIL), each on its own work arrays.

    Parameters
    ----------
    steps : the frame's :class:`StepTable` (Bézier or chord lengths, any window).
    sources : K (u, v) pixel positions (column, row), sub-pixel, on valid pixels.
    stop_distances : None or K distances (mm; ``inf`` for none): each search stops beyond its own
        (:func:`~fringe3d.analyze.geodesic.bezier_geodesic` ``stop_distance``).
    wavefront, seed_radius : as :func:`~fringe3d.analyze.geodesic.bezier_geodesic`.

    Returns
    -------
    K maps (H, W) float64 mm, ``inf`` unreachable, invalid or beyond the stop distance; each is
    the map :func:`~fringe3d.analyze.geodesic.bezier_geodesic` gives for that source alone, bit for bit (every search is
    the same deterministic computation whatever runs beside it).
    """
    seeds = [_seeds(steps.points, steps.valid, src, seed_radius) for src in sources]   # errors raise here
    stops = [np.inf] * len(seeds) if stop_distances is None else [float(d) for d in stop_distances]
    step_flat, tri_side, nbr = _flat_tables(steps.offsets, steps.valid.shape[1])
    works = _work(steps, len(seeds))

    def search(i):
        return lambda: _dijkstra_table(steps.index, steps.rows, steps.lengths, seeds[i][0], seeds[i][1], step_flat,
                                       tri_side, nbr, bool(wavefront), stops[i], *works[i])

    return _on_threads([search(i) for i in range(len(seeds))])


def _on_threads(calls) -> list:
    """Run the callables at once, the first in this thread and each other on its own (the numba
    kernels release the GIL); returns their results in order, or raises the first error here."""
    out: list = [None] * len(calls)
    failed: list = []

    def run(i):
        try:
            out[i] = calls[i]()
        except BaseException as e:   # re-raised in the caller's thread below
            failed.append(e)

    threads = [threading.Thread(target=run, args=(i,)) for i in range(1, len(calls))]
    for t in threads:
        t.start()
    if calls:
        run(0)
    for t in threads:
        t.join()
    if failed:
        raise failed[0]
    return out


def _flat_tables(offsets: np.ndarray, width: int):
    """For :func:`_dijkstra_table`: each marching step as a flat index offset ``dr·W + dc`` (n,),
    the side A → B of its two wavefront triangles as an offset index ``(n, 2)`` (−1 if it is no
    marching step) and the angular neighbours ``(n, 2)`` (:func:`_wavefront_tables`)."""
    nbr, lut = _wavefront_tables(offsets)
    R = (lut.shape[0] - 1) // 2
    side = offsets[:, None, :] - offsets[nbr]          # B − A = a − b
    inside = (np.abs(side) <= R).all(axis=2)
    tri_side = np.where(inside, lut[np.clip(side[..., 0] + R, 0, 2 * R), np.clip(side[..., 1] + R, 0, 2 * R)], -1)
    return offsets[:, 0] * int(width) + offsets[:, 1], tri_side.astype(np.int64), nbr
