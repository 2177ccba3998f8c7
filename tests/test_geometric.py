"""Geometric-constraint unwrapping (Eq. 4.14-4.21) against analytic truth."""
from __future__ import annotations

import warnings

import numpy as np
import pytest

from fringe3d.optics import PinholeDevice, Rig, intrinsics
from fringe3d.unwrap.geometric import (check_depth_range, depth_limit, geometric_unwrap, minimum_phase,
                                       propose_z_min)
from fringe3d.utils.warning_types import DepthRangeWarning

from test_triangulate import intersect_plane, intersect_sphere, look_at, small_rig


def mirrored_rig():
    """Projector on the other side of the camera: phase falls with depth along the rays."""
    cam = PinholeDevice(K=intrinsics(220.0, 220.0, 79.5, 63.5), width=160, height=128, dist=(-0.1, 0.05, 0, 0, 0))
    R, t = look_at([-80.0, 10.0, 0.0], [0.0, 0.0, 300.0])
    return Rig(cam, PinholeDevice(K=intrinsics(400.0, 400.0, 127.5, 99.5), width=256, height=200, R=R, t=t))


def true_phase(rig, X, T, angle=np.pi / 2):
    uv = rig.projector.project(X)
    w = uv[..., 1] * np.cos(angle) + uv[..., 0] * np.sin(angle)
    return 2 * np.pi * w / T


def wrap(Phi):
    return np.angle(np.exp(1j * Phi))


def test_minimum_phase_equals_projected_virtual_plane():
    rig = small_rig()
    O, D = rig.camera.rays(rig.camera.pixel_grid())
    X = intersect_plane(O, D, np.array([0, 0, 250.0]), np.array([0, 0, 1.0]))
    mp = minimum_phase(rig, 250.0, 18.0)
    np.testing.assert_allclose(mp.phi_min, true_phase(rig, X, 18.0), atol=1e-4)


@pytest.mark.parametrize("make_rig", [small_rig, mirrored_rig])
@pytest.mark.parametrize("angle", [np.pi / 2, np.deg2rad(70.0)])
def test_geometric_unwrap_recovers_absolute_phase_of_sphere_and_plane(make_rig, angle):
    rig = make_rig()
    T = 18.0
    O, D = rig.camera.rays(rig.camera.pixel_grid())
    sphere = intersect_sphere(O, D, np.array([0.0, 0.0, 300.0]), 30.0)
    mp = minimum_phase(rig, 262.0, T, angle)
    assert np.all(mp.sign == mp.sign[64, 80]) and mp.sign[64, 80] != 0
    lim = depth_limit(rig, mp)
    plane = intersect_plane(O, D, np.array([0, 0, 0.5 * (262.0 + np.nanmin(lim))]), np.array([0.05, 0.02, 1.0]))
    for X in (sphere, plane):
        ok = np.isfinite(X[..., 0])
        Phi = true_phase(rig, X, T, angle)
        assert np.nanmax(Phi) - np.nanmin(Phi) > 6 * np.pi  # several fringe orders in view
        got, valid = geometric_unwrap(wrap(Phi), mp, mask=ok)
        assert np.array_equal(valid, ok)
        assert np.max(np.abs(got[ok] - Phi[ok])) < 1e-4


def test_sign_of_phase_change_follows_projector_side():
    # projector to the right (+x): a deeper point on a ray is seen further left in the projector
    assert np.all(minimum_phase(small_rig(), 250.0, 18.0).sign == -1)
    assert np.all(minimum_phase(mirrored_rig(), 250.0, 18.0).sign == 1)


def test_depth_limit_is_one_period_beyond_z_min():
    rig = small_rig()
    T = 24.0
    mp = minimum_phase(rig, 260.0, T)
    lim = depth_limit(rig, mp)
    O, D = rig.camera.rays(rig.camera.pixel_grid())
    X = O + (lim[..., None] / D[..., 2:3]) * D  # the ray's point at the limiting depth
    dphi = true_phase(rig, X, T) - mp.phi_min
    np.testing.assert_allclose(dphi, 2 * np.pi * mp.sign, atol=1e-3)
    assert np.all(lim > 260.0)


def test_beyond_depth_range_fails_as_predicted_and_warns():
    rig = small_rig()
    T = 18.0
    mp = minimum_phase(rig, 280.0, T)
    lim = depth_limit(rig, mp)
    O, D = rig.camera.rays(rig.camera.pixel_grid())
    # a tilted plane that starts inside the range and leaves it across the image
    z_in, z_out = 281.0, float(np.nanmax(lim)) + 20.0
    X = intersect_plane(O, D, np.array([0, 0, 0.5 * (z_in + z_out)]), np.array([-(z_out - z_in) / 220.0, 0, 1.0]))
    assert np.nanmin(X[..., 2]) > 280.0
    Phi = true_phase(rig, X, T)
    with pytest.warns(DepthRangeWarning) as record:
        got, valid = geometric_unwrap(wrap(Phi), mp)
    beyond = X[..., 2] >= lim
    assert beyond.any() and (~beyond).any()
    err = got - Phi
    assert np.max(np.abs(err[~beyond])) < 1e-4
    # beyond the limit the order is off by whole periods, towards Phi_min (falling phase here: too large)
    assert np.all(np.abs(err[beyond] / (2 * np.pi) - np.round(err[beyond] / (2 * np.pi))) < 1e-4)
    assert np.all(mp.sign[beyond] * np.round(err[beyond] / (2 * np.pi)) <= -1)
    assert any("depth-range" in str(w.message).replace("depth range", "depth-range") for w in record)
    with pytest.warns(DepthRangeWarning, match="beyond"):
        res = check_depth_range(rig, mp, X[..., 2])
    assert not res["ok"] and abs(res["share_beyond"] - beyond.mean()) < 1e-9


