"""Histogram (mode) and spatial unwrappers through the decoder (ch. 6 use: modified FTP + coarse reference)."""
import math
from dataclasses import replace

import numpy as np
import pytest

from fringe3d.decode import DecodeOptions, decode
from fringe3d.patterns.manifest import DirectionPlan
from fringe3d.patterns.sets import modified_ftp, phase_shift
from fringe3d.sim import presets, render
from fringe3d.sim.primitives import Plane, Sphere
from fringe3d.sim.scene import Scene
from fringe3d.unwrap.geometric import depth_limit, minimum_phase

T, T_REF = 24.0, 380.0
Z_MIN = 360.0
TWO_PI = 2 * np.pi


def _range_mm(rig, period):
    lim = depth_limit(rig, minimum_phase(rig, Z_MIN, period))
    return float(np.nanmedian(lim[200:300, 250:400]) - Z_MIN)


def _ch6_set(w, h):
    """Modified-FTP pair (T = 24) + 3-step Bayer-dithered reference (T = 380), plan "histogram"."""
    ps = modified_ftp(T, "v", width=w, height=h).concat(phase_shift(T_REF, 3, "v", kind="bayer", width=w, height=h))
    return replace(ps, plans=(DirectionPlan("v", ps.plans[0].angle, "histogram", (T, T_REF)),))


@pytest.fixture(scope="module")
def deep_scene():
    """Three isolated spheres spread over ~2.5 single-shot depth ranges."""
    p = presets.get("high-speed")
    rig = p.rig
    rng = _range_mm(rig, T)
    balls = [Sphere((-70.0, -10.0, Z_MIN + 25.0), 20.0), Sphere((0.0, 20.0, Z_MIN + 25.0 + 1.2 * rng), 20.0),
             Sphere((70.0, -10.0, Z_MIN + 25.0 + 2.4 * rng), 20.0)]
    ps = _ch6_set(rig.projector.width, rig.projector.height)
    frames, truth = render(Scene(balls), rig, ps, p.settings, progress=False)
    return rig, ps, frames, truth


def _orders(phase, mask, truth):
    sel = mask & truth.mask
    return np.round((phase[sel] - truth.phase["v"][sel]) / TWO_PI), int(sel.sum())


def test_histogram_with_coarse_reference_is_absolute_beyond_the_single_shot_range(deep_scene):
    rig, ps, frames, truth = deep_scene
    d = decode(frames, ps, rig=rig, options=DecodeOptions(z_min=Z_MIN))
    k, n = _orders(d.phase["v"], d.mask["v"], truth)
    assert n > 8000
    assert np.mean(k == 0) >= 0.999
    # the pixel-wise geometric constraint alone (same frames, FTP pair) fails on the far spheres
    geo = replace(ps, plans=(DirectionPlan("v", ps.plans[0].angle, "geometric", (T,)),))
    g = decode(frames, geo, rig=rig, options=DecodeOptions(z_min=Z_MIN))
    kg, _ = _orders(g.phase["v"], g.mask["v"] & d.mask["v"], truth)
    assert np.mean(kg == 0) < 0.8


def test_spatial_unwrapper_is_relative_one_offset_per_object(deep_scene):
    rig, ps, frames, truth = deep_scene
    sp = replace(ps, plans=(DirectionPlan("v", ps.plans[0].angle, "spatial", (T,)),))
    d = decode(frames, sp, rig=rig, options=DecodeOptions(z_min=Z_MIN))
    for ball in range(3):
        sel = d.mask["v"] & (truth.object_id == ball) & truth.mask
        k = np.round((d.phase["v"][sel] - truth.phase["v"][sel]) / TWO_PI)
        assert sel.sum() > 2000
        assert np.mean(k == np.median(k)) >= 0.999


def test_single_group_histogram_fixes_an_object_partly_beyond_the_depth_range():
    p = presets.get("high-speed")
    rig = p.rig
    rng = _range_mm(rig, T)
    # a plane whose depth runs from 0.3 to 1.2 range beyond z_min: most of it inside the range
    tilt = math.atan2(0.9 * rng, 90.0)
    plane = Plane((0.0, 0.0, Z_MIN + 0.75 * rng), (math.sin(tilt), 0.0, -math.cos(tilt)), size=(95.0, 70.0))
    ps = modified_ftp(T, "v", width=rig.projector.width, height=rig.projector.height, method="histogram")
    frames, truth = render(Scene([plane]), rig, ps, p.settings, progress=False)
    h = decode(frames, ps, rig=rig, options=DecodeOptions(z_min=Z_MIN))
    k, n = _orders(h.phase["v"], h.mask["v"], truth)
    assert n > 10000 and np.mean(k == 0) >= 0.999
    geo = replace(ps, plans=(DirectionPlan("v", ps.plans[0].angle, "geometric", (T,)),))
    g = decode(frames, geo, rig=rig, options=DecodeOptions(z_min=Z_MIN))
    kg, _ = _orders(g.phase["v"], g.mask["v"] & h.mask["v"], truth)
    assert 0.02 < np.mean(kg != 0) < 0.5  # pixel-wise: the part beyond the range is one order off


def test_histogram_needs_rig_and_z_min(deep_scene):
    rig, ps, frames, truth = deep_scene
    with pytest.raises(ValueError, match="rig"):
        decode(frames, ps, rig=None, options=DecodeOptions(z_min=Z_MIN))
    with pytest.raises(ValueError, match="z_min"):
        decode(frames, ps, rig=rig)
