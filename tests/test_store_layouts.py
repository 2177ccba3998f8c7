"""The point store's ray_depth layout gives back the xyz layout's points bit for bit, and holds
each 3D frame's quality map and sigma_z."""
from __future__ import annotations

import warnings

import numpy as np
import pytest

from fringe3d.decode import DecodeOptions
from fringe3d.decode.edges import INVALID
from fringe3d.io.capture import read_capture
from fringe3d.io.point_sequence import read_point_sequence
from fringe3d.io.store import PointMapStore
from fringe3d.optics import Rig
from fringe3d.patterns import sets
from fringe3d.reconstruct.settings import DecodeSettings, OutputSettings, RunSettings
from fringe3d.reconstruct.sequence import FrameReconstructor, reconstruct_sequence, reconstruction_plans
from fringe3d.reconstruct.uncertainty import central_difference
from fringe3d.sim import simulate_capture
from fringe3d.sim.truth import Truth

Z340 = DecodeOptions(z_min=340.0)


@pytest.fixture(scope="module")
def seq(tmp_path_factory):
    """3 cycles of a noisy 3-step T=64 capture of a sphere before a wall: capture, patterns, rig, truth, folder."""
    folder = tmp_path_factory.mktemp("layouts") / "cap"
    ps = sets.phase_shift(64, 3, "v", width=256, height=200)
    simulate_capture(folder, preset="tiny", scene="sphere", patterns=ps, cycles=3, seed=11, progress=False)
    cap = read_capture(folder)
    ps = reconstruction_plans(cap.patterns, "geometric")
    return cap, ps, Rig.load(folder / "rig.json"), Truth.load(folder), folder


@pytest.fixture(scope="module")
def both(seq, tmp_path_factory):
    """The same sequence stored in both layouts (auto picks ray_depth on the fused path)."""
    cap, ps, rig, _, _ = seq
    out = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for layout in ("auto", "xyz"):
            d = tmp_path_factory.mktemp(layout)
            res = reconstruct_sequence(cap.frames, ps, rig, d, decode=DecodeSettings(options=Z340),
                                       outputs=OutputSettings(layout=layout), run=RunSettings(progress=False))
            out[layout] = (res, PointMapStore.open_existing(d / "points.zarr"))
    return out


def test_auto_layout_is_ray_depth_on_the_fused_path_and_gives_the_xyz_points_bit_for_bit(both):
    (res, rd), (_, xyz) = both["auto"], both["xyz"]
    assert res["store_layout"] == rd.layout == "ray_depth" and xyz.layout == "xyz"
    assert "points" not in rd.group and "depth" not in xyz.group
    for k in range(rd.frames):
        np.testing.assert_array_equal(rd.points(k), xyz.points(k))
        assert np.isfinite(rd.points(k)[..., 0]).mean() > 0.3


def test_ray_depth_is_the_camera_frame_depth_of_the_true_surface(both, seq):
    _, _, rig, truth, _ = seq
    st = both["auto"][1]
    s = st.depth(0)
    ok = np.isfinite(s) & truth.mask
    R, t = rig.camera.R, rig.camera.t
    z_true = (truth.xyz @ R.T + t)[..., 2]  # camera-frame depth: z of R X + t
    z_points = (st.points(0).astype(np.float64) @ R.T + t)[..., 2]
    assert ok.sum() > 0.9 * truth.mask.sum()
    np.testing.assert_allclose(s[ok], z_points[ok], rtol=0, atol=1e-3)  # s is the stored points' depth
    assert np.median(np.abs(s[ok] - z_true[ok])) < 0.5  # mm: the noisy render's depth error


