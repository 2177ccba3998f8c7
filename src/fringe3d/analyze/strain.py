"""Kirchhoff–Love bending strain of an inextensible membrane (dissertation ch. 6.4.3, Eq. 6.10–6.21).

For an inextensible shell the membrane strain vanishes and the Green–Lagrange strain at the
surface (θ³ = h/2) is ``E_αβ = (h/2)·κ_αβ`` (Eq. 6.11) with ``κ_αβ = b_αβ − B_αβ`` (Eq. 6.12),
the change of the second fundamental form between the reference and the current frame.

Local geometry (Eq. 6.13–6.21): around a (sub-pixel) point of an organized point map, the valid
points of an ``N×N`` pixel window are expressed in a local frame aligned with their best-fit
(tangent) plane and fitted with ``z = Aθ1² + Bθ2² + Cθ1θ2 + Dθ1 + Eθ2 + F``. Then
``r_,1 = t1 + D·n0``, ``r_,2 = t2 + E·n0`` (tangents), ``n = r_,1 × r_,2 / |…|`` (Eq. 6.21),
``r_,11 = 2A·n0``, ``r_,22 = 2B·n0``, ``r_,12 = C·n0`` and ``b_αβ = r_,αβ · n`` (Eq. 6.19–6.20).
Working in the tangent-plane frame (rather than the dissertation's θ = world x, y) keeps the
fit well conditioned on steep wing poses.

Components are compared in the same *material* basis in both frames: an orthonormal tangent
basis (e1, e2 = n × e1) whose e1 points from the point towards a material point (the first
anchor), projected on the tangent plane — exact for rigid motion and within a second-order
(curvature × distance)² angle for bending — or, when no target is given, the projection of the
world x axis (the dissertation's θ = world x, y parametrization). The gradient of the Dijkstra
distance map is *not* used: its direction snaps to the 32 marching directions (±9°). The
normal is oriented towards the camera (n · r < 0). Units: points in mm, b and κ in 1/mm, E
dimensionless (h in mm).
"""
from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

from fringe3d.analyze.anchors import distance_maps, fill_dot_holes
from fringe3d.analyze.geodesic import check_point_map, valid_mask
from fringe3d.analyze.tracking import SURFACE_SAMPLING, side_of_line, track_points
from fringe3d.phase.sampling import sample_bilinear

__all__ = ["LocalShape", "local_shape", "bending_strain", "StrainResult", "principal_strains", "TrackingSettings"]


@dataclass(frozen=True)
class TrackingSettings:
    """How the material points of a wing are tracked (Eq. 6.9) and their local shape fitted
    (Eq. 6.13-6.21): the settings :func:`wing_sequence` and
    :func:`fringe3d.analyze.wing_strain.run_strain` share.

    Attributes
    ----------
    window : int
        Odd side of the local-shape fit window, pixels (:func:`local_shape`; default 11).
    method : str
        Geodesic method: ``"bezier"`` (with wavefront update, the default), ``"bezier-edges"`` or
        ``"grid"`` (:func:`fringe3d.analyze.anchors.distance_maps`).
    radius : int
        Half-size of the Bézier marching window, pixels (default 3: a 7 x 7 window).
    fill_dots : int
        If > 0, holes within this many pixels of each anchor (dark dots do not reconstruct) are
        filled first (:func:`fringe3d.analyze.anchors.fill_dot_holes`); default 0, none.
    stop_margin : float or None
        Relative margin, dimensionless: on the deformed frames each anchor's geodesic search stops
        at ``(1 + stop_margin) · max_k d_k`` (mm), the farthest query point's reference distance
        plus this margin (an inextensible wing keeps its geodesic distances; the margin covers
        noise and the tracker's sub-pixel neighbourhood); None searches the whole map. Default 0.1.

    Examples
    --------
    >>> TrackingSettings(fill_dots=8).window
    11
    """

    window: int = 11
    method: str = "bezier"
    radius: int = 3
    fill_dots: int = 0
    stop_margin: float | None = 0.1


@dataclass
class LocalShape:
    """Local surface geometry at N points (all arrays have leading dimension N).

    point (N,3) mm; normal (N,3) unit, towards the camera; e1, e2 (N,3) orthonormal tangent
    basis; second_form (N,2,2) 1/mm in the (e1, e2) basis; residual (N,) RMS of the quadratic
    fit (mm); count (N,) valid points used; ok (N,) bool (enough points, finite result).
    """
    point: np.ndarray
    normal: np.ndarray
    e1: np.ndarray
    e2: np.ndarray
    second_form: np.ndarray
    residual: np.ndarray
    count: np.ndarray
    ok: np.ndarray


