"""Long sequences end to end: a 1280x1024 3-step + geometric sequence read from an MRAW file.

Run: ``.venv/bin/python benchmarks/bench_sequence.py [--cycles 120] [--json]`` (not a test; needs the
``dask`` and ``camfiles`` extras, both in ``.[test]``). The scene is seeded (``seed=0``).

One run measures, side by side on this machine:

- **kernel**: the per-window reconstruction on a cycle already in memory, in 3D frames/s:
  ``kernel`` is ``FrameReconstructor(cycle)`` (the fused 3-step + geometric + triangulation kernel,
  the edge / mixed-pixel quality map, the points; what this line measured before the ray_depth
  store), ``kernel_fused_only`` the fused kernel alone (ray parameters, no quality map) and
  ``window_as_stored`` what one 3D frame of the sequence costs before its store write (ray
  parameters, quality map and sigma_z);
- **copy bound**: copying one cycle's input bytes plus writing its (H, W, 3) float32 output with
  ``np.copyto`` (the machine's memory-copy bound for the same bytes), in 3D frames/s;
- **file read**: reading the MRAW file cycle by cycle (``open_frames``), in cycles/s, and the same
  frames as PNG files (``CaptureFrames``) for comparison;
- **end to end**: ``reconstruct_sequence`` from the MRAW into the zarr point store in this process
  (the default store: ray_depth layout with quality map and sigma_z, lz4 and uncompressed;
  ``store_quality=False``; and the issue's configuration: no edge tests, points only, lz4 and
  uncompressed), and ``reconstruct_capture_on_dask`` with 1 and 2 worker processes, in 3D
  frames/s;
- **store**: bytes per 3D frame on disk and write time per frame of the layouts (xyz; ray_depth
  alone; ray_depth + quality + sigma_z) and codecs (lz4, zstd-3, none), on the same 3D frame.

The sequence repeats one rendered cycle (a sphere before a wall on the ``macro`` rig); the
pipeline's cost does not depend on the scene changing.
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import os
import shutil
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np
import pyMRAW

from fringe3d.cluster.engine import close, connect, dask_executor, reconstruct_capture_on_dask
from fringe3d.decode import DecodeOptions
from fringe3d.io import store as store_module
from fringe3d.io.capture import open_frames, read_capture, write_capture
from fringe3d.io.capture_frames import CaptureFolder
from fringe3d.io.importer import import_images
from fringe3d.optics import Rig
from fringe3d.patterns import sets
from fringe3d.reconstruct.settings import DecodeSettings, OutputSettings, RunSettings
from fringe3d.reconstruct.sequence import CaptureFrames, FrameReconstructor, reconstruct_sequence, reconstruction_plans
from fringe3d.sim import simulate_capture
from fringe3d.sim.truth import Truth


#: cycles written and read as PNG files (their read rate)
PNG_CYCLES = 30


def rate(fn, n_items: int, repeat: int = 3) -> float:
    """Best items per second of ``fn`` (which processes ``n_items``) over ``repeat`` runs, after a warm-up."""
    fn()
    best = min(_timed(fn) for _ in range(repeat))
    return n_items / best


def _timed(fn) -> float:
    t = time.perf_counter()
    fn()
    return time.perf_counter() - t


def make_inputs(work: Path, cycles: int):
    """One rendered 3-step cycle at 1280x1024, repeated ``cycles`` times into an MRAW file and a
    PNG capture; returns (mraw capture folder, png capture folder, patterns, rig, z_min)."""
    one = work / "one"
    ps = sets.phase_shift(36, 3, "v", width=800, height=600)
    simulate_capture(one, preset="macro", scene="sphere", patterns=ps, seed=0, progress=False)
    cap, rig, truth = read_capture(one), Rig.load(one / "rig.json"), Truth.load(one)
    z_min = float(np.nanmin(truth.depth[truth.mask])) - 5.0
    frames = np.tile(cap.frames, (cycles, 1, 1))
    mraw, _ = pyMRAW.save_mraw(frames, str(work / "take.mraw"), bit_depth=8, info_dict={"Record Rate(fps)": 3000})
    import_images(str(Path(mraw).with_suffix(".cih")), work / "mraw-cap", manifest=one / "manifest.json")
    png_cycles = min(cycles, PNG_CYCLES)  # the PNG read rate needs no more
    write_capture(work / "png-cap", frames[:png_cycles * len(cap.patterns)], cap.patterns, meta={"bit_depth": 8})
    return work / "mraw-cap", work / "png-cap", reconstruction_plans(cap.patterns, "geometric"), rig, z_min


def store_figures(rec: FrameReconstructor, cycle: np.ndarray, work: Path) -> dict:
    """Bytes per 3D frame and write ms per frame of the point store's layouts and codecs."""
    c = rec.reconstruct(cycle)
    H, W = c.quality.shape
    cases = {"xyz": ("xyz", False), "ray_depth": ("ray_depth", False), "ray_depth+quality+sigma": ("ray_depth", True)}
    out: dict = {}
    for codec in store_module.CODECS:
        for name, (layout, q) in cases.items():
            path = work / f"store-{codec}-{name}.zarr"
            settings = store_module.StoreSettings(layout, quality=q, sigma=q, codec=codec)
            st = store_module.PointMapStore.open(path, 10, H, W, settings=settings,
                                                 rays=rec.rays if layout == "ray_depth" else None)
            arrays = {"points": c.points} if layout == "xyz" else {"depth": c.depth}
            if q:
                arrays.update(quality=c.quality, sigma_z=c.sigma_z)
            t = time.perf_counter()
            for k in range(10):
                st.write_frame(k, **arrays)
                st.mark_done([k])
            ms = (time.perf_counter() - t) / 10 * 1e3
            size = sum(f.stat().st_size for f in path.rglob("*") if f.is_file()
                       and f.relative_to(path).parts[0] in ("points", "depth", "quality", "sigma_z")) / 10
            out[f"{name} {codec}"] = {"write_ms_per_frame": round(ms, 1), "mb_per_frame": round(size / 1e6, 2)}
            shutil.rmtree(path)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cycles", type=int, default=120)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    warnings.simplefilter("ignore")  # depth-range warnings of the repeated scene are not the point here
    work = Path(tempfile.mkdtemp(prefix="bench-seq-"))
    try:
        mraw_cap, png_cap, ps, rig, z_min = make_inputs(work, args.cycles)
        opts = DecodeOptions(z_min=z_min, bit_depth=8)
        frames = open_frames(mraw_cap)
        n = len(ps)
        cycle = np.ascontiguousarray(frames[0:n])
        rec = FrameReconstructor(ps, rig, opts)
        res: dict = {"cycles": args.cycles, "shape": list(cycle.shape[1:]), "path": rec.path,
                     "cores": os.cpu_count(), "load_average": os.getloadavg()[0]}
        res["kernel_3d_per_s"] = rate(lambda: [rec(cycle) for _ in range(20)], 20)
        res["kernel_fused_only_3d_per_s"] = rate(lambda: [rec.fast.depth(cycle, rec.fused.index)
                                                          for _ in range(20)], 20)
        res["window_as_stored_3d_per_s"] = rate(lambda: [rec.reconstruct(cycle, uncertainty="z", points=False,
                                                                         texture=False)
                                                         for _ in range(20)], 20)
        buf_in, buf_out = np.empty_like(cycle), np.empty(cycle.shape[1:] + (3,), np.float32)
        src_out = np.ones_like(buf_out)
        res["copy_bound_3d_per_s"] = rate(lambda: [(np.copyto(buf_in, cycle), np.copyto(buf_out, src_out))
                                                   for _ in range(20)], 20)
        res["mraw_read_cycles_per_s"] = rate(lambda: [np.asarray(frames[c * n:(c + 1) * n])
                                                      for c in range(args.cycles)], args.cycles, repeat=2)
        png = CaptureFrames(png_cap)
        m = min(args.cycles, PNG_CYCLES)
        res["png_read_cycles_per_s"] = rate(lambda: [png[np.arange(c * n, (c + 1) * n)] for c in range(m)], m,
                                            repeat=1)

        def serial(store_quality=True, edge_mask=True, codec="lz4"):
            out = work / "serial"
            shutil.rmtree(out, ignore_errors=True)
            reconstruct_sequence(frames, ps, rig, out,
                                 decode=DecodeSettings(options=dataclasses.replace(opts, edge_mask=edge_mask)),
                                 outputs=OutputSettings(store_quality=store_quality, codec=codec),
                                 run=RunSettings(progress=False))
        serial()  # warm (numba's compiled kernels load on first use)
        res["end_to_end_serial_3d_per_s"] = args.cycles / _timed(serial)
        res["end_to_end_serial_codec_none_3d_per_s"] = args.cycles / _timed(lambda: serial(codec="none"))
        res["end_to_end_serial_no_store_quality_3d_per_s"] = args.cycles / _timed(lambda: serial(False))
        # the configuration (the modulation mask, the points only): lz4 and uncompressed
        res["end_to_end_serial_no_edge_mask_no_store_quality_3d_per_s"] = args.cycles / _timed(
            lambda: serial(False, False))
        res["end_to_end_serial_no_edge_mask_no_store_quality_codec_none_3d_per_s"] = args.cycles / _timed(
            lambda: serial(False, False, "none"))
        for workers in (1, 2):
            client = connect(workers=workers)
            try:
                def on_dask(workers=workers, client=client):
                    out = work / f"dask{workers}"
                    shutil.rmtree(out, ignore_errors=True)
                    reconstruct_capture_on_dask(CaptureFolder(str(mraw_cap)), ps, rig, out,
                                                dask_executor(client, chunk=8), DecodeSettings(opts),
                                                run=RunSettings(progress=False))
                on_dask()  # warm the workers (imports, the reconstructor's tables)
                res[f"end_to_end_dask_{workers}w_3d_per_s"] = args.cycles / _timed(on_dask)
            finally:
                close(client, own_cluster=True)
        res["store"] = store_figures(rec, cycle, work)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    res = {k: (round(v, 1) if isinstance(v, float) else v) for k, v in res.items()}
    if args.json:
        print(json.dumps(res, indent=1))
        return
    for k, v in res.items():
        print(f"{k:32s} {v}")
    k = res["kernel_3d_per_s"]
    print(f"{'end to end / kernel (serial)':32s} {res['end_to_end_serial_3d_per_s'] / k:.2f}")
    print(f"{'kernel / copy bound':32s} {k / res['copy_bound_3d_per_s']:.2f}")


if __name__ == "__main__":
    main()
