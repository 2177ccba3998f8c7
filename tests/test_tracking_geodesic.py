"""Geodesic point tracking (Eq. 6.9) against the analytic wing's material points."""
import numpy as np
import pytest
from conftest import ANCHORS, MARKERS, AnalyticWing, camera, point_map

from fringe3d.analyze.anchors import check_anchor, distance_maps, find_anchor_dots
from fringe3d.analyze.tracking import SURFACE_SAMPLING, side_of_line, track_points
from fringe3d.phase.sampling import sample_bilinear


def _wing():
    return AnalyticWing(np.array([-75.0, -35.0, 560.0]), +1,
                        curvature=lambda t: 1 / 500.0 + t * 0.2,
                        flap=lambda t: np.deg2rad(600.0) * t)


def test_tracked_markers_follow_their_material_points():
    cam, wing = camera(320, 256, 500.0), _wing()
    t0, t1 = 0.0, 0.02                                    # 12° flap, curvature 1/500 → 1/167 mm
    P0, P1 = (point_map([wing], cam, t)[0] for t in (t0, t1))
    a0 = np.array([cam.project(wing.world(*a, t0)) for a in ANCHORS])
    a1 = np.array([cam.project(wing.world(*a, t1)) for a in ANCHORS])
    q = cam.project(wing.world(MARKERS[:, 0], MARKERS[:, 1], t0))
    R1, R2 = distance_maps(P0, a0)
    d1, d2 = sample_bilinear(R1, q, **SURFACE_SAMPLING), sample_bilinear(R2, q, **SURFACE_SAMPLING)
    # reference distances equal the flat-sheet distances (isometric wing): wavefront geodesics
    np.testing.assert_allclose(d1, np.hypot(*(MARKERS - ANCHORS[0]).T), rtol=0.003)
    np.testing.assert_allclose(d2, np.hypot(*(MARKERS - ANCHORS[1]).T), rtol=0.003)
    D1, D2 = distance_maps(P1, a1)
    tr = track_points(d1, d2, D1, D2, side_of_line(q, *a0), a1)
    assert tr.ok.all() and tr.residual.max() < 1e-6
    xyz = sample_bilinear(P1, tr.uv, **SURFACE_SAMPLING)
    truth = wing.world(MARKERS[:, 0], MARKERS[:, 1], t1)
    err = np.linalg.norm(xyz - truth, axis=1)
    assert err.max() < 0.1          # mm (pixels are 1.12 mm at 560 mm)
    # the mirrored intersection is not chosen: every point stays on the wing's side
    assert (side_of_line(tr.uv, *a1) == side_of_line(q, *a0)).all()


def test_edge_only_geodesics_track_worse_by_their_direction_quantisation():
    cam, wing = camera(320, 256, 500.0), _wing()
    t0, t1 = 0.0, 0.02
    P0, P1 = (point_map([wing], cam, t)[0] for t in (t0, t1))
    a0 = np.array([cam.project(wing.world(*a, t0)) for a in ANCHORS])
    a1 = np.array([cam.project(wing.world(*a, t1)) for a in ANCHORS])
    q = cam.project(wing.world(MARKERS[:, 0], MARKERS[:, 1], t0))
    truth = wing.world(MARKERS[:, 0], MARKERS[:, 1], t1)
    errs = {}
    for method in ("bezier", "bezier-edges"):
        R1, R2 = distance_maps(P0, a0, method)
        d1, d2 = sample_bilinear(R1, q, **SURFACE_SAMPLING), sample_bilinear(R2, q, **SURFACE_SAMPLING)
        if method == "bezier-edges":   # within the stencil's 1.3 % bound, but not exact
            np.testing.assert_allclose(d1, np.hypot(*(MARKERS - ANCHORS[0]).T), rtol=0.0135)
        D1, D2 = distance_maps(P1, a1, method)
        tr = track_points(d1, d2, D1, D2, side_of_line(q, *a0), a1)
        errs[method] = np.linalg.norm(sample_bilinear(P1, tr.uv, **SURFACE_SAMPLING) - truth, axis=1).max()
    assert errs["bezier-edges"] < 1.5 and errs["bezier-edges"] > 5 * errs["bezier"]


def test_unreachable_targets_are_flagged_not_guessed():
    cam, wing = camera(320, 256, 500.0), _wing()
    P = point_map([wing], cam, 0.0)[0]
    a = np.array([cam.project(wing.world(*x, 0.0)) for x in ANCHORS])
    D1, D2 = distance_maps(P, a)
    tr = track_points(np.array([500.0]), np.array([500.0]), D1, D2, np.array([1.0]), a)
    assert not tr.ok[0] and tr.residual[0] > 100


def test_anchor_on_invalid_pixels_is_rejected():
    cam, wing = camera(320, 256, 500.0), _wing()
    P = point_map([wing], cam, 0.0)[0]
    with pytest.raises(ValueError, match="invalid"):
        check_anchor(P, (2.0, 2.0))   # background corner
    with pytest.raises(ValueError, match="outside"):
        check_anchor(P, (400.0, 2.0))


def test_anchor_dots_are_found_at_their_centres():
    img = np.zeros((120, 160))
    img[20:100, 20:140] = 200.0
    vv, uu = np.mgrid[0:120, 0:160]
    truth = np.array([[40.3, 35.6], [118.7, 80.2]])
    for u, v in truth:
        img[(uu - u) ** 2 + (vv - v) ** 2 <= 16] = 10.0
    found = find_anchor_dots(img, count=2)
    np.testing.assert_allclose(found, truth, atol=0.25)
    with pytest.raises(ValueError, match="expected 3"):
        find_anchor_dots(img, count=3)
