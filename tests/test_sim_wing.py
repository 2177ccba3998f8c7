"""Flapping-wing truth: isometry (geodesics), curvature and strain against numerical estimates."""
import numpy as np
import pytest

from fringe3d.optics import PinholeDevice, intrinsics
from fringe3d.sim.wing import Wing, WingBeat, WingDots, WingShape

TIMES = (0.0, 0.004, 0.011, 0.027)


def _wing(**kw):
    base = dict(kappa_mean=0.004, kappa_amp=1 / 50, bend_angle=0.35, bend_offset=10.0,
                anchors=[(6, 6), (140, 6)], markers=[(40, 30), (90, 25)])
    base.update(kw)
    return Wing.from_fields(base)


def _pairs(w, n, seed):
    rng = np.random.default_rng(seed)
    pts = rng.uniform([0, 0], [w.span, w.chord], (20 * n, 2))
    pts = pts[w.contains(pts)]
    return pts[:n], pts[n:2 * n]


def test_geodesic_distance_equals_flat_distance_along_dense_surface_polyline():
    w = _wing()
    a, b = _pairs(w, 20, seed=0)
    flat = w.geodesic_distance(a, b)
    np.testing.assert_allclose(flat, np.linalg.norm(a - b, axis=1))
    f = np.linspace(0, 1, 20001)[:, None]
    for t in TIMES:
        assert abs(w.kappa(t)) > 1e-3 or t == 0.0
        for p, q, dist in zip(a, b, flat):
            X = w.material_to_world((1 - f) * p + f * q, t)  # image of the flat segment, in 3D
            length = np.linalg.norm(np.diff(X, axis=0), axis=1).sum()
            assert abs(length - dist) / dist < 1e-6


def test_flat_segment_image_is_the_shortest_path_on_a_tessellated_wing():
    import potpourri3d as pp3d  # a test dependency (pyproject [test]): never skipped
    w = _wing(outline="rectangle", bend_angle=0.0, bend_offset=0.0)
    t = 0.01  # strongly bent and flapped
    # tessellate the bent sheet (vertices exactly on the surface) and let an independent
    # exact-polyhedral geodesic solver find the shortest path between two material points
    step = 1.0
    xs, ys = np.arange(0, w.span + 1e-9, step), np.arange(0, w.chord + 1e-9, step)
    gx, gy = np.meshgrid(xs, ys)
    V = w.material_to_world(np.column_stack([gx.ravel(), gy.ravel()]), t)
    nx, ny = len(xs), len(ys)
    idx = np.arange(nx * ny).reshape(ny, nx)
    q = np.stack([idx[:-1, :-1], idx[:-1, 1:], idx[1:, 1:], idx[1:, :-1]], -1).reshape(-1, 4)
    F = np.concatenate([q[:, [0, 1, 2]], q[:, [0, 2, 3]]])
    solver = pp3d.EdgeFlipGeodesicSolver(V, F)
    for (i0, j0), (i1, j1) in [((3, 2), (60, 140)), ((65, 10), (5, 120)), ((35, 0), (35, 150))]:
        path = solver.find_geodesic_path(idx[i0, j0], idx[i1, j1])
        mesh_len = np.linalg.norm(np.diff(path, axis=0), axis=1).sum()
        truth = w.geodesic_distance([xs[j0], ys[i0]], [xs[j1], ys[i1]])[0]
        # the inscribed mesh is slightly shorter: relative error O((κ·step)²) ~ 6e-4 at most
        assert abs(mesh_len - truth) / truth < 1e-4  # measured: ~5e-6
    assert abs(w.kappa(t)) * step > 0.01  # the check is not trivially flat