@numba.njit(cache=True, inline="always")
def _local_coords(pts, r, c, cen, t1, t2, n0):
    """Point (r, c) in the local frame at ``cen``: (θ1, θ2) along the tangents, z along n0."""
    dx = pts[r, c, 0] - cen[0]
    dy = pts[r, c, 1] - cen[1]
    dz = pts[r, c, 2] - cen[2]
    return (dx * t1[0] + dy * t1[1] + dz * t1[2], dx * t2[0] + dy * t2[1] + dz * t2[2],
            dx * n0[0] + dy * n0[1] + dz * n0[2])


@numba.njit(cache=True)
def _fit_quadric(pts, valid, rc, cc, half, cen, t1, t2, n0):
    """Least-squares ``z = Aθ1² + Bθ2² + Cθ1θ2 + Dθ1 + Eθ2 + F`` (Eq. 6.13) over the valid points of
    the window centred on (rc, cc), columns scaled for conditioning. Returns (coef (6,), sum of
    squared residuals)."""
    h, w = valid.shape
    ata = np.zeros((6, 6))
    atz = np.zeros(6)
    row = np.empty(6)
    for r in range(max(rc - half, 0), min(rc + half + 1, h)):
        for c in range(max(cc - half, 0), min(cc + half + 1, w)):
            if valid[r, c]:
                a1, a2, zz = _local_coords(pts, r, c, cen, t1, t2, n0)
                row[0] = a1 * a1
                row[1] = a2 * a2
                row[2] = a1 * a2
                row[3] = a1
                row[4] = a2
                row[5] = 1.0
                for a in range(6):
                    atz[a] += row[a] * zz
                    for b in range(6):
                        ata[a, b] += row[a] * row[b]
    scale = np.empty(6)
    for a in range(6):
        scale[a] = 1.0 / np.sqrt(ata[a, a]) if ata[a, a] > 0 else 1.0
    for a in range(6):
        atz[a] *= scale[a]
        for b in range(6):
            ata[a, b] *= scale[a] * scale[b]
    coef = np.linalg.solve(ata, atz) * scale
    ss = 0.0
    for r in range(max(rc - half, 0), min(rc + half + 1, h)):
        for c in range(max(cc - half, 0), min(cc + half + 1, w)):
            if valid[r, c]:
                a1, a2, zz = _local_coords(pts, r, c, cen, t1, t2, n0)
                e = zz - (coef[0] * a1 * a1 + coef[1] * a2 * a2 + coef[2] * a1 * a2 + coef[3] * a1
                          + coef[4] * a2 + coef[5])
                ss += e * e
    return coef, ss


