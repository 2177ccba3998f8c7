"""One loop, three executors: the serial path, a thread pool and Dask workers compute the 3D frames
of one capture and the same loop writes them (:func:`fringe3d.reconstruct.sequence.reconstruct_sequence`);
the stores and PLY files must agree bit for bit, and so must the books (done, empty frames)."""
from __future__ import annotations

import numpy as np
import pytest

from fringe3d.decode.options import DecodeOptions
from fringe3d.io.capture import read_capture
from fringe3d.io.capture_frames import CaptureFolder
from fringe3d.io.store import PointMapStore
from fringe3d.optics.rig import Rig
from fringe3d.patterns import sets
from fringe3d.reconstruct.executors import serial, threads
from fringe3d.reconstruct.frame import (FrameReconstructor, LaterCycle, reconstruct_window, reconstruction_plans,
                                      with_sigma)
from fringe3d.reconstruct.sequence import reconstruct_sequence
from fringe3d.reconstruct.settings import DecodeSettings, OutputSettings, RunSettings
from fringe3d.sim import simulate_capture

distributed = pytest.importorskip("distributed")  # in the test extra: CI always has it
CYCLES = 3


@pytest.fixture(scope="module")
def capture(tmp_path_factory):
    """3 cycles of a 3-step T=64 capture of a sphere before a wall, with its rig."""
    folder = tmp_path_factory.mktemp("executors") / "cap"
    ps = sets.phase_shift(64, 3, "v", width=256, height=200)
    simulate_capture(folder, preset="tiny", scene="sphere", patterns=ps, cycles=CYCLES, seed=5, progress=False)
    return folder


def run_with(capture, out, executor) -> dict:
    ps = reconstruction_plans(read_capture(capture, max_cycles=1).patterns, "geometric")
    rig = Rig.load(capture / "rig.json")
    decode = DecodeSettings(DecodeOptions(z_min=340.0))
    return reconstruct_sequence(CaptureFolder(str(capture)), ps, rig, out, decode, OutputSettings(ply=True),
                                RunSettings(progress=False), executor=executor)


def store_arrays(out) -> list[np.ndarray]:
    st = PointMapStore.open_existing(out / "points.zarr")
    assert st.completed == st.frames == CYCLES
    return [np.stack([f(k) for k in range(st.frames)]) for f in (st.read, st.depth, st.quality, st.sigma_z)]


def test_serial_threads_and_dask_write_the_same_store_bit_for_bit(capture, tmp_path):
    from fringe3d.cluster.engine import dask_executor

    summaries = {"serial": run_with(capture, tmp_path / "serial", serial),
                 "threads": run_with(capture, tmp_path / "threads", threads(2))}
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False, dashboard_address=None,
                                  silence_logs=40) as cluster, distributed.Client(cluster) as client:
        summaries["dask"] = run_with(capture, tmp_path / "dask", dask_executor(client, chunk=2))
    want = store_arrays(tmp_path / "serial")
    assert np.isfinite(want[0][..., 0]).mean() > 0.3  # the scene is there: not three empty stores
    for name in ("threads", "dask"):
        for got, ref in zip(store_arrays(tmp_path / name), want):  # points, depth, quality, sigma_z
            np.testing.assert_array_equal(got, ref)
        names = sorted(p.name for p in (tmp_path / "serial" / "ply").glob("*.ply"))
        assert names and names == sorted(p.name for p in (tmp_path / name / "ply").glob("*.ply"))
        for ply in names:  # the same measurement PLY, byte for byte
            assert (tmp_path / name / "ply" / ply).read_bytes() == (tmp_path / "serial" / "ply" / ply).read_bytes()
        assert {k: summaries[name][k] for k in ("frames_3d", "done_now", "done_before", "empty_frames")} == \
            {k: summaries["serial"][k] for k in ("frames_3d", "done_now", "done_before", "empty_frames")}


def test_the_serial_path_finishing_frames_on_the_writers_stores_what_the_threads_compute_at_once(capture,
                                                                                                   tmp_path,
                                                                                                   monkeypatch):
    """Store only (no points), with enough cores: the serial path leaves all but the fused
    kernel's pass to the store writers (a LaterCycle: quality map, masking, sigma_z on their
    threads), the thread pool computes each frame at once; the same stores, bit for bit."""
    from fringe3d.reconstruct import executors, sequence

    monkeypatch.setattr(executors, "FINISH_ON_WRITERS_FROM", 1)  # as on a machine with cores to spare
    monkeypatch.setattr(sequence, "FINISH_ON_WRITERS_FROM", 1)
    assert executors.finish_on_writers() and sequence.writer_threads() >= 1
    ps = reconstruction_plans(read_capture(capture, max_cycles=1).patterns, "geometric")
    rig = Rig.load(capture / "rig.json")
    decode = DecodeSettings(DecodeOptions(z_min=340.0))
    rec = FrameReconstructor(ps, rig, decode.options)
    cycle = np.ascontiguousarray(read_capture(capture, max_cycles=1).frames)
    later, empty = reconstruct_window(rec, cycle, False, "ray_depth", True, later="all")
    assert isinstance(later, LaterCycle) and not empty  # the serial path's frames are finished later
    at_once, _ = reconstruct_window(rec, cycle, False, "ray_depth", True)
    finished = with_sigma(later)
    for name in ("depth", "quality", "sigma_z"):
        np.testing.assert_array_equal(getattr(finished, name), getattr(at_once, name))
    runs = {name: reconstruct_sequence(CaptureFolder(str(capture)), ps, rig, tmp_path / name, decode,
                                       run=RunSettings(progress=False), executor=executor)
            for name, executor in (("serial", serial), ("threads", threads(2)))}
    a, b = (PointMapStore.open_existing(tmp_path / name / "points.zarr") for name in runs)
    assert a.completed == b.completed == CYCLES and a.layout == "ray_depth"
    assert (a.group["quality"][:] == 0).mean() > 0.3
    for name in ("depth", "quality", "sigma_z", "done"):
        np.testing.assert_array_equal(a.group[name][:], b.group[name][:])


