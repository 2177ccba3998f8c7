"""The sequence pipeline on dask.distributed: a LocalCluster of worker processes gives the same
store as the serial path, survives a killed worker, resumes after SIGKILL of the whole run, and an
unreachable scheduler is a clear error that writes nothing."""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from fringe3d.cli import main
from fringe3d.io.store import PointMapStore
from fringe3d.patterns import sets
from fringe3d.sim import simulate_capture

distributed = pytest.importorskip("distributed")  # in the test extra: CI always has it
SRC = Path(__file__).parents[1] / "src"
CYCLES = 12


@pytest.fixture(scope="module")
def capture(tmp_path_factory):
    """12 cycles of a 3-step T=64 capture of a moving ball before a wall, with its rig."""
    folder = tmp_path_factory.mktemp("dask") / "cap"
    ps = sets.phase_shift(64, 3, "v", width=256, height=200)
    simulate_capture(folder, preset="tiny", scene="sphere", patterns=ps, cycles=CYCLES, seed=3, progress=False)
    return folder


def reconstruct(capture: Path, out: Path, *extra: str) -> int:
    return main(["reconstruct", str(capture), "-c", str(capture / "rig.json"), "-o", str(out), "--method",
                 "geometric", "--z-min", "340", "-q", *extra])


def points(out: Path) -> np.ndarray:
    st = PointMapStore.open_existing(out / "points.zarr")
    assert st.completed == st.frames == CYCLES
    return np.stack([st.read(k) for k in range(st.frames)])


def store_maps(out: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Depth, quality bits and sigma_z of every frame of the store in ``out``."""
    st = PointMapStore.open_existing(out / "points.zarr")
    return tuple(np.stack([f(k) for k in range(st.frames)]) for f in (st.depth, st.quality, st.sigma_z))


@pytest.fixture(scope="module")
def serial_out(capture, tmp_path_factory):
    out = tmp_path_factory.mktemp("serial") / "out"
    assert reconstruct(capture, out) == 0
    return out


@pytest.fixture(scope="module")
def serial(serial_out):
    return points(serial_out)


def test_two_worker_processes_give_the_serial_store_bit_for_bit(capture, serial, serial_out, tmp_path):
    assert reconstruct(capture, tmp_path / "out", "--workers", "2", "--chunk", "2") == 0
    P = points(tmp_path / "out")
    assert np.isfinite(P[..., 0]).mean() > 0.3
    np.testing.assert_array_equal(P, serial)
    for got, want in zip(store_maps(tmp_path / "out"), store_maps(serial_out)):  # depth, quality, sigma_z
        np.testing.assert_array_equal(got, want)


def test_a_worker_killed_mid_run_still_ends_with_a_complete_correct_store(capture, serial, tmp_path):
    from fringe3d.cluster.engine import close, connect
    from fringe3d.cluster import chunk_task

    client = connect(workers=2)
    try:
        pids = list(client.run(os.getpid).values())
        victim = pids[0]
        # each worker's kernels share the cores: numba threads = cores // workers, not all cores each
        want = str(max(1, (os.cpu_count() or 1) // 2))
        assert set(client.run(lambda: os.environ.get("NUMBA_NUM_THREADS")).values()) == {want}

        def slow_then(job, ks):  # make the run last long enough to kill a worker inside it
            time.sleep(0.5)
            return chunk_task.run_chunk(job, ks)
        killer = subprocess.Popen([sys.executable, "-c", f"import os, time, signal; time.sleep(1.5); "
                                   f"os.kill({victim}, signal.SIGKILL)"])
        from fringe3d.cluster import engine
        original = engine.run_chunk
        engine.run_chunk = slow_then
        try:
            assert _reconstruct_with(client, capture, tmp_path / "out") == 0
            assert killer.poll() == 0, "the worker was killed before the run ended (12 tasks of 0.5 s on 2 workers)"
        finally:
            engine.run_chunk = original
            killer.wait()
        assert victim not in client.run(os.getpid).values(), "the worker was killed during the run"
    finally:
        close(client, own_cluster=True)
    np.testing.assert_array_equal(points(tmp_path / "out"), serial)


def _reconstruct_with(client, capture: Path, out: Path) -> int:
    """The reconstruct command, but on an existing client (the test's cluster)."""
    from fringe3d.commands import reconstruct as command

    original = command.connect, command.close
    command.connect, command.close = (lambda scheduler, workers: client), (lambda client, own_cluster: None)
    try:
        return reconstruct(capture, out, "--scheduler", "tcp://test-cluster", "--chunk", "1")
    finally:
        command.connect, command.close = original


def test_sigkill_of_the_whole_run_then_resume_skips_finished_frames_and_equals_an_uninterrupted_run(
        capture, serial, tmp_path):
    out = tmp_path / "out"
    argv = [sys.executable, "-m", "fringe3d", "reconstruct", str(capture), "-c", str(capture / "rig.json"), "-o",
            str(out), "--method", "geometric", "--z-min", "340", "-q", "--workers", "2", "--chunk", "1"]
    proc = subprocess.Popen(argv, env={**os.environ, "PYTHONPATH": str(SRC)}, start_new_session=True)
    try:
        deadline = time.time() + 240
        while time.time() < deadline and proc.poll() is None:
            try:
                if 0 < PointMapStore.open_existing(out / "points.zarr").completed < CYCLES:
                    break
            except (FileNotFoundError, ValueError, OSError, KeyError):
                pass
            time.sleep(0.05)
    finally:
        os.killpg(proc.pid, signal.SIGKILL)  # the run and its worker processes
        proc.wait()
    done_before = PointMapStore.open_existing(out / "points.zarr").completed
    assert 0 < done_before < CYCLES, "the kill landed mid-run"
    code = main(["reconstruct", str(capture), "-c", str(capture / "rig.json"), "-o", str(out), "--method",
                 "geometric", "--z-min", "340", "--json", "--workers", "2", "--chunk", "1"])
    assert code == 0
    np.testing.assert_array_equal(points(out), serial)
    summary = __import__("json").loads((out / "reconstruct.json").read_text())
    assert summary["done_before"] == done_before and summary["done_now"] == CYCLES - done_before


def test_an_unreachable_scheduler_is_a_clear_error_and_writes_nothing(capture, tmp_path, capsys):
    code = reconstruct(capture, tmp_path / "out", "--scheduler", "tcp://127.0.0.1:9")
    err = " ".join(capsys.readouterr().err.split())
    assert code == 2 and "cannot reach the Dask scheduler at tcp://127.0.0.1:9" in err
    assert not (tmp_path / "out").exists()


def test_two_worker_processes_write_the_serial_ply_files(capture, tmp_path):
    assert reconstruct(capture, tmp_path / "serial", "--ply", "--no-store") == 0
    assert reconstruct(capture, tmp_path / "dask", "--ply", "--no-store", "--workers", "2", "--chunk", "3") == 0
    names = sorted(p.name for p in (tmp_path / "serial" / "ply").glob("*.ply"))
    assert len(names) == CYCLES
    assert names == sorted(p.name for p in (tmp_path / "dask" / "ply").glob("*.ply"))
    for name in names:  # one writer for both paths: the same measurement PLY, byte for byte but the command
        got, want = ((tmp_path / d / "ply" / name).read_bytes().split(b"\n", 5) for d in ("dask", "serial"))
        assert got[4].startswith(b"comment command: fringe3d reconstruct") and b"--workers 2" in got[4]
        assert got[:4] + got[5:] == want[:4] + want[5:]
