"""HDR (issue 25): the specular lobe, the EMVA 1288 camera model, exposure fusion, and the HDR
figures on the simulator's shiny and printed parts against truth."""
from __future__ import annotations

import numpy as np
import pytest

from fringe3d.experiments.hdr import EXPOSURES, hdr_rows
from fringe3d.phase.exposure_fusion import fuse_exposures, split_bracket
from fringe3d.sim.noise import sense
from fringe3d.sim.settings import RenderSettings
from fringe3d.sim.specular import lobe


def _unit(v):
    v = np.asarray(v, float)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def test_specular_lobe_peaks_at_the_mirror_direction():
    n = np.array([[0.0, 0.0, 1.0]])
    light = _unit([[0.5, 0.2, 0.8]])
    mirror = 2 * (light @ n.T) * n - light
    angles = np.linspace(-0.6, 0.6, 241)  # tilt the camera direction about the mirror direction
    views = _unit(mirror + np.outer(angles, [1.0, 0.0, 0.0]))
    s = lobe(np.repeat(n, len(views), 0), np.repeat(light, len(views), 0), views, 1.0, 0.2)
    assert abs(angles[np.argmax(s)]) < 1e-9
    assert s.max() > 10 * s.min()  # a real lobe, not a flat factor


def test_specular_lobe_is_zero_behind_the_surface():
    n = np.array([[0.0, 0.0, 1.0]])
    assert lobe(n, _unit([[0.0, 0.3, -1.0]]), _unit([[0.0, -0.3, 1.0]]), 1.0, 0.2)[0] == 0.0


@pytest.mark.parametrize("level,read_e,offset", [(0.3, 20.0, 0.0), (0.05, 5.0, 10.0)])
def test_emva_model_matches_its_mean_and_variance(level, read_e, offset):
    s = RenderSettings(noise_model="emva", full_well=20000.0, read_noise_e=read_e, gain_dn_per_e=0.05,
                       dark_offset_dn=offset, bit_depth=12, seed=3)
    y = sense(np.full((400, 500), level), s, 0).astype(float)
    mu_e = level * s.full_well
    mean = offset + 0.05 * mu_e
    var = 0.05 ** 2 * (read_e ** 2 + mu_e) + 1 / 12
    assert abs(y.mean() - mean) < 5 * np.sqrt(var / y.size) + 0.01
    assert y.var() == pytest.approx(var, rel=0.03)


def test_emva_model_clips_at_the_full_well():
    s = RenderSettings(noise_model="emva", full_well=1000.0, gain_dn_per_e=0.1, bit_depth=12)
    y = sense(np.full((50, 50), 3.0), s, 0)
    assert np.all(y == 100)  # 1000 e- x 0.1 DN/e-: the well, not the ADC, saturates


def test_emva_model_needs_a_bit_depth():
    with pytest.raises(ValueError, match="bit_depth"):
        RenderSettings(noise_model="emva", bit_depth=None)


def test_fusion_takes_the_largest_unsaturated_range_and_flags_all_saturated():
    rng = np.random.default_rng(0)
    base = rng.uniform(0.1, 1.0, (3, 4, 5))  # (F, H, W)
    stacks = np.stack([np.clip(np.rint(base * g), 0, 255) for g in (60, 240, 960)]).astype(np.uint8)
    f = fuse_exposures(stacks, 255.0)
    unsat = (stacks < 255).all(axis=1)
    span = stacks.max(1).astype(int) - stacks.min(1)
    expect = np.argmax(np.where(unsat, span, -1), axis=0)
    any_ok = unsat.any(axis=0)
    assert np.array_equal(f.index[any_ok], expect[any_ok])
    assert np.array_equal(f.saturated, ~any_ok)
    picked = np.take_along_axis(stacks, f.index[None, None].astype(int), 0)[0]
    assert np.array_equal(f.frames, picked)


def test_split_bracket_names_the_counts():
    with pytest.raises(ValueError, match="3 x 4 = 12 frames"):
        split_bracket(np.zeros((11, 2, 2)), 3, 4)


@pytest.fixture(scope="module")
def shiny_rows():
    return {r["run"]: r for r in hdr_rows("shiny-part", "tiny", EXPOSURES, seed=0)}


def test_hdr_keeps_the_shiny_part_valid_at_no_worse_rms(shiny_rows):
    singles = [r for r in shiny_rows.values() if r["exposures"] == 1]
    best = max(singles, key=lambda r: r["valid"])
    hdr = shiny_rows["HDR all 3 exposures"]
    assert best["valid"] < 0.95  # one exposure loses the highlights or the matte part
    assert hdr["valid"] >= 0.98
    assert hdr["rms_on_best_mm"] <= best["rms_mm"]


def test_shiny_part_saturates_one_exposure(shiny_rows):
    assert shiny_rows["1 exposure 10 ms"]["valid"] < 0.5


def test_hdr_recovers_the_dark_half_of_the_printed_part():
    rows = {r["run"]: r for r in hdr_rows("printed-part", "tiny", EXPOSURES, seed=0)}
    best = max((r for r in rows.values() if r["exposures"] == 1), key=lambda r: r["valid"])
    hdr = rows["HDR all 3 exposures"]
    assert best["valid"] < 0.8 and hdr["valid"] >= 0.95
    assert hdr["rms_on_best_mm"] <= best["rms_mm"]


def test_scene_file_keeps_the_gloss(tmp_path):
    from fringe3d.sim import presets
    from fringe3d.sim.scene_file import scene_from_dict
    from fringe3d.sim.simulate import named_scene

    scene = named_scene("shiny-part", presets.get("tiny"))
    back = scene_from_dict(scene.to_dict())
    assert [(ob.specular, ob.roughness) for ob in back.objects] == [(1.0, 0.12), (0.6, 0.25)]
    bad = scene.to_dict()
    bad["objects"][0]["roughness"] = 0.0
    with pytest.raises(ValueError, match=r"objects\[0\].*roughness"):
        scene_from_dict(bad)
