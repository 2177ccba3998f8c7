"""CPU per frame of decoding a capture's PNG files, decoder by decoder, and of the capture reader.

Run: ``.venv/bin/python benchmarks/bench_png_decode.py [--rounds 5] [--json]`` (not a test).
The frames are ``bench_sequence.py``'s (``make_inputs``: the seeded 1280x1024 3-step cycle,
8-bit grey PNG written by ``write_capture``). Per frame, in CPU milliseconds of the decoding
thread (``time.thread_time``, medians of ``--rounds`` passes over the files): reading the file's
bytes; OpenCV's ``imdecode`` (with ``cv2.setNumThreads`` at 1 and at the cores: libpng decodes
on one thread) and ``imread``; PIL; imageio; fringe3d's ``read_image`` (OpenCV's ``imdecode``)
into a new array and into a reused one (``out``). Per 3-frame cycle, in CPU milliseconds of
the process (``time.process_time``): the capture reader
(``CaptureFrames[cycle]``, the files decoded on its read threads into the cycle's stack). CPU
time, unlike a rate, barely moves with a shared machine's load.
"""
from __future__ import annotations

import argparse
import json
import os
import shutil
import sys
import tempfile
import time
import warnings
from pathlib import Path

import cv2
import imageio.v3 as iio
import numpy as np
from PIL import Image

from fringe3d.io.capture import list_frame_files
from fringe3d.io.capture_frames import CaptureFrames
from fringe3d.io.images import read_image

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_sequence import make_inputs  # noqa: E402  (beside this script)


def per_frame_ms(fn, files: list[Path], rounds: int) -> float:
    """Median over ``rounds`` passes of the thread's CPU ms per file of ``fn(file)`` (one warm-up pass)."""
    for f in files:
        fn(f)
    runs = []
    for _ in range(rounds):
        t = time.thread_time()
        for f in files:
            fn(f)
        runs.append((time.thread_time() - t) / len(files) * 1e3)
    return round(float(np.median(runs)), 2)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    warnings.simplefilter("ignore")
    work = Path(tempfile.mkdtemp(prefix="bench-png-"))
    try:
        _, png_cap, *_ = make_inputs(work, 4)
        files = list_frame_files(png_cap)
        first = read_image(files[0])
        reused = np.empty_like(first)
        for f in files:  # the same image, whichever decoder
            assert np.array_equal(read_image(f), cv2.imread(str(f), cv2.IMREAD_UNCHANGED))

        def opencv(f):
            return cv2.imdecode(np.fromfile(f, np.uint8), cv2.IMREAD_UNCHANGED)
        threads = cv2.getNumThreads()
        cv2.setNumThreads(1)
        one_thread = per_frame_ms(opencv, files, args.rounds)
        cv2.setNumThreads(os.cpu_count() or 1)
        cases = {"read the bytes (np.fromfile)": lambda f: np.fromfile(f, np.uint8),
                 "cv2.imdecode, setNumThreads(1)": None,
                 f"cv2.imdecode, setNumThreads({os.cpu_count()})": opencv,
                 "cv2.imread(IMREAD_UNCHANGED)": lambda f: cv2.imread(str(f), cv2.IMREAD_UNCHANGED),
                 "PIL Image.open + np.asarray": lambda f: np.asarray(Image.open(f)),
                 "imageio.v3.imread": iio.imread,
                 "fringe3d read_image (new array)": read_image,
                 "fringe3d read_image (reused array)": lambda f: read_image(f, out=reused)}
        res: dict = {"frame": list(first.shape), "dtype": str(first.dtype), "files": len(files),
                     "cores": os.cpu_count(), "load_average": os.getloadavg()[0], "cpu_ms_per_frame": {}}
        for name, fn in cases.items():
            res["cpu_ms_per_frame"][name] = one_thread if fn is None else per_frame_ms(fn, files, args.rounds)
        cv2.setNumThreads(threads)
        frames = CaptureFrames(png_cap)
        cycles = [np.arange(c * 3, c * 3 + 3) for c in range(len(frames) // 3)]
        runs = []
        for _ in range(args.rounds + 1):
            p = time.process_time()
            for idx in cycles:
                frames[idx]
            runs.append((time.process_time() - p) / len(cycles) * 1e3)
        res["capture_reader_cpu_ms_per_cycle"] = round(float(np.median(runs[1:])), 1)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    if args.json:
        print(json.dumps(res, indent=1))
        return
    for k, v in res.items():
        if isinstance(v, dict):
            for kk, vv in v.items():
                print(f"  {kk:44s} {vv:7.2f} ms")
        else:
            print(f"{k:46s} {v}")


if __name__ == "__main__":
    main()
