"""Phase-domain mapping of circle centres to the projector (Eq. 2.30-2.34): order repair and
the noise of the H/V versus alpha_opt -/+ pi/4 mappings, against closed forms."""
import numpy as np
import pytest


def test_order_repair_restores_masked_fringe_orders_at_circle_centres():
    """Masked absolute phase around sample points (a dark circle's failed unwrapping) is
    rebuilt from the fine wrapped phase + the orders of the surrounding valid phase."""
    from fringe3d.calibrate.phase_mapping import FringeDirection, fringe_coordinates
    h, w = 200, 260
    vv, uu = np.mgrid[0:h, 0:w].astype(float)
    true = 2 * np.pi * (0.9 * uu + 0.15 * vv + 3e-4 * uu ** 2) / 18.0  # projector px -> phase, T = 18
    wrapped = np.angle(np.exp(1j * true))
    pts = np.array([[60.3, 50.7], [130.5, 100.2], [200.8, 150.4], [5.2, 5.9]])
    mask = np.ones((h, w), bool)
    for u, v in pts:
        mask[(uu - u) ** 2 + (vv - v) ** 2 < 9 ** 2] = False  # the circles' interiors failed
    d_plain = FringeDirection(phase=true, angle=np.pi / 2, period=18.0, mask=mask)
    assert np.all(np.isnan(fringe_coordinates(d_plain, pts)))
    d = FringeDirection(phase=true, angle=np.pi / 2, period=18.0, mask=mask, wrapped=wrapped)
    got = fringe_coordinates(d, pts)
    rr, cc = pts[:, 1], pts[:, 0]
    expect = (0.9 * cc + 0.15 * rr + 3e-4 * cc ** 2)
    assert np.max(np.abs(got - expect)) < 0.01  # projector px (bilinear on a smooth map)


@pytest.mark.parametrize("alpha_opt_deg", [90.0, 93.9, 60.0])
def test_optimal_angle_and_hv_mappings_have_the_same_projector_noise(alpha_opt_deg):
    """With equal, independent phase noise per direction, (u_p, v_p) from the alpha_opt -/+ pi/4
    pair (Eq. 2.32-2.34) has the covariance of the H/V pair (Eq. 2.30-2.31): sigma_w^2 * I,
    the closed form for any two orthogonal fringe directions. (So in an ideal rig the two
    calibrations see identical observation noise.)"""
    from fringe3d.calibrate.phase_mapping import FringeDirection, projector_points
    rng = np.random.default_rng(7)
    n, T, sigma_phi = 200_000, 18.0, 0.02
    up, vp = rng.uniform(100, 700, n), rng.uniform(100, 500, n)
    a = np.radians(alpha_opt_deg)
    covs = {}
    for name, angles in (("hv", (np.pi / 2, 0.0)), ("opt", (a - np.pi / 4, a + np.pi / 4))):
        dirs = []
        for ang in angles:
            phase = 2 * np.pi * (vp * np.cos(ang) + up * np.sin(ang)) / T + rng.normal(0, sigma_phi, n)
            dirs.append(FringeDirection(phase=phase[None, :], angle=ang, period=T))
        uv = np.stack([np.arange(n), np.zeros(n)], 1).astype(float)
        err = projector_points(dirs, uv) - np.stack([up, vp], 1)
        covs[name] = np.cov(err.T)
    sigma_w2 = (sigma_phi * T / (2 * np.pi)) ** 2
    for c in covs.values():
        assert np.allclose(c, sigma_w2 * np.eye(2), atol=0.02 * sigma_w2)


def _smooth_phase(h=160, w=200):
    vv, uu = np.mgrid[0:h, 0:w].astype(float)
    return 2 * np.pi * (0.8 * uu + 0.1 * vv + 4e-4 * uu * vv - 2e-4 * vv ** 2) / 18.0, uu, vv


def test_local_phase_fit_averages_noise_that_bilinear_keeps():
    """Noise sigma on a smooth phase: the bilinear sample keeps ~sigma/sqrt(2) of it, the
    weighted quadratic fit over r = 15 px (~700 px, 6 parameters) leaves ~sigma/sqrt(700/6)."""
    from fringe3d.calibrate.phase_mapping import local_fit_sample
    from fringe3d.phase.sampling import sample_bilinear
    true, _, _ = _smooth_phase()
    rng = np.random.default_rng(2)
    sigma = 0.05
    noisy = true + rng.normal(0, sigma, true.shape)
    pts = np.stack([rng.uniform(30, 170, 400), rng.uniform(30, 130, 400)], 1)
    exact = sample_bilinear(true, pts)  # the smooth map is locally linear to < 1e-4 rad
    e_bil = sample_bilinear(noisy, pts) - exact
    e_fit = local_fit_sample(noisy, np.ones_like(noisy), pts, 15.0) - exact
    assert 0.5 * sigma < np.std(e_bil) < 0.8 * sigma
    assert np.sqrt(np.mean(e_fit ** 2)) < 2.5 * sigma / np.sqrt(700 / 6)


def test_local_phase_fit_ignores_a_stray_fringe_order_and_masked_pixels():
    from fringe3d.calibrate.phase_mapping import local_fit_sample
    true, uu, vv = _smooth_phase()
    bad = true.copy()
    bad[(uu - 104) ** 2 + (vv - 80) ** 2 < 16] += 2 * np.pi   # a small patch one order off
    bad[(uu - 96) ** 2 + (vv - 84) ** 2 < 9] = np.nan          # and a masked hole
    pts = np.array([[100.3, 80.6]])
    got = local_fit_sample(bad, None, pts, 12.0)
    want = local_fit_sample(true, None, pts, 12.0)
    assert abs(got[0] - want[0]) < 1e-6
    assert np.isnan(local_fit_sample(np.full_like(true, np.nan), None, pts, 12.0)[0])
