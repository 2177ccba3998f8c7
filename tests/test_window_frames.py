"""A 3D frame's window read from a camera file's frame range equals the same window of the array."""
from __future__ import annotations

import numpy as np

from fringe3d.io.frame_sources import FrameRange
from fringe3d.reconstruct.frame import window_frames
from fringe3d.reconstruct.windows import window_starts


class ArraySource:
    """A frame source over an array, recording the spans read."""

    def __init__(self, frames):
        self.frames, self.shape, self.dtype, self.path, self.spans = frames, frames.shape, frames.dtype, "mem", []

    def __len__(self):
        return len(self.frames)

    def read(self, start, stop):
        self.spans.append((start, stop))
        return self.frames[start:stop].copy()


def test_windows_from_a_frame_range_equal_the_arrays_each_read_as_one_span():
    frames = np.random.default_rng(0).integers(0, 255, (10, 4, 5), dtype=np.uint8)
    src = ArraySource(frames[1:])
    rng = FrameRange(src, 0)
    for mode in ("cycle", "window"):  # windows starting mid-cycle are reordered: indexed, not read as a span
        starts = window_starts(9, 3, mode)
        ks = list(range(len(starts)))
        src.spans.clear()
        got, ref = window_frames(rng, starts, ks, 3), window_frames(frames[1:], starts, ks, 3)
        for a, b in zip(got, ref):
            assert a.flags.c_contiguous and a.shape == (3, 4, 5)
            np.testing.assert_array_equal(a, b)
        assert src.spans == [(s, s + 3) for s in starts]  # one read of the window's span each
