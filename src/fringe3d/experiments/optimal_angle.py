"""Optimal fringe angle calibration in a "well-designed" rig (ch. 2.2.1 (3), 2.2.5, Fig. 2.18-2.19).

With an (almost) horizontal baseline, horizontal fringes barely see depth. The optimal angle
alpha_opt is measured from a step-height block on a reference plane (Eq. 2.5-2.7) and
compared with the rig's true epipolar direction; the rig is then calibrated once with
horizontal/vertical fringes and once with fringes at alpha_opt -/+ pi/4 (Eq. 2.32-2.34), and
each calibration measures a sphere with its own patterns: RMS of the two orthogonal cross
sections through the sphere centre (row and column of the point map).
"""
from __future__ import annotations

import numpy as np

from fringe3d.analyze.fits import fit_sphere, inner_mask, robust_fit
from fringe3d.analyze.sections import sphere_sections
from fringe3d.calibrate.evaluation import measure_points
from fringe3d.calibrate.optimal_angle import epipolar_angle, optimal_angle
from fringe3d.calibrate.session import calibrate_observations, observe_session
from fringe3d.patterns import sets
from fringe3d.sim import presets
from fringe3d.sim.calibration_session import (
    SessionOptics,
    render_and_decode,
    scaled_camera,
    simulate_session,
)
from fringe3d.sim import Box, Plane, Scene, Sphere

NAME = "optimal-angle"
SUMMARY = "well-designed rig: alpha_opt from a step height; alpha_opt -/+ pi/4 vs H/V calibration, sphere sections"

DISSERTATION = {"sphere cross-section RMS, H/V patterns (um)": "111 / 86.0",
                "sphere cross-section RMS, alpha_opt -/+ pi/4 (um)": "69.0 / 72.7",
                "improvement in the worse section": "38%", "volume": "300 x 250 x 500 mm"}


def step_scenes(preset):
    """Reference plane and the same plane with a 30 mm step block, at the volume centre."""
    c = preset.center
    z_plane = c[2] + 60.0
    ref = Scene([Plane([0, 0, z_plane], [0, 0, -1], albedo=0.8)])
    obj = Scene([Plane([0, 0, z_plane], [0, 0, -1], albedo=0.8),
                 Box(center=[c[0], c[1], z_plane - 15.0], size=[120.0, 120.0, 30.0], albedo=0.8)])
    return ref, obj, np.array([c[0], c[1], z_plane - 30.0])


def measure_alpha(preset, rig, settings, seed):
    ps = sets.calibration(width=rig.projector.width, height=rig.projector.height)
    ref, obj, top = step_scenes(preset)
    maps = {}
    for name, scene, k in (("ref", ref, 1), ("obj", obj, 2)):
        _, _, dirs = render_and_decode(scene, rig, ps, settings.replace(seed=seed * 7919 + k))
        maps[name] = {("v" if d.angle > 1 else "h"): d.phase for d in dirs}
    res = optimal_angle(maps["obj"]["h"], maps["ref"]["h"], maps["obj"]["v"], maps["ref"]["v"])
    return res, top


def sections_rms(points, mask):
    """RMS (mm) of the circle fits of the row and the column through the sphere centre."""
    sec = sphere_sections(points, mask)
    return sec["row"].fit.rms, sec["column"].fit.rms, sec["sphere"].rms


