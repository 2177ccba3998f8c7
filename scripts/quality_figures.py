"""Issue 15 figures: edge / mixed-pixel masking and the predicted per-point uncertainty.

On the macro rig (camera scaled to 320 x 256, same field of view), blurred projector
(Gaussian defocus sigma 2 px), the preset's sensor noise (shot noise + 0.4 % read noise, 8 bit):

* a tilted plane (30 deg about y, z = 500 mm) that does not fill the projector (its left
  border is in view): residual RMS to the true plane of the points in the projector-edge band
  (true ``u_p`` within the margin of the border) without and with the edge mask; flatness
  (VDI/VDE 2634-2 ``F``, range of residuals) with the defaults vs on clean pixels only; the
  largest distance of a kept point from the true plane;
* a sphere (r = 40 mm, z = 450 mm) 70 mm in front of a plane, with a 0.5 px camera blur (the
  simulator samples each pixel at its centre; the blur mixes neighbouring pixels as a real pixel
  footprint and lens do, which makes mixed silhouette / shadow-edge pixels): ``P_F`` and fit RMS
  with the defaults, without the mask, and on clean pixels (true object = sphere, 3 px inside its
  silhouette and shadow), with the preset's noise and noise-free (16 bit);
* predicted ``sigma_z`` vs the observed per-pixel spread of z over ``--seeds`` noise seeds
  (the noiseless irradiance is rendered once; each seed runs the simulator's sensor model), for
  the three-frequency set (noise from the 9-step fit residual), three 3-step groups (noise from
  the groups' averages) and one 3-step group on the fused path (Laplacian of the average).

The plane uses no camera blur (the simulator once padded the blurred image with its edge values,
biasing the outermost column; it now renders a margin beyond the sensor and crops).

Run: ``PYTHONPATH=src python scripts/quality_figures.py --seeds 20`` (prints one JSON).
"""
from __future__ import annotations

import argparse
import json
import math

import numpy as np
from scipy import ndimage

from fringe3d.analyze.vdi import flatness, probing_errors
from fringe3d.decode import DecodeOptions
from fringe3d.patterns import sets
from fringe3d.reconstruct.sequence import FrameReconstructor, reconstruction_plans
from fringe3d.sim import presets, render
from fringe3d.sim.calibration_session import scaled_camera
from fringe3d.sim.noise import sense
from fringe3d.sim.primitives import Plane, Sphere
from fringe3d.sim.scene import Scene

TILT = 0.3
Z_PLANE = 500.0
NORMAL = np.array([math.sin(TILT), 0.0, -math.cos(TILT)])


def setup(scale: float = 0.25, defocus: float = 2.0):
    """(rig, patterns, noisy settings) of the figures."""
    p = presets.get("macro")
    rig = scaled_camera(p.rig, scale)
    ps = sets.three_frequency("v", width=rig.projector.width, height=rig.projector.height)
    return rig, ps, p.settings.replace(defocus_size=defocus)


def irradiance(scene, rig, ps, settings):
    """Noiseless float frames (F, H, W) and the truth."""
    clean = settings.replace(shot_noise=False, read_noise=0.0, bit_depth=None)
    return render(scene, rig, ps, clean, progress=False)


def noisy(irr: np.ndarray, settings, seed: int) -> np.ndarray:
    """The simulator's sensor model (shot + read noise, quantisation) applied with ``seed``;
    not the camera blur again (:func:`irradiance`'s render already applied it)."""
    s = settings.replace(seed=seed, camera_blur=0.0)
    return np.stack([sense(irr[k], s, k) for k in range(irr.shape[0])])


def reconstruct_both(rig, ps, settings, frames):
    """(with the default masks, without the edge / mixed-pixel masks) :class:`Cycle` s of ``frames``."""
    on = FrameReconstructor(ps, rig, DecodeOptions(bit_depth=settings.bit_depth)).reconstruct(frames, False)
    off = FrameReconstructor(ps, rig, DecodeOptions(bit_depth=settings.bit_depth, edge_mask=False))
    return on, off.reconstruct(frames, False)


def plane_scene():
    return Scene([Plane((0.0, 0.0, Z_PLANE), NORMAL, albedo=0.8)])


def plane_distance(pts: np.ndarray) -> np.ndarray:
    """(H, W) signed distance (mm) of points to the true plane, NaN invalid."""
    return (pts.astype(np.float64) - [0.0, 0.0, Z_PLANE]) @ NORMAL


