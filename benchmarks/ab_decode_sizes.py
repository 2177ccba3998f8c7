"""A/B of ``fringe3d.decode.decode`` between two source trees at several image sizes, alternated.

Each (round, size, tree) runs a fresh interpreter with that tree's ``src/`` first on
``PYTHONPATH`` (A B in even rounds, B A in odd ones, so that drift on a shared machine hits both):
the 15-frame three-frequency set of ``bench_decode.py``'s ramp scene at that size (every default
output on), three warm-up decodes, then ``--repeat`` timed decodes, each after one ``np.copyto``
of the frames (the copy bound). Per tree and size it prints the median over rounds of the best
wall time (ms, ns per pixel, and in copy bounds), of the median wall time and of the best CPU
time of the process (``time.process_time``, all threads: the work done, less sensitive to other
load than wall time), and the ratios B / A. On a loaded machine read the ratios, not the times.

Example: python benchmarks/ab_decode_sizes.py /work/main/src src --rounds 4 --repeat 12
"""
from __future__ import annotations

import argparse
import json
import os
import time

import numpy as np
from source_trees import child_json  # beside this script


def child(h: int, w: int, repeat: int) -> dict:
    """Timings (s) of ``repeat`` decodes of an ``h`` x ``w`` capture with the library on the path."""
    from fringe3d.decode import decode
    from fringe3d.patterns import sets
    from fringe3d.patterns.synthetic import frames_from_coordinates
    ps = sets.three_frequency("v", width=912, height=570)
    v, u = np.mgrid[0:h, 0:w].astype(np.float64)
    u_p = 5 + 0.7 * u * 1280 / w + 3 * np.sin(2 * np.pi * v / h)  # bench_decode's ramp, scaled to the width
    frames = frames_from_coordinates(ps, u_p, np.full_like(u_p, 300.0), 30, 180, noise=1.0,
                                     rng=np.random.default_rng(0), dtype=np.uint8)
    dst = np.empty_like(frames)
    for _ in range(3):
        decode(frames, ps)
    out: dict = {"wall": [], "cpu": [], "copy": []}
    for _ in range(repeat):
        t = time.perf_counter()
        np.copyto(dst, frames)
        out["copy"].append(time.perf_counter() - t)
        t, c = time.perf_counter(), time.process_time()
        decode(frames, ps)
        out["wall"].append(time.perf_counter() - t)
        out["cpu"].append(time.process_time() - c)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("a", help="source tree A (the folder holding the fringe3d package)")
    ap.add_argument("b", help="source tree B")
    ap.add_argument("--sizes", default="512x640,1024x1280,2048x2560", help="HxW list")
    ap.add_argument("--rounds", type=int, default=4)
    ap.add_argument("--repeat", type=int, default=12)
    ap.add_argument("--child", nargs=3, type=int, metavar=("H", "W", "REPEAT"), help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        print(json.dumps(child(*args.child)))
        return
    trees = {"A": os.path.abspath(args.a), "B": os.path.abspath(args.b)}
    sizes = [tuple(int(x) for x in s.split("x")) for s in args.sizes.split(",")]
    runs: dict = {(t, s): [] for t in trees for s in sizes}
    for k in range(args.rounds):
        for s in sizes:
            for t in (("A", "B") if k % 2 == 0 else ("B", "A")):
                runs[(t, s)].append(child_json(trees[t], __file__, ["x", "x", "--child", str(s[0]), str(s[1]),
                                                                    str(args.repeat)]))
    print(f"A = {trees['A']}\nB = {trees['B']}")
    for s in sizes:
        px = s[0] * s[1]
        fig = {}
        for t in trees:
            r = runs[(t, s)]
            fig[t] = [float(np.median([f(d[key]) for d in r])) * 1e3
                      for key, f in (("wall", min), ("wall", np.median), ("cpu", min), ("copy", min))]
            best, med, cpu, copy = fig[t]
            print(f"{s[1]}x{s[0]} {t}: wall best {best:.1f} ms ({best * 1e6 / px:.1f} ns/px, {best / copy:.1f}x the "
                  f"copy bound {copy:.2f} ms), wall median {med:.1f} ms, "
                  f"CPU best {cpu:.1f} ms ({cpu * 1e6 / px:.1f} ns/px)")
        a, b = fig["A"], fig["B"]
        print(f"{s[1]}x{s[0]} B/A: wall best {b[0] / a[0]:.3f}, wall median {b[1] / a[1]:.3f}, CPU {b[2] / a[2]:.3f}")


if __name__ == "__main__":
    main()
