"""Runs the CUDA kernels under numba's CUDA simulator beside the CPU kernels, on small rendered
captures, and saves both results for ``tests/test_cuda_backend.py``.

Run as a script in its own process: ``NUMBA_ENABLE_CUDASIM=1`` must be set before numba is
first imported, which the CPU tests' process has long done (the test sets it for this process
only). ``python tests/cuda_sim_worker.py OUT.npz``.
"""
from __future__ import annotations

import math
import sys
import tempfile
import warnings
from pathlib import Path

import numpy as np

H, W = 12, 16  # the simulator runs every CUDA thread as a Python thread: keep frames tiny
SHIFTS = (-2 * math.pi / 3, 0.0, 2 * math.pi / 3)
Z_MIN = 255.0


def tiny_rig():
    """A 16 x 12 camera (with distortion) whose view the sphere of :func:`scene` nearly fills."""
    from fringe3d.optics import PinholeDevice, Rig, intrinsics
    from fringe3d.sim.presets import look_at

    cam = PinholeDevice(K=intrinsics(60.0, 60.2, 7.5, 5.5), width=W, height=H, dist=(-0.12, 0.08, 0.001, -0.0015, 0.0))
    R, t = look_at([80.0, -20.0, 0.0], [0.0, 0.0, 300.0])
    proj = PinholeDevice(K=intrinsics(400.0, 400.0, 127.5, 99.5), width=256, height=200, R=R, t=t)
    return Rig(cam, proj)


def scene(with_wall: bool):
    """A sphere (within the geometric constraint's depth range from Z_MIN), optionally before a
    tilted wall (beyond it: for the temporal three-frequency decode only)."""
    from fringe3d import sim as sc

    objects = [sc.Sphere([5.0, -3.0, 300.0], 40.0)]
    return sc.Scene(objects + [sc.Plane([0.0, 0.0, 380.0], [0.1, 0.0, -1.0])] if with_wall else objects)


def render_cycles(rig, ps, n_cycles: int, ideal_first: bool, with_wall: bool):
    """``(C, F, H, W)`` float32 frames in 8-bit counts: cycle 0 ideal (noise-free analytic sinusoids) when
    asked, the rest noisy and quantised (seed = cycle); and the truth."""
    from fringe3d.sim import RenderSettings, render

    cycles, truth = [], None
    for c in range(n_cycles):
        if ideal_first and c == 0:
            st = RenderSettings(ideal=True, bit_depth=None, shadows=True)
        else:
            st = RenderSettings(read_noise=0.004, bit_depth=8, seed=c)
        f, truth = render(scene(with_wall), rig, ps, st, progress=False)
        cycles.append(np.asarray(f, np.float32) * (255.0 if st.bit_depth is None else 1.0))  # 8-bit counts
    return np.stack(cycles), truth


