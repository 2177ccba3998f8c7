"""VDI/VDE 2634-2-style figures on synthetic artefacts with known noise."""
from __future__ import annotations

import numpy as np
import pytest

from fringe3d.analyze.vdi import flatness, probing_errors, residual_range, sphere_spacing

from test_fits import cap_points, plane_points

SIGMA = 0.02  # mm


def test_probing_size_errors_centre_on_zero_and_form_matches_noise_range():
    sizes, forms, ranges = [], [], []
    for seed in range(30):
        rng = np.random.default_rng(seed)
        pts, noise = cap_points(rng, 3000, np.array([0.0, 0.0, 400.0]), 12.7, sigma=SIGMA)
        f = probing_errors(pts, true_diameter=25.4)
        sizes.append(f.size)
        forms.append(f.form)
        ranges.append(np.ptp(noise))
    sizes = np.array(sizes)
    # centred on zero: |mean| within 3 standard errors
    assert abs(sizes.mean()) < 3 * sizes.std(ddof=1) / np.sqrt(len(sizes))
    assert sizes.std() < SIGMA  # a 3000-point fit averages the noise down
    # form = range of the radial residuals: the injected noise's own range, within 5 %
    np.testing.assert_allclose(forms, ranges, rtol=0.05)


def test_flatness_matches_noise_range_and_exclusion_removes_outliers():
    rng = np.random.default_rng(7)
    pts, noise = plane_points(rng, 10000, [0.05, 0.02, -1.0], -500.0, sigma=SIGMA)
    f = flatness(pts)
    assert f.flatness == pytest.approx(np.ptp(noise), rel=0.05)
    assert f.rms == pytest.approx(np.std(noise), rel=0.02)
    bad = pts.copy()
    bad[:20] += np.array([0, 0, 5.0])  # 0.2 % gross outliers
    assert flatness(bad).flatness > 4.0
    clean = noise[20:]
    kept = clean[np.argsort(np.abs(clean))[: len(clean) - 10]]  # 30 dropped: the 20 outliers + 10 extremes
    assert flatness(bad, exclude=0.003).flatness == pytest.approx(np.ptp(kept), rel=0.05)
    with pytest.raises(ValueError, match="0.3 %"):
        residual_range(noise, exclude=0.01)


def test_sphere_spacing_errors_centre_on_zero():
    errs = []
    for seed in range(20):
        rng = np.random.default_rng(100 + seed)
        a, _ = cap_points(rng, 2000, np.array([-50.0, 0.0, 400.0]), 10.0, sigma=SIGMA)
        b, _ = cap_points(rng, 2000, np.array([50.0, 5.0, 410.0]), 10.0, sigma=SIGMA)
        pts = np.concatenate([a, b])
        ma = np.zeros(len(pts), bool)
        ma[: len(a)] = True
        s = sphere_spacing(pts, ma, ~ma, true_distance=float(np.linalg.norm([100.0, 5.0, 10.0])), true_diameter=20.0)
        errs.append(s.error)
        assert abs(s.spheres[0].size) < 5 * SIGMA
    errs = np.array(errs)
    assert abs(errs.mean()) < 3 * errs.std(ddof=1) / np.sqrt(len(errs))
    assert errs.std() < SIGMA


def test_ball_bar_with_empty_sphere_mask_is_a_clear_error():
    rng = np.random.default_rng(0)
    a, _ = cap_points(rng, 500, np.array([0.0, 0.0, 400.0]), 10.0)
    with pytest.raises(ValueError, match="second sphere"):
        sphere_spacing(a, np.ones(len(a), bool), np.zeros(len(a), bool))