def test_curvature_tensor_matches_finite_differences_of_truth_xyz():
    w = _wing()
    uv = np.array([[20.0, 10.0], [75.0, 30.0], [120.0, 20.0], [60.0, 55.0]])
    h = 1e-2
    ex, ey = np.array([h, 0]), np.array([0, h])
    for t in TIMES:
        r = lambda m, t=t: w.material_to_world(m, t)  # noqa: E731
        rx = (r(uv + ex) - r(uv - ex)) / (2 * h)
        ry = (r(uv + ey) - r(uv - ey)) / (2 * h)
        rxx = (r(uv + ex) - 2 * r(uv) + r(uv - ex)) / h**2
        ryy = (r(uv + ey) - 2 * r(uv) + r(uv - ey)) / h**2
        rxy = (r(uv + ex + ey) - r(uv + ex - ey) - r(uv - ex + ey) + r(uv - ex - ey)) / (4 * h * h)
        n = np.cross(rx, ry)
        n /= np.linalg.norm(n, axis=1, keepdims=True)
        b_fd = np.stack([np.stack([np.sum(rxx * n, 1), np.sum(rxy * n, 1)], -1),
                         np.stack([np.sum(rxy * n, 1), np.sum(ryy * n, 1)], -1)], -2)
        np.testing.assert_allclose(w.curvature_tensor(uv, t), b_fd, atol=1e-6)
        # isometry: first fundamental form is the identity in material coordinates
        np.testing.assert_allclose(np.sum(rx * rx, 1), 1, atol=1e-8)
        np.testing.assert_allclose(np.sum(rx * ry, 1), 0, atol=1e-8)
        # principal curvature: eigen-decomposition of b (I = identity)
        k, dm, dw = w.principal_curvature(uv, t)
        ev, evec = np.linalg.eigh(b_fd)
        dom = np.argmax(np.abs(ev), axis=1)
        np.testing.assert_allclose(k, ev[np.arange(len(uv)), dom], atol=1e-6)
        np.testing.assert_allclose(np.abs(np.sum(dm * evec[np.arange(len(uv)), :, dom], 1)), 1, atol=1e-6)
        dw_fd = dm[:, :1] * rx + dm[:, 1:] * ry
        np.testing.assert_allclose(dw, dw_fd, atol=1e-6)


def test_monge_curvature_tensor_matches_finite_differences_of_ray_cast_depth():
    w = _wing()
    t = 0.006
    uv = np.array([[30.0, 20.0], [80.0, 35.0], [110.0, 15.0]])
    X = w.material_to_world(uv, t)
    h = 0.05
    offs = np.array([[0, 0], [h, 0], [-h, 0], [0, h], [0, -h], [h, h], [h, -h], [-h, h], [-h, -h]])
    for x0, b_true in zip(X, w.curvature_tensor_xy(uv, t)):
        # the surface as Z(X, Y): cast parallel rays along +Z through (X, Y) + offsets
        o = np.column_stack([x0[:2] + offs, np.full(len(offs), x0[2] - 200.0)])
        hit = w.intersect(o, np.tile([0, 0, 1.0], (len(offs), 1)), time=t)
        assert hit.mask.all()
        Z = hit.points(o, np.tile([0, 0, 1.0], (len(offs), 1)))[:, 2]
        zx, zy = (Z[1] - Z[2]) / (2 * h), (Z[3] - Z[4]) / (2 * h)
        zxx, zyy = (Z[1] - 2 * Z[0] + Z[2]) / h**2, (Z[3] - 2 * Z[0] + Z[4]) / h**2
        zxy = (Z[5] - Z[6] - Z[7] + Z[8]) / (4 * h * h)
        b_fd = np.array([[zxx, zxy], [zxy, zyy]]) / np.sqrt(1 + zx * zx + zy * zy)  # Eq. (6.19)-(6.21)
        np.testing.assert_allclose(b_true, b_fd, atol=2e-5)


def test_ray_cast_hits_lie_on_the_sheet_and_map_back_to_material_points():
    w = _wing()
    cam = PinholeDevice(intrinsics(300, 300, 79.5, 63.5), 160, 128)
    o, d = cam.rays(cam.pixel_grid().reshape(-1, 2))
    for t in TIMES:
        hit = w.intersect(o, d, time=t)
        assert hit.mask.mean() > 0.1
        X = hit.points(o, d)[hit.mask]
        uv = hit.material_uv[hit.mask]
        assert w.contains(uv).all()
        np.testing.assert_allclose(w.material_to_world(uv, t), X, atol=1e-9)
        np.testing.assert_allclose(np.abs(np.sum(hit.normal[hit.mask] * w.normal(uv, t), 1)), 1, atol=1e-9)


