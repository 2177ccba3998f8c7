"""Long sequences end to end: a 1280x1024 3-step + geometric sequence read from an MRAW file.

Run: ``.venv/bin/python benchmarks/bench_sequence.py [--cycles 120] [--rounds 3] [--pipeline-only] [--json]``
(not a test; needs the ``dask`` and ``camfiles`` extras, both in ``.[test]``). The scene is seeded
(``seed=0``). ``--pipeline-only`` measures the pipeline section alone (below; no Dask, no store table).

**Pipeline** (issue 29, the must-show; ``--rounds`` alternated rounds, min / median / max): in each
round, in this order, the fused kernel alone on a cycle in memory (``fused``), ``reconstruct_sequence``
with the defaults from the camera file (``e2e camera file``: what ``fringe3d reconstruct CAPTURE``
runs, the capture folder referencing the MRAW), decoding the PNG capture's files and nothing else on
a thread pool of as many threads as cores (``decode PNGs``) and ``reconstruct_sequence`` with the
defaults from those PNG files (``e2e PNG``); the ratios e2e camera file / fused (target <= 2.5) and
e2e PNG / decode PNGs (target <= 1.3) from the best round. **Writer against the disk**: the default
store's ``write_frame`` (float16 cast, lz4, write and rename of each chunk) per frame beside writing
the same bytes in the same files with plain ``open().write()`` + rename and ``dd``-style as one file.

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
import statistics
import dataclasses
import json
import os
import shutil
import tempfile
import time
import warnings
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pyMRAW

from fringe3d.cluster.engine import close, connect, dask_executor, reconstruct_capture_on_dask
from fringe3d.decode import DecodeOptions
from fringe3d.io import store as store_module
from fringe3d.io.capture import list_frame_files, open_frames, read_capture, write_capture
from fringe3d.io.capture_frames import CaptureFolder
from fringe3d.io.images import read_image
from fringe3d.io.importer import import_images
from fringe3d.optics import Rig
from fringe3d.patterns import sets
from fringe3d.reconstruct.settings import DecodeSettings, OutputSettings, RunSettings
from fringe3d.reconstruct.sequence import CaptureFrames, FrameReconstructor, reconstruct_sequence, reconstruction_plans
from fringe3d.sim import simulate_capture
from fringe3d.sim.truth import Truth


class _Done(Exception):
    """The figures asked for are measured (``--pipeline-only``)."""


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
            st = store_module.PointMapStore.open(path, 10, H, W, layout=layout, quality=q, sigma=q,
                                                 rays=rec.rays if layout == "ray_depth" else None, codec=codec)
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


def pipeline_figures(mraw_cap: Path, png_cap: Path, ps, rig, opts: DecodeOptions, cycles: int, rounds: int,
                     work: Path) -> dict:
    """The must-show figures of issue 29 from ``rounds`` alternated rounds: per round the fused
    kernel (20 cycles in memory), ``reconstruct_sequence`` with the defaults from the camera file,
    decoding every PNG file on ``os.cpu_count()`` threads, and ``reconstruct_sequence`` from the
    PNG files; each as min / median / max seconds per 3D frame (or cycle) and the ratios of the
    best times."""
    rec = FrameReconstructor(ps, rig, opts)
    frames = open_frames(mraw_cap)
    n = len(ps)
    cycle = np.ascontiguousarray(frames[0:n])
    files = list_frame_files(png_cap)
    png_cycles = len(files) // n
    cores = os.cpu_count() or 1

    def fused():
        for _ in range(20):
            rec.fast.depth(cycle, rec.fused.index)
        return 20

    def e2e(cap: Path, count: int):
        def run():
            out = work / "e2e"
            shutil.rmtree(out, ignore_errors=True)
            reconstruct_sequence(CaptureFolder(str(cap)), ps, rig, out, DecodeSettings(opts),
                                 run=RunSettings(progress=False))
            return count
        return run

    def decode_pngs():
        with ThreadPoolExecutor(max_workers=cores) as pool:
            for _ in pool.map(read_image, files):
                pass
        return png_cycles

    cases = {"fused kernel": fused, "e2e camera file": e2e(mraw_cap, cycles), "decode PNGs": decode_pngs,
             "e2e PNG": e2e(png_cap, png_cycles)}
    for fn in cases.values():  # warm: numba's kernels load, the page cache holds the inputs
        fn()
    per: dict[str, list[float]] = {name: [] for name in cases}
    for _ in range(rounds):
        for name, fn in cases.items():
            t = time.perf_counter()
            count = fn()
            per[name].append((time.perf_counter() - t) / count)
    out: dict = {}
    for name, ts in per.items():
        out[name] = {"per_s_best": round(1 / min(ts), 1), "ms_min": round(min(ts) * 1e3, 2),
                     "ms_median": round(statistics.median(ts) * 1e3, 2), "ms_max": round(max(ts) * 1e3, 2)}
    out["e2e camera file / fused kernel"] = round(min(per["e2e camera file"]) / min(per["fused kernel"]), 2)
    out["e2e PNG / decode PNGs"] = round(min(per["e2e PNG"]) / min(per["decode PNGs"]), 2)
    return out


def writer_against_disk(rec: FrameReconstructor, cycle: np.ndarray, work: Path, frames: int = 10) -> dict:
    """The store writer per frame (``write_frame``: float16 cast, compression, write + rename of
    each array's chunk; the default layout, quality map and sigma_z) with the default codec (lz4)
    and uncompressed, each beside the disk's own bound for its bytes: the same files written with
    plain ``open().write()`` + rename, and ``dd``-style as one sequential file, in ms per frame."""
    c = rec.reconstruct(cycle, uncertainty="z", points=False, texture=False)
    H, W = c.quality.shape
    res: dict = {}
    for codec in ("lz4", "none"):
        path = work / f"writer-{codec}.zarr"
        st = store_module.PointMapStore.open(path, frames, H, W, layout="ray_depth", quality=True, sigma=True,
                                             rays=rec.rays, codec=codec)
        st.write_frame(0, depth=c.depth, quality=c.quality, sigma_z=c.sigma_z)  # warm (folders, codecs)
        t = time.perf_counter()
        for k in range(frames):
            st.write_frame(k, depth=c.depth, quality=c.quality, sigma_z=c.sigma_z)
        writer = (time.perf_counter() - t) / frames
        sizes = [f.stat().st_size for f in sorted(path.rglob("c.0.*")) if f.is_file()]
        shutil.rmtree(path)
        files, dd = plain_writes(sizes, frames, work / "plain")
        res[codec] = {"bytes_per_frame": sum(sizes), "files_per_frame": len(sizes),
                      "writer_ms": round(writer * 1e3, 2), "plain_files_ms": round(files * 1e3, 2),
                      "dd_ms": round(dd * 1e3, 2), "writer / plain files": round(writer / files, 2),
                      "writer / dd": round(writer / dd, 2)}
    return res


def plain_writes(sizes: list[int], frames: int, folder: Path) -> tuple[float, float]:
    """Seconds per frame to write files of ``sizes`` bytes (``open().write()`` + rename, as the
    store does) and, ``dd``-style, the same bytes as one file in 1 MiB blocks."""
    data = memoryview(os.urandom(max(sizes)))
    folder.mkdir()
    t = time.perf_counter()
    for k in range(frames):
        for i, size in enumerate(sizes):
            tmp, dst = folder / f"{i}.{k}.partial", folder / f"{i}.{k}"
            with open(tmp, "wb") as f:
                f.write(data[:size])
            os.replace(tmp, dst)
    files = (time.perf_counter() - t) / frames
    block = data[:1 << 20]
    total = sum(sizes) * frames
    t = time.perf_counter()
    with open(folder / "dd", "wb") as f:
        written = 0
        while written < total:
            written += f.write(block[:min(len(block), total - written)])
    dd = (time.perf_counter() - t) / frames
    shutil.rmtree(folder)
    return files, dd


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cycles", type=int, default=120)
    ap.add_argument("--rounds", type=int, default=3, help="alternated rounds of the pipeline section")
    ap.add_argument("--pipeline-only", action="store_true", help="the pipeline section and the writer alone")
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
        res["pipeline"] = pipeline_figures(mraw_cap, png_cap, ps, rig, opts, args.cycles, args.rounds, work)
        res["writer_against_disk"] = writer_against_disk(rec, cycle, work)
        res["load_average_after_pipeline"] = os.getloadavg()[0]
        if args.pipeline_only:
            raise _Done
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
    except _Done:
        pass
    finally:
        shutil.rmtree(work, ignore_errors=True)
    res = {k: (round(v, 1) if isinstance(v, float) else v) for k, v in res.items()}
    if args.json:
        print(json.dumps(res, indent=1))
        return
    for k, v in res.items():
        if isinstance(v, dict) and k != "store":
            print(k)
            for kk, vv in v.items():
                print(f"  {kk:34s} {vv}")
        else:
            print(f"{k:32s} {v}")
    if args.pipeline_only:
        return
    k = res["kernel_3d_per_s"]
    print(f"{'end to end / kernel (serial)':32s} {res['end_to_end_serial_3d_per_s'] / k:.2f}")
    print(f"{'kernel / copy bound':32s} {k / res['copy_bound_3d_per_s']:.2f}")


if __name__ == "__main__":
    main()
