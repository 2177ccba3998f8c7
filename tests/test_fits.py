"""Plane, sphere and circle fits against closed forms, and cross sections through a sphere."""
from __future__ import annotations

import numpy as np
import pytest

from fringe3d.analyze.fits import fit_circle, fit_plane, fit_sphere
from fringe3d.analyze.sections import sphere_sections
from fringe3d.optics import PinholeDevice, intrinsics

from test_triangulate import intersect_sphere


def unit(v):
    v = np.asarray(v, float)
    return v / np.linalg.norm(v)


def plane_points(rng, n, normal, offset, sigma=0.0):
    n_ = unit(normal)
    a = unit(np.cross(n_, [1, 0, 0]))
    b = np.cross(n_, a)
    st = rng.uniform(-50, 50, (n, 2))
    noise = rng.normal(0, sigma, n) if sigma else np.zeros(n)
    return offset * n_ + st[:, :1] * a + st[:, 1:] * b + noise[:, None] * n_, noise


def cap_points(rng, n, c, r, sigma=0.0, half_angle=70):
    """Points on the camera-facing cap of a sphere (a camera at the origin sees this part)."""
    view = -unit(c)
    cos_min = np.cos(np.deg2rad(half_angle))
    d = rng.normal(size=(4 * n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    d = d[d @ view > cos_min][:n]
    noise = rng.normal(0, sigma, len(d)) if sigma else np.zeros(len(d))
    return c + (r + noise)[:, None] * d, noise


def test_plane_fit_noise_free_is_exact_and_faces_the_camera():
    rng = np.random.default_rng(1)
    pts, _ = plane_points(rng, 500, [0.2, -0.1, -1.0], -300.0)
    fit = fit_plane(pts)
    np.testing.assert_allclose(fit.normal, unit([0.2, -0.1, -1.0]), atol=1e-12)
    assert fit.offset == pytest.approx(-300.0, abs=1e-9)
    assert fit.rms < 1e-10 and fit.normal[2] < 0


def test_plane_fit_rms_equals_injected_noise():
    rng = np.random.default_rng(2)
    pts, noise = plane_points(rng, 20000, [0.1, 0.3, 1.0], 400.0, sigma=0.01)
    fit = fit_plane(pts)
    assert fit.rms == pytest.approx(np.std(noise), rel=0.01)
    np.testing.assert_allclose(np.abs(fit.normal @ unit([0.1, 0.3, 1.0])), 1.0, atol=1e-7)


def test_sphere_fit_noise_free_is_exact():
    rng = np.random.default_rng(3)
    c = np.array([5.0, -8.0, 350.0])
    pts, _ = cap_points(rng, 3000, c, 20.0)
    fit = fit_sphere(pts)
    np.testing.assert_allclose(fit.center, c, atol=1e-8)
    assert fit.radius == pytest.approx(20.0, abs=1e-8) and fit.rms < 1e-9


def test_sphere_fit_with_noise_recovers_radius_and_rms():
    rng = np.random.default_rng(4)
    c = np.array([0.0, 0.0, 400.0])
    pts, noise = cap_points(rng, 20000, c, 20.0, sigma=0.02)
    fit = fit_sphere(pts)
    assert abs(fit.radius - 20.0) < 0.005
    assert fit.rms == pytest.approx(np.std(noise), rel=0.02)
    fixed = fit_sphere(pts, radius=20.0)
    assert np.linalg.norm(fixed.center - c) < 0.01


def test_sphere_fit_organized_map_gives_residual_map():
    cam = PinholeDevice(K=intrinsics(220.0, 220.0, 79.5, 63.5), width=160, height=128)
    O, D = cam.rays(cam.pixel_grid())
    X = intersect_sphere(O, D, np.array([3.0, 2.0, 300.0]), 40.0)
    fit = fit_sphere(X)
    assert fit.residual_map.shape == (128, 160)
    assert np.array_equal(np.isfinite(fit.residual_map), np.isfinite(X[..., 0]))
    assert fit.radius == pytest.approx(40.0, abs=1e-6)


def test_circle_fit_recovers_3d_circle_from_half_arc():
    c = np.array([10.0, -4.0, 300.0])
    n = unit([0.3, 0.5, 0.8])
    a = unit(np.cross(n, [1, 0, 0]))
    b = np.cross(n, a)
    t = np.linspace(0, np.pi, 200)
    pts = c + 15.0 * (np.cos(t)[:, None] * a + np.sin(t)[:, None] * b)
    fit = fit_circle(pts)
    np.testing.assert_allclose(fit.center, c, atol=1e-8)
    assert fit.radius == pytest.approx(15.0, abs=1e-8)
    assert abs(abs(fit.normal @ n) - 1) < 1e-10 and fit.rms < 1e-9


def test_row_and_column_sections_through_sphere_match_closed_form():
    cam = PinholeDevice(K=intrinsics(220.0, 220.0, 79.5, 63.5), width=160, height=128)
    O, D = cam.rays(cam.pixel_grid())
    c, R = np.array([4.0, -3.0, 300.0]), 40.0
    X = intersect_sphere(O, D, c, R)
    sec = sphere_sections(X)
    i, j = sec["centre_pixel"]
    for axis, line in (("row", D[i]), ("column", D[:, j])):
        s = sec[axis]
        # the slice plane through the camera centre containing that pixel line
        n = unit(np.cross(line[0], line[-1]))
        d = abs(n @ c)
        assert s.fit.radius == pytest.approx(np.sqrt(R * R - d * d), abs=1e-6)
        assert s.fit.rms < 1e-6
    assert abs(sec["row"].index - (63.5 + 220 * c[1] / c[2])) <= 1
    assert abs(sec["column"].index - (79.5 + 220 * c[0] / c[2])) <= 1


def test_fit_bad_input_errors():
    with pytest.raises(ValueError, match="valid points"):
        fit_plane(np.zeros((10, 10, 3)), mask=np.zeros((10, 10), bool))
    with pytest.raises(ValueError, match="valid points"):
        fit_sphere(np.full((10, 10, 3), np.nan))
    with pytest.raises(ValueError, match="mask has shape"):
        fit_sphere(np.zeros((10, 10, 3)), mask=np.ones((5, 5), bool))
    with pytest.raises(ValueError, match="shape"):
        fit_plane(np.zeros((10, 2)))
    with pytest.raises(ValueError, match="collinear"):
        fit_plane(np.stack([np.arange(5.0)] * 3, axis=1))
