"""The simulator's camera blur at the sensor border: the renderer draws a margin beyond the sensor
and crops, so border pixels see the scene beyond the border as a lens brings it, not copies of
the edge pixels (:func:`fringe3d.sim.noise.sense`)."""
from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np

from fringe3d.patterns import sets
from fringe3d.sim import presets, render
from fringe3d.sim.noise import blur_margin, sense
from fringe3d.sim.primitives import Plane
from fringe3d.sim.scene import Scene

SCRIPT = Path(__file__).resolve().parents[1] / "scripts" / "border_figures.py"


def test_a_linear_ramp_stays_linear_up_to_the_border():
    s = presets.get("tiny").settings.replace(camera_blur=1.5, shot_noise=False, read_noise=0.0, bit_depth=None)
    m = blur_margin(s)
    assert m == 6  # round(4 sigma): scipy's kernel radius
    v, u = np.mgrid[-m:40 + m, -m:50 + m].astype(float)
    ramp = 0.2 + 0.01 * u + 0.004 * v      # a Gaussian blur leaves a linear function unchanged
    out = sense(ramp, s, 0, m)
    assert out.shape == (40, 50)
    assert np.abs(out - ramp[m:-m, m:-m]).max() < 1e-6
    uniform = sense(np.full((40 + 2 * m, 50 + 2 * m), 0.3), s, 0, m)
    assert np.abs(uniform - 0.3).max() < 1e-6
    # without the margin the edge pixels are copied outward: the border is biased by
    # slope * sigma / sqrt(2 pi) (the mean of max(x, 0) under the kernel), here 0.006
    biased = sense(ramp[m:-m, m:-m], s, 0)
    assert abs((biased - ramp[m:-m, m:-m])[20, 0] - 0.01 * 1.5 / np.sqrt(2 * np.pi)) < 5e-4


def test_blurred_render_equals_the_unblurred_render_of_a_wider_sensor_blurred_and_cropped():
    """scripts/border_figures.py: tiny rig, tilted plane, T = 18 px 3-step, camera blur 1 px."""
    spec = importlib.util.spec_from_file_location("border_figures", SCRIPT)
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    f = mod.camera_blur_border_figures()
    assert f["after"]["intensity_error_border"] < 1e-5 and f["after"]["intensity_error_inside"] < 1e-5
    assert f["after"]["phase_error_border_rad"] < 1e-5
    assert f["before"]["phase_error_border_rad"] > 0.05  # edge padding: a real bias of the former model


def test_the_truth_holds_the_sensor_pixels_only():
    p = presets.get("tiny")
    ps = sets.phase_shift(18, 3, "v", width=p.rig.projector.width, height=p.rig.projector.height)
    scene = Scene([Plane((0, 0, 420.0), (0.2, 0.1, -1.0), albedo=0.8)])
    s = p.settings.replace(shot_noise=False, read_noise=0.0, bit_depth=None)
    frames, blurred = render(scene, p.rig, ps, s.replace(camera_blur=1.0), progress=False)
    _, sharp = render(scene, p.rig, ps, s, progress=False)
    assert frames.shape == (3, p.rig.camera.height, p.rig.camera.width)
    assert np.array_equal(blurred.depth, sharp.depth, equal_nan=True)
    assert np.array_equal(blurred.up, sharp.up, equal_nan=True)