def test_the_store_holds_the_reconstructions_quality_bits_and_sigma_z(both, seq):
    cap, ps, rig, _, _ = seq
    st = both["auto"][1]
    rec = FrameReconstructor(ps, rig, Z340)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        c = rec.reconstruct(np.ascontiguousarray(cap.frames[0:3]))
    np.testing.assert_array_equal(st.quality(0), c.quality)
    # sigma_z is stored as float16: the per-axis z of the reconstruction rounded to three digits
    assert st.sigma_array.dtype == np.float16
    np.testing.assert_array_equal(st.sigma_z(0), c.sigma_xyz[..., 2].astype(np.float16).astype(np.float32))
    ok = np.isfinite(c.sigma_xyz[..., 2])
    np.testing.assert_allclose(st.sigma_z(0)[ok], c.sigma_xyz[..., 2][ok], rtol=2 ** -11)
    kept = st.quality(0) == 0
    np.testing.assert_array_equal(kept, np.isfinite(st.depth(0)))  # a point is kept exactly where its bits are 0
    assert (st.quality(0)[~kept] != 0).all() and (st.quality(0)[~np.isfinite(c.depth)] != 0).all()
    sz = st.sigma_z(0)[kept]
    assert np.isfinite(sz).all() and (sz > 0).all()


def test_fused_sigma_is_the_central_difference_of_the_triangulation(seq):
    """The exact ``|D ds/dw| sigma_w`` of the fused path against a central difference of the
    closed-form triangulation (:func:`fringe3d.reconstruct.uncertainty.central_difference`)."""
    _, ps, rig, _, _ = seq
    tri = FrameReconstructor(ps, rig, Z340).fast.tri
    H, W = tri.shape
    w = np.tile(np.linspace(40.0, 200.0, W), (H, 1))
    sigma_w = np.full((H, W), 0.05)
    mask = np.ones((H, W), bool)
    J = central_difference(lambda h: tri.points(w + h, mask).astype(np.float64), 1e-2)
    expect = np.abs(J) * 0.05
    got = tri.point_sigma_from_w(w, sigma_w, mask)
    ok = np.isfinite(expect[..., 0])
    assert ok.mean() > 0.5  # the rest of the w range lies behind the camera
    np.testing.assert_allclose(got[ok], expect[ok], rtol=2e-3, atol=1e-6)


def test_no_store_quality_leaves_the_arrays_out_and_a_resume_must_match(seq, tmp_path):
    cap, ps, rig, _, _ = seq
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        reconstruct_sequence(cap.frames, ps, rig, tmp_path, decode=DecodeSettings(options=Z340),
                             outputs=OutputSettings(store_quality=False), run=RunSettings(progress=False))
        st = PointMapStore.open_existing(tmp_path / "points.zarr")
        assert not st.has_quality and not st.has_sigma
        with pytest.raises(ValueError, match="holds no quality maps"):
            st.quality(0)
        with pytest.raises(ValueError, match="new output folder"):
            reconstruct_sequence(cap.frames, ps, rig, tmp_path, decode=DecodeSettings(options=Z340),
                                 run=RunSettings(progress=False))


def test_ray_depth_is_refused_where_the_points_do_not_come_from_the_rays(seq, tmp_path):
    cap, ps, rig, _, _ = seq
    with pytest.raises(ValueError, match="ray_depth store layout needs the fused"):
        reconstruct_sequence(cap.frames, ps, rig, tmp_path, decode=DecodeSettings(options=Z340, fast=False),
                             outputs=OutputSettings(layout="ray_depth"), run=RunSettings(progress=False))


def test_a_ray_depth_store_opens_in_xarray_and_as_a_strain_sequence(both):
    xr = pytest.importorskip("xarray")
    st = both["auto"][1]
    ds = xr.open_zarr(st.path, consolidated=False)
    assert ds["depth"].dims == ("frame", "row", "column") and ds["depth"].attrs["units"] == "mm"
    assert ds["ray_direction"].dims == ("axis", "row", "column") and ds["ray_origin"].dims == ("axis",)
    assert ds["quality"].dims == ds["sigma_z"].dims == ("frame", "row", "column")
    X = (ds["ray_origin"] + ds["depth"].isel(frame=1) * ds["ray_direction"]).transpose("row", "column", "axis")
    np.testing.assert_allclose(X.values, st.points(1), rtol=0, atol=1e-4, equal_nan=True)  # float64 vs float32 mm
    seqn = read_point_sequence(st.path)
    assert len(seqn) == st.frames and seqn.shape == st.shape + (3,)
    np.testing.assert_array_equal(seqn[2], st.points(2).astype(np.float64))


