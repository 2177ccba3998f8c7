"""Saturation by what it breaks (issue 23): valid shares under overexposure on the simulator.

The tiny rig, sphere scene (``lit`` = the simulator's truth mask: not in shadow or background),
the well-designed preset's sensor noise (read 0.4 % + shot noise, seed 3), 8-bit frames; the
camera ``gain`` overexposes (1 = nominal). Per capture and direction:

- ``valid``: share of all pixels kept; ``lit``: share lit; ``kept/lit``: kept lit pixels over lit;
- ``right``: share of kept pixels in the true stripe (code) or with ``|error| < 1`` projector px;
- ``rms``: coordinate error (projector px) of the kept pixels (code: within half a stripe);
- ``clipped``: share of lit pixels with a frame at 255; ``masked``: share masked for clipping
  (``info["quality"][d]["saturation"]``).

Captures: Gray code only (T = 8) with inverses and with white/black only; OpenCV's
``GrayCodePattern`` sequence as clean 0/255 frames (ideal sampling, no ambient, no noise, gain
50); phase + Gray code (4 and 9 steps) and the three-frequency set.

Run: PYTHONPATH=src python scripts/saturation_figures.py
"""
from __future__ import annotations

import dataclasses
import warnings

import numpy as np

from fringe3d.decode import decode
from fringe3d.patterns import sets
from fringe3d.patterns.layouts import opencv_graycode
from fringe3d.patterns.manifest import FrameSpec
from fringe3d.sim import presets
from fringe3d.sim.render import render
from fringe3d.sim.simulate import make_scene


def gray_only(w: int, h: int, inverse: bool):
    ps = sets.gray_code(8.0, "v", width=w, height=h, inverse=inverse)
    return dataclasses.replace(ps, frames=ps.frames + (FrameSpec(kind="white", role="texture"),
                                                       FrameSpec(kind="black", role="reference")))


def report(label: str, frames: np.ndarray, ps, truth, code: bool) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        d = decode(frames, ps)
    lit = truth.mask
    for direction, true in (("v", truth.up), ("h", truth.vp)):
        if direction not in d.directions:
            continue
        m = d.mask[direction]
        err = d.projector_coordinate(direction)[m] - true[m]
        if code and d.period[direction] > 1:
            t = d.period[direction]
            right = np.floor((d.projector_coordinate(direction)[m] + 0.5) / t) == np.floor((true[m] + 0.5) / t)
            rms = np.sqrt(np.mean(err[np.abs(err) <= t / 2] ** 2))
        else:
            right, rms = np.abs(err) < 1.0, np.sqrt(np.mean(err ** 2))
        sat = d.info["quality"][direction].get("saturation", {})
        masked = sum(v["masked"] for v in sat.values())
        clipped = (frames >= 255).any(axis=0)[lit].mean()
        print(f"{label:34s} {direction}  valid {m.mean():.4f}  lit {lit.mean():.4f}  kept/lit "
              f"{(m & lit).sum() / lit.sum():.4f}  right {right.mean():.5f}  rms {rms:.3f}  clipped {clipped:.3f}  "
              f"masked for clipping {masked:.4f}")


def main() -> None:
    p = presets.get("tiny")
    w, h = p.rig.projector.width, p.rig.projector.height
    ref = presets.get("well-designed").settings
    noisy = p.settings.replace(read_noise=ref.read_noise, shot_noise=ref.shot_noise, bit_depth=8, seed=3)
    scene = make_scene("sphere", p)
    for inverse in (True, False):
        for gain in (1.0, 2.5, 5.0):
            ps = gray_only(w, h, inverse)
            frames, truth = render(scene, p.rig, ps, noisy.replace(gain=gain), progress=False)
            report(f"gray-only {'inverses' if inverse else 'white/black'} gain {gain}", frames, ps, truth, True)
    ps = opencv_graycode(w, h)
    clean = p.settings.replace(ideal=True, ambient=0.0, gain=50.0, read_noise=0.0, shot_noise=False, bit_depth=8)
    frames, truth = render(scene, p.rig, ps, clean, progress=False)
    report("opencv clean 0/255", frames, ps, truth, True)
    for name, ps in (("psp 4-step T16 + gray", sets.psp_with_gray_code(16, 4, "v", width=w, height=h)),
                     ("psp 9-step T16 + gray", sets.psp_with_gray_code(16, 9, "v", width=w, height=h)),
                     ("three-frequency", sets.three_frequency("v", width=w, height=h))):
        for gain in (1.0, 1.4, 2.0):
            frames, truth = render(scene, p.rig, ps, noisy.replace(gain=gain), progress=False)
            report(f"{name} gain {gain}", frames, ps, truth, False)


if __name__ == "__main__":
    main()