@numba.njit(cache=True, nogil=True)  # frames run on threads (fringe3d strain --workers)
def _local_shape_kernel(pts, valid, toward, has_toward, uv, half, min_count, out):
    h, w = valid.shape
    n = uv.shape[0]
    for q in range(n):
        out[q, :] = np.nan
        u = uv[q, 0]
        v = uv[q, 1]
        if not (u >= 0.0 and v >= 0.0 and u <= w - 1 and v <= h - 1):
            continue
        # centre point: bilinear interpolation (requires its 4 corners valid)
        r0 = min(int(np.floor(v)), h - 2)
        c0 = min(int(np.floor(u)), w - 2)
        fr = v - r0
        fc = u - c0
        if not (valid[r0, c0] and valid[r0 + 1, c0] and valid[r0, c0 + 1] and valid[r0 + 1, c0 + 1]):
            continue
        cen = np.empty(3)
        for k in range(3):
            cen[k] = ((1 - fr) * ((1 - fc) * pts[r0, c0, k] + fc * pts[r0, c0 + 1, k])
                      + fr * ((1 - fc) * pts[r0 + 1, c0, k] + fc * pts[r0 + 1, c0 + 1, k]))
        rc = int(np.round(v))
        cc = int(np.round(u))
        # pass 1: centroid and scatter for the local frame
        cnt = 0
        mean = np.zeros(3)
        for r in range(max(rc - half, 0), min(rc + half + 1, h)):
            for c in range(max(cc - half, 0), min(cc + half + 1, w)):
                if valid[r, c]:
                    cnt += 1
                    for k in range(3):
                        mean[k] += pts[r, c, k]
        if cnt < min_count:
            continue
        mean /= cnt
        cov = np.zeros((3, 3))
        for r in range(max(rc - half, 0), min(rc + half + 1, h)):
            for c in range(max(cc - half, 0), min(cc + half + 1, w)):
                if valid[r, c]:
                    for a in range(3):
                        for b in range(3):
                            cov[a, b] += (pts[r, c, a] - mean[a]) * (pts[r, c, b] - mean[b])
        evals, evecs = np.linalg.eigh(cov)
        n0 = evecs[:, 0].copy()
        t1 = evecs[:, 2].copy()
        t2 = np.cross(n0, t1)
        # pass 2: least squares in (θ1, θ2, z) with origin at the centre point (Eq. 6.13-6.15)
        coef, ss = _fit_quadric(pts, valid, rc, cc, half, cen, t1, t2, n0)
        A, B, C, D, E, F = coef[0], coef[1], coef[2], coef[3], coef[4], coef[5]
        # differential geometry at θ = 0 (Eq. 6.16–6.21)
        r1 = t1 + D * n0
        r2 = t2 + E * n0
        nn = np.cross(r1, r2)
        nn /= np.sqrt(nn[0] ** 2 + nn[1] ** 2 + nn[2] ** 2)
        p = cen + F * n0
        if nn[0] * p[0] + nn[1] * p[1] + nn[2] * p[2] > 0:  # orient towards the camera
            nn = -nn
        ndot = nn[0] * n0[0] + nn[1] * n0[1] + nn[2] * n0[2]
        bc = np.empty((2, 2))
        bc[0, 0] = 2 * A * ndot
        bc[1, 1] = 2 * B * ndot
        bc[0, 1] = C * ndot
        bc[1, 0] = C * ndot
        g = np.empty((2, 2))
        g[0, 0] = r1 @ r1
        g[0, 1] = r1 @ r2
        g[1, 0] = g[0, 1]
        g[1, 1] = r2 @ r2
        ginv = np.linalg.inv(g)
        # material direction e1
        if has_toward:
            e1 = toward[q] - p
        else:
            e1 = np.array([1.0, 0.0, 0.0])
        e1 = e1 - (e1 @ nn) * nn
        e1 /= np.sqrt(e1 @ e1)
        e2 = np.cross(nn, e1)
        # coordinates of e1, e2 in (r1, r2) and the second form in the orthonormal basis
        c1 = np.empty(2)
        c2 = np.empty(2)
        c1[0] = ginv[0, 0] * (r1 @ e1) + ginv[0, 1] * (r2 @ e1)
        c1[1] = ginv[1, 0] * (r1 @ e1) + ginv[1, 1] * (r2 @ e1)
        c2[0] = ginv[0, 0] * (r1 @ e2) + ginv[0, 1] * (r2 @ e2)
        c2[1] = ginv[1, 0] * (r1 @ e2) + ginv[1, 1] * (r2 @ e2)
        ii11 = c1 @ (bc @ c1)
        ii12 = c1 @ (bc @ c2)
        ii22 = c2 @ (bc @ c2)
        out[q, 0:3] = p
        out[q, 3:6] = nn
        out[q, 6:9] = e1
        out[q, 9:12] = e2
        out[q, 12] = ii11
        out[q, 13] = ii12
        out[q, 14] = ii22
        out[q, 15] = np.sqrt(ss / cnt)
        out[q, 16] = cnt


