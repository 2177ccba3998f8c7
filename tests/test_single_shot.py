"""Single-shot FTP / modified FTP + geometric constraint (ch. 4) on simulated frames, against truth."""
import math

import numpy as np
import pytest

from fringe3d.patterns.sets import modified_ftp
from fringe3d.reconstruct.single_shot import SingleShotSettings, single_shot
from fringe3d.utils.warning_types import DepthRangeWarning
from fringe3d.sim import presets, render
from fringe3d.sim.primitives import Plane, Sphere
from fringe3d.sim.scene import Scene
from fringe3d.unwrap.geometric import depth_limit, minimum_phase

T = 18.0
Z_MIN = 380.0


def _range_mm(rig):
    lim = depth_limit(rig, minimum_phase(rig, Z_MIN, T))
    return float(np.nanmedian(lim[200:300, 250:400]) - Z_MIN)


def _capture(objects, seed=0):
    p = presets.get("high-speed")
    rig = p.rig
    ps = modified_ftp(T, "v", width=rig.projector.width, height=rig.projector.height)
    frames, truth = render(Scene(objects), rig, ps, p.settings.replace(seed=seed), progress=False)
    return rig, frames, truth


@pytest.fixture(scope="module")
def in_range():
    rig = presets.get("high-speed").rig
    rng = _range_mm(rig)
    # a sphere and a tilted plane, all between z_min + 5 mm and z_min + 0.8 * range
    sphere = Sphere((-40.0, 0.0, Z_MIN + 5.0 + 25.0), 25.0)
    tilt = math.atan2(0.4 * rng, 60.0)
    plane = Plane((45.0, 0.0, Z_MIN + 0.45 * rng), (math.sin(tilt), 0.0, -math.cos(tilt)), size=(60.0, 70.0))
    return _capture([sphere, plane])


def _order_share(res, truth):
    sel = res.mask & truth.mask
    k = np.round((res.phase[sel] - truth.phase["v"][sel]) / (2 * np.pi))
    return float(np.mean(k == 0)), int(sel.sum())


@pytest.mark.parametrize("method", ["ftp", "modified_ftp"])
@pytest.mark.parametrize("window", ["hanning", "circular"])
def test_single_shot_gets_correct_absolute_order_on_isolated_objects(in_range, method, window):
    rig, frames, truth = in_range
    imgs = frames[:1] if method == "ftp" else frames
    res = single_shot(imgs, rig, T, Z_MIN, method=method, settings=SingleShotSettings(window=window))
    share, n = _order_share(res, truth)
    assert n > 10000
    assert share >= 0.999
    assert not res.range_check["warned"]


def test_modified_ftp_phase_is_closer_to_truth_than_ftp(in_range):
    rig, frames, truth = in_range
    errs = {}
    for method, imgs in (("ftp", frames[:1]), ("modified_ftp", frames)):
        res = single_shot(imgs, rig, T, Z_MIN, method=method, settings=SingleShotSettings(erode=3))
        sel = res.mask & truth.mask
        errs[method] = np.sqrt(np.mean((res.phase[sel] - truth.phase["v"][sel]) ** 2))
    assert errs["modified_ftp"] < errs["ftp"] < 0.5


def test_beyond_depth_range_order_is_off_by_one_exactly_where_theory_says_and_warns():
    rig = presets.get("high-speed").rig
    rng = _range_mm(rig)
    tilt = math.atan2(30.0, 80.0)  # plane depth spans the limit +-15 mm
    plane = Plane((0.0, 0.0, Z_MIN + rng), (math.sin(tilt), 0.0, -math.cos(tilt)), size=(85.0, 70.0))
    rig, frames, truth = _capture([plane], seed=1)
    with pytest.warns(DepthRangeWarning, match="depth range"):
        res = single_shot(frames, rig, T, Z_MIN, method="modified_ftp")
    mp = minimum_phase(rig, Z_MIN, T)
    sel = res.mask & truth.mask
    r_true = mp.sign * (truth.phase["v"] - mp.phi_min)
    k_err = np.round((res.phase - truth.phase["v"]) / (2 * np.pi))
    beyond = sel & (r_true > 2 * np.pi + 0.25)
    inside = sel & (r_true < 2 * np.pi - 0.25)
    assert beyond.sum() > 1000 and inside.sum() > 1000
    assert np.all(mp.sign[beyond] * k_err[beyond] == -1)
    assert np.all(k_err[inside] == 0)
    assert res.range_check["warned"]


def test_bad_input_is_rejected(in_range):
    rig, frames, truth = in_range
    with pytest.raises(ValueError, match="needs 2 image"):
        single_shot(frames[:1], rig, T, Z_MIN, method="modified_ftp")
    with pytest.raises(ValueError, match="unknown single-shot method"):
        single_shot(frames[:1], rig, T, Z_MIN, method="psp")
    with pytest.raises(ValueError, match="sizes disagree"):
        single_shot(frames[:1, :100, :100], rig, T, Z_MIN)
    with pytest.raises(ValueError, match="behind"):
        single_shot(frames[:1], rig, T, -10.0)
    with pytest.raises(ValueError, match="empty"):
        single_shot(frames[:1], rig, T, Z_MIN, mask=np.zeros(frames.shape[1:], bool))
