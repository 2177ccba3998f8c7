"""A/B of the one-direction quality map (:func:`fringe3d.decode._fused_quality.fused_quality_map`
and :func:`~fringe3d.decode._fused_quality.finish_quality_map`) against the previous kernels kept in
``tests/reference_implementations.py``, alternated in one process on one numba thread.

A 1280 x 1024 map like the tests' (depth steps, holes, contrast drops, unlit pixels). Each round
times A then B (B then A in odd rounds) ``--repeat`` times each with ``time.process_time`` (the
CPU of the process: on one thread the work done, less sensitive to other load than wall time),
and prints per variant the median over rounds of the best and of the median time per call, and
the ratios B / A. Checks the outputs equal first.

``--steps``, ``--slope`` shape the scene: the default (the tests' ramp, 1 px per pixel, 5 % of
the pixels stepped) has half its pixels above GRADIENT's 1 px floor, the worst case for the
count; ``--steps 0.001 --slope 0.7`` is a smooth surface with a few steps. With ``--part
finish`` the finish alone is timed (on a copy of the map: the copy is in both).

Example: PYTHONPATH=src:tests python benchmarks/ab_quality_map.py --rounds 7 --repeat 15
"""
from __future__ import annotations

import argparse
import time

import numba
import numpy as np


def maps(shape, seed=0, extent=(-0.5, 1279.5), steps=0.05, slope=None):
    """The tests' maps at ``shape``: a ramp (``extent`` over the width, or ``slope`` px per pixel)
    with a fraction ``steps`` of isolated depth steps of 6 px, noise, holes, unlit and mixed pixels."""
    rng = np.random.default_rng(seed)
    H, W = shape
    stop = extent[1] + 3 if slope is None else -3 + slope * (W - 1)
    w = np.linspace(-3, stop, W, dtype=np.float32)[None, :].repeat(H, 0)
    w += np.where(rng.random(shape) < steps, 6.0, 0.0).astype(np.float32)
    w += rng.normal(0, 0.05, shape).astype(np.float32)
    valid = rng.random(shape) > 0.1
    w[~valid] = np.nan
    average = rng.uniform(20, 200, shape).astype(np.float32)
    average[rng.random(shape) < 0.03] = 0.0
    modulation = (average * rng.uniform(0.3, 0.9, shape)).astype(np.float32)
    modulation[rng.random(shape) < 0.05] *= np.float32(0.2)
    return valid, w, modulation, average


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=7)
    ap.add_argument("--repeat", type=int, default=15)
    ap.add_argument("--height", type=int, default=1024)
    ap.add_argument("--width", type=int, default=1280)
    ap.add_argument("--steps", type=float, default=0.05,
                    help="fraction of pixels with a depth step (0.05: a quarter of the pixels jump > 1 px)")
    ap.add_argument("--part", choices=("both", "map", "finish"), default="both",
                    help="time fused_quality_map and finish_quality_map, or one of them")
    ap.add_argument("--slope", type=float, default=None,
                    help="fringe coordinate per camera pixel (default: the extent over the width, 1 px)")
    args = ap.parse_args()
    import reference_implementations as ref

    from fringe3d.decode import _fused_quality as fq
    numba.set_num_threads(1)
    extent = (-0.5, args.width - 0.5)
    valid, w, mod, avg = maps((args.height, args.width), extent=extent, steps=args.steps, slope=args.slope)
    rng = np.random.default_rng(1)
    mask = valid | (rng.random(valid.shape) < 0.02)
    order = rng.random(valid.shape) < 0.01
    sat = rng.random(valid.shape) < 0.01
    res = rng.random(valid.shape).astype(np.float32)

    q0 = ref.fused_quality_map_previous(valid, w, extent, 2.0, mod, avg, rim=1)

    def run(fused, finish):
        if args.part == "finish":
            q = q0.copy()
        else:
            q = fused(valid, w, extent, 2.0, mod, avg, rim=1)
        if args.part != "map":
            finish(q, mask, order, sat, res, 0.9)
        return q

    variants = {"A (previous)": (ref.fused_quality_map_previous, ref.finish_quality_map_previous),
                "B (current)": (fq.fused_quality_map, fq.finish_quality_map)}
    outs = [run(*v) for v in variants.values()]
    assert np.array_equal(outs[0], outs[1]), "the maps differ"
    names = list(variants)
    best: dict = {n: [] for n in names}
    med: dict = {n: [] for n in names}
    for r in range(args.rounds):
        for n in (names if r % 2 == 0 else names[::-1]):
            ts = []
            for _ in range(args.repeat):
                t0 = time.process_time()
                run(*variants[n])
                ts.append(time.process_time() - t0)
            best[n].append(min(ts))
            med[n].append(float(np.median(ts)))
    for n in names:
        print(f"{n:14s} best {1e3 * np.median(best[n]):6.2f} ms  median {1e3 * np.median(med[n]):6.2f} ms per call")
    a, b = names
    ratio_best = np.median(best[b]) / np.median(best[a])
    print(f"B / A: best {ratio_best:.3f}  median {np.median(med[b]) / np.median(med[a]):.3f}")


if __name__ == "__main__":
    main()
