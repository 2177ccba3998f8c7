"""Motion-induced error of phase shifting (dissertation ch. 5.2.4, Fig. 5.3).

A sphere moves by 2% of its diameter along y for every captured frame while a two-frequency
phase-shifting sequence is projected (``patterns.sets.two_frequency``): 3-step low frequency
(T = 54 px) unwrapped by the geometric constraint (Eq. 4.21, z_min just in front of the
sphere), then 3-step high frequency (T = 18 px) unwrapped by the low one (Eq. 1.5). Phase
shifting assumes a static object, so the moving sphere's reconstruction shows a periodic error
(at the fringe frequency and its double, like a phase-shift error); a static sphere rendered
with the same noise gives the noise floor.

Errors are measured against the simulator's truth at the middle high-frequency frame: the
phase error (rad) of the unwrapped high-frequency phase, and the 3D error (mm) of the
triangulated point, as its distance to the true sphere surface at that instant.
"""
from __future__ import annotations

import numpy as np

from fringe3d.patterns import sets
from fringe3d.patterns.conventions import coarse_to_fine_order, phase_to_w
from fringe3d.phase.psp import wrapped_phase
from fringe3d.reconstruct.triangulate import triangulate
from fringe3d.sim import presets, render
from fringe3d.sim import Scene, Sphere
from fringe3d.unwrap.geometric import geometric_unwrap, minimum_phase

NAME = "motion-error"
SUMMARY = "ch. 5.2.4: sphere moving 2% of its diameter per frame, two-frequency PSP -> periodic error"

HIGH, LOW = 18.0, 54.0
STEP = 0.02  # fraction of the diameter moved per frame


def _patterns(width, height):
    return sets.two_frequency(HIGH, LOW, "v", width=width, height=height)


def measure(preset, radius: float, step_fraction: float, seed: int, progress: bool = False) -> dict:
    """Render the sphere moving ``step_fraction`` of its diameter per frame; decode; compare."""
    proj = preset.rig.projector
    ps = _patterns(proj.width, proj.height)
    # as in the dissertation, motion is the only error source: no shot or read noise (the
    # static floor is then 8-bit quantisation, projector pixelation and defocus)
    s = preset.settings.replace(seed=seed, shot_noise=False, read_noise=0.0)
    lo = ps.indices(group=ps.groups("v")[0])
    hi = ps.indices(group=ps.groups("v")[1])
    assert ps.frames[hi[0]].period == HIGH and ps.frames[lo[0]].period == LOW
    ref = hi[1]  # truth at the middle high-frequency frame
    v = np.array([0.0, step_fraction * 2 * radius * s.frame_rate, 0.0])  # mm/s along y
    c0 = preset.center - v * ref / s.frame_rate  # the sphere is at the volume centre at frame ``ref``
    scene = Scene([Sphere(c0, radius, velocity=v)], name="moving-sphere")
    frames, truth = render(scene, preset.rig, ps, s, progress=progress)
    ph_hi = wrapped_phase(frames, index=hi)
    ph_lo = wrapped_phase(frames, index=lo)
    z_min = float(preset.center[2] - radius - 5.0)
    Phi_lo, _ = geometric_unwrap(ph_lo.phase, minimum_phase(preset.rig, z_min, LOW), check=False)
    k = coarse_to_fine_order(Phi_lo, ph_hi.phase, LOW / HIGH)
    Phi = ph_hi.phase + 2 * np.pi * k  # Eq. (1.5)
    t_ref = truth.frame(ref) if truth.per_frame else truth
    seen = truth.mask.all(axis=0) if truth.per_frame else truth.mask
    full = 2.0**s.bit_depth - 1 if s.bit_depth else 1.0
    mask = seen & (ph_hi.modulation > 0.05 * full) & (ph_lo.modulation > 0.05 * full) & np.isfinite(Phi)
    dphi_all = (Phi - t_ref.phase["v"])[mask].astype(float)
    good = np.abs(dphi_all) < np.pi  # right fringe order
    X = triangulate(preset.rig, up=np.where(mask, phase_to_w(Phi, HIGH, scale_first=False), np.nan))
    c_ref = preset.center
    radial_all = np.linalg.norm(X[mask].astype(float) - c_ref, axis=1) - radius
    dphi, radial = dphi_all[good], radial_all[good]
    err_map = np.full(mask.shape, np.nan)
    err_map[mask] = np.where(good, dphi_all, np.nan)
    fraction, amp1, amp2 = periodic_part(err_map, t_ref.phase["v"].astype(float))
    radial_map = np.full(mask.shape, np.nan)
    radial_map[mask] = np.where(good, radial_all, np.nan)
    return {"phase_rms": float(np.sqrt(np.mean(dphi**2))), "rms_mm": float(np.sqrt(np.mean(radial**2))),
            "section": cross_section(radial_map, err_map, preset.rig.camera.project(c_ref[None])[0]),
            "rms_all_mm": float(np.sqrt(np.mean(radial_all**2))), "amp_1x": amp1, "amp_2x": amp2,
            "periodic_fraction": fraction, "pixels": int(mask.sum()), "order_errors": int((~good).sum())}


