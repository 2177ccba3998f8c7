"""Out-of-focus projector calibration (dissertation ch. 2.2.4-2.3.2, Fig. 2.15-2.16).

The macro rig is calibrated through the phase domain with the projector in focus, slightly
and strongly defocused (squared binary fringes, which defocus turns into sinusoids); each
calibration then measures a sphere under the same defocus. Because a defocused projector's
OTF is real and symmetric (Eq. 2.26-2.29) the phase - and so the calibration - does not
depend on the defocus: the three sphere RMS figures should agree.
"""
from __future__ import annotations

import numpy as np

from fringe3d.analyze.fits import fit_sphere, inner_mask, robust_fit
from fringe3d.calibrate.evaluation import measure_points
from fringe3d.calibrate.session import calibrate_observations, observe_session
from fringe3d.optics.defocus import fundamental_contrast
from fringe3d.patterns import sets
from fringe3d.sim import presets
from fringe3d.sim.calibration_session import (
    SessionOptics,
    render_and_decode,
    scaled_camera,
    simulate_session,
)
from fringe3d.sim import Scene, Sphere
from fringe3d.utils.console import track

NAME = "defocus-calibration"
SUMMARY = "calibrate the macro rig with an in-focus / slightly / strongly defocused projector; sphere RMS per level"

DISSERTATION = {"sphere RMS (um), in focus / slightly / greatly defocused": "71 / 77 / 73",
                "volume": "150 x 250 x 200 mm"}
#: Gaussian projector blur sigma (projector px). 0.5: the squared binary T=18 stays binary; 1.5: its
#: 3rd harmonic is damped to 29%; 3.0: to 0.7% (the fringes look sinusoidal, Fig. 2.15(c)).
LEVELS = (("in focus", 0.5), ("slightly defocused", 1.5), ("strongly defocused", 3.0))


def sphere_scene(preset):
    c = preset.center
    return Scene([Sphere(center=c, radius=40.0, albedo=0.8)]), c, 40.0


def sphere_rms(rig, dirs, truth):
    """Robust sphere fit of the points a rig reconstructs from decoded directions: (rms mm,
    radius mm, dropped fraction)."""
    pts = measure_points(rig, dirs)
    ok = inner_mask(truth.mask) & np.all(np.isfinite(pts), -1)
    fit, _, dropped = robust_fit(fit_sphere, pts, ok)
    return fit.rms, fit.radius, dropped


