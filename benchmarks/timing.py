"""Quick timing of the decode hot paths at 1280 x 1024 (not a test; the full comparison with
peers lives in ``benchmarks/bench_decode.py``, which times the same bound and reference in alternated rounds).

Run: ``.venv/bin/python benchmarks/timing.py [--repeat 20] [--threads 1]``. Prints best and
median ms per call for the fused 15-frame three-frequency decode, the 3-step wrapped phase, the
copy bound of each and the "copy + arctan2" reference, plus the load average (the machine may be
shared).

The bound (issue 29): copying the input bytes (``np.copyto`` of the uint8 frame stack into a
preallocated buffer), the memory-copy bound. The reference "copy + arctan2" adds NumPy's
vectorised ``np.arctan2`` over the output pixels, float32 inputs and float32 output (``out=``
preallocated), timed separately and summed; it costs many times the copy
at 1280x1024 and made slow decoders look near their bound, so it is no longer the bound.
"""
from __future__ import annotations

import argparse
import os
import time

import numpy as np


def time_call(fn, repeat: int) -> tuple[float, float]:
    """(best, median) wall time in seconds of ``repeat`` calls of ``fn`` after one warm-up."""
    fn()  # compile / warm up
    times = []
    for _ in range(repeat):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return float(np.min(times)), float(np.median(times))


def bound_times(frames: np.ndarray, repeat: int, seed: int = 1) -> dict:
    """Copy bound and "copy + arctan2" reference for decoding ``frames`` (F, H, W) to one (H, W) phase map.

    Returns seconds: ``copy_best/copy_median`` (``np.copyto`` of the frames into a preallocated
    array: the copy bound), ``atan_best/atan_median`` (``np.arctan2`` of two (H, W) float32 arrays
    into a preallocated float32 output) and their sums ``best`` and ``median`` (the "copy +
    arctan2" reference, not the bound).
    """
    h, w = frames.shape[1:]
    rng = np.random.default_rng(seed)
    y = rng.standard_normal((h, w)).astype(np.float32)
    x = rng.standard_normal((h, w)).astype(np.float32)
    out = np.empty((h, w), np.float32)
    dst = np.empty_like(frames)
    cb, cm = time_call(lambda: np.copyto(dst, frames), repeat)
    ab, am = time_call(lambda: np.arctan2(y, x, out=out), repeat)
    return {"copy_best": cb, "copy_median": cm, "atan_best": ab, "atan_median": am,
            "best": cb + ab, "median": cm + am}


def run(repeat: int = 20, height: int = 1024, width: int = 1280, seed: int = 0) -> dict:
    """Times in ms (best and median) of the fused three-frequency decode, the 3-step wrapped
    phase, their copy bounds and "copy + arctan2" references on synthetic uint8 frames (noise 2 grey levels)."""
    from fringe3d.phase.psp import default_shifts, wrapped_phase
    from fringe3d.unwrap.temporal import three_frequency_decode

    rng = np.random.default_rng(seed)
    v, u = np.mgrid[0:height, 0:width].astype(np.float64)
    w = 0.6 * u + 0.05 * v
    groups = [(18.0, 9), (21.0, 3), (144.0, 3)]
    frames = np.concatenate([
        np.stack([120 + 90 * np.cos(2 * np.pi * w / t + d) for d in default_shifts(n)]) for t, n in groups])
    frames = np.clip(np.round(frames + rng.normal(0, 2, frames.shape)), 0, 255).astype(np.uint8)
    idx = [list(range(0, 9)), list(range(9, 12)), list(range(12, 15))]
    shifts = [default_shifts(9), default_shifts(3), default_shifts(3)]
    three = np.ascontiguousarray(frames[9:12])

    def fused():
        three_frequency_decode(frames, idx, shifts, (18, 21, 144), w_range=(0, 819), min_modulation=5.0,
                               saturation_level=255)

    out = {}
    for name, fn in (("three_frequency_fused", fused), ("three_step", lambda: wrapped_phase(three))):
        out[f"{name}_best_ms"], out[f"{name}_median_ms"] = (1e3 * t for t in time_call(fn, repeat))
    for name, stack in (("three_frequency", frames), ("three_step", three)):
        b = bound_times(stack, repeat)
        out[f"{name}_bound_best_ms"], out[f"{name}_bound_median_ms"] = 1e3 * b["copy_best"], 1e3 * b["copy_median"]
        out[f"{name}_copy_atan_best_ms"], out[f"{name}_copy_atan_median_ms"] = 1e3 * b["best"], 1e3 * b["median"]
    import numba
    out["numba_threads"] = numba.get_num_threads()
    out["load_average"] = [round(x, 2) for x in os.getloadavg()]
    out["shape"] = [height, width]
    return out


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--repeat", type=int, default=20)
    p.add_argument("--threads", type=int, default=None, help="numba threads (default: all cores)")
    a = p.parse_args(argv)
    import fringe3d.phase._kernels  # noqa: F401  (sets OMP_WAIT_POLICY before numba starts its threads)
    if a.threads:
        import numba
        numba.set_num_threads(a.threads)
    r = run(a.repeat)
    for k, val in r.items():
        print(f"{k}: {round(val, 2) if isinstance(val, float) else val}")
    for name in ("three_frequency_fused", "three_step"):
        bound = name.replace("_fused", "") + "_bound"
        print(f"{name} / bound: best {r[name + '_best_ms'] / r[bound + '_best_ms']:.2f}, "
              f"median {r[name + '_median_ms'] / r[bound + '_median_ms']:.2f}")


if __name__ == "__main__":
    main()