def test_a_resumed_dask_run_computes_only_the_frames_the_store_lacks(capture, tmp_path):
    from fringe3d.cluster.engine import dask_executor

    out = tmp_path / "out"
    run_with(capture, out, serial)
    st = PointMapStore.open_existing(out / "points.zarr")
    (out / "ply" / "frame_00001.ply").unlink()  # frame 1 is no longer done
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False, dashboard_address=None,
                                  silence_logs=40) as cluster, distributed.Client(cluster) as client:
        res = run_with(capture, out, dask_executor(client))
    assert res["done_before"] == CYCLES - 1 and res["done_now"] == 1 and st.completed == CYCLES


def test_thread_workers_share_the_kernel_threads():
    """Each worker of ``threads(workers)`` runs its kernels on ``n // workers`` numba threads (at
    least one), ``n`` the caller's, not on all of them; the caller's own setting is left alone."""
    import threading
    from types import SimpleNamespace

    import numba

    seen: dict[int, int] = {}

    class Job:
        rec = SimpleNamespace(backend="cpu")

        def run(self, ks):
            seen[threading.get_ident()] = numba.get_num_threads()
            return [(k, None, False) for k in ks]

    n = numba.get_num_threads()
    for workers in (1, 2, n + 1):
        seen.clear()
        assert [k for k, _, _ in threads(workers)(Job(), list(range(6)))] == list(range(6))
        assert set(seen.values()) == {max(1, n // workers)}
        assert numba.get_num_threads() == n


def test_the_kernels_keep_the_threads_the_store_writers_leave():
    """One store writer below FINISH_ON_WRITERS_FROM numba threads, else half of them and at least
    two, each on one numba thread; the compute's kernels run on the rest (at least one) while they
    write, all of them after."""
    import numba

    from fringe3d.reconstruct import executors, sequence

    n = numba.get_num_threads()
    writers = sequence.writer_threads()
    assert writers == (max(2, n // 2) if executors.finish_on_writers() else 1) and writers >= 1
    with sequence._kernel_threads_beside(writers):
        assert numba.get_num_threads() == max(1, n - writers)
    assert numba.get_num_threads() == n
    assert sequence.in_flight(writers) >= writers + 1  # every writer busy and the next frame queued


def test_on_two_numba_threads_two_writers_finish_the_frames_beside_a_one_thread_kernel():
    """2 cores: the main thread runs the fused kernel alone on one numba thread, two store writers
    finish the frames (quality map, sigma_z, compression, writes): three busy threads, so no
    core waits while one stage waits for the other."""
    import numba

    from fringe3d.reconstruct import executors, sequence

    if numba.config.NUMBA_NUM_THREADS < 2:
        pytest.skip("numba runs on one thread here")
    n = numba.get_num_threads()
    numba.set_num_threads(2)
    try:
        assert executors.finish_on_writers() and sequence.writer_threads() == 2
        with sequence._kernel_threads_beside(2):
            assert numba.get_num_threads() == 1
    finally:
        numba.set_num_threads(n)


def test_the_serial_path_leaves_the_frames_to_the_writers_although_its_loop_runs_on_fewer_kernel_threads(
        capture, tmp_path, monkeypatch):
    """The choice is made on the caller's numba threads, not inside the writing loop (where the
    kernels run on one thread beside two writers, and the lazy choice left only sigma_z to them):
    every frame of a store-only run reaches the writers as a LaterCycle, and the store is the one
    the frames computed at once give."""
    import numba

    from fringe3d.reconstruct import sequence

    if numba.config.NUMBA_NUM_THREADS < 2:
        pytest.skip("numba runs on one thread here")
    kinds = []
    real = sequence._write_frame

    def recording(k, cycle, *args):
        kinds.append(isinstance(cycle, LaterCycle))
        return real(k, cycle, *args)

    def store_only(out, executor):
        ps = reconstruction_plans(read_capture(capture, max_cycles=1).patterns, "geometric")
        reconstruct_sequence(CaptureFolder(str(capture)), ps, Rig.load(capture / "rig.json"), out,
                             DecodeSettings(DecodeOptions(z_min=340.0)), run=RunSettings(progress=False),
                             executor=executor)
    n = numba.get_num_threads()
    numba.set_num_threads(2)
    try:
        monkeypatch.setattr(sequence, "_write_frame", recording)
        store_only(tmp_path / "serial", serial)
    finally:
        numba.set_num_threads(n)
    assert kinds == [True] * CYCLES
    monkeypatch.setattr(sequence, "_write_frame", real)
    store_only(tmp_path / "threads", threads(2))
    a, b = (PointMapStore.open_existing(tmp_path / name / "points.zarr") for name in ("serial", "threads"))
    for k in range(CYCLES):
        np.testing.assert_array_equal(a.depth(k), b.depth(k))
        np.testing.assert_array_equal(a.quality(k), b.quality(k))
        np.testing.assert_array_equal(a.sigma_z(k), b.sigma_z(k))