def run(quick: bool = False, seed: int = 0) -> dict:
    preset = presets.get("well-designed")
    scale = 0.25 if quick else 1.0
    n_poses = 4 if quick else 10
    rig_true = scaled_camera(preset.rig, scale)
    settings = preset.settings
    est, top = measure_alpha(preset, rig_true, settings, seed)
    alpha_true = epipolar_angle(rig_true, top)
    alpha_err = float(np.degrees(abs((est["alpha_opt"] - alpha_true + np.pi / 2) % np.pi - np.pi / 2)))
    W, H = rig_true.projector.width, rig_true.projector.height
    variants = (("H/V", sets.calibration(width=W, height=H)),
                ("alpha_opt -/+ pi/4", sets.optimal_angle_calibration(est["alpha_opt"], width=W, height=H)))
    sphere = Scene([Sphere(center=preset.center, radius=50.0, albedo=0.8)])
    rows, worse = [], {}
    for k, (label, ps) in enumerate(variants):
        ss = simulate_session(preset, n_poses=n_poses, seed=seed, patterns=ps, progress=False,
                              optics=SessionOptics(camera_scale=scale))
        obs, info = observe_session(ss.poses, ss.board, progress=False)
        cal, _ = calibrate_observations(obs, info, ss.board)
        _, truth, dirs = render_and_decode(sphere, rig_true, ps, settings.replace(seed=seed * 7919 + 11 + k))
        pts = measure_points(cal.rig, dirs)
        ok = inner_mask(truth.mask) & np.all(np.isfinite(pts), -1)
        _, used, dropped = robust_fit(fit_sphere, pts, ok)
        r_row, r_col, r_all = sections_rms(pts, used)
        worse[label] = max(r_row, r_col)
        rows.append([label, len(obs), cal.rms["camera_px"], cal.rms["projector_px"], 1000 * r_row, 1000 * r_col,
                     1000 * r_all, 100 * dropped])
    gain = 1.0 - worse["alpha_opt -/+ pi/4"] / worse["H/V"]
    return {
        "tables": [
            {"title": f"{NAME}: optimal fringe angle from a 30 mm step (Eq. 2.5-2.7)",
             "columns": ["figure", "value"],
             "rows": [["dPhi_h (rad)", est["dphi_h"]], ["dPhi_v (rad)", est["dphi_v"]],
                      ["alpha_opt measured (deg)", float(np.degrees(est["alpha_opt"]))],
                      ["alpha_opt true, epipolar direction (deg)", float(np.degrees(alpha_true))],
                      ["error (deg)", alpha_err]]},
            {"title": f"{NAME}: sphere r=50 mm measured with each calibration ({n_poses} poses, camera "
                      f"{rig_true.camera.width}x{rig_true.camera.height}, preset noise)",
             "columns": ["patterns", "poses", "camera RMS (px)", "projector RMS (px)", "row section RMS (um)",
                         "column section RMS (um)", "sphere-fit RMS (um)", "outliers dropped (%)"],
             "rows": rows}],
        "dissertation": DISSERTATION,
        "figures": {"alpha_opt_deg": float(np.degrees(est["alpha_opt"])),
                    "alpha_true_deg": float(np.degrees(alpha_true)),
                    "alpha_error_deg": alpha_err, "worse_section_gain": gain},
        "goals": {"alpha_opt within 2 deg of truth": alpha_err <= 2.0,
                  ">= 38% lower RMS in the worse section": gain >= 0.38},
        "notes": ["well-designed preset: baseline 4 deg out of the horizontal, so horizontal fringes are nearly "
                  "depth-blind; both calibrations use the same board poses and the 18/21/144 three-frequency set",
                  "each calibration measures the sphere with its own fringe directions; (u_p, v_p) from the two "
                  "phases by the Eq. 2.32-2.34 rotation, least-squares triangulation (Eq. 2.37)",
                  "in this ideal rig the two pattern pairs are information-equivalent: with equal independent phase "
                  "noise per direction, (u_p, v_p) from any two orthogonal fringe angles has covariance "
                  "sigma_w^2 I (tests/test_calibrate_phase_mapping.py), and the defocus OTF moves no phase at any "
                  "angle; so both calibrations and both sphere measurements agree within their noise. The "
                  "dissertation's 38% gain (3 board poses, a real DLP projector) needs an effect this model leaves "
                  "out; the experiment reproduces alpha_opt and the Eq. 2.32-2.34 pipeline, not that gain"]
                 + (["quick variant: 320x256 camera, 4 poses"] if quick else []),
    }