def local_shape(points: np.ndarray, uv: np.ndarray, window: int = 11, toward: np.ndarray | None = None,
                min_fraction: float = 0.75) -> LocalShape:
    """Quadratic-fit surface geometry at sub-pixel positions ``uv`` (Eq. 6.13–6.21).

    Parameters
    ----------
    points : (H, W, 3) float, mm, NaN invalid.
    uv : (N, 2) float pixel positions (u column, v row).
    window : odd int ≥ 3, side of the square pixel neighbourhood used for the fit.
    toward : optional (3,) or (N, 3) mm, a material point (e.g. the first anchor) that e1
        points to (projected on the tangent plane). Without it e1 is the world x axis projected
        on the tangent plane.
    min_fraction : fraction of the window that must be valid for a result.

    Returns
    -------
    LocalShape
        Point, normal, tangent basis (e1, e2), second fundamental form (1/mm), fit RMS (mm),
        point count and ``ok`` flag per position; NaN where too few window pixels are valid.
    """
    if window < 3 or window % 2 == 0:
        raise ValueError(f"window must be an odd integer ≥ 3 (pixels); got {window}")
    pts = check_point_map(points)
    valid = valid_mask(pts)   # the kernel reads valid pixels only, so NaN elsewhere is harmless
    uv = np.atleast_2d(np.asarray(uv, dtype=np.float64))
    if uv.shape[1] != 2:
        raise ValueError(f"uv must have shape (N, 2); got {uv.shape}")
    has = toward is not None
    tw = np.broadcast_to(np.asarray(toward if has else np.zeros(3), dtype=np.float64), (uv.shape[0], 3)).copy()
    min_count = max(6, int(min_fraction * window * window))
    out = np.empty((uv.shape[0], 17))
    _local_shape_kernel(pts, valid, tw, has, uv, window // 2, min_count, out)
    ii = np.empty((uv.shape[0], 2, 2))
    ii[:, 0, 0], ii[:, 0, 1], ii[:, 1, 0], ii[:, 1, 1] = out[:, 12], out[:, 13], out[:, 13], out[:, 14]
    ok = np.isfinite(out[:, :15]).all(axis=1)
    cnt = np.nan_to_num(out[:, 16]).astype(np.int64)
    return LocalShape(out[:, 0:3], out[:, 3:6], out[:, 6:9], out[:, 9:12], ii, out[:, 15], cnt, ok)


def principal_strains(E: np.ndarray, e1: np.ndarray | None = None, e2: np.ndarray | None = None):
    """Principal values (N,2) ascending, and directions of a symmetric 2×2 tensor field E (N,2,2).

    Parameters
    ----------
    E : (N, 2, 2) array_like
        Symmetric tensors in the (e1, e2) basis; rows with a non-finite entry give NaN.
    e1, e2 : (N, 3) ndarray, optional
        The basis vectors in 3D; with both, the principal directions are also returned in 3D.

    Returns
    -------
    values : (N, 2) ndarray
        Eigenvalues, ascending.
    directions2d : (N, 2, 2) ndarray
        Columns = eigenvectors in the (e1, e2) basis.
    dominant : (N,) ndarray
        The eigenvalue of largest magnitude.
    directions3d : (N, 2, 3) ndarray or None
        The eigenvectors in 3D (``[:, k]`` for eigenvalue ``k``); None without ``e1`` and ``e2``.
    """
    E = np.asarray(E, dtype=np.float64)
    good = np.isfinite(E).all(axis=(1, 2))
    vals = np.full(E.shape[:2], np.nan)
    vecs = np.full(E.shape, np.nan)
    if good.any():
        vals[good], vecs[good] = np.linalg.eigh(E[good])
    idx = np.where(np.abs(vals[:, 1]) >= np.abs(vals[:, 0]), 1, 0)
    dominant = np.take_along_axis(vals, idx[:, None], axis=1)[:, 0]
    d3 = None
    if e1 is not None and e2 is not None:
        d3 = vecs[:, 0, :, None] * e1[:, None, :] + vecs[:, 1, :, None] * e2[:, None, :]
    return vals, vecs, dominant, d3


@dataclass
class StrainResult:
    """Bending strain at N material points (Eq. 6.11–6.12).

    E (N,2,2) Green–Lagrange strain in the material basis; kappa (N,2,2) 1/mm; principal (N,2);
    dominant (N,); direction (N,2,3) principal directions in the current frame; ok (N,) bool.
    """
    E: np.ndarray
    kappa: np.ndarray
    principal: np.ndarray
    dominant: np.ndarray
    direction: np.ndarray
    ok: np.ndarray
    current: LocalShape
    reference: LocalShape


def bending_strain(reference: LocalShape, current: LocalShape, thickness: float) -> StrainResult:
    """``E = (h/2)(b − B)`` (Eq. 6.11–6.12) from the reference (B) and current (b) local shapes
    of the same material points. ``thickness`` h in mm (> 0).

    Parameters
    ----------
    reference : LocalShape
        Local shapes of the N points on the reference frame (B).
    current : LocalShape
        Local shapes of the same N points on the current frame (b).
    thickness : float
        Wing (membrane) thickness h, mm (> 0).

    Returns
    -------
    StrainResult
        Strain ``E`` (N, 2, 2), curvature change ``kappa`` (1/mm), principal strains, dominant
        strain, principal directions in the current frame and ``ok`` (both shapes valid).
    """
    if not (thickness > 0):
        raise ValueError(f"thickness must be a positive number in mm; got {thickness}")
    if reference.second_form.shape != current.second_form.shape:
        raise ValueError("reference and current shapes must describe the same number of points")
    kappa = current.second_form - reference.second_form
    E = 0.5 * thickness * kappa
    vals, _, dom, d3 = principal_strains(E, current.e1, current.e2)
    ok = reference.ok & current.ok
    return StrainResult(E, kappa, vals, dom, d3, ok, current, reference)


# --- a whole sequence: track material points of one wing and compute their strain ---------------
@dataclass
class WingSequence:
    """Tracking and strain of N material points of one wing over F frames.

    ref_uv (N,2) reference pixel positions; d (N,2) reference geodesic distances to the anchors
    (mm); uv (F,N,2); xyz (F,N,3) mm; E (F,N,2,2); principal (F,N,2); dominant (F,N);
    residual (F,N) mm (tracking residual); ok (F,N) bool: tracked and fitted.
    """
    ref_uv: np.ndarray
    d: np.ndarray
    uv: np.ndarray
    xyz: np.ndarray
    E: np.ndarray
    principal: np.ndarray
    dominant: np.ndarray
    residual: np.ndarray
    ok: np.ndarray


def wing_sequence(frames, anchors, query_uv: np.ndarray, thickness: float,
                  tracking: TrackingSettings | None = None, reference: int = 0, progress=None) -> WingSequence:
    """Track ``query_uv`` (N,2) of the reference frame through ``frames`` and compute strain.

    Tracking: Eq. 6.9 (:func:`fringe3d.analyze.tracking.track_points`); strain: Eq. 6.11–6.21
    with the direction towards the farther anchor as the material direction.
    Frames are read one at a time (``frames[i]``), so memory does not grow with F beyond the
    (F, N) result arrays.

    Parameters
    ----------
    frames : sequence of F point maps (H, W, 3) mm
        (or an indexable ``i -> map`` with ``len``).
    anchors : (F, 2, 2)
        Anchor pixel positions (u, v) of this wing on every frame.
    query_uv : (N, 2)
        Pixel positions (u column, v row) of the material points on the reference frame.
    thickness : float
        Wing thickness h, mm (> 0; :func:`bending_strain`).
    tracking : TrackingSettings, optional
        Fit window, geodesic method and window, dot filling and search margin (default
        ``TrackingSettings()``).
    reference : int
        Index of the reference frame.
    progress : callable, optional
        Called with no argument once per frame.

    Returns
    -------
    WingSequence
        Reference positions and distances, and per frame the tracked ``uv`` (px), ``xyz`` (mm),
        strain ``E``, principal and dominant strains, tracking residual (mm) and ``ok`` flags.
    """
    anchors = np.asarray(anchors, dtype=np.float64)
    nf = len(frames)
    if anchors.shape != (nf, 2, 2):
        raise ValueError(f"anchors must have shape (frames={nf}, 2, 2); got {anchors.shape}")
    ref = wing_reference(frames[reference], anchors[reference], query_uv, thickness, tracking)
    n = ref.q.shape[0]
    out = WingSequence(ref.q, ref.d, np.full((nf, n, 2), np.nan), np.full((nf, n, 3), np.nan),
                       np.full((nf, n, 2, 2), np.nan), np.full((nf, n, 2), np.nan), np.full((nf, n), np.nan),
                       np.full((nf, n), np.nan), np.zeros((nf, n), bool))
    for f in range(nf):
        r = wing_frame(ref, None if f == reference else frames[f], anchors[f], f)
        out.uv[f], out.xyz[f], out.E[f], out.principal[f] = r.uv, r.xyz, r.E, r.principal
        out.dominant[f], out.residual[f], out.ok[f] = r.dominant, r.residual, r.ok
        if progress is not None:
            progress()
    return out


@dataclass
class WingReference:
    """What every frame of one wing is tracked against (from the reference frame).

    points (H, W, 3) mm the reference map (dot holes filled); anchors (2, 2) px; q (N, 2) the
    query pixels; d (N, 2) mm their geodesic distances to the anchors (the reference distance
    maps themselves are not kept: a Dask worker receives this object); side (N,) ±1 their side
    of the anchor line; far (N,) index of the farther anchor (the material direction); stop (2,)
    mm or None, each deformed frame's search radius; B the reference :class:`LocalShape`; and the
    run's thickness (mm), window (px), method, radius and fill_dots.
    """
    points: np.ndarray
    anchors: np.ndarray
    q: np.ndarray
    d: np.ndarray
    side: np.ndarray
    far: np.ndarray
    stop: np.ndarray | None
    B: LocalShape
    thickness: float
    window: int
    method: str
    radius: int
    fill_dots: int


@dataclass
class WingFrame:
    """One frame's results for N points of one wing (the rows of :class:`WingSequence`): uv (N, 2)
    px, xyz (N, 3) mm, E (N, 2, 2), principal (N, 2), dominant (N,), residual (N,) mm, ok (N,)."""
    uv: np.ndarray
    xyz: np.ndarray
    E: np.ndarray
    principal: np.ndarray
    dominant: np.ndarray
    residual: np.ndarray
    ok: np.ndarray


def _filled(points, anchors, fill_dots: int) -> np.ndarray:
    return fill_dot_holes(points, anchors, fill_dots) if fill_dots > 0 else np.asarray(points, float)


def wing_reference(points: np.ndarray, anchors: np.ndarray, query_uv: np.ndarray, thickness: float,
                   tracking: TrackingSettings | None = None) -> WingReference:
    """The :class:`WingReference` of one wing from its reference point map (H, W, 3) mm and anchors
    (2, 2) px (parameters as :func:`wing_sequence`): the reference distance maps (Eq. 6.7–6.8),
    the query points' distances, sides and material direction, and their local shapes (Eq. 6.13–6.21)."""
    t = tracking if tracking is not None else TrackingSettings()
    window, method, radius, fill_dots, stop_margin = t.window, t.method, t.radius, t.fill_dots, t.stop_margin
    anchors = np.asarray(anchors, dtype=np.float64)
    q = np.atleast_2d(np.asarray(query_uv, dtype=np.float64))
    ref_pts = _filled(points, anchors, fill_dots)
    R1, R2 = distance_maps(ref_pts, anchors, method, radius)
    d = np.stack([sample_bilinear(R1, q, **SURFACE_SAMPLING), sample_bilinear(R2, q, **SURFACE_SAMPLING)], axis=1)
    side = side_of_line(q, *anchors)
    # material direction: towards the farther anchor (well defined, same choice in every frame)
    far = np.where(d[:, 0] >= d[:, 1], 0, 1)
    stop = None
    if stop_margin is not None:
        dmax = np.array([np.max(c[np.isfinite(c)], initial=0.0) for c in d.T])
        stop = np.where(dmax > 0, (1.0 + float(stop_margin)) * dmax, np.inf)
    B = local_shape(ref_pts, q, window, toward=sample_bilinear(ref_pts, anchors, **SURFACE_SAMPLING)[far])
    return WingReference(ref_pts, anchors, q, d, side, far, stop, B, float(thickness), int(window), method,
                         int(radius), int(fill_dots))


def wing_frame(ref: WingReference, points: np.ndarray | None, anchors: np.ndarray, index: int = 0) -> WingFrame:
    """Track the reference's points on one frame and compute their strain (Eq. 6.9–6.21).

    points : (H, W, 3) mm, or None for the reference frame itself (then ``anchors`` are ignored).
    anchors : (2, 2) px this frame's anchors. index : the frame's number, for messages.
    Depends on nothing but ``ref`` and this frame, so frames can be processed in any order or at once.
    """
    n = ref.q.shape[0]
    if points is None:
        pts, anchors = ref.points, ref.anchors
        uv, res, okt = ref.q.copy(), np.zeros(n), np.isfinite(ref.d).all(axis=1)
    else:
        anchors = np.asarray(anchors, dtype=np.float64)
        try:
            pts = _filled(points, anchors, ref.fill_dots)
            D1, D2 = distance_maps(pts, anchors, ref.method, ref.radius, stop_distance=ref.stop)
        except ValueError as e:
            raise ValueError(f"frame {index}: {e}") from None
        tr = track_points(ref.d[:, 0], ref.d[:, 1], D1, D2, ref.side, anchors)
        uv, res, okt = tr.uv, tr.residual, tr.ok
    cur = local_shape(pts, uv, ref.window, toward=sample_bilinear(pts, anchors, **SURFACE_SAMPLING)[ref.far])
    st = bending_strain(ref.B, cur, ref.thickness)
    xyz = sample_bilinear(np.asarray(pts, dtype=np.float64), uv, **SURFACE_SAMPLING)
    ok = okt & st.ok & np.isfinite(xyz).all(axis=1)
    return WingFrame(uv, xyz, st.E, st.principal, st.dominant, res, ok)
