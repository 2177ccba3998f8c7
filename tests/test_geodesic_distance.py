"""Geodesic distance maps against closed forms (plane, cylinder, sphere) and potpourri3d."""

import numpy as np
import pytest

from fringe3d.analyze.geodesic import (MARCH_OFFSETS, _virtual_source, bezier_arc_length, bezier_geodesic,
                                       grid_geodesic, heat_geodesic, heat_time_coefficient, step_table,
                                       table_geodesics)


def cylinder_map(h=128, w=160, radius=40.0, pitch=0.3, z0=300.0):
    """Cylinder (axis along y) sampled on a camera-like grid; returns map and unrolled coords."""
    v, u = np.mgrid[0:h, 0:w].astype(float)
    y = (v - h / 2) * pitch
    s = (u - w / 2) * pitch
    pts = np.dstack([radius * np.sin(s / radius), y, z0 - radius * (1 - np.cos(s / radius))])
    return pts, s, y


def sphere_map(n=121, radius=30.0, z0=300.0):
    """Upper cap of a sphere seen from the camera (orthographic grid), great-circle truth."""
    v, u = np.mgrid[0:n, 0:n].astype(float)
    x = (u - n // 2) * 0.3
    y = (v - n // 2) * 0.3
    r2 = x ** 2 + y ** 2
    z = np.where(r2 < (0.8 * radius) ** 2, np.sqrt(np.maximum(radius ** 2 - r2, 0)), np.nan)
    pts = np.dstack([x, y, z0 - z])
    pts[~np.isfinite(z)] = np.nan
    return pts


def rel_error(d, truth, mask):
    return np.abs(d[mask] - truth[mask]) / truth[mask]


def test_march_offsets_are_the_32_primitive_directions_of_a_7x7_window():
    assert len(MARCH_OFFSETS) == 32
    assert np.abs(MARCH_OFFSETS).max() == 3
    assert all(np.gcd(abs(a), abs(b)) == 1 for a, b in MARCH_OFFSETS)


def test_bezier_arc_length_matches_closed_forms():
    # collinear evenly spaced control points: the chord
    assert bezier_arc_length([0, 0, 0], [1, 0, 0], [2, 0, 0], [3, 0, 0]) == pytest.approx(3.0, rel=1e-12)
    # parabola-like Bézier (0,0)-(1,1)-(2,1)-(3,0): compare with dense polyline
    P = np.array([[0, 0, 0], [1, 1, 0], [2, 1, 0], [3, 0, 0]], float)
    t = np.linspace(0, 1, 200001)[:, None]
    B = (1 - t) ** 3 * P[0] + 3 * (1 - t) ** 2 * t * P[1] + 3 * (1 - t) * t ** 2 * P[2] + t ** 3 * P[3]
    ref = np.linalg.norm(np.diff(B, axis=0), axis=1).sum()
    assert bezier_arc_length(*P) == pytest.approx(ref, rel=2e-4)


def test_plane_distances_along_march_directions_are_exact():
    v, u = np.mgrid[0:40, 0:50].astype(float)
    pts = np.dstack([u * 0.5, v * 0.5, np.full_like(u, 200.0)])
    d = bezier_geodesic(pts, (10, 10))
    truth = 0.5 * np.hypot(u - 10, v - 10)
    for di, dj in MARCH_OFFSETS:
        r, c = 10 + 3 * di, 10 + 3 * dj
        if 0 <= r < 40 and 0 <= c < 50:
            assert d[r, c] == pytest.approx(truth[r, c], rel=1e-9)


def stencil_norm(dv, du):
    """Closed form of the shortest chain of 7×7 marching steps on a unit-pitch plane: the norm
    whose unit ball is the convex hull of the unit step directions a/|a| (facets between
    angularly adjacent directions)."""
    a = MARCH_OFFSETS[np.argsort(np.arctan2(MARCH_OFFSETS[:, 0], MARCH_OFFSETS[:, 1]))].astype(float)
    a /= np.linalg.norm(a, axis=1, keepdims=True)
    b = np.roll(a, -1, axis=0)
    normals = np.stack([np.linalg.solve(np.stack([p, q]), [1.0, 1.0]) for p, q in zip(a, b)])
    return np.max(normals[:, 0, None, None] * dv + normals[:, 1, None, None] * du, axis=0)


def test_edge_only_bezier_dijkstra_error_is_the_stencil_direction_quantisation():
    v, u = np.mgrid[0:61, 0:61].astype(float)
    pts = np.dstack([u * 0.5, v * 0.5, np.full_like(u, 200.0)])
    d = bezier_geodesic(pts, (30, 30), wavefront=False)
    expected = 0.5 * stencil_norm(v - 30, u - 30)
    assert np.allclose(d, expected, rtol=1e-9, atol=1e-9)
    with np.errstate(invalid="ignore", divide="ignore"):
        rel = d / (0.5 * np.hypot(u - 30, v - 30)) - 1
    disk = (np.hypot(u - 30, v - 30) > 5) & (np.hypot(u - 30, v - 30) < 30)
    assert rel[disk].max() == pytest.approx(1 / np.cos(np.arctan(1 / 3) / 2) - 1, rel=0.05)   # 1.3 %
    assert 0.004 < rel[disk].mean() < 0.006                   # ≈ Σφ³/(12 Σφ) = 0.49 % for uniform directions


def test_wavefront_bezier_dijkstra_is_exact_on_a_cylinder_from_a_subpixel_source():
    pts, s, y = cylinder_map()
    src = (20.37, 30.61)
    r0, c0, fr, fc = 30, 20, 0.61, 0.37
    s0 = (1 - fc) * s[r0, c0] + fc * s[r0, c0 + 1]
    y0 = (1 - fr) * y[r0, c0] + fr * y[r0 + 1, c0]
    truth = np.hypot(s - s0, y - y0)
    far = truth > 2.0
    e = rel_error(bezier_geodesic(pts, src), truth, far)
    assert e.mean() < 1e-4 and e.max() < 1e-3
    e_edges = rel_error(bezier_geodesic(pts, src, wavefront=False), truth, far)
    assert e_edges.mean() > 20 * e.mean()


def test_bezier_dijkstra_beats_8_neighbour_and_heat_method_on_a_cylinder():
    pts, s, y = cylinder_map()
    src = (20, 30)
    truth = np.hypot(s - s[30, 20], y - y[30, 20])  # unrolled Euclidean distance
    far = truth > 5.0
    d_bez = bezier_geodesic(pts, src, wavefront=False)
    d_8 = grid_geodesic(pts, src)
    d_heat = heat_geodesic(pts, src)
    e_bez, e_8, e_heat = (rel_error(d, truth, far) for d in (d_bez, d_8, d_heat))
    # metrication bound of the 32-direction stencil: sec(atan(1/3)/2) − 1 ≈ 1.3 %
    assert e_bez.max() < 0.0135
    assert e_bez.mean() < 0.006
    assert e_8.mean() > 5 * e_bez.mean()          # 8-neighbour: up to sec(22.5°) − 1 ≈ 8 %
    assert e_8.max() == pytest.approx(1 / np.cos(np.pi / 8) - 1, rel=0.05)
    assert e_heat.mean() > e_bez.mean()


def test_bezier_dijkstra_on_a_sphere_matches_great_circle_distance():
    """Non-developable: the wavefront update is no longer exact but still beats the edge-only chain."""
    R = 30.0
    pts = sphere_map(radius=R)
    c = 60
    src = pts[c, c] - np.array([0, 0, 300.0])
    q = pts - np.array([0, 0, 300.0])
    truth = R * np.arccos(np.clip((q @ src) / R ** 2, -1, 1))
    d_edges = bezier_geodesic(pts, (c, c), wavefront=False)
    d = bezier_geodesic(pts, (c, c))
    m = np.isfinite(truth) & (truth > 3) & np.isfinite(d)
    e, e_edges = rel_error(d, truth, m), rel_error(d_edges, truth, m)
    assert e_edges.mean() < 0.008 and e_edges.max() < 0.02
    assert e.mean() < 0.002 and e.mean() < e_edges.mean() / 3


def test_holes_block_the_front_instead_of_being_jumped():
    v, u = np.mgrid[0:60, 0:60].astype(float)
    pts = np.dstack([u, v, np.full_like(u, 100.0)])
    pts[:50, 28:31] = np.nan  # a wall 3 px thick, open at the bottom (rows 50..59)
    d = bezier_geodesic(pts, (10, 10))
    assert np.isinf(d[:50, 28:31]).all()
    # (u=50, v=10) must go around the wall through the gap: at least the detour length
    detour = np.hypot(28 - 10, 50 - 10) + np.hypot(50 - 31, 50 - 10)
    assert d[10, 50] >= 0.99 * detour
    # an isolated island is unreachable
    pts2 = pts.copy()
    pts2[:, 28:31] = np.nan
    d2 = bezier_geodesic(pts2, (10, 10))
    assert np.isinf(d2[:, 40:]).all()


def test_source_on_invalid_pixel_or_outside_is_rejected():
    pts, _, _ = cylinder_map(20, 20)
    pts[5, 5] = np.nan
    with pytest.raises(ValueError, match="invalid"):
        bezier_geodesic(pts, (5, 5))
    with pytest.raises(ValueError, match="outside"):
        bezier_geodesic(pts, (25, 3))
    with pytest.raises(ValueError, match=r"\(H, W, 3\)"):
        bezier_geodesic(pts[..., :2], (3, 3))


def test_heat_method_time_step_grows_with_the_map_so_the_far_field_survives():
    # a long strip: with t = h² the heat is lost in round-off a few hundred edges from the source
    pts, s, y = cylinder_map(h=40, w=1000, radius=300.0, pitch=0.1)
    truth = np.hypot(s - s[20, 5], y - y[20, 5])
    far = truth > 60.0                                          # > 600 edge lengths away
    assert heat_time_coefficient(pts) == pytest.approx((1000 / 300) ** 2)
    e_auto = rel_error(heat_geodesic(pts, (5, 20)), truth, far)
    e_h2 = rel_error(heat_geodesic(pts, (5, 20), t_coef=1.0), truth, far)
    assert e_h2.mean() > 0.25 and e_auto.mean() < 0.1


@pytest.mark.parametrize("wavefront", [True, False])
def test_step_table_search_gives_the_full_search_distances(wavefront):
    pts, _, _ = cylinder_map()
    pts[40:50, 60:75] = np.nan                               # a hole the front must go around
    pts[np.random.default_rng(3).random(pts.shape[:2]) < 0.01] = np.nan
    full = bezier_geodesic(pts, (20.3, 64.6), wavefront=wavefront)
    steps = step_table(pts)
    tab = bezier_geodesic(pts, (20.3, 64.6), wavefront=wavefront, steps=steps)
    assert np.array_equal(np.isfinite(tab), np.isfinite(full))
    f = np.isfinite(full)
    np.testing.assert_allclose(tab[f], full[f], rtol=1e-12, atol=1e-12)
    # the same table serves a second source on the same frame
    np.testing.assert_allclose(bezier_geodesic(pts, (120.0, 30.0), steps=steps)[f],
                               bezier_geodesic(pts, (120.0, 30.0))[f], rtol=1e-12, atol=1e-12)


def test_bounded_search_matches_the_full_search_within_the_stop_distance():
    pts, s, y = cylinder_map()
    src = (30.0, 64.0)
    full = bezier_geodesic(pts, src)
    stop = 15.0
    bounded = bezier_geodesic(pts, src, stop_distance=stop)
    near = full <= stop
    assert near.sum() > 1000 and (~near).sum() > 1000
    np.testing.assert_allclose(bounded[near], full[near], rtol=1e-12, atol=1e-12)
    assert np.isinf(bounded[~near]).all()                   # nothing beyond the stop distance is settled
    # and against the cylinder's closed form (unrolled plane distance) at the query points
    truth = np.hypot(s - s[64, 30], y - y[64, 30])
    q = near & (truth > 3.0)
    assert np.max(np.abs(bounded[q] - truth[q]) / truth[q]) < 1e-3


def test_step_table_must_match_the_requested_window():
    pts, _, _ = cylinder_map(32, 40)
    with pytest.raises(ValueError, match="another window"):
        bezier_geodesic(pts, (5, 5), radius=2, steps=step_table(pts, radius=3))


def _step_by_hand(pts, r, c, dr, dc):
    """Bézier arc length of the step (r, c) → (r + dr, c + dc) with P1, P2 interpolated bilinearly
    at k/3 of the way (numpy, corner by corner); None when a point it needs is invalid."""
    h, w, _ = pts.shape
    if not (0 <= r + dr < h and 0 <= c + dc < w):
        return None
    ctrl = []
    for k in (0, 1, 2, 3):
        fr, fc = r + dr * k / 3, c + dc * k / 3
        r0, c0 = int(np.floor(fr + 1e-12)), int(np.floor(fc + 1e-12))
        ar, ac = fr - r0, fc - c0
        ar, ac = (0.0 if ar < 1e-9 else ar), (0.0 if ac < 1e-9 else ac)
        corners = {(r0 + i, c0 + j): (ar if i else 1 - ar) * (ac if j else 1 - ac)
                   for i in (0, 1) if i == 0 or ar > 0 for j in (0, 1) if j == 0 or ac > 0}
        if any(not np.isfinite(pts[q]).all() for q in corners):
            return None
        ctrl.append(sum(wgt * pts[q] for q, wgt in corners.items()))
    return bezier_arc_length(*ctrl)


def test_step_table_holds_each_steps_bezier_length_and_minus_one_where_a_point_is_invalid():
    pts, _, _ = cylinder_map(130, 22)                      # tall enough for the two-thread row split
    rng = np.random.default_rng(5)
    pts[rng.random(pts.shape[:2]) < 0.05] = np.nan
    pts[20:26, 8:15] = np.nan
    pts[5, 7, 2] = np.inf                                   # one bad coordinate invalidates the pixel
    steps = step_table(pts)
    n_valid = n_invalid = 0
    for r, c in zip(*np.nonzero(steps.index >= 0)):         # every node, every step
        for o, (dr, dc) in enumerate(MARCH_OFFSETS):
            got = steps.lengths[steps.index[r, c], o]
            want = _step_by_hand(pts, r, c, dr, dc)
            if want is None:
                assert got == -1.0
                n_invalid += 1
            else:
                assert got == pytest.approx(want, rel=1e-12)
                n_valid += 1
    assert n_valid > 50000 and n_invalid > 10000


def test_searches_run_together_give_each_sources_own_map_bit_for_bit():
    pts, _, _ = cylinder_map()
    pts[40:50, 60:75] = np.nan
    sources, stops = [(20.3, 64.6), (120.0, 30.0), (80.5, 100.2)], [20.0, np.inf, 9.0]
    together = table_geodesics(step_table(pts), sources, stops)
    for src, stop, d in zip(sources, stops, together):
        assert np.array_equal(d, bezier_geodesic(pts, src, steps=step_table(pts), stop_distance=stop))
    assert np.isinf(together[2][~(together[2] <= 9.0)]).all() and np.isfinite(together[1]).sum() > 15000


def test_virtual_source_bound_never_drops_a_candidate_that_would_win():
    rng = np.random.default_rng(11)
    n, kept = 20000, 0
    for la, lb, lc, da, db in zip(*(rng.uniform(0.05, 1.0, (3, n))), *(rng.uniform(0.0, 50.0, (2, n)))):
        db = da + (db - 25.0) * lc / 25.0                    # |da − db| ≤ lc: S exists
        v = _virtual_source(la, lb, lc, da, db, np.inf)
        if np.isfinite(v):
            kept += 1
            assert _virtual_source(la, lb, lc, da, db, v * (1 + 1e-14)) == v
            assert _virtual_source(la, lb, lc, da, db, v) == v
    assert kept > 1000
