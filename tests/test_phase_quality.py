"""Validity mask: modulation threshold, saturation at the bit depth's max code, dark frames."""
import warnings

import numpy as np
import pytest

from fringe3d.phase.quality import (FrameQualityWarning, check_frames, default_min_modulation, full_scale,
                                    saturation_level, validity_mask)


def test_full_scale_and_saturation_level_follow_bit_depth():
    assert full_scale(np.zeros(1, np.uint8)) == 255
    assert full_scale(np.zeros(1, np.uint16)) == 65535
    assert full_scale(np.zeros(1, np.uint16), bit_depth=12) == 4095
    assert saturation_level(np.zeros(1, np.float32)) == np.inf
    assert saturation_level(np.zeros(1, np.float32), bit_depth=10) == 1023
    assert default_min_modulation(np.zeros(1, np.uint8)) == pytest.approx(5.1)


def test_validity_mask_applies_modulation_threshold_and_saturation():
    frames = np.full((3, 4, 5), 100, np.uint16)
    frames[2, 1, 1] = 4095                       # at the 12-bit max code
    frames[0, 2, 2] = 4000                       # bright but not saturated
    average = np.full((4, 5), 100.0)
    modulation = np.full((4, 5), 50.0)
    modulation[3, 4] = 4.0
    mask = validity_mask(average, modulation, frames, bit_depth=12, min_modulation=5.0)
    expected = np.ones((4, 5), bool)
    expected[1, 1] = False
    expected[3, 4] = False
    assert np.array_equal(mask, expected)


def test_check_frames_reports_dark_and_saturated_frames():
    frames = np.full((4, 64, 64), 120, np.uint8)
    frames[1] = 1
    frames[3, :32] = 255
    with pytest.warns(FrameQualityWarning) as rec:
        out = check_frames(frames)
    assert out["dark"] == [1] and out["saturated"] == [3]
    assert out["saturated_fraction"][3] == pytest.approx(0.5)
    assert len(rec) == 2
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_frames(np.full((4, 64, 64), 120, np.uint8))   # healthy frames: no warning


def test_check_frames_counts_integer_frames_at_the_exact_cuts():
    # 8-bit: the dark cut is 2 % of 255 = 5.1 counts, so 5 is dark and 6 is lit; 255 saturates
    frames = np.stack([np.full((40, 50), 5, np.uint8), np.full((40, 50), 6, np.uint8),
                       np.full((40, 50), 254, np.uint8), np.full((40, 50), 255, np.uint8)])
    frames[2, :10] = 255                         # a quarter of the pixels at the max code
    with pytest.warns(FrameQualityWarning):
        out = check_frames(frames)
    assert out["dark"] == [0]
    assert out["saturated_fraction"] == [0.0, 0.0, 0.25, 1.0]
    # a 12-bit sensor in 16-bit words saturates at 4095, not 65535; 8-bit words never reach 4095
    words = np.full((2, 40, 50), 4094, np.uint16)
    words[1, :, :5] = 4095
    assert check_frames(words, bit_depth=12)["saturated_fraction"] == [0.0, 0.1]
    with pytest.warns(FrameQualityWarning):
        assert check_frames(frames, bit_depth=12)["saturated_fraction"] == [0.0] * 4


def _subsample_share(frames, cut, step):
    """The share of ``frames[f, ::step, ::step]`` at or above ``cut`` per frame, counted directly
    on a copy of the subsample (integers against ``ceil(cut)``, floats in their own dtype)."""
    sub = np.ascontiguousarray(frames[:, ::step, ::step]).reshape(frames.shape[0], -1)
    c = sub.dtype.type(np.ceil(cut) if sub.dtype.kind in "ui" else cut)
    return [np.count_nonzero(row >= c) / max(1, sub.shape[1]) for row in sub]


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16, np.int16, np.float32, np.float64])
def test_check_frames_shares_are_the_counts_of_the_strided_subsample(dtype):
    """The compiled counting pass reports exactly the shares of the strided subsample, whatever
    the dtype, the layout (a transposed view) and the height (over 255 sampled rows per frame)."""
    rng = np.random.default_rng(3)
    top = 1.0 if np.dtype(dtype).kind == "f" else np.iinfo(dtype).max
    for shape in ((3, 600, 7), (3, 700, 800)):
        frames = (rng.random(shape) * 1.1 * top).clip(0, top).astype(dtype)
        frames[0] = (frames[0] * 0.01).astype(dtype)                     # mostly dark
        frames[1, :, ::3] = dtype(top)                                   # a third saturated
        frames[2, ::2] = dtype(0.02 * top) if np.dtype(dtype).kind == "f" else dtype(np.ceil(0.02 * top))
        for f in (frames, np.swapaxes(frames, 1, 2)):
            step = max(1, int(np.sqrt(f.shape[1] * f.shape[2] / 16384)))
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", FrameQualityWarning)
                out = check_frames(f)
            level = saturation_level(f) if np.dtype(dtype).kind != "f" else np.inf
            want_sat = _subsample_share(f, level, step) if np.isfinite(level) else [0.0] * 3
            assert out["saturated_fraction"] == want_sat
            lit = _subsample_share(f, 0.02 * full_scale(f), step)
            assert out["dark"] == [i for i in range(3) if lit[i] < 0.01]
