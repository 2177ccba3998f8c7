"""Every pattern-set builder, synthesised from known projector coordinates, decodes to the truth.

Pins the manifest contract between the builders and the decoder: frame fields, plans,
angles above pi/2 (negative fringe coordinates), code offsets. (Period-wide Gray codes fail next
to their stripe edges by design: see test_experiment_unwrap_noise.)
"""
import math

import numpy as np
import pytest

from fringe3d.decode import decode
from fringe3d.patterns import sets
from fringe3d.patterns.synthetic import frames_from_coordinates


@pytest.fixture(scope="module")
def coords():
    v, u = np.mgrid[0:96, 0:128].astype(np.float64)
    return 20 + 5.8 * u + 4 * np.sin(v / 9), 15 + 6.0 * v  # projector (u_p, v_p) seen by each camera pixel


def _truth(u_p, v_p, angle, period):
    return 2 * np.pi * (v_p * math.cos(angle) + u_p * math.sin(angle)) / period


@pytest.mark.parametrize("name,build", [
    ("three-frequency v", lambda: sets.three_frequency("v")),
    ("three-frequency h", lambda: sets.three_frequency("h")),
    ("hierarchical", lambda: sets.hierarchical((16, 128, 1024), (4, 3, 3), "v")),
    ("gray T/2", lambda: sets.psp_with_gray_code(20, 4, "h")),
    ("binary code", lambda: sets.psp_with_gray_code(20, 3, "v", code=sets.CodeFrames("binary"))),
    ("calibration", lambda: sets.calibration()),
    ("optimal angle 100 deg", lambda: sets.optimal_angle_calibration(math.radians(100))),
    ("gray at 130 deg", lambda: sets.psp_with_gray_code(24, 4, "d", angle=math.radians(130))),
])
def test_builder_output_decodes_to_the_true_absolute_phase(coords, name, build):
    ps = build()
    u_p, v_p = coords
    frames = frames_from_coordinates(ps, u_p, v_p, a=30, b=180, noise=0.5, rng=np.random.default_rng(3),
                                     dtype=np.uint8)
    d = decode(frames, ps)
    for plan in ps.plans:
        g = d.phase[plan.direction]
        err = g - _truth(u_p, v_p, plan.angle, d.period[plan.direction])
        assert d.mask[plan.direction].all(), name
        assert np.abs(err).max() < 0.1, (name, plan.direction, np.abs(err).max())


@pytest.mark.parametrize("steps", [3, 4, 7])
def test_phase_shift_set_decodes_to_the_wrapped_truth(coords, steps):
    ps = sets.phase_shift(17.3, steps, "x", angle=0.6)
    u_p, v_p = coords
    frames = frames_from_coordinates(ps, u_p, v_p)  # float, no noise
    d = decode(frames, ps)
    err = np.angle(np.exp(1j * (d.wrapped["x"] - _truth(u_p, v_p, 0.6, 17.3))))
    assert np.abs(err).max() < 1e-4


@pytest.mark.parametrize("build", [sets.ftp, sets.modified_ftp])
def test_ftp_sets_decode_to_the_wrapped_truth_away_from_borders(build):
    v, u = np.mgrid[0:128, 0:160].astype(np.float64)
    u_p, v_p = 20 + 2 * u, 15 + 2 * v  # T = 12 projector px = 6 camera px per fringe
    ps = build(12)
    d = decode(frames_from_coordinates(ps, u_p, v_p, dtype=np.uint8), ps)
    err = np.angle(np.exp(1j * (d.wrapped["v"] - 2 * np.pi * u_p / 12)))[16:-16, 16:-16]  # 16 px border
    assert np.sqrt(np.mean(err ** 2)) < 0.01
