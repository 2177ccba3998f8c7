"""Bending strain (Eq. 6.10–6.21) against closed-form curvature and the analytic wing."""
import numpy as np
import pytest
from conftest import ANCHORS, MARKERS, AnalyticWing, camera, point_map

from fringe3d.analyze.strain import (
    bending_strain,
    local_shape,
    principal_strains,
    TrackingSettings,
    wing_sequence,
)


def cylinder_map(radius=40.0, h=96, w=128, pitch=0.3, tilt=0.0):
    v, u = np.mgrid[0:h, 0:w].astype(float)
    y = (v - h / 2) * pitch
    s = (u - w / 2) * pitch
    p = np.dstack([radius * np.sin(s / radius), y, -radius * (1 - np.cos(s / radius))])
    c, sn = np.cos(tilt), np.sin(tilt)
    p = p @ np.array([[c, 0, sn], [0, 1, 0], [-sn, 0, c]]).T
    p[..., 2] += 300.0
    return p


def test_second_form_of_a_cylinder_is_one_over_radius_along_the_bend():
    R = 40.0
    ls = local_shape(cylinder_map(R), np.array([[64.0, 48.0], [30.3, 20.7], [100.0, 70.0]]), window=11)
    assert ls.ok.all()
    # e1 = world x projected: the bending direction. Concave towards the camera: b = +1/R
    np.testing.assert_allclose(ls.second_form[:, 0, 0], 1 / R, rtol=1e-3)
    np.testing.assert_allclose(ls.second_form[:, 0, 1], 0, atol=1e-8)
    np.testing.assert_allclose(ls.second_form[:, 1, 1], 0, atol=1e-8)
    assert (ls.normal[:, 2] < 0).all()  # oriented towards the camera


def test_steep_tilted_cylinder_keeps_its_curvature():
    R = 40.0
    ls = local_shape(cylinder_map(R, tilt=np.deg2rad(60)), np.array([[64.0, 48.0]]), window=11)
    k = np.linalg.eigvalsh(ls.second_form[0])
    assert np.abs(k).max() == pytest.approx(1 / R, rel=2e-3)
    assert np.abs(k).min() < 1e-6


def test_sphere_second_form_is_isotropic():
    R = 50.0
    n = 101
    v, u = np.mgrid[0:n, 0:n].astype(float)
    x, y = (u - 50) * 0.25, (v - 50) * 0.25
    z = 300.0 + np.sqrt(R ** 2 - x ** 2 - y ** 2)  # far cap: concave towards the camera
    ls = local_shape(np.dstack([x, y, z]), np.array([[50.0, 50.0], [70.2, 35.5]]), window=9)
    for ii in ls.second_form:
        np.testing.assert_allclose(np.linalg.eigvalsh(ii), [1 / R, 1 / R], rtol=2e-3)


def test_principal_strains_of_a_known_tensor():
    E = np.array([[[1.0, 2.0], [2.0, -3.0]]])
    vals, vecs, dom, _ = principal_strains(E)
    np.testing.assert_allclose(vals[0], np.linalg.eigvalsh(E[0]))
    assert dom[0] == pytest.approx(vals[0, 0])  # the larger magnitude (negative) one


def test_bad_window_and_thickness_are_rejected():
    p = cylinder_map()
    with pytest.raises(ValueError, match="odd"):
        local_shape(p, [[10, 10]], window=4)
    ls = local_shape(p, [[10, 10]], window=5)
    with pytest.raises(ValueError, match="thickness"):
        bending_strain(ls, ls, thickness=0)


def _wing_run(curvature, flap, times, h=0.1):
    cam = camera(320, 256, 500.0)
    wing = AnalyticWing(np.array([-75.0, -35.0, 560.0]), +1, curvature=curvature, flap=flap)
    maps = [point_map([wing], cam, t)[0] for t in times]
    anchors = np.array([[cam.project(wing.world(a[0], a[1], t)) for a in ANCHORS] for t in times])
    q = cam.project(wing.world(MARKERS[:, 0], MARKERS[:, 1], times[0]))
    return wing, wing_sequence(maps, anchors, q, thickness=h, tracking=TrackingSettings(window=9, radius=3))


def test_rigid_flapping_gives_zero_strain():
    times = np.linspace(0, 0.02, 4)
    _, res = _wing_run(lambda t: 1 / 300.0, lambda t: np.deg2rad(25) * np.sin(2 * np.pi * 25 * t), times)
    assert res.ok.all()
    assert np.abs(res.E).max() < 1e-6


def test_bending_strain_matches_the_analytic_wing_within_5_percent():
    times = np.linspace(0, 0.02, 4)
    curv = lambda t: 1 / 500.0 + (1 / 250.0) * np.sin(np.pi * 25 * t) ** 2  # noqa: E731
    wing, res = _wing_run(curv, lambda t: np.deg2rad(20) * np.sin(2 * np.pi * 25 * t), times)
    truth = np.array([wing.bending_strain(t, times[0], 0.1) for t in times])
    assert res.ok.all()
    peak = np.abs(truth).max()
    assert np.abs(res.dominant - truth[:, None]).max() < 0.05 * peak
    # the minor principal strain (across the span) vanishes
    minor = np.take_along_axis(res.principal, np.argmin(np.abs(res.principal), axis=2)[..., None], 2)[..., 0]
    assert np.abs(minor).max() < 0.05 * peak
