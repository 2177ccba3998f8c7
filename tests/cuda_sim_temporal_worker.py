"""Decodes small rendered 15-frame three-frequency captures with the decoder's default method on
the CUDA backend (:mod:`fringe3d.decode.device_temporal`, every per-pixel output made on the device)
under numba's CUDA simulator, beside the CPU backend, and saves both for
``tests/test_cuda_temporal.py``.

A separate process because ``NUMBA_ENABLE_CUDASIM=1`` must be set before numba is first
imported. ``python tests/cuda_sim_temporal_worker.py OUT.npz``.
"""
from __future__ import annotations

import json
import sys
import warnings

import numpy as np

from cuda_sim_worker import Z_MIN, render_cycles, tiny_rig

#: Option sets: the defaults; strict tests (a wide edge margin, rim 2, strict ratios and a finite
#: disagreement threshold: EDGE, RIM, GRADIENT, MOD_DROP, INCONSISTENT); no edge tests.
OPTIONS = {"default": {}, "strict": {"edge_margin": 90.0, "rim": 2, "modulation_ratio": 0.9, "gradient_ratio": 1.5,
                                     "max_disagreement": 0.05},
           "no_edges": {"edge_mask": False}}
KEYS = ("phase", "mask", "quality", "phase_sigma", "wrapped", "modulation")


def main(out_path: str) -> None:
    from fringe3d.decode import DecodeOptions, decode
    from fringe3d.decode import device_temporal
    from fringe3d.gpu.runtime import cuda_module
    from fringe3d.patterns import sets
    from fringe3d.reconstruct.frame import FrameReconstructor

    cuda_module()  # the simulator counts as a device
    import fringe3d.decode.decoder as decoder

    calls = []  # the device path was taken (not the old one: the fused kernel alone on the device)
    decoder.device_direction = lambda ctx: calls.append(1) or device_temporal.device_direction(ctx)
    r: dict[str, np.ndarray] = {}
    rig = tiny_rig()
    ps = sets.three_frequency("v", width=256, height=200)
    f15, _ = render_cycles(rig, ps, 1, ideal_first=False, with_wall=True)
    cycles = [np.round(f15[0]).astype(np.uint8),
              np.clip(np.round(f15[0] * 1.6), 0, 255).astype(np.uint8)]  # bright: clipped samples
    d = ps.plans[0].direction
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for name, extra in OPTIONS.items():
            for c, frames in enumerate(cycles):
                if name != "default" and c == 0:  # the option sets' other bits: on the bright capture
                    continue
                for backend in ("cpu", "cuda"):
                    dec = decode(frames, ps, options=DecodeOptions(backend=backend, **extra))
                    for key in KEYS:
                        r[f"{name}_{c}_{backend}_{key}"] = np.asarray(getattr(dec, key)[d])
                    r[f"{name}_{c}_{backend}_texture"] = np.asarray(dec.texture)
                    r[f"{name}_{c}_{backend}_info"] = np.array(json.dumps(dec.info["quality"][d], sort_keys=True,
                                                                          default=float))
        # through the engine: points, quality and sigma_xyz of the decode path
        for backend in ("cpu", "cuda"):
            rec = FrameReconstructor(ps, rig, DecodeOptions(z_min=Z_MIN), backend=backend)
            cyc = rec.reconstruct(cycles[0], uncertainty=True)
            for key in ("points", "quality", "sigma_xyz", "texture"):
                r[f"rec_{backend}_{key}"] = np.asarray(getattr(cyc, key))
    r["device_calls"] = np.array(len(calls))
    # the blur's median by radix selection on its own: odd and even counts, ties, zero denominators
    from numba import cuda

    from fringe3d.gpu.temporal_outputs import DeviceDecode

    rng = np.random.default_rng(7)
    for n in (95, 96):  # 90 and 91 ratios: an even and an odd count
        fine = rng.choice(np.float32([0.0, 0.25, 0.5, 0.75, 1.0, 3.0]), n) * rng.uniform(0.5, 2.0, n).astype(np.float32)
        fine[10:30] = np.float32(0.5)  # ties
        coarse = rng.choice(np.float32([1.0, 2.0, 1.5]), n)
        coarse[:3] = 0.0  # no ratio
        mask = np.ones(n, bool)
        mask[3:5] = False
        m = mask & (coarse > 0)
        dev = DeviceDecode.__new__(DeviceDecode)
        dev.cuda, dev.tk, dev.n = cuda, __import__("fringe3d.gpu.temporal_kernels", fromlist=["x"]), n
        dev.modulation, dev.modulation3, dev.mask = cuda.to_device(fine), cuda.to_device(coarse), cuda.to_device(mask)
        r[f"median_{n}_count"] = np.array(int(m.sum()))
        r[f"median_{n}_numpy"] = np.array(float(np.median(fine[m] / coarse[m])))
        r[f"median_{n}_device"] = np.array(dev.ratio_median())
    np.savez(out_path, **r)


if __name__ == "__main__":
    main(sys.argv[1])