def main(out_path: str) -> None:
    from numba import cuda

    from fringe3d.decode import DecodeOptions
    from fringe3d.gpu.runtime import cuda_module
    from fringe3d.io.store import PointMapStore
    from fringe3d.patterns import sets
    from fringe3d.phase.psp import wrapped_phase
    from fringe3d.reconstruct.settings import DecodeSettings, RunSettings
    from fringe3d.reconstruct.sequence import reconstruct_sequence, reconstruction_plans
    from fringe3d.reconstruct.triangulate import FastThreeStep, Triangulator
    from fringe3d.unwrap.geometric import geometric_unwrap, minimum_phase
    from fringe3d.unwrap.temporal import three_frequency_decode

    cuda_module()  # the simulator counts as a device
    r: dict[str, np.ndarray] = {}
    rig = tiny_rig()

    # -- 3-step + geometric + triangulation (fused), and the same steps one by one
    ps3 = reconstruction_plans(sets.phase_shift(18.0, 3, "v", width=256, height=200), "geometric")
    f3, truth = render_cycles(rig, ps3, 3, ideal_first=True, with_wall=False)
    f3 = np.concatenate([f3[:1], np.round(f3[1:])])  # cycles 1, 2 hold uint8 values
    r["truth_xyz"], r["truth_mask"] = truth.xyz, truth.mask
    idx3 = np.arange(3)
    shifts3 = [fr.shift for fr in ps3.frames]
    mp = minimum_phase(rig, Z_MIN, 18.0)
    tri = Triangulator(rig)
    cpu_fast = FastThreeStep(tri, mp, shifts3, min_modulation=5.0)
    gpu_fast = FastThreeStep(tri, mp, shifts3, min_modulation=5.0, backend="cuda")
    r["fused_cpu"] = np.stack([cpu_fast.points(f) for f in f3])
    r["fused_gpu_streamed"] = gpu_fast.points(f3)  # host frames: 2-cycle chunks, double-buffered
    from fringe3d.gpu.streaming import _POOL
    before = {k: id(v) for k, v in _POOL.buffers.items()}
    r["fused_gpu_streamed_again"] = gpu_fast.points(f3)  # the next batch: the same chunk buffers, reused
    r["pool_reused"] = np.array(bool(before) and before == {k: id(v) for k, v in _POOL.buffers.items()})
    from fringe3d.gpu import ops
    geometry = ops.ThreeStepGeometry(gpu_fast.coef, gpu_fast.phi_min, gpu_fast.sign, gpu_fast.scale, tri.O,
                                     tri.D_planes, tri.Q, tri.P3)
    r["fused_gpu_chunk2"] = ops.three_step_points(f3, idx3, geometry, gpu_fast.min_mod2, chunk=2)
    d_pts = gpu_fast.points(cuda.to_device(f3), device_output=True)  # resident: device in, device out
    r["fused_gpu_resident_is_device"] = np.array(hasattr(d_pts, "copy_to_host") and not isinstance(d_pts, np.ndarray))
    r["fused_gpu_resident"] = d_pts.copy_to_host()
    r["fused_gpu_one_cycle"] = gpu_fast.points(f3[1])
    d_chunked = ops.three_step_points(f3, idx3, geometry, gpu_fast.min_mod2, chunk=2, device_output=True)
    r["fused_gpu_chunk2_device"] = d_chunked.copy_to_host()  # host frames up in chunks, results left on the device

    # wrapped phase (3-step), geometric unwrap, closed-form triangulation
    cpu_ph = [wrapped_phase(f, shifts=shifts3) for f in f3]
    gpu_ph = wrapped_phase(f3, shifts=shifts3, backend="cuda")
    r["psp3_cpu"] = np.stack([p.phase for p in cpu_ph])
    r["psp3_gpu"] = gpu_ph.phase
    r["psp3_mod_cpu"] = np.stack([p.modulation for p in cpu_ph])
    r["psp3_mod_gpu"] = gpu_ph.modulation
    masks = r["psp3_mod_cpu"] >= 5.0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        geo_cpu = [geometric_unwrap(p, mp, m) for p, m in zip(r["psp3_cpu"], masks)]
        geo_gpu = geometric_unwrap(r["psp3_cpu"], mp, masks, backend="cuda")
    r["geo_cpu"] = np.stack([g[0] for g in geo_cpu])
    r["geo_cpu_mask"] = np.stack([g[1] for g in geo_cpu])
    r["geo_gpu"], r["geo_gpu_mask"] = geo_gpu
    # the same two steps with everything on the device: frames, wrapped phase, absolute phase
    ph_dev = wrapped_phase(cuda.to_device(f3), shifts=shifts3, backend="cuda", device_output=True)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        phi_dev, valid_dev = geometric_unwrap(ph_dev.phase, mp, backend="cuda", device_output=True)
        r["geo_nomask_cpu"] = np.stack([geometric_unwrap(p, mp)[0] for p in r["psp3_cpu"]])
    r["geo_dev_is_device"] = np.array(hasattr(phi_dev, "copy_to_host") and hasattr(valid_dev, "copy_to_host"))
    r["geo_dev"] = phi_dev.copy_to_host()
    w = r["geo_cpu"].astype(np.float64) * 18.0 / (2 * math.pi)
    r["tri_cpu"] = np.stack([tri.points(wi, mi) for wi, mi in zip(w, r["geo_cpu_mask"])])
    r["tri_gpu"] = tri.points(w, r["geo_cpu_mask"], backend="cuda")

    # -- 15-frame three-frequency decode (9 + 3 + 3 steps) and its 9-step wrapped phase
    ps15 = sets.three_frequency("v", width=256, height=200)
    f15, _ = render_cycles(rig, ps15, 2, ideal_first=False, with_wall=True)
    f15 = f15.astype(np.uint8)
    g = [[i for i, fr in enumerate(ps15.frames) if fr.group == name] for name in dict.fromkeys(fr.group for fr in
                                                                                            ps15.frames)]
    shifts = [[ps15.frames[i].shift for i in gi] for gi in g]
    periods = ps15.plans[0].periods
    kw = dict(w_range=(0.0, 255.0), min_modulation=5.0, saturation_level=255.0)
    tf_cpu = [three_frequency_decode(f, g, shifts, periods, **kw) for f in f15]
    tf_gpu = three_frequency_decode(f15, g, shifts, periods, backend="cuda", **kw)
    for name in ("phase", "wrapped", "modulation", "average", "mask", "texture"):
        r[f"tf_cpu_{name}"] = np.stack([getattr(t, name) for t in tf_cpu])
        r[f"tf_gpu_{name}"] = getattr(tf_gpu, name)
    r["tf_periods"] = np.asarray(periods, float)
    r["psp9_cpu"] = np.stack([wrapped_phase(f, shifts=shifts[0], index=g[0]).phase for f in f15])
    r["psp9_gpu"] = wrapped_phase(f15, shifts=shifts[0], index=g[0], backend="cuda").phase
    r["psp9_mod_cpu"] = np.stack([wrapped_phase(f, shifts=shifts[0], index=g[0]).modulation for f in f15])

    # -- a 3-cycle sequence into the point store, cpu and cuda backends
    seq = np.round(f3[1:].reshape(-1, H, W)).astype(np.uint8)
    opts = DecodeOptions(z_min=Z_MIN)
    with tempfile.TemporaryDirectory() as tmp, warnings.catch_warnings():
        warnings.simplefilter("ignore")
        stores = {}
        for backend in ("cpu", "cuda"):
            res = reconstruct_sequence(seq, ps3, rig, f"{tmp}/{backend}", decode=DecodeSettings(options=opts),
                                       run=RunSettings(progress=False, backend=backend))
            st = PointMapStore.open_existing(f"{tmp}/{backend}/points.zarr")
            stores[backend] = np.stack([st.read(k) for k in range(res["frames_3d"])])
            r[f"seq_{backend}_path"] = np.array(res["path"])
    r["seq_cpu"], r["seq_cuda"] = stores["cpu"], stores["cuda"]

    # -- the same sequence as a capture folder: `fringe3d reconstruct --device cuda` and --device cpu
    from fringe3d.cli import main as cli
    from fringe3d.cluster.engine import close, connect, dask_executor, reconstruct_capture_on_dask
    from fringe3d.io.capture import write_capture
    from fringe3d.io.capture_frames import CaptureFolder

    with tempfile.TemporaryDirectory() as tmp, warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cap = write_capture(f"{tmp}/cap", seq, ps3)
        rig.save(f"{tmp}/rig.json")
        for device in ("cpu", "cuda"):
            code = cli(["reconstruct", str(cap), "-c", f"{tmp}/rig.json", "-o", f"{tmp}/{device}", "--z-min",
                        str(Z_MIN), "-q", "--device", device])
            st = PointMapStore.open_existing(f"{tmp}/{device}/points.zarr")
            r[f"cli_{device}"] = np.stack([st.read(k) for k in range(st.frames)])
            r[f"cli_{device}_code"] = np.array(code)

    with tempfile.TemporaryDirectory() as tmp, warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cap = write_capture(f"{tmp}/cap", seq, ps3)
        client = connect(workers=1, gpu=True)  # its worker process inherits NUMBA_ENABLE_CUDASIM
        try:
            res = reconstruct_capture_on_dask(CaptureFolder(str(cap)), ps3, rig, Path(f"{tmp}/out"),
                                              dask_executor(client, chunk=1), DecodeSettings(opts),
                                              run=RunSettings("cuda", progress=False))
        finally:
            close(client, own_cluster=True)
        st = PointMapStore.open_existing(f"{tmp}/out/points.zarr")
        r["dask_cuda"] = np.stack([st.read(k) for k in range(res["frames_3d"])])
        r["dask_tasks"] = np.array(res["tasks"])
    np.savez(out_path, **r)


if __name__ == "__main__":
    main(sys.argv[1])