def plane_figures(rig, ps, settings, seed: int = 1) -> dict:
    irr, truth = irradiance(plane_scene(), rig, ps, settings)
    frames = noisy(irr, settings, seed)
    on, off = reconstruct_both(rig, ps, settings, frames)
    up = np.asarray(truth.up, np.float64)
    lo, hi = -0.5, rig.projector.width - 0.5
    margin = 6.0  # 2 px + 2 sigma_b for the 2 px blur
    band = ((up < lo + margin) | (up > hi - margin)) & np.isfinite(up)
    d_on, d_off = plane_distance(on.points), plane_distance(off.points)
    clean = (up > lo + 10) & (up < hi - 10)
    clean &= ndimage.binary_erosion(np.isfinite(d_off), iterations=3)
    clean_pts = np.where(clean[..., None], off.points, np.nan)

    def rms(d, m):
        v = d[m & np.isfinite(d)]
        return float(np.sqrt(np.mean(v ** 2))) if v.size else None

    f_on, f_off, f_clean = flatness(on.points), flatness(off.points), flatness(clean_pts)
    return {"band_points_without_mask": int((band & np.isfinite(d_off)).sum()),
            "band_rms_without_mask": rms(d_off, band),
            "band_points_with_mask": int((band & np.isfinite(d_on)).sum()),
            "band_rms_with_mask": rms(d_on, band),
            "flatness_default": f_on.flatness, "flatness_no_mask": f_off.flatness,
            "flatness_clean": f_clean.flatness, "flatness_ratio": f_on.flatness / f_clean.flatness,
            "max_distance_default": float(np.nanmax(np.abs(d_on))),
            "max_distance_no_mask": float(np.nanmax(np.abs(d_off))),
            "points_default": int(np.isfinite(d_on).sum()), "points_no_mask": int(np.isfinite(d_off).sum())}


def sphere_scene():
    return Scene([Sphere((0.0, 0.0, 450.0), 40.0, albedo=0.8), Plane((0.0, 0.0, 520.0), (0, 0, -1), albedo=0.8)])


def sphere_figures(rig, ps, settings, seed: int = 1) -> dict:
    settings = settings.replace(camera_blur=0.5)
    irr, truth = irradiance(sphere_scene(), rig, ps, settings)
    frames = noisy(irr, settings, seed)
    on, off = reconstruct_both(rig, ps, settings, frames)
    sphere = np.asarray(truth.object_id) == 0
    lit = np.asarray(truth.mask, bool)
    clean = ndimage.binary_erosion(sphere & lit & np.isfinite(off.points[..., 0]), iterations=3)
    out = {}
    for name, pts, m in (("default", on.points, sphere), ("no_mask", off.points, sphere), ("clean", off.points, clean)):
        f = probing_errors(pts, m & np.isfinite(pts[..., 0]))
        out[name] = {"P_F": f.form, "rms": f.rms, "n": f.n_points, "ratio_PF_rms": f.form / f.rms}
    return out


def sigma_figures(rig, ps, settings, seeds: int, z_min: float | None = None) -> dict:
    """Predicted vs observed depth spread on the tilted plane over ``seeds`` noise seeds."""
    irr, _ = irradiance(plane_scene(), rig, ps, settings)
    rec = FrameReconstructor(ps, rig, DecodeOptions(bit_depth=settings.bit_depth, z_min=z_min))
    zs, sig = [], []
    for s in range(seeds):
        c = rec.reconstruct(noisy(irr, settings, 100 + s))
        zs.append(c.points[..., 2])
        sig.append(c.sigma_xyz[..., 2])
    z, sz = np.stack(zs).astype(np.float64), np.stack(sig).astype(np.float64)
    ok = np.isfinite(z).all(axis=0) & np.isfinite(sz).all(axis=0)
    observed = z[:, ok].std(axis=0, ddof=1)
    predicted = np.sqrt(np.mean(sz[:, ok] ** 2, axis=0))
    return {"seeds": seeds, "pixels": int(ok.sum()), "path": rec.path,
            "observed_rms_sigma_z": float(np.sqrt(np.mean(observed ** 2))),
            "predicted_rms_sigma_z": float(np.sqrt(np.mean(predicted ** 2))),
            "ratio": float(np.sqrt(np.mean(observed ** 2) / np.mean(predicted ** 2))),
            "median_pixel_ratio": float(np.median(observed / predicted))}


def three_step_sets(rig):
    """(three 3-step groups, hierarchical 16/128/1024: noise from the groups' averages) and
    (one 3-step T=144 group, geometric constraint from z_min = 420 mm, the fused path: noise
    from the Laplacian of the average image)."""
    w, h = rig.projector.width, rig.projector.height
    hier = sets.hierarchical((16, 128, 1024), (3, 3, 3), "v", width=w, height=h)
    single = reconstruction_plans(sets.phase_shift(144, 3, "v", width=w, height=h), "geometric")
    return hier, single


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--scale", type=float, default=0.25)
    a = ap.parse_args()
    rig, ps, st = setup(a.scale)
    hier, single = three_step_sets(rig)
    quiet = st.replace(shot_noise=False, read_noise=0.0, bit_depth=16)
    print(json.dumps({"plane": plane_figures(rig, ps, st), "sphere": sphere_figures(rig, ps, st),
                      "sphere_noise_free": sphere_figures(rig, ps, quiet),
                      "sigma_z": sigma_figures(rig, ps, st, a.seeds),
                      "sigma_z_three_3step_groups": sigma_figures(rig, hier, st, a.seeds),
                      "sigma_z_single_3step": sigma_figures(rig, single, st, a.seeds, z_min=420.0)}, indent=1))


if __name__ == "__main__":
    main()
