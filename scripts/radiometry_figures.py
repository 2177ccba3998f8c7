"""Projector nonlinearity and its compensation (issue 25, "Must show"), on the simulator.

The tiny rig, a plane and the sphere scene, noiseless 16-bit frames, fringe period 18 projector
px, 3 and 4 equal steps. Two projectors: a power law ``gamma 2.2`` and a measured-looking table
with a square-law toe and a knee at 75 % input into a flat shoulder (``KNEE``). Per projector,
steps and scene, against the simulator's truth on its lit pixels:

- ``phase``: RMS wrapped-phase error (rad);
- ``3D``: RMS distance (mm) of the triangulated point (projector column from the measured phase,
  its fringe order from the truth, so that only the phase error counts) to the true point;
  the ``truth`` row triangulates the true projector column (the floor of the method);

without compensation (``raw``) and with each compensation, all from the *measured* response
(a 18-level grey ramp on a flat target, 8-bit, :func:`fringe3d.radiometry.fit_response`):
``response`` (per-pixel fit through the response table, :func:`response_phase`),
``phase-LUT`` (the phase-error table of the measured response, Zhang & Yau 2007) and
``harmonic`` (the gamma estimated from the capture itself, N >= 4 only) and, for 3 steps,
``2-freq`` (the ripple estimated from the disagreement with a second 3-step set at period 23
px, after Xing & Guo 2018; fringe orders from the truth).

In decode (:func:`fringe3d.decode.decode`, the fringe orders its own): a 3-step three-frequency
heterodyne capture (periods 18/21/144) decoded as it comes (``raw``) and with
``compensate="disagreement"`` (``decode --compensate disagreement``): phase and 3D error of the
decoded wrapped phase on all lit pixels, and the share of them the decode keeps valid.

Also printed: the response round trip (measured vs true table at the ramp's levels, in grey
levels) and the diagnostic (:func:`fringe3d.radiometry.diagnose`) on a gamma-2.2 and a linear
4-step capture of the plane.

Run: PYTHONPATH=src python scripts/radiometry_figures.py
"""
from __future__ import annotations

import numpy as np

from fringe3d.decode import DecodeOptions, decode
from fringe3d.patterns import sets
from fringe3d.phase.psp import wrapped_phase
from fringe3d.radiometry import (ResponseLUT, diagnose, disagreement_lut, fit_response, harmonic_lut, lut_from_response,
                                 power_law, response_phase)
from fringe3d.radiometry.phase_error import wrap
from fringe3d.reconstruct.triangulate import triangulate
from fringe3d.sim import presets, render
from fringe3d.sim.simulate import make_scene
from fringe3d.sim.virtual_devices import VirtualRigState

PRESET = presets.get("tiny")
PERIOD = 18
SECOND_PERIOD = 23
SEED = 7
_X = np.linspace(0.0, 1.0, 33)
KNEE = tuple(np.where(_X < 0.75, 0.9 * (_X / 0.75) ** 2, 0.9 + 0.1 * (_X - 0.75) / 0.25).tolist())
CURVES = {"gamma 2.2": {"gamma": 2.2}, "knee": {"response": KNEE}, "linear": {"gamma": 1.0}}


def true_response(curve: str) -> ResponseLUT:
    return ResponseLUT(_X, np.asarray(KNEE)) if curve == "knee" else power_law(CURVES[curve]["gamma"])


def measure_response(curve: str) -> tuple[ResponseLUT, float]:
    """The grey-ramp response of the simulated projector and its worst error (grey levels)."""
    s = PRESET.settings.replace(bit_depth=8, seed=SEED, **CURVES[curve])
    rig = VirtualRigState(PRESET, make_scene("plane", PRESET), s)
    proj = PRESET.rig.projector
    levels = np.arange(0, 256, 15)
    frames = []
    for k, lv in enumerate(levels):
        rig.set_image(np.full((proj.height, proj.width), lv, np.uint8))
        frames.append(rig.exposure_image(0.0, k))
    lut = fit_response(levels, np.stack(frames), full_scale=255)
    err = np.max(np.abs(lut.apply(levels / 255.0) - true_response(curve).apply(levels / 255.0))) * 255
    return lut, float(err)


def absolute(wrapped: np.ndarray, truth, period: float) -> np.ndarray:
    """The absolute phase of a measured wrapped phase, its fringe orders from the truth."""
    true_abs = 2.0 * np.pi * truth.up / period
    return true_abs + wrap(wrapped - true_abs)


