"""``fringe3d strain`` on dask.distributed: a LocalCluster of worker processes writes the serial run's
files byte for byte (also when a worker dies mid-run), and an unreachable scheduler or two Dask
options at once are clear errors that write nothing."""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest
from conftest import write_wing_sequence

from fringe3d.cli import main

distributed = pytest.importorskip("distributed")  # in the test extra: CI always has it
TIMES = (0.0, 0.005, 0.01, 0.015, 0.02)


@pytest.fixture(scope="module")
def sequence(tmp_path_factory):
    """Five frames of a bending, flapping wing (points_*.npy, with textures carrying two dark anchor
    dots that the run follows) and the reference anchors 'u1,v1,u2,v2' px."""
    folder = tmp_path_factory.mktemp("seq")
    anchors0, _ = write_wing_sequence(folder, TIMES)
    return folder, ",".join(f"{x:.4f}" for x in anchors0.ravel())


def strain(seq, out: Path, *extra: str) -> int:
    folder, arg = seq
    return main(["strain", str(folder), "--anchors", arg, "-o", str(out), "--step", "6", "--window", "9",
                 "--fill-dots", "0", "--no-figures", "-q", *extra])


def frame_files(out: Path) -> dict[str, bytes]:
    """Every per-frame output (CSV, per-point arrays, VTU frames, PVD) by relative path, as bytes."""
    paths = [out / "strain.csv", out / "strain.pvd", *sorted((out / "arrays").rglob("*.npy")),
             *sorted((out / "vtk").glob("*.vtu"))]
    return {str(p.relative_to(out)): p.read_bytes() for p in paths}


@pytest.fixture(scope="module")
def serial(sequence, tmp_path_factory):
    out = tmp_path_factory.mktemp("serial") / "out"
    assert strain(sequence, out) == 0
    files = frame_files(out)
    assert len([k for k in files if k.endswith(".vtu")]) == len(TIMES) and len(files) == 2 + 7 + len(TIMES)
    ok = np.load(out / "arrays" / "wing_0" / "ok.npy")
    assert ok.shape[0] == len(TIMES) and ok.mean() > 0.85  # a real run, not empty frames
    return files


def test_a_local_cluster_of_two_worker_processes_writes_the_serial_files_byte_for_byte(sequence, serial, tmp_path):
    assert strain(sequence, tmp_path / "out", "--dask-workers", "2") == 0
    got = frame_files(tmp_path / "out")
    assert sorted(got) == sorted(serial)
    for name, data in serial.items():
        assert got[name] == data, name


class DieOnce:
    """A strain frame task whose worker process dies (os._exit) the first time it reaches ``frame``."""

    def __init__(self, task, marker: str, frame: int):
        self.task, self.marker, self.frame = task, marker, frame

    def __call__(self, f: int):
        if f == self.frame and not os.path.exists(self.marker):
            Path(self.marker).touch()
            os._exit(1)
        return self.task(f)


def test_a_worker_that_dies_mid_run_has_its_frame_rerun_and_the_files_equal_the_serial_run(
        sequence, serial, tmp_path, monkeypatch):
    from fringe3d.cluster import strain_frames
    from fringe3d.commands import strain as command

    marker = tmp_path / "died"
    original = strain_frames.frames_on_dask

    def dying(client):
        frames = original(client)
        return lambda task, n: frames(DieOnce(task, str(marker), 2), n)
    monkeypatch.setattr(command, "frames_on_dask", dying)
    assert strain(sequence, tmp_path / "out", "--dask-workers", "2") == 0
    assert marker.exists(), "a worker died on frame 2"
    got = frame_files(tmp_path / "out")
    for name, data in serial.items():
        assert got[name] == data, name


def test_an_unreachable_scheduler_exits_2_naming_it_and_writes_nothing(sequence, tmp_path, capsys):
    assert strain(sequence, tmp_path / "out", "--scheduler", "tcp://127.0.0.1:9") == 2
    err = " ".join(capsys.readouterr().err.split())
    assert "cannot reach the Dask scheduler at tcp://127.0.0.1:9" in err
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("extra, text", [
    (("--processes", "2", "--scheduler", "tcp://127.0.0.1:9"), "either --processes"),
    (("--processes", "2", "--threads", "2"), "--threads 2 runs threads"),
    (("--processes", "0"), "--processes must be at least 1"),
])
def test_conflicting_or_bad_scheduler_options_exit_2_and_write_nothing(sequence, tmp_path, capsys, extra, text):
    assert strain(sequence, tmp_path / "out", *extra) == 2
    assert text in " ".join(capsys.readouterr().err.split())
    assert not (tmp_path / "out").exists()
