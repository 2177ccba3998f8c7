"""Long sequences end to end: a 1280x1024 3-step + geometric sequence read from an MRAW file.

Run: ``.venv/bin/python benchmarks/bench_sequence.py [--cycles 120] [--repeat 20] [--rounds 3]
[--pipeline-only] [--json]`` (not a test; needs the ``dask`` and ``camfiles`` extras, both in
``.[test]``). The scene is seeded (``seed=0``). The in-memory cases (kernels, copy bound) are
timed in ``--repeat`` alternated rounds (every case once per round, in rotating order), the serial
end-to-end runs in ``--rounds`` alternated rounds; min / median / max go to the JSON ``figures``
(``benchmarks/summary.py``). ``--pipeline-only`` measures the pipeline and the writer (below) alone.

**Pipeline** (issue 29's must-show, ``--rounds`` alternated rounds): the fused kernel alone on a
cycle in memory, ``reconstruct_sequence`` with the defaults from the camera file (a capture folder
referencing the MRAW, as ``fringe3d reconstruct CAPTURE`` reads it), decoding the PNG capture's
files and nothing else as the reader does (``read_image``, OpenCV's decoder, on
``read_threads()`` threads), and ``reconstruct_sequence`` with the defaults from those PNG
files; printed with the ratios e2e camera file / fused kernel (target <= 2.5) and e2e PNG /
decode PNGs (target <= 1.3), medians of the rounds. On N cores the e2e PNG run needs the
decoding's CPU plus the reconstruction's, so that ratio is at least 1 + (reconstruction CPU) /
(decoding CPU) unless the cores idle while only decoding. **Writer against the
disk**: the store's ``write_frame`` (float16 cast, compression, write + rename of each chunk; the
default arrays) with lz4 and uncompressed, each beside writing the same bytes in the same files
with plain ``open().write()`` + rename and ``dd``-style as one file.

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

The sequence repeats one rendered cycle (a sphere before a wall on the ``macro`` rig, fringe
period ``PERIOD`` = 120 projector px); the pipeline's cost does not depend on the scene changing.
At the period of 36 px this benchmark once used, the wall lay beyond the geometric constraint's
unambiguous depth range from the sphere's front (z_min), so about 1.1 M of the 1.3 M pixels got
the wrong fringe order; the wrap errors (pixels whose point projects more than half a period off
the truth's projector coordinate) are counted and reported (0 at 120 px).
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import os
import shutil
import sys
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
from fringe3d.io.capture_frames import CaptureFolder, read_threads
from fringe3d.io.images import read_image
from fringe3d.io.importer import import_images
from fringe3d.optics import Rig
from fringe3d.patterns import sets
from fringe3d.reconstruct.settings import DecodeSettings, OutputSettings, RunSettings
from fringe3d.reconstruct.sequence import CaptureFrames, FrameReconstructor, reconstruct_sequence, reconstruction_plans
from fringe3d.sim import simulate_capture
from fringe3d.sim.truth import Truth

sys.path.insert(0, str(Path(__file__).resolve().parent))
from summary import alternated, figure, format_table, stats, table_rows, timed_figures  # noqa: E402  (beside this script)


class _Measured(Exception):
    """The figures asked for are measured (``--pipeline-only``)."""


#: cycles written and read as PNG files (their read rate)
PNG_CYCLES = 30
#: fringe period (projector px): wide enough that the whole sphere-and-wall scene lies within the
#: geometric constraint's unambiguous depth range (36 px put the wall beyond it)
PERIOD = 120.0


def _timed(fn) -> float:
    t = time.perf_counter()
    fn()
    return time.perf_counter() - t


def make_inputs(work: Path, cycles: int):
    """One rendered 3-step cycle at 1280x1024, repeated ``cycles`` times into an MRAW file and a
    PNG capture; returns (mraw capture folder, png capture folder, patterns, rig, z_min, truth)."""
    one = work / "one"
    ps = sets.phase_shift(PERIOD, 3, "v", width=800, height=600)
    simulate_capture(one, preset="macro", scene="sphere", patterns=ps, seed=0, progress=False)
    cap, rig, truth = read_capture(one), Rig.load(one / "rig.json"), Truth.load(one)
    z_min = float(np.nanmin(truth.depth[truth.mask])) - 5.0
    frames = np.tile(cap.frames, (cycles, 1, 1))
    mraw, _ = pyMRAW.save_mraw(frames, str(work / "take.mraw"), bit_depth=8, info_dict={"Record Rate(fps)": 3000})
    import_images(str(Path(mraw).with_suffix(".cih")), work / "mraw-cap", manifest=one / "manifest.json")
    png_cycles = min(cycles, PNG_CYCLES)  # the PNG read rate needs no more
    write_capture(work / "png-cap", frames[:png_cycles * len(cap.patterns)], cap.patterns, meta={"bit_depth": 8})
    return work / "mraw-cap", work / "png-cap", reconstruction_plans(cap.patterns, "geometric"), rig, z_min, truth


def wrap_errors(rig: Rig, points: np.ndarray, truth: Truth) -> int:
    """Pixels whose point is finite but on the wrong fringe: its projector coordinate is off the
    truth's by more than half a period."""
    valid = np.isfinite(points[..., 0]) & truth.mask & np.isfinite(truth.up)
    up = rig.projector.project(points[valid].astype(np.float64))[..., 0]
    return int(np.sum(np.abs(up - truth.up[valid]) > PERIOD / 2))


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