def capture(scene_name: str, steps: int, curve: str, period: float = PERIOD):
    s = PRESET.settings.replace(ideal=True, bit_depth=16, read_noise=0.0, shot_noise=False, camera_blur=0.0,
                                seed=SEED, **CURVES[curve])
    ps = sets.phase_shift(period, steps, "v", width=PRESET.rig.projector.width,
                          height=PRESET.rig.projector.height)
    frames, truth = render(make_scene(scene_name, PRESET), PRESET.rig, ps, s, progress=False)
    return frames.astype(np.float64), truth


def errors(phase: np.ndarray, truth) -> tuple[float, float]:
    """RMS phase error (rad) and RMS 3D error (mm) of a wrapped phase against the truth."""
    m = truth.mask
    e = wrap(phase - truth.phase["v"])
    up = truth.up + e * PERIOD / (2.0 * np.pi)
    xyz = triangulate(PRESET.rig, up=np.where(m, up, np.nan), mask=m)
    d = np.linalg.norm(xyz[m] - truth.xyz[m], axis=-1)
    return float(np.sqrt(np.mean(e[m] ** 2))), float(np.sqrt(np.mean(d ** 2)))


def table(curve: str, lut: ResponseLUT) -> None:
    for scene_name in ("plane", "sphere"):
        for steps in (3, 4):
            frames, truth = capture(scene_name, steps, curve)
            raw = wrapped_phase(frames).phase
            rows = {"truth": errors(truth.phase["v"], truth), "raw": errors(raw, truth),
                    "response": errors(response_phase(frames, lut)[0], truth),
                    "phase-LUT": errors(lut_from_response(lut, steps=steps).correct(raw), truth)}
            if steps >= 4:
                rows["harmonic"] = errors(harmonic_lut(frames, truth.mask)[0].correct(raw), truth)
            else:  # a second period, 23 px: the two frequencies' disagreement (Xing & Guo 2018)
                frames_b, truth_b = capture(scene_name, steps, curve, period=SECOND_PERIOD)
                lut_d = disagreement_lut(absolute(raw, truth, PERIOD), PERIOD,
                                         absolute(wrapped_phase(frames_b).phase, truth_b, SECOND_PERIOD),
                                         SECOND_PERIOD, steps, truth.mask)
                rows["2-freq"] = errors(lut_d.correct(raw), truth)
            base = rows["raw"][0]
            for name, (ph, mm) in rows.items():
                gain = "" if name in ("truth", "raw") else f"  ({base / max(ph, 1e-12):6.1f}x lower)"
                print(f"{curve:9s} {scene_name:6s} {steps}-step {name:9s} phase {ph:.5f} rad  3D {mm:.5f} mm{gain}")


def decode_rows() -> None:
    """``decode`` with and without ``compensate="disagreement"`` on 3-step three-frequency captures."""
    proj = PRESET.rig.projector
    ps = sets.three_frequency("v", steps=(3, 3, 3), width=proj.width, height=proj.height)
    for curve in ("gamma 2.2", "knee", "linear"):
        s = PRESET.settings.replace(ideal=True, bit_depth=16, read_noise=0.0, shot_noise=False, camera_blur=0.0,
                                    seed=SEED, **CURVES[curve])
        for scene_name in ("plane", "sphere"):
            frames, truth = render(make_scene(scene_name, PRESET), PRESET.rig, ps, s, progress=False)
            base = None
            for how in (None, "disagreement"):
                d = decode(frames, ps, rig=PRESET.rig, options=DecodeOptions(compensate=how))
                ph, mm = errors(d.wrapped["v"], truth)
                base = ph if base is None else base
                gain = f"  ({base / max(ph, 1e-12):6.1f}x lower)" if how else ""
                print(f"decode {curve:9s} {scene_name:6s} 3-step 3-freq {how or 'raw':12s} phase {ph:.5f} rad  "
                      f"3D {mm:.5f} mm  valid {d.mask['v'][truth.mask].mean():.3f}{gain}")


def main() -> None:
    for curve in ("gamma 2.2", "knee"):
        lut, err = measure_response(curve)
        print(f"{curve}: response round trip, worst |measured - true| = {err:.3f} grey levels")
        table(curve, lut)
    decode_rows()
    for curve in ("gamma 2.2", "linear"):
        frames, truth = capture("plane", 4, curve)
        r = diagnose(frames, truth.mask, period=PERIOD)
        print(f"diagnostic, {curve} 4-step plane: nonlinear={r.nonlinear} gamma={r.gamma:.3f} "
              f"ripple {r.ripple_rad:.4f} rad = {r.ripple_px} px; fix: {r.fix}")


if __name__ == "__main__":
    main()
