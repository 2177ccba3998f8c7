"""Where a 3D frame's CPU time goes in ``reconstruct_sequence`` (defaults), thread by thread.

Run: ``.venv/bin/python benchmarks/bench_sequence_cpu.py [--cycles 60] [--rounds 3] [--png]``
(not a test). The same seeded 1280x1024 scene as ``bench_sequence.py`` (``make_inputs``), read
from the MRAW file (``--png``: from the PNG capture). Per 3D frame, in CPU milliseconds
(``time.thread_time``, medians of ``--rounds`` runs): the main thread (the kernels, the quality
map, sigma_z and the loop: the pipeline's critical path), the store writer thread
(``_write_frame``: float16 cast, compression, writes) and the reader's calls
(``window_frames``; PNG decoding runs on the read pool beside it and shows in ``process``
only), and the whole process. CPU time, unlike a rate, barely moves with the machine's
load: on a shared machine it compares revisions where rates cannot. On N free cores the
serial pipeline runs at most at ``1000 / max(main, writer)`` 3D frames/s, and at most at
``N * 1000 / process``.
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

import numpy as np

from fringe3d.decode import DecodeOptions
from fringe3d.io.capture_frames import CaptureFolder
from fringe3d.reconstruct import executors, sequence
from fringe3d.reconstruct.settings import DecodeSettings, RunSettings

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_sequence import make_inputs  # noqa: E402  (beside this script)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cycles", type=int, default=60)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--png", action="store_true", help="read the PNG capture instead of the MRAW file")
    args = ap.parse_args()
    warnings.simplefilter("ignore")  # depth-range warnings of the repeated scene are not the point here
    work = Path(tempfile.mkdtemp(prefix="bench-seq-cpu-"))
    spent = {"writer": 0.0, "reader": 0.0}

    def timed(fn, key):
        def run(*a, **k):
            t = time.thread_time()
            try:
                return fn(*a, **k)
            finally:
                spent[key] += time.thread_time() - t
        return run

    sequence._write_frame = timed(sequence._write_frame, "writer")
    executors.window_frames = timed(executors.window_frames, "reader")
    try:
        mraw_cap, png_cap, ps, rig, z_min, _ = make_inputs(work, args.cycles)
        cap = png_cap if args.png else mraw_cap
        decode = DecodeSettings(DecodeOptions(z_min=z_min, bit_depth=8))

        def once(limit=None) -> dict:
            out = work / "out"
            shutil.rmtree(out, ignore_errors=True)
            for k in spent:
                spent[k] = 0.0
            t, p, w = time.thread_time(), time.process_time(), time.perf_counter()
            n = sequence.reconstruct_sequence(CaptureFolder(str(cap), limit), ps, rig, out, decode,
                                              run=RunSettings(progress=False))["done_now"]
            return {"main": (time.thread_time() - t) / n * 1e3, "writer": spent["writer"] / n * 1e3,
                    "reader": spent["reader"] / n * 1e3, "process": (time.process_time() - p) / n * 1e3,
                    "rate_3d_per_s": n / (time.perf_counter() - w)}

        once(3 * len(ps))  # warm-up: numba's compiled kernels load on first use
        runs = [once() for _ in range(args.rounds)]
    finally:
        shutil.rmtree(work, ignore_errors=True)
    med = {k: round(float(np.median([r[k] for r in runs])), 1) for k in runs[0]}
    print(json.dumps({"source": "png" if args.png else "mraw", "cycles": args.cycles, "cores": os.cpu_count(),
                      "load_average": os.getloadavg()[0], "cpu_ms_per_3d_frame": med}))


if __name__ == "__main__":
    main()
