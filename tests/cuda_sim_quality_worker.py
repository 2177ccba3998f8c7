"""Runs the fused 3-step path with every per-pixel output on the device (quality bits, masked
ray parameters, texture, sigma_z; :meth:`FrameReconstructor.device_cycles`) under numba's CUDA
simulator beside the CPU backend, on small rendered captures, and saves both for
``tests/test_cuda_quality.py``.

A separate process because ``NUMBA_ENABLE_CUDASIM=1`` must be set before numba is first
imported. ``python tests/cuda_sim_quality_worker.py OUT.npz``.
"""
from __future__ import annotations

import glob
import sys
import tempfile
import warnings

import numpy as np

from cuda_sim_worker import H, W, Z_MIN, render_cycles, tiny_rig

#: Option sets: the defaults; a wide edge margin (the sphere's w spans about 81-186 px of the
#: 256 px pattern: EDGE at both ends), rim 2 and strict gradient and contrast ratios (RIM beyond
#: one pixel, GRADIENT, MOD_DROP). Without edge tests: the one cycle through reconstruct().
OPTIONS = {"default": {}, "strict": {"edge_margin": 90.0, "rim": 2, "modulation_ratio": 0.9, "gradient_ratio": 1.5}}


def main(out_path: str) -> None:
    from fringe3d.decode import DecodeOptions
    from fringe3d.gpu.runtime import cuda_module
    from fringe3d.patterns import sets
    from fringe3d.reconstruct.depth import EmptyMaskError
    from fringe3d.reconstruct.frame import FrameReconstructor
    from fringe3d.io.store import PointMapStore
    from fringe3d.reconstruct.sequence import reconstruct_sequence, reconstruction_plans
    from fringe3d.reconstruct.settings import DecodeSettings, OutputSettings, RunSettings

    cuda_module()  # the simulator counts as a device
    from fringe3d.gpu import quality_kernels as qk

    r: dict[str, np.ndarray] = {"bits": np.array([qk.INVALID, qk.EDGE, qk.GRADIENT, qk.MOD_DROP, qk.RIM])}
    rig = tiny_rig()
    ps3 = reconstruction_plans(sets.phase_shift(18.0, 3, "v", width=256, height=200), "geometric")
    f3, _ = render_cycles(rig, ps3, 2, ideal_first=False, with_wall=False)
    cycles = [np.round(f).astype(np.uint8) for f in f3]
    cycles.append(np.zeros((3, H, W), np.uint8))  # no modulation anywhere: an empty phase mask
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for name, extra in OPTIONS.items():
            opts = DecodeOptions(z_min=Z_MIN, **extra)
            cpu = FrameReconstructor(ps3, rig, opts, backend="cpu")
            dev = FrameReconstructor(ps3, rig, opts, backend="cuda")
            assert cpu.fast is not None and dev.on_device("z")
            got = dev.device_cycles(cycles, "z", points=True, texture=True)
            r[f"{name}_empty_is_none"] = np.array(got[-1] is None)
            for key in ("quality", "depth", "sigma_z", "texture", "points"):
                r[f"{name}_cpu_{key}"] = np.stack([getattr(cpu.reconstruct(c, uncertainty="z"), key)
                                                   for c in cycles[:-1]])
                r[f"{name}_gpu_{key}"] = np.stack([getattr(g, key) for g in got[:-1]])
            try:
                cpu.reconstruct(cycles[-1], uncertainty="z")
                r[f"{name}_cpu_empty_raises"] = np.array(False)
            except EmptyMaskError:
                r[f"{name}_cpu_empty_raises"] = np.array(True)
        # one cycle through reconstruct() on the device, without edge tests, sigma_z or texture
        opts = DecodeOptions(z_min=Z_MIN, edge_mask=False)
        cpu = FrameReconstructor(ps3, rig, opts, backend="cpu")
        dev = FrameReconstructor(ps3, rig, opts, backend="cuda")
        one = dev.reconstruct(cycles[1], uncertainty=False, texture=False)
        ref = cpu.reconstruct(cycles[1], uncertainty=False, texture=False)
        r["one_gpu_quality"], r["one_cpu_quality"] = one.quality, ref.quality
        r["one_gpu_depth"], r["one_cpu_depth"] = one.depth, ref.depth
        r["one_gpu_none"] = np.array(one.sigma_z is None and one.texture is None)
        # the sequence path (what `fringe3d reconstruct` runs): the store's quality maps and
        # sigma_z, with PLY files (points and texture) written too, cpu and cuda backends
        seq = np.concatenate(cycles[:2])
        with tempfile.TemporaryDirectory() as tmp:
            for backend in ("cpu", "cuda"):
                res = reconstruct_sequence(seq, ps3, rig, f"{tmp}/{backend}",
                                           decode=DecodeSettings(options=DecodeOptions(z_min=Z_MIN)),
                                           outputs=OutputSettings(ply=True),
                                           run=RunSettings(progress=False, backend=backend))
                st = PointMapStore.open_existing(f"{tmp}/{backend}/points.zarr")
                n = res["frames_3d"]
                r[f"seq_{backend}_quality"] = np.stack([st.quality(k) for k in range(n)])
                r[f"seq_{backend}_sigma_z"] = np.stack([st.sigma_z(k) for k in range(n)])
                r[f"seq_{backend}_ply_files"] = np.array(len(glob.glob(f"{tmp}/{backend}/**/*.ply", recursive=True)))
    np.savez(out_path, **r)


if __name__ == "__main__":
    main(sys.argv[1])
