"""Hybrid FTP+PSP (Eq. 5.13-5.15) on the simulator's free-falling balls, against its truth phase."""
import numpy as np
import pytest

from fringe3d.decode import DecodeOptions
from fringe3d.reconstruct.motion import dissertation_sequence, hybrid_view, measure
from fringe3d.sim import presets, render
from fringe3d.sim.motion import GRAVITY_MM_S2
from fringe3d.sim.primitives import Sphere
from fringe3d.sim.scene import Scene
from fringe3d.sim.textures import Blotches

TWO_PI = 2 * np.pi


@pytest.fixture(scope="module")
def capture():
    p = presets.get("high-speed")
    rig = p.rig
    ps6 = dissertation_sequence(rig.projector.width, rig.projector.height)
    g = (0.0, GRAVITY_MM_S2, 0.0)
    balls = [Sphere((-60, -30, 430), 20, velocity=(100, 3000, 0), acceleration=g, spin=(0, 0, 20),
                    texture=Blotches(0.6, 0.3, seed=1)),
             Sphere((10, 20, 470), 20, velocity=(0, 2500, 0), acceleration=g),
             Sphere((75, -40, 395), 20, velocity=(-80, 2000, 0), acceleration=g, spin=(10, 0, 0))]
    frames, truth = render(Scene(balls), rig, ps6, p.settings.replace(frame_rate=1500.0, seed=3), progress=False)
    return rig, ps6, frames, truth


def test_hybrid_gets_every_balls_fringe_order_from_simulated_frames(capture):
    rig, ps6, frames, truth = capture
    ps4, idx = hybrid_view(ps6)
    m = measure(frames[idx], ps4, rig, DecodeOptions(z_min=340.0, erode=4))
    t = truth.frame(idx[0])  # FTP frame I_h3
    labels = m.labels
    assert len(m.object_orders) == 3
    for ball in range(3):
        own = (t.object_id == ball) & m.mask
        assert own.sum() > 2000
        err = m.phase[own] - t.phase["v"][own]
        assert round(float(np.median(err)) / TWO_PI) == 0, "wrong fringe order k_s"
        # every pixel of the ball is within a fraction of a fringe of the truth (no 2π slips)
        assert np.mean(np.abs(err) < 1.5) > 0.995
        assert np.sqrt(np.mean(err ** 2)) < 0.4
    assert set(np.unique(labels[m.mask])) == set(m.object_orders)


def test_two_frequency_psp_suffers_motion_error_the_hybrid_avoids(capture):
    rig, ps6, frames, truth = capture
    ps4, idx = hybrid_view(ps6)
    hyb = measure(frames[idx], ps4, rig, DecodeOptions(z_min=340.0, erode=4))
    psp = measure(frames, ps6, rig, DecodeOptions(z_min=340.0))
    t_h, t_p = truth.frame(idx[0]), truth.frame(1)
    e_h = (hyb.phase - t_h.phase["v"])[(t_h.object_id >= 0) & hyb.mask]
    e_p = (psp.phase - t_p.phase["v"])[(t_p.object_id >= 0) & psp.mask]
    share_slip_h = np.mean(np.abs(e_h) > np.pi)
    share_slip_p = np.mean(np.abs(e_p) > np.pi)
    assert share_slip_h < 0.005 < share_slip_p


def test_hybrid_view_selects_last_high_frame_and_low_set():
    ps6 = dissertation_sequence(912, 1140)
    ps4, idx = hybrid_view(ps6)
    assert idx == [2, 3, 4, 5]
    assert ps4.frames[0].kind == "square" and ps4.frames[0].shift == pytest.approx(4 * np.pi / 3)
    assert [f.kind for f in ps4.frames[1:]] == ["bayer"] * 3
    assert ps4.plans[0].method == "hybrid" and ps4.plans[0].periods == (18.0, 228.0)


def test_hybrid_rejects_missing_rig_and_wrong_frame_count(capture):
    rig, ps6, frames, truth = capture
    ps4, idx = hybrid_view(ps6)
    with pytest.raises(ValueError, match="rig"):
        measure(frames[idx], ps4, None, DecodeOptions(z_min=340.0))
    with pytest.raises(ValueError, match="expected 4 frames"):
        measure(frames, ps4, rig, DecodeOptions(z_min=340.0))


def test_hybrid_on_the_simulators_named_falling_balls_scene():
    from fringe3d.sim.catalog import falling_balls_scene

    p = presets.get("high-speed")
    rig = p.rig
    ps6 = dissertation_sequence(rig.projector.width, rig.projector.height)
    ps4, idx = hybrid_view(ps6)
    scene = falling_balls_scene(p, n=3, seed=0)  # checker-printed, spinning, isolated balls
    frames, truth = render(scene, rig, ps6, p.settings.replace(frame_rate=1500.0, seed=0), progress=False)
    m = measure(frames[idx], ps4, rig, DecodeOptions(z_min=p.volume["z"][0], erode=4))
    t = truth.frame(idx[0])
    for ball in range(3):
        own = (t.object_id == ball) & m.mask
        assert own.sum() > 1500
        err = m.phase[own] - t.phase["v"][own]
        assert round(float(np.median(err)) / TWO_PI) == 0
        assert np.sqrt(np.mean(err ** 2)) < 0.4


def test_hybrid_plan_on_a_set_without_a_single_ftp_frame_is_rejected(capture):
    from dataclasses import replace as dc_replace

    from fringe3d.patterns.manifest import DirectionPlan

    rig, ps6, frames, truth = capture
    bad = dc_replace(ps6, plans=(DirectionPlan("v", ps6.plans[0].angle, "hybrid", (18.0, 228.0)),))
    with pytest.raises(ValueError, match="1 high-frequency frame"):
        measure(frames, bad, rig, DecodeOptions(z_min=340.0))


def test_saturated_pixels_of_the_ftp_frame_are_left_out(capture):
    rig, ps6, frames, truth = capture
    ps4, idx = hybrid_view(ps6)
    f4 = frames[idx].copy()
    t = truth.frame(idx[0])
    v, u = np.argwhere(t.object_id == 1).mean(axis=0).astype(int)
    f4[0, v - 5:v + 5, u - 5:u + 5] = 255  # a specular glint on ball 1 in I_h3
    m = measure(f4, ps4, rig, DecodeOptions(z_min=340.0, erode=0))
    assert not m.mask[v - 5:v + 5, u - 5:u + 5].any()
    own = (t.object_id == 1) & m.mask
    assert round(float(np.median(m.phase[own] - t.phase["v"][own])) / TWO_PI) == 0