def pipeline_figures(mraw_cap: Path, png_cap: Path, ps, rig, opts: DecodeOptions, cycles: int, rounds: int,
                     work: Path) -> tuple[list[dict], dict]:
    """Issue 29's must-show in ``rounds`` alternated rounds: the fused kernel (a cycle in memory),
    ``reconstruct_sequence`` with the defaults from the camera file, decoding every PNG file as
    the reader does (``read_image`` on ``read_threads()`` threads), ``reconstruct_sequence``
    from the PNG files; the figures (two groups: camera file against the kernel, PNG files
    against decoding them) and the ratios."""
    rec = FrameReconstructor(ps, rig, opts)
    n = len(ps)
    cycle = np.ascontiguousarray(open_frames(mraw_cap)[0:n])
    files = list_frame_files(png_cap)
    png_cycles = len(files) // n

    def e2e(cap: Path):
        def run():
            out = work / "e2e"
            shutil.rmtree(out, ignore_errors=True)
            reconstruct_sequence(CaptureFolder(str(cap)), ps, rig, out, DecodeSettings(opts),
                                 run=RunSettings(progress=False))
        return run

    def decode_pngs():
        with ThreadPoolExecutor(max_workers=read_threads()) as pool:
            for _ in pool.map(read_image, files):
                pass

    def fused():
        for _ in range(20):
            rec.fast.depth(cycle, rec.fused.index)

    t = alternated({"fused": fused, "e2e_camera": e2e(mraw_cap), "decode_png": decode_pngs,
                    "e2e_png": e2e(png_cap)}, rounds)
    per = {"fused": 20, "e2e_camera": cycles, "decode_png": png_cycles, "e2e_png": png_cycles}
    rates = {k: [per[k] / x for x in ts] for k, ts in t.items()}
    cam = "pipeline: reconstruct a sequence from the camera file (MRAW), defaults"
    pngs = f"pipeline: reconstruct a sequence from PNG files, defaults, {os.cpu_count()} cores"
    figs = [figure(cam, "fused kernel alone (depth)", "kernel", "3D frames/s", rates["fused"]),
            figure(cam, "end to end from the camera file", "ours", "3D frames/s", rates["e2e_camera"]),
            figure(pngs, "decode the PNG files alone as the reader does", "bound", "cycles/s", rates["decode_png"]),
            figure(pngs, "end to end from the PNG files", "ours", "3D frames/s", rates["e2e_png"])]
    med = {k: stats(v)["median"] for k, v in rates.items()}
    ratios = {"e2e camera file / fused kernel (target <= 2.5)": round(med["fused"] / med["e2e_camera"], 2),
              "e2e PNG / decode PNGs (target <= 1.3)": round(med["decode_png"] / med["e2e_png"], 2),
              "e2e camera file 3D frames/s (median; target >= 150)": round(med["e2e_camera"], 1),
              "e2e PNG 3D frames/s (median)": round(med["e2e_png"], 1)}
    return figs, ratios


