"""The simulator's camera blur at the sensor border: the renderer draws a margin beyond the sensor
and crops, so border pixels see the scene beyond the border as a lens brings it, not copies of
the edge pixels (:func:`fringe3d.sim.noise.sense`)."""
from __future__ import annotations

import dataclasses

import numpy as np
from scipy.ndimage import gaussian_filter

from fringe3d.patterns import sets
from fringe3d.sim import presets, render
from fringe3d.sim.noise import blur_margin, sense
from fringe3d.sim.primitives import Plane
from fringe3d.sim.scene import Scene


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
    p = presets.get("tiny")
    ps = sets.phase_shift(18, 3, "v", width=p.rig.projector.width, height=p.rig.projector.height)
    s = p.settings.replace(camera_blur=1.0, shot_noise=False, read_noise=0.0, bit_depth=None)
    scene = Scene([Plane((0, 0, 420.0), (0.2, 0.1, -1.0), albedo=0.8)])
    frames, truth = render(scene, p.rig, ps, s, progress=False)
    m = blur_margin(s)
    cam = p.rig.camera
    K = cam.K.copy()
    K[0, 2] += m
    K[1, 2] += m
    wide = dataclasses.replace(p.rig, camera=dataclasses.replace(cam, K=K, width=cam.width + 2 * m,
                                                                 height=cam.height + 2 * m))
    sharp, wide_truth = render(scene, wide, ps, s.replace(camera_blur=0.0), progress=False)
    expected = np.stack([gaussian_filter(f.astype(np.float64), 1.0)[m:-m, m:-m] for f in sharp])
    assert frames.shape == (3, cam.height, cam.width)
    assert np.abs(frames - expected).max() < 1e-5
    assert np.array_equal(truth.depth, wide_truth.depth[m:-m, m:-m], equal_nan=True)  # truth: the sensor's pixels
