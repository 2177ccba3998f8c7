"""Capture frames decoded (by OpenCV) into their place in the cycle's stack: read_image copies an
image that fits ``out`` into it and returns anything else as read; capture stacks read by
CaptureFrames and read_capture equal the frames written, in any order; a frame that does not
fit is still named."""
from __future__ import annotations

import numpy as np
import pytest

from fringe3d.io.capture import read_capture, write_capture
from fringe3d.io.capture_frames import CaptureFrames
from fringe3d.io.images import read_image, write_image
from fringe3d.patterns import sets


def _image(dtype, shape=(13, 17), seed=0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    smooth = np.add.outer(np.arange(shape[0]) * 31, np.arange(shape[1]) * 7)
    return ((smooth + rng.integers(0, 40, shape)) % (np.iinfo(dtype).max + 1)).astype(dtype)


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16])
def test_an_image_that_fits_out_is_written_there_and_returned(tmp_path, dtype):
    img = _image(dtype)
    write_image(tmp_path / "f.png", img)
    stack = np.zeros((3,) + img.shape, dtype)
    got = read_image(tmp_path / "f.png", out=stack[1])
    assert got is not None and np.shares_memory(got, stack)
    np.testing.assert_array_equal(stack[1], img)
    assert not stack[0].any() and not stack[2].any()


@pytest.mark.parametrize("out", [np.zeros((13, 16), np.uint8), np.zeros((13, 17), np.uint16)])
def test_an_image_that_does_not_fit_out_is_returned_as_read_and_out_left_alone(tmp_path, out):
    img = _image(np.uint8)
    write_image(tmp_path / "f.png", img)
    got = read_image(tmp_path / "f.png", out=out)
    assert got is not out
    np.testing.assert_array_equal(got, img)
    assert not out.any()


def test_a_corrupt_frame_file_is_named_by_read_image(tmp_path):
    write_image(tmp_path / "good.png", _image(np.uint8))
    (tmp_path / "bad.png").write_bytes((tmp_path / "good.png").read_bytes()[:60])
    with pytest.raises(ValueError, match="bad.png"):
        read_image(tmp_path / "bad.png", out=np.empty((13, 17), np.uint8))


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16])
def test_capture_stacks_decoded_in_place_equal_the_frames_written(tmp_path, dtype):
    frames = np.stack([_image(dtype, (9, 11), seed=s) for s in range(5)])
    (tmp_path / "frames").mkdir()
    for i, f in enumerate(frames):
        write_image(tmp_path / "frames" / f"{i:05d}.png", f)
    lazy = CaptureFrames(tmp_path)
    for idx in ([2, 0, 1], [4], [3, 4], []):
        got = lazy[np.array(idx)]
        assert got.dtype == dtype and got.flags.c_contiguous
        np.testing.assert_array_equal(got, frames[idx])
    np.testing.assert_array_equal(lazy[3], frames[3])


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16])
def test_a_capture_read_whole_equals_the_frames_written_and_names_a_misfit(tmp_path, dtype):
    ps = sets.phase_shift(18, 3, "v", width=40, height=30)
    frames = np.stack([_image(dtype, (12, 20), seed=s) for s in range(6)])
    write_capture(tmp_path, frames, ps, meta={"bit_depth": 8 * np.dtype(dtype).itemsize})
    got = read_capture(tmp_path).frames
    assert got.dtype == dtype
    np.testing.assert_array_equal(got, frames)
    write_image(tmp_path / "frames" / "00004.png", _image(dtype, (11, 20)))
    with pytest.raises(ValueError, match=r"00004\.png has shape \(11, 20\).*00000\.png has \(12, 20\)"):
        read_capture(tmp_path)