def writer_against_disk(rec: FrameReconstructor, cycle: np.ndarray, work: Path, rounds: int,
                        frames: int = 10) -> list[dict]:
    """The store writer per frame (``write_frame``: float16 cast, compression, write + rename of
    each array's chunk; ray_depth with the quality map and sigma_z) with lz4 and uncompressed,
    each beside the disk's own bound for its bytes: the same files written with plain
    ``open().write()`` + rename, and ``dd``-style as one sequential file; figures in ms per frame."""
    c = rec.reconstruct(cycle, uncertainty="z", points=False, texture=False)
    H, W = c.quality.shape
    figs = []
    for codec in ("lz4", "none"):
        path = work / f"writer-{codec}.zarr"
        st = store_module.PointMapStore.open(path, frames, H, W, rays=rec.rays, settings=store_module.StoreSettings(
            "ray_depth", quality=True, sigma=True, codec=codec))

        def write(st=st):
            for k in range(frames):
                st.write_frame(k, depth=c.depth, quality=c.quality, sigma_z=c.sigma_z)
        write()
        sizes = [f.stat().st_size for f in sorted(path.rglob("c.0.*")) if f.is_file()]
        data = memoryview(os.urandom(max(sizes)))
        folder = work / "plain"
        folder.mkdir(exist_ok=True)

        def plain(data=data, sizes=sizes, folder=folder):
            for k in range(frames):
                for i, size in enumerate(sizes):
                    tmp, dst = folder / f"{i}.{k}.partial", folder / f"{i}.{k}"
                    with open(tmp, "wb") as f:
                        f.write(data[:size])
                    os.replace(tmp, dst)

        def dd(data=data, sizes=sizes, folder=folder):
            total, block, written = sum(sizes) * frames, data[:1 << 20], 0
            with open(folder / "dd", "wb") as f:
                while written < total:
                    written += f.write(block[:min(len(block), total - written)])

        t = alternated({"writer": write, "plain": plain, "dd": dd}, rounds)
        group = f"store writer against the disk: {codec}, {sum(sizes) / 1e6:.2f} MB in {len(sizes)} files per frame"
        names = {"writer": f"store writer ({codec}): cast, compress, write",
                 "plain": "plain writes + rename, same files", "dd": "dd-style: the same bytes as one file"}
        roles = {"writer": "ours", "plain": "bound", "dd": "reference"}
        figs += [figure(group, names[k], roles[k], "ms", [1e3 * x / frames for x in ts]) for k, ts in t.items()]
        shutil.rmtree(path)
        shutil.rmtree(folder)
    return figs


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cycles", type=int, default=120)
    ap.add_argument("--repeat", type=int, default=20, help="alternated rounds of the in-memory cases")
    ap.add_argument("--rounds", type=int, default=3, help="alternated rounds of the serial end-to-end runs")
    ap.add_argument("--pipeline-only", action="store_true", help="the pipeline and the writer against the disk alone")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    warnings.simplefilter("ignore")  # depth-range warnings of the repeated scene are not the point here
    work = Path(tempfile.mkdtemp(prefix="bench-seq-"))
    group = "reconstruct a sequence: 3-step + geometric, 1280x1024, MRAW in, zarr store out"
    figs: list[dict] = []
    try:
        mraw_cap, png_cap, ps, rig, z_min, truth = make_inputs(work, args.cycles)
        opts = DecodeOptions(z_min=z_min, bit_depth=8)
        frames = open_frames(mraw_cap)
        n = len(ps)
        cycle = np.ascontiguousarray(frames[0:n])
        rec = FrameReconstructor(ps, rig, opts)
        res: dict = {"benchmark": "sequence", "cycles": args.cycles, "shape": list(cycle.shape[1:]),
                     "path": rec.path, "cores": os.cpu_count(), "load_average": os.getloadavg()[0],
                     "period_px": PERIOD, "wrap_errors": wrap_errors(rig, rec.reconstruct(cycle).points, truth)}
        pipe, res["pipeline"] = pipeline_figures(mraw_cap, png_cap, ps, rig, opts, args.cycles, args.rounds, work)
        figs += pipe + writer_against_disk(rec, cycle, work, args.rounds)
        res["load_average_after_pipeline"] = os.getloadavg()[0]
        if args.pipeline_only:
            raise _Measured
        buf_in, buf_out = np.empty_like(cycle), np.empty(cycle.shape[1:] + (3,), np.float32)
        src_out = np.ones_like(buf_out)
        mem = alternated({
            "kernel_fused_only": lambda: rec.fast.depth(cycle, rec.fused.index),
            "kernel": lambda: rec(cycle),
            "window_as_stored": lambda: rec.reconstruct(cycle, uncertainty="z", points=False, texture=False),
            "copy_bound": lambda: (np.copyto(buf_in, cycle), np.copyto(buf_out, src_out))}, args.repeat)
        for k, ts in mem.items():
            res[f"{k}_3d_per_s"] = 1.0 / stats(ts)["median"]
        figs += timed_figures(group, mem, {"kernel_fused_only": "kernel", "kernel": "reference",
                                           "window_as_stored": "reference", "copy_bound": "bound"},
                              unit="3D frames/s",
                              names={"kernel_fused_only": "fused kernel alone (depth)",
                                     "kernel": "FrameReconstructor: kernel + quality map + points",
                                     "window_as_stored": "one window as stored (+ sigma_z)",
                                     "copy_bound": "copy bound: cycle in, points out"})
        reads = alternated({"mraw": lambda: [np.asarray(frames[c * n:(c + 1) * n]) for c in range(args.cycles)]},
                           2)["mraw"]
        res["mraw_read_cycles_per_s"] = args.cycles / min(reads)
        figs.append(figure(group, "read the MRAW cycle by cycle", "reference", "cycles/s",
                           [args.cycles / t for t in reads]))
        png = CaptureFrames(png_cap)
        m = min(args.cycles, PNG_CYCLES)
        png_t = alternated({"png": lambda: [png[np.arange(c * n, (c + 1) * n)] for c in range(m)]}, 1)["png"]
        res["png_read_cycles_per_s"] = m / min(png_t)
        figs.append(figure(group, "read the same frames as PNG files", "reference", "cycles/s",
                           [m / t for t in png_t]))

        def serial(store_quality=True, edge_mask=True, codec="lz4"):
            out = work / "serial"
            shutil.rmtree(out, ignore_errors=True)
            reconstruct_sequence(frames, ps, rig, out,
                                 decode=DecodeSettings(options=dataclasses.replace(opts, edge_mask=edge_mask)),
                                 outputs=OutputSettings(store_quality=store_quality, codec=codec),
                                 run=RunSettings(progress=False))
        e2e = {  # the defaults; uncompressed; no quality map stored; the configuration
            "end_to_end_serial": serial,  # (the modulation mask, the points only), lz4 and uncompressed
            "end_to_end_serial_codec_none": lambda: serial(codec="none"),
            "end_to_end_serial_no_store_quality": lambda: serial(False),
            "end_to_end_serial_no_edge_mask_no_store_quality": lambda: serial(False, False),
            "end_to_end_serial_no_edge_mask_no_store_quality_codec_none": lambda: serial(False, False, "none")}
        e2e_t = alternated(e2e, args.rounds)  # warm-up included (numba's compiled kernels load on first use)
        names = {"end_to_end_serial": "reconstruct_sequence, defaults (lz4)",
                 "end_to_end_serial_codec_none": "reconstruct_sequence, uncompressed",
                 "end_to_end_serial_no_store_quality": "reconstruct_sequence, no quality stored",
                 "end_to_end_serial_no_edge_mask_no_store_quality": "reconstruct_sequence, no edge mask/quality",
                 "end_to_end_serial_no_edge_mask_no_store_quality_codec_none":
                     "reconstruct_sequence, no edge mask/quality, uncompressed"}
        for k, ts in e2e_t.items():
            res[f"{k}_3d_per_s"] = args.cycles / stats(ts)["median"]
            figs.append(figure(group, names[k], "ours", "3D frames/s", [args.cycles / t for t in ts]))
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
                t = _timed(on_dask)
                res[f"end_to_end_dask_{workers}w_3d_per_s"] = args.cycles / t
                figs.append(figure(group, f"on Dask, {workers} worker process(es)", "ours", "3D frames/s",
                                   [args.cycles / t]))
            finally:
                close(client, own_cluster=True)
        res["store"] = store_figures(rec, cycle, work)
    except _Measured:
        pass
    finally:
        shutil.rmtree(work, ignore_errors=True)
    res = {k: (round(v, 1) if isinstance(v, float) else v) for k, v in res.items()}
    res["figures"] = figs
    res["groups"] = {group: {"scene": f"rendered sphere before a wall, macro rig, T = {PERIOD:g} px",
                             "wrap_errors": res["wrap_errors"]}}
    if args.json:
        print(json.dumps(res, indent=1))
        return
    for k, v in res.items():
        if k == "pipeline":
            for kk, vv in v.items():
                print(f"{kk:54s} {vv}")
        elif k not in ("figures", "groups"):
            print(f"{k:32s} {v}")
    print(format_table(table_rows(figs), res["groups"]))


if __name__ == "__main__":
    main()
