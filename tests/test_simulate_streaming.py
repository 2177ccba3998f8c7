"""``simulate_capture`` renders and writes frame by frame: the same capture and truth as rendering the
whole take in memory first (:func:`fringe3d.sim.render.render`, what it did before)."""
import json

import numpy as np
import pytest

from fringe3d.io.capture import read_capture
from fringe3d.io.npy_stream import NpyFrameWriter, pack_npz, read_npy_frame
from fringe3d.sim import RenderChanges, Truth, presets, simulate_capture
from fringe3d.sim.catalog import named_scene
from fringe3d.sim.render import render
from fringe3d.sim.simulate import make_patterns, make_scene


def _in_memory(scene, patterns, frames, frame_rate):
    """Frames and truth of the whole take rendered at once, as ``simulate_capture`` got them before."""
    p = presets.get("tiny")
    s = p.settings.replace(frame_rate=frame_rate)
    ps = make_patterns(patterns, p.rig.projector.width, p.rig.projector.height)
    return render(scene, p.rig, ps, s, times=np.arange(frames) / frame_rate, progress=False)


@pytest.mark.parametrize("moving", [False, True], ids=["static-sphere", "moving-falling-balls"])
def test_streamed_capture_and_truth_equal_the_in_memory_render(tmp_path, moving):
    p = presets.get("tiny")
    scene = named_scene("falling-balls", p) if moving else "sphere"
    sc = make_scene(scene, p)
    simulate_capture(tmp_path / "c", "tiny", sc, "two-frequency", frames=12, progress=False,
                     render=RenderChanges(frame_rate=500.0))
    frames, truth = _in_memory(sc, "two-frequency", 12, 500.0)
    np.testing.assert_array_equal(read_capture(tmp_path / "c").frames, frames)
    got = Truth.load(tmp_path / "c")
    assert got.per_frame == moving and got.xyz.shape == truth.xyz.shape
    for name in ("xyz", "depth", "up", "vp", "normal", "object_id", "mask", "hit"):
        np.testing.assert_array_equal(getattr(got, name), getattr(truth, name), err_msg=name)
    assert got.phase.keys() == truth.phase.keys()
    for d in truth.phase:
        np.testing.assert_array_equal(got.phase[d], truth.phase[d])
    meta = json.loads((tmp_path / "c" / "truth" / "truth.json").read_text())
    assert meta["times"] == [k / 500.0 for k in range(12)] and meta["per_frame"] == moving
    if moving:
        assert meta["truth_times"] == truth.meta["truth_times"]
    # nothing left behind but the bundle
    assert sorted(f.name for f in (tmp_path / "c" / "truth").iterdir()) == ["truth.json", "truth.npz"]


def test_frame_writer_round_trips_and_leaves_no_file_when_short(tmp_path):
    a = np.random.default_rng(0).normal(size=(4, 3, 2)).astype(np.float32)
    with NpyFrameWriter(tmp_path / "a.npy", 4, (3, 2), np.float32) as w:
        for x in a:
            w.append(x)
    np.testing.assert_array_equal(np.load(tmp_path / "a.npy"), a)
    np.testing.assert_array_equal(read_npy_frame(tmp_path / "a.npy", 2), a[2])
    pack_npz(tmp_path / "a.npz", {"a": tmp_path / "a.npy"})
    np.testing.assert_array_equal(np.load(tmp_path / "a.npz")["a"], a)
    with pytest.raises(ValueError, match="1 of 4 frames"):
        with NpyFrameWriter(tmp_path / "b.npy", 4, (3, 2), np.float32) as w:
            w.append(a[0])
    with pytest.raises(ValueError, match="shape"):
        with NpyFrameWriter(tmp_path / "c.npy", 4, (3, 2), np.float32) as w:
            w.append(a[0].T)
    assert sorted(f.name for f in tmp_path.iterdir()) == ["a.npy", "a.npz"]
