"""Reading ahead (fringe3d.io.read_ahead.ReadAhead): the items of the keys in order, at most
``depth`` read and not taken, a read's error raised at its item with the file named, and the
reader stopped when the caller stops (an exception, ``KeyboardInterrupt``, leaving early)."""
from __future__ import annotations

import itertools
import random
import threading
import time

import numpy as np
import pytest

from fringe3d.io import capture_frames as capture_frames_module
from fringe3d.io.capture_frames import CaptureFolder, CaptureFrames
from fringe3d.io.images import write_image
from fringe3d.io.read_ahead import ReadAhead


def reader_threads() -> list[threading.Thread]:
    return [t for t in threading.enumerate() if t.name.startswith("fringe3d-read-ahead")]


@pytest.fixture
def png_frames(tmp_path):
    """A capture folder of 12 small PNG frames (each a different random image) and the frames."""
    rng = np.random.default_rng(3)
    frames = rng.integers(0, 256, (12, 9, 11), dtype=np.uint8)
    (tmp_path / "frames").mkdir()
    for i, f in enumerate(frames):
        write_image(tmp_path / "frames" / f"{i:05d}.png", f)
    return tmp_path, frames


def test_cycles_read_ahead_equal_the_frames_written_in_order(png_frames):
    folder, truth = png_frames
    lazy = CaptureFrames(folder)
    cycles = [np.arange(c * 3, c * 3 + 3) for c in range(4)]
    with ReadAhead(lambda idx: lazy[idx], cycles, depth=2) as read:
        got = list(read)
    assert len(got) == 4
    for idx, cyc in zip(cycles, got):
        np.testing.assert_array_equal(cyc, truth[idx])


@pytest.mark.parametrize("workers", [1, 3])
def test_order_is_the_keys_order_whatever_each_read_takes(workers):
    def slow_sometimes(k):
        time.sleep(random.Random(k).choice([0.0, 0.002]))
        return k

    with ReadAhead(slow_sometimes, range(20), depth=4, workers=workers) as read:
        assert list(read) == list(range(20))


def test_several_workers_read_items_at_once():
    """With 3 workers, 3 reads run together: each waits for the other two to have started."""
    barrier = threading.Barrier(3, timeout=10)

    def together(k):
        barrier.wait()
        return k

    with ReadAhead(together, range(6), depth=3, workers=3) as read:
        assert list(read) == list(range(6))
    assert not reader_threads()


def test_serial_sequences_read_png_windows_on_several_workers(png_frames):
    """The serial executor reads a PNG capture's windows at least two at once (a camera file's
    or an array's one at a time: a copy)."""
    from fringe3d.reconstruct.executors import read_workers

    folder, truth = png_frames
    assert read_workers(CaptureFrames(folder), 3) >= 2
    assert read_workers(truth, 3) == 1


@pytest.mark.parametrize("depth, workers", [(1, 1), (3, 1), (3, 2)])
def test_at_most_depth_items_are_read_and_not_taken(depth, workers):
    drawn = {"n": 0}

    def keys():
        for k in itertools.count():
            drawn["n"] += 1
            yield k

    ahead = []
    with ReadAhead(lambda k: k, keys(), depth=depth, workers=workers) as read:
        for taken, _ in enumerate(read, start=1):
            ahead.append(drawn["n"] - taken)
            if taken == 10:
                break
    assert max(ahead) == depth  # keys drawn beyond those taken: exactly the depth asked for
    assert not reader_threads()


def test_a_read_error_is_raised_at_its_item_naming_the_file(png_frames):
    folder, truth = png_frames
    bad = folder / "frames" / "00007.png"
    bad.write_bytes(b"not a png")
    lazy = CaptureFrames(folder)
    got = []
    with pytest.raises(ValueError, match="00007.png"):
        with ReadAhead(lambda idx: lazy[idx], [np.arange(c * 3, c * 3 + 3) for c in range(4)], depth=3) as read:
            for cyc in read:
                got.append(cyc)
    assert len(got) == 2  # the cycles before the broken file's arrived whole
    np.testing.assert_array_equal(np.concatenate(got), truth[:6])
    assert not reader_threads()


def test_an_interrupt_in_the_caller_stops_the_reader():
    started = []

    def read(k):
        started.append(k)
        return k

    with pytest.raises(KeyboardInterrupt):
        with ReadAhead(read, itertools.count(), depth=2) as items:
            for k in items:
                if k == 1:
                    raise KeyboardInterrupt  # the user stops the run while item 1 is processed
    assert not reader_threads()
    n = len(started)
    assert n <= 2 + 2  # the two taken and at most depth more
    time.sleep(0.01)
    assert len(started) == n  # nothing is read after the stop


def test_leaving_the_iteration_early_without_a_with_block_stops_the_reader():
    it = iter(ReadAhead(lambda k: k, itertools.count(), depth=2))
    assert next(it) == 0
    it.close()
    assert not reader_threads()


def test_a_depth_or_workers_below_one_is_refused():
    with pytest.raises(ValueError, match="at least 1"):
        ReadAhead(lambda k: k, range(3), depth=0)
    with pytest.raises(ValueError, match="workers must be at least 1"):
        ReadAhead(lambda k: k, range(3), workers=0)


def test_a_capture_opened_for_a_sequence_hands_over_the_frames_it_read_first_in_any_order(png_frames):
    folder, truth = png_frames
    lazy = CaptureFolder(str(folder)).open()
    assert set(lazy._first) == set(range(12))  # every frame of this small capture read at the opening
    for idx in ([3, 4, 5], [0, 1, 2], [0, 1, 2], [11], [6, 7, 8, 9, 10]):
        np.testing.assert_array_equal(lazy[np.array(idx)], truth[idx])
    np.testing.assert_array_equal(lazy[4], truth[4])
    assert not lazy._first  # each handed over once, none kept


def test_a_read_far_past_the_frames_read_first_drops_them(png_frames, monkeypatch):
    folder, truth = png_frames
    monkeypatch.setattr(capture_frames_module, "READ_FIRST", 3)
    lazy = CaptureFolder(str(folder)).open()
    assert set(lazy._first) == {0, 1, 2}
    np.testing.assert_array_equal(lazy[np.arange(9, 12)], truth[9:12])  # a resumed sequence
    assert not lazy._first
    np.testing.assert_array_equal(lazy[np.arange(0, 3)], truth[0:3])


def test_a_corrupt_frame_read_first_is_named_when_it_is_asked_for(png_frames):
    folder, truth = png_frames
    (folder / "frames" / "00004.png").write_bytes(b"\x89PNG\r\n\x1a\nbroken")
    lazy = CaptureFolder(str(folder)).open()
    np.testing.assert_array_equal(lazy[np.arange(0, 3)], truth[0:3])
    with pytest.raises(ValueError, match="00004.png"):
        lazy[np.arange(3, 6)]