def run(quick: bool = False, seed: int = 0) -> dict:
    preset = presets.get("macro")
    scale = 0.25 if quick else 0.5
    n_poses = 4 if quick else 10
    rig_true = scaled_camera(preset.rig, scale)
    patterns = sets.binary_fine_calibration(rig_true.projector.width, rig_true.projector.height)
    scene, centre, radius = sphere_scene(preset)
    cals, meas = [], []
    for k, (_label, sigma) in enumerate(track(LEVELS, "defocus levels")):
        ss = simulate_session(preset, n_poses=n_poses, seed=seed, patterns=patterns, progress=False,
                              optics=SessionOptics(camera_scale=scale, defocus=sigma))
        obs, info = observe_session(ss.poses, ss.board, progress=False)
        cal, _ = calibrate_observations(obs, info, ss.board)
        s = preset.settings.replace(defocus="gaussian", defocus_size=sigma, seed=seed * 7919 + 17 + k)
        _, truth, dirs = render_and_decode(scene, rig_true, patterns, s)
        cals.append((cal, len(obs)))
        meas.append((truth, dirs))
    # the slightly defocused sphere once more without sensor noise: what is left is calibration error
    clean = preset.settings.replace(defocus="gaussian", defocus_size=LEVELS[1][1], shot_noise=False, read_noise=0.0,
                                    bit_depth=16)
    _, truth_c, dirs_c = render_and_decode(scene, rig_true, patterns, clean)
    contrast = np.array([fundamental_contrast(sigma) for _, sigma in LEVELS])
    rows, own, common = [], [], []
    for k, ((label, sigma), (cal, n_obs)) in enumerate(zip(LEVELS, cals)):
        rms_own, r_own, dropped = sphere_rms(cal.rig, meas[k][1], meas[k][0])
        rms_com, _, _ = sphere_rms(cal.rig, meas[1][1], meas[1][0])
        rms_clean, r_clean, _ = sphere_rms(cal.rig, dirs_c, truth_c)
        own.append(1000 * rms_own)
        common.append(1000 * rms_com)
        # noise-limited prediction from the in-focus level: RMS scales with 1 / contrast
        predicted = own[0] * contrast[0] / contrast[k]
        rows.append([label, sigma, n_obs, cal.rms["camera_px"], cal.rms["projector_px"], 1000 * rms_own,
                     float(contrast[k]), float(predicted), 1000 * (r_own - radius), 100 * dropped,
                     1000 * rms_com, 1000 * rms_clean, 1000 * (r_clean - radius)])
    own, common = np.array(own), np.array(common)
    predicted = own[0] * contrast[0] / contrast
    spread_own = float((own.max() - own.min()) / own.min())
    spread_common = float((common.max() - common.min()) / common.min())
    return {
        "tables": [{"title": f"{NAME}: macro rig, squared binary T=18 (9 steps) + sinusoid T=21/144, {n_poses} poses, "
                             f"camera {rig_true.camera.width}x{rig_true.camera.height}, preset camera noise",
                    "columns": ["projector", "defocus sigma (proj px)", "poses", "camera RMS (px)",
                                "projector RMS (px)", "sphere RMS, measured at this defocus (um)",
                                "fringe contrast (T=18 fundamental)", "noise-limited prediction (um)",
                                "radius error (um)", "outliers dropped (%)",
                                "sphere RMS, common frames (slightly defocused) (um)",
                                "sphere RMS, common noise-free frames (um)", "radius error, noise-free (um)"],
                    "rows": rows}],
        "dissertation": DISSERTATION,
        "figures": {"sphere_rms_um": own.tolist(), "spread_fraction": spread_own,
                    "fundamental_contrast": contrast.tolist(), "noise_limited_prediction_um": predicted.tolist(),
                    "sphere_rms_common_frames_um": common.tolist(), "spread_fraction_common_frames": spread_common},
        "goals": {"three levels agree within 15% (each measured at its own defocus)": spread_own <= 0.15,
                  "each sphere RMS <= 73 um (own defocus)": bool(np.all(own <= 73.0)),
                  "own-defocus RMS within 5% of the contrast (noise-limited) prediction":
                      bool(np.all(np.abs(own / predicted - 1) <= 0.05)),
                  "three calibrations agree within 15% (common frames)": spread_common <= 0.15,
                  "each sphere RMS <= 73 um (common frames)": bool(np.all(common <= 73.0))},
        "notes": [f"sphere r = {radius} mm at the volume centre; Gaussian projector defocus (sigma in projector "
                  "pixels); camera noise = macro preset (shot noise at 10,000 e- full well, read noise 0.4% of "
                  "full scale, 8 bit)",
                  "'own defocus': each calibration measures the sphere under its own defocus, so its fringe contrast "
                  "(and phase noise) falls as the blur grows; 'common frames': every calibration reconstructs the "
                  "same measured frames (slightly defocused), isolating the calibration's own accuracy; the noise-free "
                  "columns repeat that without sensor noise, leaving only calibration error",
                  "the measured-at-own-defocus RMS follows the noise-limited prediction RMS(in focus) x "
                  "C(in focus)/C(level), C = exp(-2 pi^2 sigma^2 / T^2): the phase noise grows as the blur eats the "
                  "fringe contrast. Agreement within 15% at one's own defocus would need C(strong) >= 0.87 "
                  "C(in focus), i.e. sigma <= 1.5 px at T = 18, where the squared binary still carries an 11% 3rd "
                  "harmonic (not 'greatly defocused'); the dissertation's flat 71/77/73 um implies an error floor "
                  "independent of defocus that this ideal rig does not have (its noise-free floor is the last column)",
                  "sphere RMS is over all sphere pixels 2 px inside the silhouette (the dissertation used one "
                  "cross section); isolated fringe-order errors (> 5 robust sigma) are dropped before the fit",
                  f"camera rendered at {rig_true.camera.width}x{rig_true.camera.height} (the preset's 1280x1024 "
                  "scaled) to finish within 3 minutes on this machine"]
                 + (["quick variant: 4 poses"] if quick else []),
    }