def test_anchor_and_marker_dots_have_their_albedo():
    w = _wing()
    pts = np.vstack([w.anchors, w.markers, [[70.0, 40.0]]])
    X = w.material_to_world(pts, 0.01)
    hit = w.intersect(np.zeros(3), X, time=0.01)  # rays from the camera through each point
    np.testing.assert_allclose(hit.material_uv, pts, atol=1e-9)
    np.testing.assert_allclose(hit.albedo, [w.anchor_albedo] * 2 + [w.marker_albedo] * 2 + [w.albedo])


def test_bending_strain_is_half_thickness_times_curvature_change():
    w = _wing(thickness=0.2)
    uv = np.array([[50.0, 20.0]])
    E = w.bending_strain(uv, 0.01)
    np.testing.assert_allclose(E, 0.1 * w.curvature_tensor(uv, 0.01))
    Er = w.bending_strain(uv, 0.01, time_ref=0.0)
    np.testing.assert_allclose(Er, 0.1 * (w.curvature_tensor(uv, 0.01) - w.curvature_tensor(uv, 0.0)))
    assert w.dominant_strain(uv, 0.01)[0] == pytest.approx(0.1 * w.kappa(0.01))


def test_flapping_rotates_about_the_root_hinge_periodically():
    w = _wing(kappa_amp=0.0, bend_offset=0.0)  # constant bend: only the flapping moves the sheet
    uv = w.material_grid(10.0)
    axis, root = w.hinge_axis(), w.root
    ref = w.material_to_world(uv, 0.0) - root
    for t in TIMES:
        X = w.material_to_world(uv, t) - root
        np.testing.assert_allclose(w.material_to_world([[0.0, 0.0]], t)[0], root, atol=1e-12)
        np.testing.assert_allclose(X @ axis, ref @ axis, atol=1e-9)  # along the hinge: fixed
        # about the hinge: rotated by the flap angle ψ(t) - ψ(0)
        perp0, perp = ref - np.outer(ref @ axis, axis), X - np.outer(X @ axis, axis)
        big = np.linalg.norm(perp0, axis=1) > 1
        ang = np.arctan2(np.cross(perp0[big], perp[big]) @ axis, np.sum(perp0[big] * perp[big], 1))
        np.testing.assert_allclose(ang, w.flap_angle(t) - w.flap_angle(0.0), atol=1e-9)
    w = _wing()
    period = 1 / w.frequency
    np.testing.assert_allclose(w.material_to_world(uv, 0.003), w.material_to_world(uv, 0.003 + period), atol=1e-9)
    assert np.abs(w.material_to_world(uv, 0.003) - w.material_to_world(uv, 0.013)).max() > 5.0


def test_wing_rejects_bad_parameters():
    with pytest.raises(ValueError, match="inside the outline"):
        Wing(dots=WingDots(anchors=[(149, 69)]))
    with pytest.raises(ValueError, match="wrap"):
        Wing(beat=WingBeat(kappa_amp=0.1))
    with pytest.raises(ValueError, match="outline"):
        Wing(WingShape(outline="circle"))
    with pytest.raises(ValueError, match="inside the wing outline"):
        Wing().geodesic_distance([0, 0], [200, 0])


def test_bounding_sphere_encloses_the_bent_sheet():
    w = Wing(WingShape(outline="rectangle"),  # almost a half tube
             WingBeat(kappa_mean=0.0, kappa_amp=np.pi / 70 * 0.99))
    for t in (0.0, 0.01, 0.03):
        c, r = w.bounding_sphere(t)
        X = w.material_to_world(w.material_grid(0.5), t)
        assert np.linalg.norm(X - c, axis=1).max() <= r
