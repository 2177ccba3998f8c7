"""Issue 15: the quality map and sigma_z through reconstruct (both code paths) and the CLI switches."""
from __future__ import annotations

import json

import numpy as np
import pytest
import tifffile

from fringe3d.cli import main
from fringe3d.decode import DecodeOptions, edges
from fringe3d.io.capture import read_capture
from fringe3d.optics import Rig
from fringe3d.patterns import sets
from fringe3d.pipeline import reconstruct_capture
from fringe3d.reconstruct.sequence import FrameReconstructor, reconstruction_plans
from fringe3d.sim import RenderChanges, simulate_capture
from fringe3d.sim.truth import Truth


@pytest.fixture(scope="module")
def three_step(tmp_path_factory):
    """A noisy 3-step T=64 capture of the tiny preset's sphere before a wall (fused fast path)."""
    folder = tmp_path_factory.mktemp("q") / "cap"
    ps = sets.phase_shift(64, 3, "v", width=256, height=200)
    simulate_capture(folder, preset="tiny", scene="sphere", patterns=ps, seed=7, progress=False,
                     render=RenderChanges(noise=0.005))
    return folder


def test_fast_path_and_decode_path_mask_the_same_way(three_step):
    cap = read_capture(three_step)
    rig = Rig.load(three_step / "rig.json")
    ps = reconstruction_plans(cap.patterns, "geometric")
    opts = DecodeOptions(z_min=340.0, bit_depth=cap.meta.get("bit_depth"))
    fast = FrameReconstructor(ps, rig, opts)
    slow = FrameReconstructor(ps, rig, opts, fast=False)
    assert fast.fast is not None and slow.fast is None
    a, b = fast.reconstruct(cap.frames), slow.reconstruct(cap.frames)
    assert np.array_equal(np.isfinite(a.points[..., 0]), a.quality == 0)
    assert (a.quality & edges.EDGE).any() and (a.quality & edges.RIM).any()
    # same bits on both paths except where the paths' modulation masks differ by a pixel
    agree = (a.quality == 0) == (b.quality == 0)
    assert agree.mean() > 0.99
    t = Truth.load(three_step)
    for c in (a, b):
        ok = np.isfinite(c.sigma_xyz[..., 2])
        assert np.array_equal(ok, np.isfinite(c.points[..., 0]))
        err = np.abs(c.points[..., 2] - t.xyz[..., 2])[ok & t.mask]
        # sigma_z is the depth noise the capture's own frames predict: the errors' RMS is of that size
        ratio = np.sqrt(np.mean(err ** 2)) / np.sqrt(np.mean(c.sigma_xyz[..., 2][ok & t.mask] ** 2))
        assert 0.5 < ratio < 2.0, ratio
    off = FrameReconstructor(ps, rig, DecodeOptions(z_min=340.0, bit_depth=cap.meta.get("bit_depth"),
                                                    edge_mask=False)).reconstruct(cap.frames, False)
    assert np.isfinite(off.points[..., 0]).sum() > np.isfinite(a.points[..., 0]).sum()
    assert not (off.quality & ~np.uint8(edges.INVALID)).any()


@pytest.mark.parametrize("edge_mask", [True, False])
def test_sigma_z_left_for_later_is_the_same_map_bit_for_bit(three_step, edge_mask):
    """``uncertainty="z later"`` (what a serial sequence asks for: the writer's thread computes
    sigma_z) leaves the same map to ``with_sigma`` as ``"z"`` computes at once, with or without
    the edge tests; the depth and the quality bits are those of ``"z"`` too."""
    from fringe3d.reconstruct.frame import with_sigma

    cap = read_capture(three_step)
    ps = reconstruction_plans(cap.patterns, "geometric")
    rec = FrameReconstructor(ps, Rig.load(three_step / "rig.json"),
                             DecodeOptions(z_min=340.0, bit_depth=cap.meta.get("bit_depth"), edge_mask=edge_mask))
    now = rec.reconstruct(cap.frames, uncertainty="z", points=False, texture=False)
    later = rec.reconstruct(cap.frames, uncertainty="z later", points=False, texture=False)
    assert later.sigma_z is None and later.sigma_later is not None and now.sigma_later is None
    done = with_sigma(later)
    assert done.sigma_later is None and with_sigma(now) is now
    for a, b in ((done.sigma_z, now.sigma_z), (done.depth, now.depth), (done.quality, now.quality)):
        assert a.dtype == b.dtype and a.tobytes() == b.tobytes()
    assert np.isfinite(now.sigma_z).any()


def test_reconstruction_exposes_quality_and_sigma_z(three_step):
    r = reconstruct_capture(three_step, three_step / "rig.json", method="geometric", z_min=340.0)
    assert r.quality is not None and r.quality.dtype == np.uint8 and r.sigma_z is not None
    assert np.array_equal(r.mask, r.quality == 0)
    assert np.nanmedian(r.sigma_z) > 0
    loose = reconstruct_capture(three_step, three_step / "rig.json", method="geometric", z_min=340.0,
                                edge_mask=False)
    assert loose.mask.sum() > r.mask.sum()


def test_cli_edge_mask_switches(three_step, tmp_path, capsys):
    rig = str(three_step / "rig.json")
    assert main(["reconstruct", str(three_step), "-c", rig, "-o", str(tmp_path / "on"), "--z-min", "340",
                 "-m", "geometric", "--json"]) == 0
    assert main(["reconstruct", str(three_step), "-c", rig, "-o", str(tmp_path / "off"), "--z-min", "340",
                 "-m", "geometric", "--no-edge-mask", "--json"]) == 0
    assert main(["reconstruct", str(three_step), "-c", rig, "-o", str(tmp_path / "wide"), "--z-min", "340",
                 "-m", "geometric", "--edge-margin", "12", "--json"]) == 0
    capsys.readouterr()
    valid = {k: int(np.isfinite(np.load(tmp_path / k / "points.npy")[..., 0]).sum()) for k in ("on", "off", "wide")}
    assert valid["off"] > valid["on"] > valid["wide"]
    q = tifffile.imread(tmp_path / "on" / "quality.tif")
    assert q.dtype == np.uint8 and (q & edges.EDGE).any()
    assert tifffile.imread(tmp_path / "on" / "sigma_z.tif").dtype == np.float32
    assert main(["decode", str(three_step), "-o", str(tmp_path / "dec"), "--calibration", rig, "--z-min", "340",
                 "--method", "geometric", "--edge-margin", "5", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["results"][0]["info"]["quality"]["v"]["edge_margin"] == 5.0
    assert (tmp_path / "dec" / "quality_v.tif").exists()
    assert main(["decode", str(three_step), "-o", str(tmp_path / "dec2"), "--calibration", rig, "--z-min", "340",
                 "--method", "geometric", "--no-edge-mask", "--quiet"]) == 0
    q2 = tifffile.imread(tmp_path / "dec2" / "quality_v.tif")
    assert not (q2 & ~np.uint8(edges.INVALID)).any()
