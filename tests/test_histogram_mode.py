"""Mode-of-fringe-order (histogram) logic of Eq. (5.13)-(5.15)."""
import numpy as np
import pytest

from fringe3d.unwrap.histogram import (apply_order_shift, fringe_order_difference,
                                       histogram_unwrap, mode_of_orders)

TWO_PI = 2 * np.pi


def test_mode_is_robust_to_a_large_minority_of_outliers():
    rng = np.random.default_rng(0)
    labels = np.zeros((60, 60), int)
    labels[5:30, 5:30] = 1
    labels[35:55, 10:50] = 2
    k_e = np.full(labels.shape, np.nan)
    k_e[labels == 1] = 3
    k_e[labels == 2] = -2
    # 40% of each object gets wrong orders spread over many values (motion error)
    for lab in (1, 2):
        idx = np.flatnonzero(labels.ravel() == lab)
        bad = rng.choice(idx, size=int(0.4 * idx.size), replace=False)
        k_e.ravel()[bad] = rng.integers(-8, 9, size=bad.size)
    votes = mode_of_orders(k_e, labels)
    assert votes[1].k_s == 3 and votes[2].k_s == -2
    assert 0.6 <= votes[1].share < 1.0
    assert votes[1].votes == (labels == 1).sum()


def test_nan_pixels_do_not_vote_and_small_objects_are_skipped():
    labels = np.array([[1, 1, 1, 2]])
    k_e = np.array([[np.nan, 4, 4, 1]])
    votes = mode_of_orders(k_e, labels, min_votes=2)
    assert set(votes) == {1}
    assert votes[1].k_s == 4 and votes[1].votes == 2


def test_histogram_unwrap_restores_absolute_phase_from_coarse_reference():
    rng = np.random.default_rng(3)
    h, w, T, T_ref = 64, 80, 18.0, 228.0
    v, u = np.mgrid[0:h, 0:w].astype(float)
    truth = TWO_PI * (3 * u + 0.2 * v + 40) / T
    labels = np.zeros((h, w), int)
    labels[:, :35] = 1
    labels[:, 45:] = 2
    offsets = {1: 5, 2: -7}
    phi_r = truth.copy()
    for lab, k in offsets.items():
        phi_r[labels == lab] += TWO_PI * k
    # reference at the low frequency, with noise equal to ~0.8 rad at the high frequency
    phi_ref = truth * T / T_ref + rng.normal(0, 0.8 * T / T_ref, truth.shape)
    phi_a, votes = histogram_unwrap(phi_r, labels, phi_ref, scale=T_ref / T)
    for lab, k in offsets.items():
        assert votes[lab].k_s == -k
    np.testing.assert_allclose(phi_a[labels > 0], truth[labels > 0], atol=1e-3)
    assert np.all(np.isnan(phi_a[labels == 0]))


def test_fringe_order_difference_matches_closed_form():
    phi_r = np.array([0.1, 2.0, -1.0])
    phi_ref = np.array([0.1 + TWO_PI, 2.0 - 2 * TWO_PI + 0.5, -1.0]) / 2.0
    np.testing.assert_array_equal(fringe_order_difference(phi_r, phi_ref, scale=2.0), [1, -2, 0])


def test_apply_order_shift_leaves_unvoted_objects_nan():
    labels = np.array([[1, 2]])
    out = apply_order_shift(np.array([[0.0, 0.0]]), labels, mode_of_orders(np.array([[2, np.nan]]), labels))
    assert out[0, 0] == pytest.approx(2 * TWO_PI) and np.isnan(out[0, 1])


def test_bad_input_is_rejected():
    with pytest.raises(ValueError, match="shape"):
        fringe_order_difference(np.zeros((2, 2)), np.zeros((3, 2)))
    with pytest.raises(ValueError, match="positive"):
        fringe_order_difference(np.zeros(2), np.zeros(2), scale=0)
    with pytest.raises(ValueError, match="labels shape"):
        mode_of_orders(np.zeros((2, 2)), np.zeros((2, 3), int))