def cross_section(radial_map, phase_map, centre_px, samples: int = 25) -> list[list]:
    """Rows ``[column, 3D error (mm), phase error (rad)]`` along the image row through the
    sphere centre (Fig. 5.3 h-i), ``samples`` columns evenly across the sphere."""
    row = int(round(centre_px[1]))
    cols = np.flatnonzero(np.isfinite(radial_map[row]))
    if cols.size == 0:
        return []
    pick = np.unique(np.linspace(cols[0], cols[-1], samples).round().astype(int))
    return [[int(c), float(radial_map[row, c]), float(phase_map[row, c])] for c in pick]


def periodic_part(err: np.ndarray, Phi: np.ndarray) -> tuple[float, float, float]:
    """How much of a phase-error map oscillates with the fringes.

    In tiles two camera fringe periods wide, fit ``err ~ a + b cos(Phi) + c sin(Phi) +
    d cos(2 Phi) + e sin(2 Phi)`` (Phi = true absolute phase). Returns the fraction of the error
    variance about the tile means carried by the harmonic terms, and the RMS amplitudes of the
    1x and 2x terms (rad).
    """
    gy, gx = np.gradient(Phi)
    g = np.hypot(gx, gy)[np.isfinite(err)]
    g = g[np.isfinite(g) & (g > 0)]
    tile = int(np.clip(2 * 2 * np.pi / np.median(g), 8, 64)) if g.size else 16
    H, W = err.shape
    num = den = 0.0
    a1, a2, n = [], [], 0
    for y in range(0, H, tile):
        for x in range(0, W, tile):
            e = err[y:y + tile, x:x + tile].ravel()
            p = Phi[y:y + tile, x:x + tile].ravel()
            ok = np.isfinite(e) & np.isfinite(p)
            if ok.sum() < 20:
                continue
            e, p = e[ok], p[ok]
            A = np.stack([np.ones_like(p), np.cos(p), np.sin(p), np.cos(2 * p), np.sin(2 * p)], 1)
            c = np.linalg.lstsq(A, e, rcond=None)[0]
            num += float(np.sum((A[:, 1:] @ c[1:]) ** 2))
            den += float(np.sum((e - e.mean()) ** 2))
            a1.append(np.hypot(c[1], c[2]))
            a2.append(np.hypot(c[3], c[4]))
            n += 1
    if n == 0 or den == 0:
        return 0.0, 0.0, 0.0
    return num / den, float(np.sqrt(np.mean(np.square(a1)))), float(np.sqrt(np.mean(np.square(a2))))


def run(quick: bool = False, seed: int = 0) -> dict:
    preset = presets.get("tiny" if quick else "macro")
    radius = 0.3 * float(min(preset.size[0], preset.size[1]))
    moving = measure(preset, radius, STEP, seed)
    static = measure(preset, radius, 0.0, seed)
    ratio = moving["rms_mm"] / static["rms_mm"] if static["rms_mm"] > 0 else float("inf")
    rows = []
    for label, m in (("static sphere", static), ("moving 2% of D per frame", moving)):
        rows.append([label, m["pixels"], m["phase_rms"], m["amp_1x"], m["amp_2x"], m["periodic_fraction"],
                     m["rms_mm"], m["order_errors"], m["rms_all_mm"]])
    return {
        "tables": [{"title": f"motion-induced error, {preset.name} rig, sphere D = {2 * radius:.0f} mm, "
                             f"two-frequency PSP (T = {HIGH:g} / {LOW:g} px, 3 + 3 steps, geometric constraint)",
                    "columns": ["case", "pixels", "phase RMS (rad)", "1x-fringe amplitude (rad)",
                                "2x-fringe amplitude (rad)", "periodic fraction", "3D RMS (mm)",
                                "fringe-order errors", "3D RMS incl. order errors (mm)"],
                    "rows": rows},
                   {"title": "cross-section through the moving sphere's centre row (cf. Fig. 5.3 h-i)",
                    "columns": ["image column", "3D error (mm)", "phase error (rad)"],
                    "rows": moving["section"]}],
        "dissertation": {"motion": "sphere moves 2% of its diameter per frame (10% over six patterns)",
                         "result": "periodic structural error on the sphere surface (Fig. 5.3 h-i)"},
        "goals": {"moving RMS >= 5x static RMS": bool(ratio >= 5.0),
                  "error is periodic (>= 50% of its local variance at 1x/2x the fringe frequency)":
                      bool(moving["periodic_fraction"] >= 0.5)},
        "figures": {"moving_rms_mm": moving["rms_mm"], "static_rms_mm": static["rms_mm"], "ratio": ratio,
                    "moving_phase_rms_rad": moving["phase_rms"], "static_phase_rms_rad": static["phase_rms"],
                    "periodic_fraction": moving["periodic_fraction"]},
        "notes": [f"RMS ratio moving / static = {ratio:.1f}",
                  "3D error = distance of the triangulated point to the true sphere at the middle "
                  "high-frequency frame; phase error against the truth phase at that frame; RMS and "
                  "periodic fraction over pixels with the right fringe order (order errors counted apart)",
                  f"render settings: {preset.name} preset without shot/read noise (motion is the only "
                  f"error source, as in the dissertation's simulation): {preset.settings.bit_depth}-bit, "
                  f"projector defocus {preset.settings.defocus} {preset.settings.defocus_size:g} px; seed {seed}"],
    }
