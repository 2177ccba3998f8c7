"""The per-object (spatial) unwrapper keeps dark but well-modulated surfaces (issue 13, item 4):
its object mask is cut on modulation, never on average brightness; nearly black frames warn."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from fringe3d.decode import DecodeOptions, decode
from fringe3d.patterns import sets
from fringe3d.phase.quality import FrameQualityWarning
from fringe3d.sim import presets
from fringe3d.sim.primitives import Plane
from fringe3d.sim.render import render
from fringe3d.sim.scene import Scene
from fringe3d.unwrap.segmentation import modulation_mask
from fringe3d.utils.warning_types import DataQualityWarning

T = 18.0


def _spatial_set(width: int, height: int):
    ps = sets.phase_shift(T, 3, "v", width=width, height=height)
    return dataclasses.replace(ps, plans=(dataclasses.replace(ps.plans[0], method="spatial"),))


@pytest.fixture(scope="module")
def two_albedo_scene():
    """Two square plates side by side on the tiny rig: albedo 0.1 (object 0) and 0.9 (object 1)."""
    p = presets.get("tiny")
    ps = _spatial_set(p.rig.projector.width, p.rig.projector.height)
    scene = Scene([Plane((-36.0, 0.0, 400.0), (0.0, 0.0, -1.0), albedo=0.1, size=(70.0, 120.0)),
                   Plane((36.0, 0.0, 400.0), (0.0, 0.0, -1.0), albedo=0.9, size=(70.0, 120.0))])
    frames, truth = render(scene, p.rig, ps, p.settings, progress=False)
    return ps, frames, truth


def test_spatial_unwrap_keeps_a_dark_well_modulated_plate(two_albedo_scene):
    ps, frames, truth = two_albedo_scene
    d = decode(frames, ps)
    kept = d.mask["v"]
    own = decode(frames, ps, options=DecodeOptions(edge_mask=False)).mask["v"]  # the method's own mask
    share = {}
    for obj in (0, 1):
        region = truth.mask & (truth.object_id == obj)
        assert region.sum() > 1000
        assert (own & region).sum() / region.sum() >= 0.95, obj
        # the default edge / mixed-pixel masks take the plates' one-pixel rims (~6 % of these small
        # plates), the dark plate's no more than the bright one's: contrast, not brightness (no
        # projector-edge band: the spatial phase is relative)
        share[obj] = (kept & region).sum() / region.sum()
        assert share[obj] >= 0.90, obj
        # relative phase: the truth up to one 2 pi k per object (Eq. 5.12), no jumps inside
        err = d.phase["v"][kept & region] - 2 * np.pi * truth.up[kept & region] / T
        k = np.round((err - np.median(err)) / (2 * np.pi))
        assert np.all(k == 0) and np.abs(err - np.median(err)).max() < 0.5
    assert share[0] >= share[1] - 0.02
    assert not (kept & ~truth.hit).any()  # no background


def test_modulation_mask_ignores_brightness_and_drops_the_noise_floor():
    B = np.full((4, 6), 0.4)           # background: noise-level modulation
    B[:, :3], B[:, 3:5] = 60.0, 6.0     # bright plate, dark plate (a tenth of the modulation)
    m = modulation_mask(B)
    assert m[:, :5].all() and not m[:, 5].any()
    assert not modulation_mask(B, valid=np.zeros_like(B, bool)).any()
    with pytest.raises(ValueError, match="2-D"):
        modulation_mask(B[0])


def test_nearly_black_frames_warn_even_with_hot_pixels_and_noise():
    rng = np.random.default_rng(0)
    ps = _spatial_set(64, 48)
    frames = np.clip(rng.normal(2.0, 1.0, (3, 48, 64)), 0, 255).astype(np.uint8)
    frames[:, 5, 7] = 255  # hot pixels: the old max-based check saw a bright frame
    frames[:, 30, 40] = 200
    with pytest.warns(FrameQualityWarning, match="nearly black") as rec:
        d = decode(frames, ps)
    assert all(issubclass(w.category, DataQualityWarning) for w in rec if w.category is FrameQualityWarning)
    assert not d.mask["v"].any()
