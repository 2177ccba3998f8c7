"""Benchmark of the CUDA backend (:mod:`fringe3d.gpu`) at 1280 x 1024, beside the device's copy
bandwidth and the CPU kernels on the same machine. Not run in CI; needs an NVIDIA GPU and
``pip install 'fringe3d[cuda]'`` (``--smoke`` runs it at 16 x 12 pixels under numba's CUDA
simulator, only to prove that the script works).

Two workloads, uint8 frames in, per 3D frame:

* ``fused 3-step``: 3 frames -> wrapped phase -> geometric constraint -> closed-form point
  (:class:`fringe3d.reconstruct.FastThreeStep` ``backend="cuda"``); out (H, W, 3) float32;
  also writing only the ray parameter (what the store keeps), and with every output of
  ``fringe3d reconstruct --device cuda`` (:func:`fringe3d.gpu.fused_outputs.three_step_outputs`:
  ray parameter masked by the quality tests, quality bits, sigma_z, texture; 13 bytes a pixel;
  its CPU reference is the fused kernel plus :func:`fringe3d.reconstruct.fast_quality.fast_quality`).
* ``three-frequency``: the 15-frame (9 + 3 + 3 step) heterodyne decode
  (:func:`fringe3d.unwrap.temporal.three_frequency_decode` ``backend="cuda"``); out absolute
  phase, wrapped phase, modulation, average, texture (float32) and the mask (bool).
* ``three-frequency decode + assessment``: the decoder's default plan on the 15 frames of
  :func:`fringe3d.patterns.sets.three_frequency` with every per-pixel output of the decode
  (mask, quality bits, phase sigma, texture) made on the device
  (:func:`fringe3d.decode.decode` ``DecodeOptions(backend="cuda")``,
  :mod:`fringe3d.decode.device_temporal`), one cycle per call, host frames in and host maps out,
  against the same call on the CPU backend; it reports whether the mask and the quality bits
  equal the CPU's and the largest phase and phase-sigma differences. Only ``gpu_fps`` and
  ``cpu_fps`` (the decode is per cycle: no resident or batched figure).

Each is timed (fixed repeat counts after one warm-up launch, which also compiles):

* ``resident``: frames already on the device, outputs left there (one launch over ``--cycles``);
* ``with transfers``: host frames in, host outputs back (pinned, double-buffered chunks on two
  streams, :func:`fringe3d.gpu.streaming.run_batched`);
* ``bound (device)``: a device-to-device copy of the same bytes (input + output of ``--cycles``
  3D frames); the kernel cannot beat reading its input and writing its output once;
* ``bound (host<->device)``: pinned host-to-device copy of the input plus device-to-host copy of
  the output (sequential: the transfer-inclusive rate cannot beat it unless the two directions
  overlap);
* ``cpu``: the numba CPU kernels on all cores, one 3D frame per call.

Targets (issue 17): >= 10,000 3D frames/s resident, >= 2,000 with transfers, resident within 3x
of the device bound. Sized so one run takes about 4 minutes or less on an H200.

Run: ``python benchmarks/bench_cuda.py --out cuda.json`` (``--smoke`` for the simulator check).
"""
from __future__ import annotations

import argparse
import json
import math
import os
import platform
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from summary import figure  # noqa: E402  (beside this script)

TARGET_RESIDENT = 10_000.0
TARGET_TRANSFER = 2_000.0
TARGET_BOUND_RATIO = 3.0
SHIFTS3 = (-2 * math.pi / 3, 0.0, 2 * math.pi / 3)
PERIOD3 = 36.0
PERIODS15 = (18.0, 21.0, 144.0)
STEPS15 = (9, 3, 3)


