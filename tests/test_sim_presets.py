"""Rig presets: the dissertation's systems, checked against their stated geometry."""
import itertools

import numpy as np
import pytest

from fringe3d.patterns import sets
from fringe3d.sim import presets


@pytest.mark.parametrize("name", presets.NAMES)
def test_preset_volume_is_seen_by_camera_and_lit_by_projector(name):
    p = presets.get(name)
    corners = np.array(list(itertools.product(*[p.volume[k] for k in "xyz"])))
    for dev in (p.rig.camera, p.rig.projector):
        uv = dev.project(corners)
        assert np.all(uv[:, 0] > -0.5) and np.all(uv[:, 0] < dev.width - 0.5), (name, dev.kind)
        assert np.all(uv[:, 1] > -0.5) and np.all(uv[:, 1] < dev.height - 0.5), (name, dev.kind)


@pytest.mark.parametrize("name", presets.NAMES)
def test_three_frequency_sets_unwrap_at_any_angle_on_every_projector(name):
    proj = presets.get(name).rig.projector
    assert np.hypot(proj.width, proj.height) < 1008  # equivalent period of 18/21/144
    sets.optimal_angle_calibration(np.deg2rad(37.0), width=proj.width, height=proj.height)


def test_macro_rig_matches_the_dissertation_system():
    p = presets.get("macro")
    cam, proj = p.rig.camera, p.rig.projector
    assert (cam.width, cam.height) == (1280, 1024)
    assert cam.K[0, 0] * 0.0048 == pytest.approx(8.0)  # 8 mm lens, 4.8 um pixels
    angle = np.degrees(np.arccos(proj.R[2] @ np.array([0, 0, 1.0])))
    assert angle == pytest.approx(13.0, abs=0.5)
    assert p.size == pytest.approx([250, 150, 200])


def depth_sensitivity(p):
    """Projector-coordinate change (du_p, dv_p) per mm of depth at the volume centre."""
    X0 = np.array([0.0, 0.0, p.center[2]])
    q = p.rig.projector.project(np.array([X0, X0 * (1 + 1 / X0[2])]))
    return q[1] - q[0]


def test_well_designed_rig_has_one_nearly_depth_blind_direction():
    du, dv = depth_sensitivity(presets.get("well-designed"))
    assert abs(dv) < 0.1 * abs(du)  # horizontal fringes (v_p) nearly blind
    assert abs(dv) > 0.02 * abs(du)  # ... but not exactly: alpha_opt is non-trivial
    du_m, dv_m = depth_sensitivity(presets.get("macro"))
    assert abs(dv_m) > 0.2 * abs(du_m)  # the macro rig sees depth in both directions


def test_microscope_is_telecentric_with_a_10_by_8_mm_field():
    p = presets.get("microscope")
    assert p.rig.telecentric
    cam = p.rig.camera
    o, d = cam.rays(np.array([[0.0, 0.0], [cam.width - 1.0, 0.0], [0.0, cam.height - 1.0]]))
    # field size measured in the plane perpendicular to the viewing direction
    assert 10.0 < np.linalg.norm(o[1] - o[0]) < 14.0
    assert 8.0 < np.linalg.norm(o[2] - o[0]) < 11.0
    assert p.size == pytest.approx([10.0, 8.0, 5.0])
    assert p.rig.projector.K[0, 0] > 5000  # long focal length


def test_high_speed_rig_projects_binary_patterns_in_the_khz_range():
    p = presets.get("high-speed")
    lo, hi = p.extra["frame_rate_range"]
    assert 1500 <= p.settings.frame_rate <= 5000 and (lo, hi) == (1500, 5000)
    assert p.settings.defocus == "gaussian" and p.settings.defocus_size >= 2.0


def test_tiny_preset_is_small():
    cam = presets.get("tiny").rig.camera
    assert (cam.width, cam.height) == (160, 128)


def test_unknown_preset_lists_the_valid_ones():
    with pytest.raises(ValueError, match="unknown preset 'mega'.*macro.*well-designed.*microscope.*high-speed.*tiny"):
        presets.get("mega")


@pytest.mark.parametrize("name", presets.NAMES)
def test_default_scene_and_patterns_fit_each_preset(name):
    from fringe3d.sim.simulate import make_patterns, make_scene
    from fringe3d.sim.validate import scene_problems
    p = presets.get(name)
    proj = p.rig.projector
    ps = make_patterns(p.patterns, proj.width, proj.height)
    assert (ps.width, ps.height) == (proj.width, proj.height)
    scene = make_scene(None, p)
    assert scene_problems(scene, p.rig, times=(0.0, 5 / p.settings.frame_rate)) == []
