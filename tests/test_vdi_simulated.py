"""VDI/VDE 2634-2-style figures on simulated artefacts agree with the simulator's truth.

Sphere pair (ball bar) and plane rendered by the virtual rig with sensor noise (8-bit, read
noise), decoded (9-step T=18 + hierarchical 90/300) and triangulated; six seeds. Size and
spacing errors must centre on zero; form and flatness must match the range of the measured
points' own errors against the true surfaces (i.e. come from the noise, not from a bias).
"""
from __future__ import annotations

import numpy as np
import pytest

from fringe3d.analyze.fits import fit_plane
from fringe3d.analyze.vdi import flatness, probing_errors, sphere_spacing
from fringe3d.decode import decode
from fringe3d.patterns import sets
from fringe3d.reconstruct import points_from_decoded
from fringe3d.sim import render
from fringe3d import sim as sc
from fringe3d.sim.presets import get

SEEDS = range(6)


def measure(scene, seed):
    p = get("tiny")
    ps = sets.hierarchical((18, 90, 300), (9, 3, 3), "v", width=256, height=200)
    frames, truth = render(scene, p.rig, ps, p.settings.replace(read_noise=0.004, seed=seed), progress=False)
    P = points_from_decoded(decode(frames, ps), p.rig)
    return P, truth


@pytest.fixture(scope="module")
def ball_bar_runs():
    scene = sc.Scene([sc.Sphere([-45.0, 0.0, 400.0], 25.0), sc.Sphere([45.0, 5.0, 410.0], 25.0)])
    return [measure(scene, s) for s in SEEDS]


@pytest.fixture(scope="module")
def plane_runs():
    scene = sc.Scene([sc.Plane([0.0, 0.0, 420.0], [0.1, 0.05, -1.0])])
    return [measure(scene, s) for s in SEEDS]


def centred_on_zero(x):
    x = np.asarray(x)
    return abs(x.mean()) < 3 * x.std(ddof=1) / np.sqrt(len(x)) + 1e-6


def test_probing_size_centred_on_zero_and_form_from_noise(ball_bar_runs):
    sizes = []
    for P, t in ball_bar_runs:
        m = t.mask & (t.object_id == 0) & np.isfinite(P[..., 0])
        f = probing_errors(P, m, true_diameter=50.0)
        sizes.append(f.size)
        radial = np.linalg.norm(P[m] - np.array([-45.0, 0.0, 400.0]), axis=1) - 25.0  # errors vs the true sphere
        assert 0.6 * np.ptp(radial) < f.form < 1.05 * np.ptp(radial)
        assert f.rms == pytest.approx(np.std(radial), rel=0.25)
    assert centred_on_zero(sizes) and np.max(np.abs(sizes)) < 0.2  # mm


def test_sphere_spacing_centred_on_zero(ball_bar_runs):
    L = float(np.linalg.norm([90.0, 5.0, 10.0]))
    errs = []
    for P, t in ball_bar_runs:
        ok = np.isfinite(P[..., 0]) & t.mask
        errs.append(sphere_spacing(P, ok & (t.object_id == 0), ok & (t.object_id == 1), L, 50.0).error)
    assert centred_on_zero(errs) and np.max(np.abs(errs)) < 0.2


def test_flatness_from_noise(plane_runs):
    n = np.array([0.1, 0.05, -1.0])
    n /= np.linalg.norm(n)
    for P, t in plane_runs:
        ok = np.isfinite(P[..., 0]) & t.mask
        f = flatness(P, ok)
        dist = (P[ok] - np.array([0.0, 0.0, 420.0])) @ n  # errors vs the true plane
        assert 0.6 * np.ptp(dist) < f.flatness < 1.05 * np.ptp(dist)
        assert f.rms == pytest.approx(np.std(dist), rel=0.1)
        assert abs(fit_plane(P, ok).normal @ n) > 1 - 1e-5
