"""Spatial (relative) unwrapping per object: recovers a smooth phase up to one 2π offset per object."""
import numpy as np
import pytest

from fringe3d.unwrap.segmentation import segment_objects, box_centres, match_objects, shift_image
from fringe3d.unwrap.spatial import unwrap_objects

TWO_PI = 2 * np.pi


def _disks(h, w, centres, radius):
    v, u = np.mgrid[0:h, 0:w]
    m = np.zeros((h, w), bool)
    for cu, cv in centres:
        m |= (u - cu) ** 2 + (v - cv) ** 2 <= radius ** 2
    return m


def _smooth_phase(h, w, period=9.0):
    v, u = np.mgrid[0:h, 0:w].astype(float)
    # carrier plus a dome and a tilt: many wraps, gradients below pi per pixel
    return TWO_PI * u / period + 25.0 * np.exp(-((u - 70) ** 2 + (v - 60) ** 2) / 900.0) + 0.05 * v


def test_spatial_unwrap_recovers_smooth_phase_up_to_one_offset_per_object():
    h, w = 128, 160
    truth = _smooth_phase(h, w)
    mask = _disks(h, w, [(45, 60), (120, 70)], 30)
    wrapped = np.angle(np.exp(1j * truth))
    wrapped[~mask] = np.nan
    phi_r, labels = unwrap_objects(wrapped, mask)
    assert labels.max() == 2
    for lab in (1, 2):
        d = (phi_r - truth)[labels == lab]
        k = np.round(d / TWO_PI)
        assert np.all(k == k[0]), "one rigid offset per object"
        np.testing.assert_allclose(d, TWO_PI * k[0], atol=1e-4)
    assert np.all(np.isnan(phi_r[~mask]))


def test_spatial_unwrap_handles_noise_without_spurious_jumps():
    rng = np.random.default_rng(1)
    h, w = 96, 128
    truth = _smooth_phase(h, w, period=12.0)
    mask = _disks(h, w, [(64, 48)], 40)
    wrapped = np.angle(np.exp(1j * (truth + rng.normal(0, 0.3, truth.shape))))
    phi_r, labels = unwrap_objects(wrapped, mask)
    k = np.round((phi_r - truth)[labels == 1] / TWO_PI)
    assert np.mean(k == np.median(k)) > 0.999


def test_segmentation_drops_tiny_regions_and_labels_isolated_objects():
    m = _disks(100, 100, [(25, 25), (75, 70)], 15)
    m[5:7, 90:92] = True  # 4-pixel speck
    labels = segment_objects(m, min_size=20)
    assert labels.max() == 2
    assert labels[6, 91] == 0
    c = box_centres(labels)
    np.testing.assert_allclose(sorted(c.values()), [(25, 25), (75, 70)])


def test_match_objects_returns_bounding_box_centre_shift():
    a = segment_objects(_disks(100, 120, [(30, 30), (80, 60)], 12))
    b = segment_objects(_disks(100, 120, [(33, 41), (78, 71)], 12))
    ms = match_objects(a, b)
    got = {(m.du, m.dv) for m in ms}
    assert got == {(3.0, 11.0), (-2.0, 11.0)}


def test_shift_image_reads_source_at_offset():
    img = np.arange(20.0).reshape(4, 5)
    out = shift_image(img, du=1, dv=2)
    assert out[0, 0] == img[2, 1]
    assert np.isnan(out[3, 4])


def test_bad_input_is_rejected_with_clear_message():
    with pytest.raises(ValueError, match="2-D"):
        unwrap_objects(np.zeros((2, 3, 4)))
    with pytest.raises(ValueError, match="mask shape"):
        unwrap_objects(np.zeros((4, 4)), np.ones((3, 4), bool))
    with pytest.raises(ValueError, match="min_size"):
        segment_objects(np.ones((4, 4), bool), min_size=0)


def test_foreground_mask_separates_lit_objects_and_rejects_flat_frames():
    from fringe3d.unwrap.segmentation import foreground_mask

    avg = np.full((50, 60), 5.0)
    avg[10:30, 10:30] = 120.0
    mod = np.zeros_like(avg)
    mod[10:30, 10:30] = 60.0
    mod[10:30, 10:15] = 5.0  # lit but no fringes (contrast 5/120 < 0.15)
    m = foreground_mask(avg, mod)
    assert m[20, 20] and not m[40, 40] and not m[20, 12]
    with pytest.raises(ValueError, match="constant"):
        foreground_mask(np.zeros((8, 8)))
    with pytest.raises(ValueError, match="modulation shape"):
        foreground_mask(avg, mod[:10])