def test_an_empty_frame_is_stored_as_invalid(seq, tmp_path):
    cap, ps, rig, _, _ = seq
    frames = cap.frames.copy()
    frames[3:6] = 0  # no modulation in the second cycle
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = reconstruct_sequence(frames, ps, rig, tmp_path, decode=DecodeSettings(options=Z340),
                                   run=RunSettings(progress=False))
    st = PointMapStore.open_existing(tmp_path / "points.zarr")
    assert res["empty_frames"] == 1 and st.completed == 3
    assert np.isnan(st.depth(1)).all() and (st.quality(1) == INVALID).all() and np.isnan(st.sigma_z(1)).all()


def test_the_command_writes_the_layout_and_arrays_asked_for(seq, tmp_path, capsys):
    from fringe3d.cli import main
    folder = seq[4]
    base = ["reconstruct", str(folder), "-c", str(folder / "rig.json"), "--method", "geometric", "--z-min", "340",
            "-q"]
    assert main(base + ["-o", str(tmp_path / "a"), "--store-layout", "xyz", "--no-store-quality"]) == 0
    st = PointMapStore.open_existing(tmp_path / "a" / "points.zarr")
    assert st.layout == "xyz" and not st.has_quality and not st.has_sigma and st.completed == 3
    assert main(base + ["-o", str(tmp_path / "b")]) == 0
    st = PointMapStore.open_existing(tmp_path / "b" / "points.zarr")
    assert st.layout == "ray_depth" and st.has_quality and st.has_sigma and st.completed == 3
    assert main(base + ["-o", str(tmp_path / "c"), "--store-layout", "bogus"]) == 2
    assert "--store-layout must be auto, xyz or ray_depth" in capsys.readouterr().err
    assert not (tmp_path / "c").exists()


@pytest.mark.parametrize("codec", ["none", "zstd"])
def test_store_codec_changes_the_bytes_on_disk_not_the_data(both, seq, tmp_path, codec, capsys):
    from fringe3d.cli import main

    _, _, _, _, folder = seq
    out = tmp_path / codec
    assert main(["reconstruct", str(folder), "-c", str(folder / "rig.json"), "-o", str(out), "--method",
                 "geometric", "--z-min", "340", "-q", "--store-codec", codec]) == 0
    st, ref = PointMapStore.open_existing(out / "points.zarr"), both["auto"][1]
    for name in ("depth", "quality", "sigma_z"):
        comps = st.group[name].compressors
        assert (len(comps) == 0) if codec == "none" else (comps[0].cname.value == codec)
        np.testing.assert_array_equal(st.group[name][:], ref.group[name][:])
    raw = sum(f.stat().st_size for f in (out / "points.zarr" / "depth").glob("c.*"))
    assert (raw == st.frames * st.shape[0] * st.shape[1] * 4) == (codec == "none")  # raw: 4 bytes a pixel


def test_an_unknown_store_codec_is_a_clear_error_and_writes_nothing(seq, tmp_path, capsys):
    from fringe3d.cli import main

    _, _, _, _, folder = seq
    assert main(["reconstruct", str(folder), "-c", str(folder / "rig.json"), "-o", str(tmp_path / "o"),
                 "--z-min", "340", "--store-codec", "gzip"]) == 2
    err = capsys.readouterr().err
    assert "--store-codec" in err and "lz4" in err and "Traceback" not in err
    assert not (tmp_path / "o").exists()
