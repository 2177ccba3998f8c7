"""Quick timing of the decode hot paths at 1280 x 1024 (not a test; the full comparison with
peers lives in ``benchmarks/``).

Run: ``.venv/bin/python -m fringe3d.decode.timing [--repeat 20] [--threads 1]``. Prints ms per call (best of ``repeat``)
for the fused 15-frame three-frequency decode, the 3-step wrapped phase, and the
unavoidable-work bound (copying the input bytes + numpy.arctan2 over the output pixels).
"""
from __future__ import annotations

import argparse
import time

import numpy as np


def _median_ms(fn, repeat: int) -> float:
    """Best-of-``repeat`` wall time in ms (the machine may be shared; the minimum is the
    least disturbed run)."""
    fn()  # compile / warm up
    times = []
    for _ in range(repeat):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return 1e3 * float(np.min(times))


def run(repeat: int = 20, height: int = 1024, width: int = 1280, seed: int = 0) -> dict:
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
    y = np.empty((height, width))
    x = np.empty((height, width))

    def fused():
        three_frequency_decode(frames, idx, shifts, (18, 21, 144), w_range=(0, 819), min_modulation=5.0,
                               saturation_level=255)

    def bound(stack):
        def f():
            stack.copy()
            np.arctan2(y, x)
        return f

    x[:] = rng.normal(size=x.shape)
    y[:] = rng.normal(size=y.shape)
    out = {
        "three_frequency_fused_ms": _median_ms(fused, repeat),
        "three_frequency_bound_ms": _median_ms(bound(frames), repeat),
        "three_step_ms": _median_ms(lambda: wrapped_phase(three), repeat),
        "three_step_bound_ms": _median_ms(bound(three), repeat),
        "shape": [height, width],
    }
    return out


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--repeat", type=int, default=20)
    p.add_argument("--threads", type=int, default=None, help="numba threads (default: all cores)")
    a = p.parse_args(argv)
    if a.threads:
        import numba
        numba.set_num_threads(a.threads)
    r = run(a.repeat)
    for k, val in r.items():
        print(f"{k}: {val if isinstance(val, list) else round(val, 2)}")
    print(f"fused / bound: {r['three_frequency_fused_ms'] / r['three_frequency_bound_ms']:.2f}; "
          f"3-step / bound: {r['three_step_ms'] / r['three_step_bound_ms']:.2f}")


if __name__ == "__main__":
    main()
