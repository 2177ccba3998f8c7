"""The point store writes whole-frame chunks itself (fringe3d.io._chunk_write): the bytes on disk
are the ones zarr's own ``array[k] = frame`` writes, for every codec the store uses."""
from __future__ import annotations

import numpy as np
import pytest

from fringe3d.io import store as store_module
from fringe3d.io._chunk_write import chunk_writer
from fringe3d.io.store import PointMapStore, StoreSettings

H, W = 48, 64


def frame_data(seed: int) -> dict:
    """A depth map with NaN holes, quality bits and sigma_z of one frame."""
    rng = np.random.default_rng(seed)
    depth = (300 + rng.normal(size=(H, W))).astype(np.float32)
    depth[rng.random((H, W)) < 0.2] = np.nan
    quality = rng.integers(0, 64, (H, W)).astype(np.uint8)
    return {"depth": depth, "quality": quality, "sigma_z": np.abs(depth - 300).astype(np.float32)}


def open_store(path) -> PointMapStore:
    rays = (np.zeros(3), np.ones((3, H, W), np.float32))
    return PointMapStore.open(path, 3, H, W, settings=StoreSettings("ray_depth", quality=True, sigma=True), rays=rays)


@pytest.mark.parametrize("codec", ["lz4", "zstd", "none"])
def test_direct_chunk_writes_are_the_bytes_zarr_writes(tmp_path, monkeypatch, codec):
    monkeypatch.setattr(store_module, "CODEC", codec)
    ours, theirs = open_store(tmp_path / "ours.zarr"), open_store(tmp_path / "zarr.zarr")
    for name in ("depth", "quality", "sigma_z"):
        assert chunk_writer(ours.group[name]) is not None  # the direct path is the one taken
    for k in range(3):
        data = frame_data(k)
        ours.write_frame(k, **data)
        for name, v in data.items():
            theirs.group[name][k] = v  # zarr's own write path
    for name in ("depth", "quality", "sigma_z"):
        for k in range(3):
            key = f"{name}/c.{k}.0.0"  # flat chunk keys (store.FRAME_KEYS)
            assert (tmp_path / "ours.zarr" / key).read_bytes() == (tmp_path / "zarr.zarr" / key).read_bytes()
        np.testing.assert_array_equal(ours.group[name][:], theirs.group[name][:])
    assert not list((tmp_path / "ours.zarr").rglob("*.partial"))  # no temporary left behind


def test_chunk_writer_declines_arrays_it_cannot_write(tmp_path):
    import zarr
    g = zarr.open_group(str(tmp_path / "g.zarr"), mode="w")
    two_frames = g.create_array("a", shape=(4, H, W), chunks=(2, H, W), dtype="float32")
    assert chunk_writer(two_frames) is None  # several frames per chunk: zarr's read-modify-write is needed
    assert chunk_writer(zarr.zeros((3, H, W), chunks=(1, H, W))) is None  # an in-memory store


def test_marking_several_frames_done_at_once(tmp_path):
    st = open_store(tmp_path / "s.zarr")
    st.mark_done([2, 0])
    again = PointMapStore.open_existing(tmp_path / "s.zarr")
    assert again.pending() == [1] and again.completed == 2 and again.group.attrs["completed"] == 2
    st.mark_done([])
    assert PointMapStore.open_existing(tmp_path / "s.zarr").pending() == [1]
