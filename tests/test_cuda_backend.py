"""The CUDA backend (``backend="cuda"``, :mod:`fringe3d.gpu`) equals the CPU kernels and the
simulator's truth, run under numba's CUDA simulator; and asking for it without a device is a
clear error.

The simulator must be switched on before numba is imported, so the kernels run in a separate
process (``tests/cuda_sim_worker.py``, ~10 s on 12 x 16 pixel frames) whose results all tests
here share. No physical GPU is involved anywhere in these tests.
"""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from fringe3d.gpu import runtime

HERE = Path(__file__).parent
PHASE_TOL = 1e-5  # rad
POINT_TOL = 1e-4  # mm


def _env(**extra) -> dict:
    env = dict(os.environ)
    src = str(HERE.parent / "src")
    env["PYTHONPATH"] = src + os.pathsep + env.get("PYTHONPATH", "")
    env.update(extra)
    return env


@pytest.fixture(scope="module")
def sim(tmp_path_factory):
    out = tmp_path_factory.mktemp("cudasim") / "results.npz"
    p = subprocess.run([sys.executable, str(HERE / "cuda_sim_worker.py"), str(out)], env=_env(NUMBA_ENABLE_CUDASIM="1"),
                       capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr[-3000:]
    return dict(np.load(out))


def angle_diff(a, b):
    return np.abs(np.angle(np.exp(1j * (np.asarray(a, np.float64) - np.asarray(b, np.float64)))))


def same_points(a, b, tol=POINT_TOL):
    """Same NaN pattern and every finite point within ``tol`` mm."""
    assert np.array_equal(np.isnan(a[..., 0]), np.isnan(b[..., 0]))
    ok = np.isfinite(a[..., 0])
    assert ok.any()
    assert np.max(np.abs(a[ok] - b[ok])) <= tol


def test_fused_three_step_kernel_equals_cpu_for_streamed_chunked_and_resident_frames(sim):
    for key in ("fused_gpu_streamed", "fused_gpu_chunk2", "fused_gpu_resident"):
        same_points(sim["fused_cpu"], sim[key])
    same_points(sim["fused_cpu"][1], sim["fused_gpu_one_cycle"])


def test_the_next_batch_reuses_the_chunk_buffers_and_gives_the_same_points(sim):
    assert bool(sim["pool_reused"])  # no pinned or device buffer made again
    np.testing.assert_array_equal(sim["fused_gpu_streamed_again"], sim["fused_gpu_streamed"])


def test_results_can_stay_on_the_device(sim):
    assert bool(sim["fused_gpu_resident_is_device"]) and bool(sim["geo_dev_is_device"])
    same_points(sim["fused_cpu"], sim["fused_gpu_chunk2_device"])  # host frames in chunks, device results


def test_wrapped_phase_and_geometric_unwrap_chained_on_the_device_equal_cpu(sim):
    cpu, dev = sim["geo_nomask_cpu"], sim["geo_dev"]
    ok = np.isfinite(cpu) & (sim["psp3_mod_cpu"] >= 5.0)
    assert ok.mean() > 0.5 and np.array_equal(np.isnan(cpu), np.isnan(dev))
    assert np.abs(cpu[ok] - dev[ok]).max() <= PHASE_TOL


def test_fused_three_step_kernel_equals_truth_on_a_noise_free_render(sim):
    pts, truth, mask = sim["fused_gpu_streamed"][0], sim["truth_xyz"], sim["truth_mask"]
    ok = mask & np.isfinite(pts[..., 0])
    assert ok.sum() > 0.9 * mask.sum()
    assert np.max(np.abs(pts[ok] - truth[ok])) < 1e-3  # mm, as the CPU kernel's test


def test_three_step_and_nine_step_wrapped_phase_equal_cpu(sim):
    ok = sim["psp3_mod_cpu"] >= 5.0
    assert ok.mean() > 0.5
    assert angle_diff(sim["psp3_cpu"], sim["psp3_gpu"])[ok].max() <= PHASE_TOL
    assert np.abs(sim["psp3_mod_cpu"] - sim["psp3_mod_gpu"]).max() <= 1e-4  # counts
    ok9 = sim["psp9_mod_cpu"] >= 5.0
    assert angle_diff(sim["psp9_cpu"], sim["psp9_gpu"])[ok9].max() <= PHASE_TOL


def test_geometric_unwrap_equals_cpu(sim):
    assert np.array_equal(sim["geo_cpu_mask"], sim["geo_gpu_mask"])
    m = sim["geo_cpu_mask"]
    assert m.any() and np.isnan(sim["geo_gpu"][~m]).all()
    assert np.abs(sim["geo_cpu"][m] - sim["geo_gpu"][m]).max() <= PHASE_TOL


def test_closed_form_triangulation_equals_cpu(sim):
    same_points(sim["tri_cpu"], sim["tri_gpu"])


def test_three_frequency_decode_equals_cpu(sim):
    m = sim["tf_cpu_mask"]
    assert np.array_equal(m, sim["tf_gpu_mask"]) and m.mean() > 0.5
    assert np.isnan(sim["tf_gpu_phase"][~m]).all()
    assert np.abs(sim["tf_cpu_phase"][m] - sim["tf_gpu_phase"][m]).max() <= PHASE_TOL
    assert angle_diff(sim["tf_cpu_wrapped"], sim["tf_gpu_wrapped"])[m].max() <= PHASE_TOL
    for name in ("modulation", "average", "texture"):  # float32 sums in 8-bit counts
        assert np.abs(sim[f"tf_cpu_{name}"] - sim[f"tf_gpu_{name}"])[m].max() <= 1e-4


def test_sequence_on_the_cuda_backend_writes_the_cpu_point_maps(sim):
    assert str(sim["seq_cuda_path"]) == str(sim["seq_cpu_path"])
    same_points(sim["seq_cpu"], sim["seq_cuda"])


def test_cli_device_cuda_writes_the_cpu_point_maps(sim):
    assert int(sim["cli_cpu_code"]) == 0 and int(sim["cli_cuda_code"]) == 0
    same_points(sim["cli_cpu"], sim["cli_cuda"])


def test_dask_gpu_worker_writes_the_cpu_point_maps(sim):
    assert int(sim["dask_tasks"]) == 2  # 2 cycles, one task each, on the worker declaring GPU=1
    same_points(sim["seq_cpu"], sim["dask_cuda"])


class _Client:
    """Stands in for a distributed.Client: workers and their declared resources only."""

    def __init__(self, resources):
        self.resources = resources

    def scheduler_info(self):
        return {"workers": {f"tcp://w{i}": {"resources": r} for i, r in enumerate(self.resources)}}

    def submit(self, *a, **k):  # pragma: no cover - must not be reached
        raise AssertionError("no task may be submitted without a GPU worker")


def test_cuda_job_on_a_cluster_without_gpu_workers_is_a_clear_error():
    from fringe3d.cluster.engine import gpu_workers, sequence_job
    from fringe3d.io.capture_frames import CaptureFolder
    from fringe3d.reconstruct.executors import WindowJob

    class _Rec:  # only the backend is read before the check
        backend = "cuda"

    assert gpu_workers(_Client([{}, {"GPU": 1}])) == ["tcp://w1"]
    job = WindowJob(_Rec(), None, (0,), False, "xyz", False, capture=CaptureFolder("cap", 3))  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="--resources GPU=1"):
        sequence_job(job, _Client([{}, {"CPU": 4}]))


