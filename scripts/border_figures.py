"""Issue 15 figures at the borders: the projector-edge band at oblique fringe angles and the
simulator's camera blur at the sensor border.

* Oblique edge band: the tiny rig, a plane wider than the projector's light, Gaussian projector
  defocus (sigma 2 px), two fringe directions at pi/3 -+ pi/4 (``optimal_angle_calibration``).
  Per direction, the pixels kept in the true border band (projector pixel within the edge margin
  of any border) and the RMS of their fringe-coordinate error ``w - w_true`` (projector px), and
  the same inside (3 px further in): ``before`` with each direction's own band test only (the
  decoder's two-direction step off), ``after`` with it.
* Camera blur at the sensor border: the tiny rig, a tilted plane, a T = 18 px 3-step set, camera
  blur sigma 1 px, noise-free float frames. Reference: a sharp render of a sensor ``4 sigma``
  wider on every side, blurred and cropped (what a lens brings onto the border pixels). ``before``:
  the sharp sensor-sized render blurred with edge padding (``mode="nearest"``, the former
  simulator); ``after``: the simulator's render (a margin beyond the sensor, cropped). Largest
  intensity error (fraction of full scale) in the outer 2 px and inside, and the largest phase
  error in the outer 2 px (rad and projector px).

Run: ``PYTHONPATH=src python scripts/border_figures.py`` (prints one JSON; deterministic).
"""
from __future__ import annotations

import dataclasses
import json
import math
from unittest import mock

import numpy as np
from scipy.ndimage import gaussian_filter

import fringe3d.decode.decoder as decoder
from fringe3d.decode import DecodeOptions, decode, edges
from fringe3d.patterns import sets
from fringe3d.phase.psp import wrapped_phase
from fringe3d.sim import presets, render
from fringe3d.sim.noise import blur_margin, sense
from fringe3d.sim.primitives import Plane
from fringe3d.sim.scene import Scene


def oblique_capture():
    """(patterns, uint8 frames, truth) of the oblique edge-band figure."""
    p = presets.get("tiny")
    ps = sets.optimal_angle_calibration(math.pi / 3, width=p.rig.projector.width, height=p.rig.projector.height)
    s = p.settings.replace(defocus="gaussian", defocus_size=2.0, seed=1)
    frames, truth = render(Scene([Plane((0, 0, 700.0), (0, 0, -1.0), albedo=0.8)]), p.rig, ps, s, progress=False)
    return ps, frames, truth


def band_figures(ps, d, truth) -> dict:
    """Per direction ``{"band": (kept pixels, w error RMS px), "inner": (...)}`` of a decode ``d``."""
    up, vp = truth.up, truth.vp
    m = max(d.info["quality"][p.direction]["edge_margin"] for p in ps.plans)
    lit = np.isfinite(up)
    band = edges.border_band(up, vp, ps.width, ps.height, m) & lit
    inner = ~edges.border_band(up, vp, ps.width, ps.height, m + 3) & lit
    out: dict = {"edge_margin": m}
    for p in ps.plans:
        err = d.projector_coordinate(p.direction) - (vp * math.cos(p.angle) + up * math.sin(p.angle))
        out[p.direction] = {}
        for name, sel in (("band", band), ("inner", inner)):
            v = err[sel & d.mask[p.direction]]
            out[p.direction][name] = (int(v.size), float(np.sqrt(np.mean(v ** 2))) if v.size else 0.0)
    return out


def oblique_band_figures(capture=None) -> dict:
    """``{"before": band_figures, "after": band_figures}`` (see the module docstring)."""
    ps, frames, truth = capture or oblique_capture()
    opts = DecodeOptions(bit_depth=8)
    after = band_figures(ps, decode(frames, ps, options=opts), truth)
    with mock.patch.object(decoder, "mask_projector_border", lambda *a: None):
        before = band_figures(ps, decode(frames, ps, options=opts), truth)
    return {"before": before, "after": after}


def _phase(frames: np.ndarray) -> np.ndarray:
    return wrapped_phase(frames, shifts=2 * np.pi * np.arange(3) / 3).phase


def camera_blur_border_figures(sigma: float = 1.0) -> dict:
    """``{"before": {...}, "after": {...}}`` errors against the wide reference (module docstring)."""
    p = presets.get("tiny")
    ps = sets.phase_shift(18, 3, "v", width=p.rig.projector.width, height=p.rig.projector.height)
    s = p.settings.replace(camera_blur=sigma, shot_noise=False, read_noise=0.0, bit_depth=None)
    scene = Scene([Plane((0, 0, 420.0), (0.2, 0.1, -1.0), albedo=0.8)])
    m = blur_margin(s)
    cam = p.rig.camera
    K = cam.K.copy()
    K[0, 2] += m
    K[1, 2] += m
    wide = dataclasses.replace(p.rig, camera=dataclasses.replace(cam, K=K, width=cam.width + 2 * m,
                                                                 height=cam.height + 2 * m))
    sharp_wide, _ = render(scene, wide, ps, s.replace(camera_blur=0.0), progress=False)
    ref = np.stack([gaussian_filter(f.astype(np.float64), sigma)[m:-m, m:-m] for f in sharp_wide])
    sharp, _ = render(scene, p.rig, ps, s.replace(camera_blur=0.0), progress=False)
    results = {"before": np.stack([sense(f, s, k) for k, f in enumerate(sharp)]),  # edge padding, no margin
               "after": render(scene, p.rig, ps, s, progress=False)[0]}
    border = np.zeros(ref.shape[1:], bool)
    border[:2] = border[-2:] = True
    border[:, :2] = border[:, -2:] = True
    out = {"margin_px": m}
    for name, frames in results.items():
        err = np.abs(frames - ref)
        dphi = np.abs(np.angle(np.exp(1j * (_phase(frames) - _phase(ref)))))
        worst = float(np.nanmax(dphi[border]))
        out[name] = {"intensity_error_border": float(err[:, border].max()),
                     "intensity_error_inside": float(err[:, ~border].max()),
                     "phase_error_border_rad": worst, "phase_error_border_px": worst * 18 / (2 * math.pi)}
    return out


def main() -> None:
    print(json.dumps({"oblique_edge_band": oblique_band_figures(), "camera_blur_border": camera_blur_border_figures()},
                     indent=1))


if __name__ == "__main__":
    main()
