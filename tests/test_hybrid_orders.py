"""Hybrid FTP+PSP fringe-order search (Eq. 5.13-5.15) on closed-form phase maps with known motion."""
import numpy as np
import pytest

from fringe3d.unwrap.hybrid import hybrid_phase
from fringe3d.unwrap.segmentation import segment_objects
from fringe3d.unwrap.spatial import unwrap_objects

TWO_PI = 2 * np.pi
T, T_L = 18.0, 228.0


DEPTH_GAIN = 0.6  # projector pixels of phase shift per camera pixel of dome height


def _phi_min(h, w):
    """Phase (period T_L) of the nearest plane: projector column = camera column + 100 (closed form)."""
    v, u = np.mgrid[0:h, 0:w].astype(float)
    return TWO_PI * (u + 100.0) / T_L


def _scene(h, w, centres, radius):
    """Absolute phase (period T) of balls at the given centres, NaN off the balls.

    A plane-parallel rig in closed form: the projector column seen by camera pixel (u, v) is
    u + 100 plus a depth term (here a dome, DEPTH_GAIN * height above the nearest plane), so a
    ball that moves across the fringes changes the phase it shows, one moving along them does not.
    """
    v, u = np.mgrid[0:h, 0:w].astype(float)
    phi = np.full((h, w), np.nan)
    for cu, cv in centres:
        r2 = (u - cu) ** 2 + (v - cv) ** 2
        inside = r2 <= radius ** 2
        dome = np.sqrt(np.clip(radius ** 2 - r2, 0, None))
        # absolute phase: projector column grows with camera column and shifts with depth (dome)
        phi[inside] = (TWO_PI * (u + DEPTH_GAIN * dome + 100.0) / T)[inside]
    return phi


def _moving_pair(shifts, noise_e=0.0, outlier_share=0.0, seed=0):
    rng = np.random.default_rng(seed)
    h, w, rad = 128, 160, 22
    c0 = [(40, 40), (110, 45), (75, 80)]
    c1 = [(cu + du, cv + dv) for (cu, cv), (du, dv) in zip(c0, shifts)]
    truth = _scene(h, w, c0, rad)
    moved = _scene(h, w, c1, rad)  # what the low-frequency frames saw, later in time
    phi_e = moved * T / T_L + rng.normal(0, noise_e, moved.shape)
    if outlier_share:
        ok = np.flatnonzero(np.isfinite(phi_e.ravel()))
        bad = rng.choice(ok, int(outlier_share * ok.size), replace=False)
        phi_e.ravel()[bad] += rng.uniform(-3, 3, bad.size)  # motion-induced garbage
    wrapped = np.angle(np.exp(1j * truth))
    phi_r, labels_r = unwrap_objects(wrapped, np.isfinite(truth))
    labels_e = segment_objects(np.isfinite(moved))
    return truth, phi_r, labels_r, phi_e, labels_e


def _check_exact(res, truth, phi_r, labels_r):
    for lab in np.unique(labels_r[labels_r > 0]):
        obj = labels_r == lab
        k_true = np.round(np.nanmean(truth[obj] - phi_r[obj]) / TWO_PI)
        assert res.votes[lab].k_s == k_true
    np.testing.assert_allclose(res.phase[labels_r > 0], truth[labels_r > 0], atol=1e-4)


def test_hybrid_recovers_exact_fringe_order_per_object_with_motion_compensation():
    # falling objects: mostly along the (vertical) fringes, 12-20 px per capture
    shifts = [(2, 15), (-3, 12), (1, 20)]
    truth, phi_r, labels_r, phi_e, labels_e = _moving_pair(shifts, noise_e=0.02, outlier_share=0.3)
    res = hybrid_phase(phi_r, labels_r, phi_e, T, T_L, labels_e=labels_e)
    assert len(res.votes) == 3 and not res.unmatched
    _check_exact(res, truth, phi_r, labels_r)
    # measured shifts are the known displacements (bounding-box centres of equal disks)
    assert sorted(res.shifts.values()) == sorted((float(a), float(b)) for a, b in shifts)


def test_compensation_makes_every_pixel_vote_for_the_right_order():
    # noise-free vertical motion: compensated k_e is exact everywhere the ball overlaps itself,
    # uncompensated k_e compares different surface points and disagrees on part of the ball
    shifts = [(0, 20), (0, 20), (0, 20)]
    truth, phi_r, labels_r, phi_e, labels_e = _moving_pair(shifts)
    plain = hybrid_phase(phi_r, labels_r, phi_e, T, T_L)  # no labels_e: Eq. (5.13) with Δ = 0
    good = hybrid_phase(phi_r, labels_r, phi_e, T, T_L, labels_e=labels_e)
    _check_exact(good, truth, phi_r, labels_r)
    for lab in good.votes:
        assert good.votes[lab].share == 1.0
        assert good.votes[lab].votes == (labels_r == lab).sum()
        assert plain.votes[lab].share < 0.97 and plain.votes[lab].votes < good.votes[lab].votes


def test_motion_across_fringes_needs_the_minimum_phase_correction():
    # 12 px across the fringes: the surface's own phase changes by 2π·12/18 > π
    shifts = [(12, 3), (12, 3), (12, 3)]
    truth, phi_r, labels_r, phi_e, labels_e = _moving_pair(shifts)
    plain = hybrid_phase(phi_r, labels_r, phi_e, T, T_L, labels_e=labels_e)
    corrected = hybrid_phase(phi_r, labels_r, phi_e, T, T_L, labels_e=labels_e,
                             phi_min=_phi_min(*truth.shape))
    _check_exact(corrected, truth, phi_r, labels_r)
    obj = labels_r > 0
    assert not np.allclose(plain.phase[obj], truth[obj], atol=1.0)


def test_hybrid_rejects_mismatched_shapes_and_periods():
    z = np.zeros((4, 4))
    with pytest.raises(ValueError, match="same"):
        hybrid_phase(z, np.zeros((4, 5), int), z, T, T_L)
    with pytest.raises(ValueError, match="positive"):
        hybrid_phase(z, z.astype(int), z, 0, T_L)
    with pytest.raises(ValueError, match="phi_min shape"):
        hybrid_phase(z, z.astype(int), z, T, T_L, phi_min=np.zeros((3, 3)))