def test_unknown_backend_is_a_value_error():
    with pytest.raises(ValueError, match="expected one of cpu, cuda"):
        runtime.check_backend("gpu")


def test_missing_numba_cuda_names_the_extra(monkeypatch):
    monkeypatch.setitem(sys.modules, "numba.cuda", None)  # import numba.cuda now fails
    with pytest.raises(runtime.CudaUnavailableError, match=r"numba-cuda.*fringe3d\[cuda\]"):
        runtime.cuda_module()


def test_cli_device_cuda_without_a_driver_exits_2_and_writes_nothing(tmp_path):
    """A CUDA driver that cannot be found (as on any machine without an NVIDIA driver): the
    library raises CudaUnavailableError, the CLI prints its message without a traceback, exits
    2 and creates no output folder."""
    from fringe3d.patterns import sets
    from fringe3d.sim import simulate_capture

    cap = tmp_path / "cap"
    simulate_capture(cap, preset="tiny", scene="sphere", patterns=sets.phase_shift(18, 3, "v", width=256, height=200),
                     seed=1, progress=False)
    out = tmp_path / "out"
    fake = tmp_path / "libcuda.so"  # a file that is no driver library: loading it fails like a missing driver
    fake.write_bytes(b"not a shared library")
    env = _env(NUMBA_CUDA_DRIVER=str(fake), NUMBA_ENABLE_CUDASIM="0")
    p = subprocess.run([sys.executable, "-m", "fringe3d", "reconstruct", str(cap), "-c", str(cap / "rig.json"), "-o",
                        str(out), "--method", "geometric", "--z-min", "300", "--device", "cuda"],
                       env=env, capture_output=True, text=True, timeout=120)
    assert p.returncode == 2, p.stdout + p.stderr
    assert "CUDA driver" in p.stderr and "--device cpu" in p.stderr
    assert "Traceback" not in p.stderr
    assert not out.exists()
