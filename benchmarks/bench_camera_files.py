"""Benchmark: memory of reading a referenced camera file (MRAW, CINE, multi-page TIFF, zarr) cycle by cycle.

Writes a 3000-frame 160x128 uint16 recording (123 MB) in each format to a temporary folder,
imports it as a referencing capture folder and reports the peak of Python/NumPy allocations
(``tracemalloc``) and the wall time of ``Capture.iter_cycles()`` over all 1000 3-frame cycles,
against ``read_capture`` of the whole sequence. ``python benchmarks/bench_camera_files.py``.
The CINE file is written by the tests' helper ``tests/cine_writer.py`` (no library writes CINE).
"""
from __future__ import annotations

import sys
import tempfile
import time
import tracemalloc
from pathlib import Path

import numpy as np
import pyMRAW
import tifffile
import zarr

from fringe3d.io.capture import read_capture
from fringe3d.io.importer import ImportLayout, import_camera_file, layout_patterns

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from cine_writer import write_cine  # noqa: E402  (the tests' CINE writer)

sys.path.insert(0, str(Path(__file__).resolve().parent))
from summary import figure  # noqa: E402  (beside this script)

F, H, W = 3000, 128, 160


def write_files(d: Path) -> dict:
    frames = np.random.default_rng(0).integers(0, 4096, (F, H, W), dtype=np.uint16)
    _, cih = pyMRAW.save_mraw(frames, str(d / "run.mraw"), bit_depth=16)
    write_cine(d / "take.cine", frames, real_bpp=12)
    with tifffile.TiffWriter(d / "stack.tif", bigtiff=True) as tif:
        for f in frames:
            tif.write(f, photometric="minisblack")
    group = zarr.open_group(str(d / "frames.zarr"), mode="w")
    group.create_array("frames", shape=frames.shape, dtype=frames.dtype, chunks=(1, H, W))[:] = frames
    return {"mraw": Path(cih), "cine": d / "take.cine", "tiff": d / "stack.tif", "zarr": d / "frames.zarr"}


def peak_mb(fn) -> tuple[float, float]:
    """(peak traced MB, seconds) of ``fn()``."""
    tracemalloc.start()
    t0 = time.perf_counter()
    fn()
    dt = time.perf_counter() - t0
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    return peak / 1e6, dt


def main() -> None:
    import argparse
    import json
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", action="store_true", help="print one JSON object")
    args = ap.parse_args()
    ps = layout_patterns(ImportLayout("phase-shift", (256, 200), steps=3, period=16))
    group = f"read a camera file cycle by cycle, {F} frames {W}x{H} uint16 ({F * H * W * 2 / 1e6:.0f} MB)"
    res: dict = {"benchmark": "camera_files", "figures": []}
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        if not args.json:
            print(f"recording: {F} frames {W}x{H} uint16 = {F * H * W * 2 / 1e6:.0f} MB")
        for kind, src in write_files(d).items():
            out = d / f"cap_{kind}"
            import_camera_file(src, out, ps, bit_depth=None if kind in ("mraw", "cine") else 12)
            lazy = peak_mb(lambda out=out: sum(int(c[0, 0, 0]) for c in read_capture(out, max_cycles=1).iter_cycles()))
            full = peak_mb(lambda out=out: read_capture(out))
            res[kind] = {"iter_cycles_peak_mb": lazy[0], "iter_cycles_s": lazy[1], "read_capture_peak_mb": full[0],
                         "read_capture_s": full[1]}
            res["figures"] += [figure(group, f"{kind}: iter_cycles, peak traced memory", "ours", "MB", [lazy[0]]),
                               figure(group, f"{kind}: iter_cycles over {F // 3} cycles", "ours", "s", [lazy[1]])]
            if not args.json:
                print(f"{kind}: iter_cycles over {F // 3} cycles peak {lazy[0]:.2f} MB in {lazy[1]:.2f} s; "
                      f"read_capture (all) peak {full[0]:.1f} MB in {full[1]:.2f} s")
    if args.json:
        print(json.dumps(res, indent=1))


if __name__ == "__main__":
    main()
