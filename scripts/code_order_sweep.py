"""Code + phase fringe orders (issue 23): off-by-a-period pixels and the order-consistency share.

1. Sweep: a projector-coordinate ramp (8 .. 264 px in steps of 1/64 px, so every period boundary
   is hit exactly) rendered to 8-bit frames: 3-step phase of period T = 16 px (frames 1 and 2
   equal on the boundaries: wrapped phase 0 or a few 1e-16 rad) and Gray / binary code frames
   with inverses (or a mid-grey threshold), blurred over 0.7 projector px, stripes of T, T/2 and
   T/4, noise-free and with sigma 1.5 counts (seed 1). Counts the valid pixels off by a period
   (after the ORDER check where the code has one).
2. Simulator: ``simulate_capture`` (preset high-speed, static sphere, seed 1) of 3-step
   phase T = 18 + Gray code of stripes 9 (the ``gray-code`` set), 18 and 36 px and binary code
   of 18 px; decoded with the defaults; the valid pixels off by a period against the truth's
   ``up`` and the ``order_inconsistent`` share of ``decoded.json``'s summary.

Runs on the tree before issue 23 too (no ORDER check there). Run:
PYTHONPATH=src python scripts/code_order_sweep.py [--sweep-only] [--out /tmp/code-orders]
"""
from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np

import fringe3d.unwrap.temporal as temporal
from fringe3d.decode import DecodeOptions, decode
from fringe3d.io.capture import read_capture
from fringe3d.patterns import sets
from fringe3d.phase.psp import wrapped_phase
from fringe3d.sim.simulate import simulate_capture

PERIOD = 16.0


def _word(w, stripe, code):
    c = np.floor(w / stripe).astype(np.int64)
    return c ^ (c >> 1) if code == "gray" else c


def _render(stripe, nbits, code, sigma, seed, blur=0.7):
    rng = np.random.default_rng(seed)
    i, j = np.mgrid[0:16, 0:1024].astype(np.float64)
    w = 8.0 + (j * 16 + i) / 64.0
    phase = np.stack([120 + 80 * np.cos(2 * np.pi * w / PERIOD + s) for s in 2 * np.pi * np.arange(3) / 3])
    g = np.linspace(-2.5, 2.5, 21)
    wt = np.exp(-0.5 * g * g)
    wt /= wt.sum()
    bits = np.zeros((nbits,) + w.shape)
    for o, a in zip(g, wt):
        cw = _word(w + o * blur, stripe, code)
        for b in range(nbits):
            bits[b] += a * ((cw >> (nbits - 1 - b)) & 1)
    frames = np.concatenate([phase, 20 + 180 * bits, 20 + 180 * (1 - bits)])
    frames = frames + (rng.normal(0.0, sigma, frames.shape) if sigma else 0.0)
    wp = np.arange(0.0, 300.0, 1 / 16) + 1 / 32
    images = np.stack([(_word(wp, stripe, code) >> (nbits - 1 - b)) & 1 for b in range(nbits)])
    return np.clip(np.round(frames), 0, 255).astype(np.uint8), w, images, wp


def sweep_case(ratio, code, sigma, inverse, seed=1):
    """(valid pixels off by a period, valid pixels) of one sweep case."""
    stripe = PERIOD * ratio
    nbits = int(math.ceil(math.log2(300 / stripe)))
    frames, w, images, wp = _render(stripe, nbits, code, sigma, seed)
    pr = wrapped_phase(frames, index=range(3))
    bits = range(3, 3 + nbits)
    inv = range(3 + nbits, 3 + 2 * nbits) if inverse else None
    thr = None if inverse else np.full(w.shape, 110.0, np.float32)
    if hasattr(temporal, "code_stripes"):   # issue 23: the ORDER check masks what it flags
        contrast = (2.0 if inverse else 1.0) * pr.modulation
        res = temporal.gray_code_order(frames, bits, pr.phase, PERIOD, temporal.code_stripes(images, wp),
                                       inverse_index=inv, threshold=thr, contrast=contrast)
        keep = res.valid & (res.residual <= temporal.MAX_CODE_RESIDUAL)
    else:
        res = temporal.gray_code_order(frames, bits, pr.phase, PERIOD, temporal.code_centers(images, wp),
                                       inverse_index=inv, threshold=thr)
        keep = res.valid
    off = keep & (np.round((res.phase - 2 * np.pi * w / PERIOD) / (2 * np.pi)) != 0)
    return int(off.sum()), int(keep.sum())


def simulated_case(out: Path, code_period, code="gray"):
    """(valid pixels off by a period, valid pixels, order_inconsistent share or None)."""
    ps = sets.psp_with_gray_code(18, 3, "v", width=800, height=600, code=sets.CodeFrames(code, period=code_period))
    folder = out / f"{code}-{code_period:g}"
    if not (folder / "truth").is_dir():
        simulate_capture(folder, preset="high-speed", scene="sphere", patterns=ps, seed=1, progress=False)
    cap = read_capture(folder)
    d = decode(cap.frames, cap.patterns, options=DecodeOptions(bit_depth=cap.bit_depth))
    with np.load(folder / "truth" / "truth.npz") as t:
        up, hit = t["up"], t["hit"].astype(bool)
    valid = d.mask["v"] & hit
    off = valid & (np.abs(d.projector_coordinate("v") - up) > 9.0)
    return int(off.sum()), int(valid.sum()), d.summary()["directions"]["v"].get("order_inconsistent")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sweep-only", action="store_true")
    ap.add_argument("--out", default="/tmp/code-orders", help="folder for the simulated captures")
    args = ap.parse_args()
    print("sweep: stripe/period code sigma inverse -> off-by-a-period / valid")
    for ratio in (1.0, 0.5, 0.25):
        for code in ("gray", "binary"):
            for sigma in (0.0, 1.5):
                for inverse in (True, False):
                    off, kept = sweep_case(ratio, code, sigma, inverse)
                    print(f"  {ratio:<5g} {code:6} {sigma:<4g} {inverse!s:5} -> {off} / {kept}")
    if args.sweep_only:
        return
    print("simulated (high-speed, sphere, seed 1): code stripe -> off-by-a-period / valid, order_inconsistent")
    for code, cp in (("gray", 9.0), ("gray", 18.0), ("binary", 18.0), ("gray", 36.0)):
        off, valid, share = simulated_case(Path(args.out), cp, code)
        print(f"  {code} {cp:g} px -> {off} / {valid}, {share}")


if __name__ == "__main__":
    main()