def test_scene_inside_range_gives_no_warning():
    rig = small_rig()
    mp = minimum_phase(rig, 270.0, 18.0)
    O, D = rig.camera.rays(rig.camera.pixel_grid())
    X = intersect_sphere(O, D, np.array([0.0, 0.0, 300.0]), 25.0)
    ok = np.isfinite(X[..., 0])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        geometric_unwrap(wrap(true_phase(rig, X, 18.0)), mp, mask=ok)
        assert check_depth_range(rig, mp, X[..., 2], mask=ok)["ok"]


def test_z_min_behind_camera_is_a_clear_error():
    with pytest.raises(ValueError, match="behind"):
        minimum_phase(small_rig(), -10.0, 18.0)
    with pytest.raises(ValueError, match="behind"):
        minimum_phase(small_rig(), 0.0, 18.0)


def test_propose_z_min_from_reference_plane():
    rig = small_rig()
    O, D = rig.camera.rays(rig.camera.pixel_grid())
    X = intersect_plane(O, D, np.array([0, 0, 300.0]), np.array([0.1, 0, 1.0]))
    assert propose_z_min(X, margin=5.0) == pytest.approx(np.nanmin(X[..., 2]) - 5.0)
    assert propose_z_min(X[..., 2], margin=0.0) == pytest.approx(np.nanmin(X[..., 2]))
    with pytest.raises(ValueError, match="no valid depth"):
        propose_z_min(np.full((4, 4), np.nan))


def frames_for(ps, up, vp):
    """Noise-free frames of a pattern set for exact projector coordinates (manifest model)."""
    out = []
    for f in ps.frames:
        w = vp * np.cos(f.angle) + up * np.sin(f.angle)
        out.append(0.1 + 0.4 * (1 + np.cos(2 * np.pi * w / f.period + f.shift)))
    return np.nan_to_num(np.stack(out), nan=0.1).astype(np.float32)


def test_decoder_runs_geometric_and_two_frequency_geometric_plans():
    from dataclasses import replace

    from fringe3d.decode import DecodeOptions, decode
    from fringe3d.patterns import sets
    from fringe3d.patterns.manifest import DirectionPlan
    from fringe3d.reconstruct import points_from_decoded

    rig = small_rig()
    O, D = rig.camera.rays(rig.camera.pixel_grid())
    X = intersect_sphere(O, D, np.array([0.0, 0.0, 300.0]), 40.0)
    ok = np.isfinite(X[..., 0])
    uv = rig.projector.project(X)
    one = sets.phase_shift(24, 3, "v", width=256, height=200)
    one = replace(one, plans=(DirectionPlan("v", np.pi / 2, "geometric", (24.0,)),))
    two = sets.two_frequency(18, 144, "v", width=256, height=200)
    assert two.plans[0].method == "two_frequency_geometric"
    for ps, z_min in ((one, 255.0), (two, 200.0)):
        dec = decode(frames_for(ps, uv[..., 0], uv[..., 1]), ps, rig=rig,
                         options=DecodeOptions(z_min=z_min, min_modulation=0.05, edge_mask=False))
        T = dec.period["v"]  # the method's own mask (edge_mask=False): the lit region, pixel for pixel
        assert np.array_equal(dec.mask["v"], ok)
        np.testing.assert_allclose(dec.phase["v"][ok], 2 * np.pi * uv[..., 0][ok] / T, atol=1e-3)
        pts = points_from_decoded(dec, rig)
        assert np.max(np.abs(pts[ok] - X[ok])) < 1e-3
        with pytest.raises(ValueError, match="rig"):
            decode(frames_for(ps, uv[..., 0], uv[..., 1]), ps, options=DecodeOptions(z_min=z_min))
        with pytest.raises(ValueError, match="z_min"):
            decode(frames_for(ps, uv[..., 0], uv[..., 1]), ps, rig=rig)


def test_minimum_phase_for_a_telecentric_rig():
    from test_triangulate import intersect_plane as plane_hit
    from test_triangulate import telecentric_rig

    rig = telecentric_rig()
    O, D = rig.camera.rays(rig.camera.pixel_grid())
    T = 36.0
    mp = minimum_phase(rig, 99.0, T)
    X0 = plane_hit(O, D, np.array([0, 0, 99.0]), np.array([0, 0, 1.0]))
    np.testing.assert_allclose(mp.phi_min, true_phase(rig, X0, T), atol=1e-3)
    X = plane_hit(O, D, np.array([0, 0, 100.0]), np.array([0.05, 0.02, 1.0]))
    Phi = true_phase(rig, X, T)
    got, _ = geometric_unwrap(wrap(Phi), mp)
    assert np.max(np.abs(got - Phi)) < 1e-4