def parse(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", required=True, help="JSON results file (written; not overwritten without --overwrite)")
    ap.add_argument("--overwrite", action="store_true", help="replace an existing --out file")
    ap.add_argument("--smoke", action="store_true", help="16 x 12 pixels under numba's CUDA simulator (no GPU)")
    ap.add_argument("--cycles", type=int, default=None, help="3D frames per launch (default 256; smoke 2)")
    ap.add_argument("--repeat", type=int, default=None, help="timed repeats (default 10; smoke 1)")
    ap.add_argument("--seed", type=int, default=0, help="seed of the camera noise added to the frames")
    return ap.parse_args(argv)


def build_rig(width: int, height: int):
    """A pinhole camera of ``width`` x ``height`` pixels (f = 1.1 width) 150 mm beside a
    1280 x 800 projector (f = 1000 px) converging at 400 mm: the scene spans ~900 projector
    columns, inside the three-frequency set's 1008 px beat."""
    from fringe3d.optics import PinholeDevice, Rig, intrinsics
    from fringe3d.sim.presets import look_at

    f = 1.1 * width
    cam = PinholeDevice(K=intrinsics(f, f, (width - 1) / 2, (height - 1) / 2), width=width, height=height)
    R, t = look_at([150.0, 0.0, 0.0], [0.0, 0.0, 400.0])
    proj = PinholeDevice(K=intrinsics(1000.0, 1000.0, 639.5, 399.5), width=1280, height=800, R=R, t=t)
    return Rig(cam, proj)


def scene_w(rig):
    """Projector column ``u_p`` seen by every camera pixel on a tilted plane near z = 400 mm."""
    import numpy as np

    from fringe3d.optics.rays import RayGeometry, projector_fringe_coordinate

    geo = RayGeometry(rig, math.pi / 2)
    h, w = geo.shape
    v, u = np.mgrid[0:h, 0:w]
    z = 400.0 + 20.0 * (u / w - 0.5) + 10.0 * (v / h - 0.5)
    X = geo.ray_points_at_z(z)
    return projector_fringe_coordinate(rig, X, math.pi / 2)


def fringe_frames(w, periods, steps, shifts, rng):
    """uint8 frames ``127.5 + 100 cos(2 pi w / T + delta) + noise`` of each group, in order."""
    import numpy as np

    out = []
    for T, n, d in zip(periods, steps, shifts):
        for dk in d[:n]:
            f = 127.5 + 100.0 * np.cos(2 * math.pi * w / T + dk) + rng.normal(0.0, 1.0, w.shape)
            out.append(np.clip(np.round(f), 0, 255).astype(np.uint8))
    return np.stack(out)


def timed(fn, repeat: int, sync) -> float:
    """Median wall seconds of ``repeat`` calls of ``fn`` (each followed by ``sync()``), after one warm-up."""
    import numpy as np

    fn()
    sync()
    times = []
    for _ in range(repeat):
        t = time.perf_counter()
        fn()
        sync()
        times.append(time.perf_counter() - t)
    return float(np.median(times))


def copy_bounds(cuda, in_bytes: int, out_bytes: int, repeat: int) -> dict:
    """Seconds for a device-to-device copy of ``in_bytes + out_bytes``, a pinned host-to-device
    copy of ``in_bytes`` and a device-to-host copy of ``out_bytes`` into pinned memory."""
    import numpy as np

    total = in_bytes + out_bytes
    d_a = cuda.device_array(total, np.uint8)
    d_b = cuda.device_array(total, np.uint8)
    h_in = cuda.pinned_array(in_bytes, np.uint8)
    h_in[:] = 1
    h_out = cuda.pinned_array(out_bytes, np.uint8)
    d_in = d_a[:in_bytes]
    d_out = d_b[:out_bytes]
    sync = cuda.synchronize
    return {"d2d_s": timed(lambda: d_b.copy_to_device(d_a), repeat, sync),
            "h2d_s": timed(lambda: d_in.copy_to_device(h_in), repeat, sync),
            "d2h_s": timed(lambda: d_out.copy_to_host(h_out), repeat, sync)}


def workload(name, cuda, cycles_host, run_gpu, run_cpu, in_bytes, out_bytes, repeat, cpu_repeat) -> dict:
    """Times one workload; rates in 3D frames per second."""
    n = cycles_host.shape[0]
    resident = [cuda.to_device(cycles_host)]
    res = {"workload": name, "cycles": n, "in_bytes_per_frame": in_bytes, "out_bytes_per_frame": out_bytes}
    t_res = timed(lambda: run_gpu(resident[0], True), repeat, cuda.synchronize)
    resident.clear()  # free the device copy before the copy bounds allocate theirs
    t_xfer = timed(lambda: run_gpu(cycles_host, False), max(1, repeat // 3), cuda.synchronize)
    b = copy_bounds(cuda, in_bytes * n, out_bytes * n, repeat)
    t_cpu = timed(lambda: run_cpu(cycles_host[0]), cpu_repeat, lambda: None)
    res.update({
        "resident_fps": n / t_res,
        "with_transfers_fps": n / t_xfer,
        "bound_device_fps": n / b["d2d_s"],
        "bound_host_device_fps": n / (b["h2d_s"] + b["d2h_s"]),
        "d2d_GBps": 2 * (in_bytes + out_bytes) * n / b["d2d_s"] / 1e9,  # read + write
        "h2d_GBps": in_bytes * n / b["h2d_s"] / 1e9,
        "d2h_GBps": out_bytes * n / b["d2h_s"] / 1e9,
        "cpu_fps": 1.0 / t_cpu,
    })
    res["resident_vs_bound"] = res["bound_device_fps"] / res["resident_fps"]
    res["meets"] = {"resident>=10000": res["resident_fps"] >= TARGET_RESIDENT,
                    "with_transfers>=2000": res["with_transfers_fps"] >= TARGET_TRANSFER,
                    "resident_within_3x_of_bound": res["resident_vs_bound"] <= TARGET_BOUND_RATIO}
    return res


def every_output(cuda, gpu3, cpu3, frames3, extent: tuple[float, float], repeats: tuple[int, int]) -> dict:
    """The fused 3-step workload with every output of the sequence path made on the device
    (masked ray parameter, quality bits with the default edge tests, sigma_z, texture), against
    the CPU kernel plus :func:`fringe3d.reconstruct.fast_quality.fast_quality`."""
    import numpy as np

    from fringe3d.decode import DecodeOptions
    from fringe3d.decode.edges import BASE_MARGIN
    from fringe3d.gpu import fused_outputs as fo
    from fringe3d.reconstruct.fast_quality import fast_quality

    opts = DecodeOptions(z_min=0.0)
    lo, hi = extent
    settings = fo.QualitySettings(True, lo + BASE_MARGIN, hi - BASE_MARGIN, float(opts.gradient_ratio), 1.0,
                                  float(opts.modulation_ratio), int(opts.rim), 255.0)
    qo, po, qd, pd = gpu3.tri._ray_rows()
    rows = fo.SigmaRows(po * qd - qo * pd, qd, pd, float(np.float32(gpu3.mp.period / (2 * math.pi))), 3)
    inputs = fo.device_inputs(gpu3.device_geometry()[0], rows)
    idx = np.arange(3)

    def run_gpu(fr, dev):
        return fo.three_step_outputs(fr, idx, inputs, gpu3.min_mod2, settings, True, device_output=dev)

    def run_cpu(fr):
        fq = fast_quality(cpu3, fr, idx, SHIFTS3, cpu3.depth_fields(fr, idx), extent, opts, "z")
        return fq, np.add(fq.average, fq.modulation, dtype=np.float32) / np.float32(255.0)

    got = run_gpu(frames3[:1], False)
    fq, _ = run_cpu(frames3[0])
    res = workload("fused 3-step + quality, sigma_z, texture", cuda, frames3, run_gpu, run_cpu,
                   3 * frames3[0, 0].size, 13 * frames3[0, 0].size, *repeats)
    res["quality_bits_equal_cpu"] = bool(np.array_equal(got.quality[0], fq.quality))
    return res


def temporal_assessment(rig, w, rng, repeats: tuple[int, int]) -> dict:
    """The decoder's default three-frequency plan with its assessment on the device, one cycle a
    call (:func:`fringe3d.decode.decode`, ``backend="cuda"`` against ``"cpu"``), on uint8 frames of
    the manifest's periods and shifts over the fringe coordinate ``w``."""
    import warnings

    import numpy as np

    from fringe3d.decode import DecodeOptions, decode
    from fringe3d.patterns import sets

    ps = sets.three_frequency("v", width=rig.projector.width, height=rig.projector.height)
    frames = np.stack([np.clip(np.round(127.5 + 100.0 * np.cos(2 * math.pi * w / f.period + f.shift)
                                        + rng.normal(0.0, 1.0, w.shape)), 0, 255).astype(np.uint8)
                       for f in ps.frames])
    d = ps.plans[0].direction
    opts = {b: DecodeOptions(backend=b) for b in ("cpu", "cuda")}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        dec = {b: decode(frames, ps, options=o) for b, o in opts.items()}
        m = dec["cpu"].mask[d]
        s_cpu, s_gpu = dec["cpu"].phase_sigma[d], dec["cuda"].phase_sigma[d]
        res = {"workload": "three-frequency decode + assessment (quality, phase sigma, texture)",
               "frames": len(ps), "periods": list(ps.plans[0].periods),
               "mask_equal_cpu": bool(np.array_equal(m, dec["cuda"].mask[d])),
               "quality_bits_equal_cpu": bool(np.array_equal(dec["cpu"].quality[d], dec["cuda"].quality[d])),
               "kept_share": float(m.mean()),
               "max_abs_phase_diff_rad": float(np.max(np.abs(dec["cpu"].phase[d][m] - dec["cuda"].phase[d][m])))
               if m.any() else float("nan"),
               "max_rel_phase_sigma_diff": float(np.max(np.abs(s_gpu[m] / s_cpu[m] - 1.0))) if m.any()
               else float("nan"),
               "max_abs_texture_diff": float(np.max(np.abs(dec["cpu"].texture - dec["cuda"].texture)))}
        res["gpu_fps"] = 1.0 / timed(lambda: decode(frames, ps, options=opts["cuda"]), repeats[0], lambda: None)
        res["cpu_fps"] = 1.0 / timed(lambda: decode(frames, ps, options=opts["cpu"]), repeats[1], lambda: None)
    return res


def main(argv=None) -> int:
    args = parse(argv)
    if os.path.exists(args.out) and not args.overwrite:
        print(f"error: {args.out} exists; pass --overwrite to replace it", file=sys.stderr)
        return 2
    if args.smoke:
        os.environ["NUMBA_ENABLE_CUDASIM"] = "1"  # before numba is imported
    import numpy as np

    from fringe3d.gpu import CudaUnavailableError, cuda_module
    from fringe3d.phase.psp import default_shifts
    from fringe3d.reconstruct.triangulate import FastThreeStep, Triangulator
    from fringe3d.unwrap.geometric import minimum_phase
    from fringe3d.unwrap.temporal import three_frequency_decode

    try:
        cuda = cuda_module()
    except CudaUnavailableError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    width, height = (16, 12) if args.smoke else (1280, 1024)
    cycles = args.cycles or (2 if args.smoke else 256)
    repeat = args.repeat or (1 if args.smoke else 10)
    cpu_repeat = 1 if args.smoke else 10
    rng = np.random.default_rng(args.seed)
    rig = build_rig(width, height)
    w = scene_w(rig)
    px = width * height

    # fused 3-step + geometric + triangulation
    f3 = fringe_frames(w, [PERIOD3], [3], [SHIFTS3], rng)
    frames3 = np.broadcast_to(f3, (cycles,) + f3.shape).copy()
    z_min = float(np.nanmin(Triangulator(rig).points(w)[..., 2])) - 5.0
    mp = minimum_phase(rig, z_min, PERIOD3)
    tri = Triangulator(rig)
    gpu3 = FastThreeStep(tri, mp, SHIFTS3, min_modulation=5.0, backend="cuda")
    cpu3 = FastThreeStep(tri, mp, SHIFTS3, min_modulation=5.0)
    check = gpu3.points(frames3[:1])[0]
    ref = cpu3.points(frames3[0])
    ok = np.isfinite(ref[..., 0])
    err3 = float(np.nanmax(np.abs(check[ok] - ref[ok]))) if ok.any() else float("nan")
    r3 = workload("fused 3-step + geometric + triangulation", cuda, frames3,
                  lambda fr, dev: gpu3.points(fr, device_output=dev), lambda fr: cpu3.points(fr),
                  3 * px, 12 * px, repeat, cpu_repeat)
    r3["max_abs_diff_vs_cpu_mm"] = err3
    # the same kernel writing only the ray parameter s (4 bytes a pixel; what the sequence store keeps)
    r3d = workload("fused 3-step, ray parameter out (store)", cuda, frames3,
                   lambda fr, dev: gpu3.depth(fr, device_output=dev), lambda fr: cpu3.depth(fr),
                   3 * px, 4 * px, repeat, cpu_repeat)
    r3q = every_output(cuda, gpu3, cpu3, frames3, (float(np.nanmin(w)) - 1.0, float(np.nanmax(w)) + 1.0),
                       (repeat, cpu_repeat))
    del frames3

    # 15-frame three-frequency decode
    shifts = [default_shifts(n) for n in STEPS15]
    f15 = fringe_frames(w, PERIODS15, STEPS15, shifts, rng)
    cyc15 = max(1, cycles // 4)
    frames15 = np.broadcast_to(f15, (cyc15,) + f15.shape).copy()
    idx = [list(range(0, 9)), list(range(9, 12)), list(range(12, 15))]
    kw = dict(w_range=(float(np.nanmin(w)) - 1.0, float(np.nanmax(w)) + 1.0), min_modulation=5.0,
              saturation_level=255.0)  # the scene's span, within the 1008 px beat
    tf_gpu = three_frequency_decode(frames15[:1], idx, shifts, PERIODS15, backend="cuda", **kw)
    tf_cpu = three_frequency_decode(f15, idx, shifts, PERIODS15, **kw)
    m = tf_cpu.mask & tf_gpu.mask[0]
    err15 = float(np.max(np.abs(tf_gpu.phase[0][m] - tf_cpu.phase[m]))) if m.any() else float("nan")
    r15 = workload("three-frequency 15-frame decode", cuda, frames15,
                   lambda fr, dev: three_frequency_decode(fr, idx, shifts, PERIODS15, backend="cuda",
                                                          device_output=dev, **kw),
                   lambda fr: three_frequency_decode(fr, idx, shifts, PERIODS15, **kw),
                   15 * px, 21 * px, repeat, cpu_repeat)
    r15["max_abs_diff_vs_cpu_rad"] = err15
    del frames15
    rta = temporal_assessment(rig, w, rng, (repeat, cpu_repeat))

    dev = "numba CUDA simulator (not a GPU)" if args.smoke else str(cuda.get_current_device().name)
    report = {"device": dev, "smoke": bool(args.smoke), "size": [width, height], "seed": args.seed,
              "repeat": repeat, "cpu": platform.processor() or platform.machine(), "cpu_cores": os.cpu_count(),
              "targets": {"resident_fps": TARGET_RESIDENT, "with_transfers_fps": TARGET_TRANSFER,
                          "resident_vs_bound": TARGET_BOUND_RATIO},
              "results": [r3, r3d, r3q, r15]}
    report["figures"] = [  # benchmarks/summary.py: one value each (the repeats are summed inside workload)
        figure(f"CUDA {r['workload']}, {width}x{height}, {dev}", name, role, "3D frames/s", [r[key]])
        for r in report["results"]
        for key, role, name in (("bound_device_fps", "bound", "device copy bound (input + output bytes)"),
                                ("bound_host_device_fps", "reference", "host<->device copy bound"),
                                ("resident_fps", "kernel", "kernel, frames resident on the device"),
                                ("with_transfers_fps", "ours", "with transfers (pinned, two streams)"),
                                ("cpu_fps", "reference", "the CPU kernel, all cores"))]
    report["temporal_assessment"] = rta
    report["figures"] += [figure(f"CUDA {rta['workload']}, {width}x{height}, {dev}", name, role, "3D frames/s",
                                 [rta[key]])
                          for key, role, name in (("gpu_fps", "ours", "decode() on the device, one cycle a call"),
                                                  ("cpu_fps", "reference", "decode() on the CPU, all cores"))]
    cols = ["resident_fps", "with_transfers_fps", "bound_device_fps", "bound_host_device_fps", "cpu_fps",
            "resident_vs_bound"]
    print(f"device: {dev}   {width}x{height}   (3D frames/s; resident_vs_bound = bound / resident)")
    print(f"{'workload':42s}" + "".join(f"{c:>22s}" for c in cols))
    for r in report["results"]:
        print(f"{r['workload']:42s}" + "".join(f"{r[c]:22.1f}" for c in cols))
        print(f"{'':42s}  meets: {r['meets']}")
    print(f"{rta['workload']}: {rta['gpu_fps']:.1f} 3D frames/s on the device, {rta['cpu_fps']:.1f} on the CPU; "
          f"mask equal {rta['mask_equal_cpu']}, quality bits equal {rta['quality_bits_equal_cpu']}, "
          f"max phase diff {rta['max_abs_phase_diff_rad']:.2g} rad, max phase sigma diff "
          f"{rta['max_rel_phase_sigma_diff']:.2g} (relative)")
    with open(args.out, "w") as fh:
        json.dump(report, fh, indent=2)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
