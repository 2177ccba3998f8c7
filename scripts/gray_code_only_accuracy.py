"""Gray-code-only decoding on the simulator (issue 13): exact stripe share, masked vs shadowed
share and the projector-coordinate RMS against the simulator's truth (``Truth.up`` / ``vp``).

The tiny rig with the well-designed preset's sensor noise (read 0.4 % + shot noise, seed 3);
columns and rows, with inverse frames or with the white/black pair only, stripe widths T = 8 and
4 projector px. Per capture and direction:

- ``exact``: the share of kept pixels whose decoded stripe (the codeword's) is the true one, the
  stripe containing the simulator's projector coordinate at the pixel centre (stripe ``c``
  covers ``w`` in ``[c T - 1/2, c T + T - 1/2)``: pixel centres ``c T .. c T + T - 1``);
  ``sub`` the same share for the stripe of the sub-stripe coordinate (``floor((w + 1/2) / T)``);
- ``masked`` / ``shadow``: the masked share against the simulator's shadow share (every pixel
  it does not light), and ``kept-but-shadowed``;
- ``rms``: the sub-stripe coordinate's error (px) over the pixels within half a stripe;
- ``bound``: the exact share a decoder that keeps every lit pixel can reach at best from each
  pixel's own frames: from the noiseless frames (same scene) each bit's true difference ``D``
  and the noise ``sigma`` of its measurement (shot + read + quantisation), a bit's sign is
  wrong with probability ``Phi(-|D| / sigma)``; ``bound = 1 - mean(sum_b Phi(-|D_b| / sigma_b))``;
- ``keep-all``: ``exact`` and ``masked`` with ``edge_thr=0`` (every stripe-edge pixel kept).

Run: PYTHONPATH=src python scripts/gray_code_only_accuracy.py
"""
from __future__ import annotations

import dataclasses

import numpy as np
from scipy.special import ndtr

from fringe3d.decode import DecodeOptions, decode
from fringe3d.patterns import sets
from fringe3d.patterns.manifest import FrameSpec, PatternSet
from fringe3d.sim import presets
from fringe3d.sim.render import render
from fringe3d.sim.settings import RenderSettings
from fringe3d.sim.simulate import make_scene


def code_set(stripe: float, width: int, height: int, inverse: bool) -> PatternSet:
    """Gray-code columns + rows of stripe width ``stripe`` (with or without inverse frames), then
    a white and a black frame."""
    ps = sets.gray_code(stripe, "v", width=width, height=height, inverse=inverse).concat(
        sets.gray_code(stripe, "h", width=width, height=height, inverse=inverse))
    return dataclasses.replace(ps, frames=ps.frames + (FrameSpec(kind="white", role="texture"),
                                                       FrameSpec(kind="black", role="reference")))


def per_pixel_bound(clean: np.ndarray, ps: PatternSet, s: RenderSettings, direction: str, lit: np.ndarray) -> float:
    """Best exact-stripe share of a keep-every-lit-pixel decoder (see the module docstring).

    clean : (F, H, W) noiseless frames in full-scale units; lit : (H, W) bool, the pixels counted."""
    top = 2.0 ** s.bit_depth - 1
    var = clean / s.full_well * s.shot_noise + s.read_noise ** 2 + 1.0 / (12 * top ** 2)
    code = [i for i, f in enumerate(ps.frames) if f.role == "code" and f.direction == direction]
    direct = [i for i in code if not ps.frames[i].inverse]
    inverse = [i for i in code if ps.frames[i].inverse]
    if inverse:
        diff, v = clean[direct] - clean[inverse], var[direct] + var[inverse]
    else:
        white, black = ps.indices(kind="white")[0], ps.indices(kind="black")[0]
        diff = clean[direct] - 0.5 * (clean[white] + clean[black])
        v = var[direct] + 0.25 * (var[white] + var[black])
    wrong = ndtr(-np.abs(diff) / np.sqrt(v)).sum(axis=0)
    return float(1.0 - wrong[lit].mean())


def main() -> None:
    p = presets.get("tiny")
    ref = presets.get("well-designed").settings
    s = p.settings.replace(read_noise=ref.read_noise, shot_noise=ref.shot_noise, seed=3)
    noiseless = s.replace(read_noise=0.0, shot_noise=False, bit_depth=None)
    W, H = p.rig.projector.width, p.rig.projector.height
    for scene in ("textured-spheres", "sphere"):
        for T in (8.0, 4.0):
            for inv in (True, False):
                ps = code_set(T, W, H, inv)
                f, t = render(make_scene(scene, p), p.rig, ps, s, progress=False)
                clean, _ = render(make_scene(scene, p), p.rig, ps, noiseless, progress=False)
                centre = decode(f, ps, options=DecodeOptions(sub_stripe=False))
                sub = decode(f, ps)
                keep_all = decode(f, ps, options=DecodeOptions(sub_stripe=False, edge_thr=0.0))
                shadow = 1 - t.mask.mean()

                def stripe(w, T=T):
                    return np.floor((w + 0.5) / T)

                for k, tw in (("v", t.up), ("h", t.vp)):
                    m = centre.mask[k]
                    truth = stripe(tw[m])
                    ex = (stripe(centre.projector_coordinate(k)[m]) == truth).mean()
                    ws = sub.projector_coordinate(k)[m]
                    ex_sub = (stripe(ws) == truth).mean()
                    err = ws - tw[m]
                    near = np.abs(err) <= T / 2
                    ma = keep_all.mask[k]
                    ex_all = (stripe(keep_all.projector_coordinate(k)[ma]) == stripe(tw[ma])).mean()
                    print(f"{scene:16s} T={T:g} inverses={inv!s:5s} {k}: exact {100 * ex:.3f} % "
                          f"(sub {100 * ex_sub:.3f} %)  masked {100 * (1 - m.mean()):.2f} %  "
                          f"shadow {100 * shadow:.2f} %  kept-but-shadowed {int((m & ~t.mask).sum())}  "
                          f"rms {np.sqrt(np.mean(err[near] ** 2)):.3f} px  "
                          f"bound {100 * per_pixel_bound(clean, ps, s, k, t.mask):.3f} %  "
                          f"keep-all: exact {100 * ex_all:.3f} % masked {100 * (1 - ma.mean()):.2f} %")


if __name__ == "__main__":
    main()
