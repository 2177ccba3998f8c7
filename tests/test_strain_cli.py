"""``fringe3d strain``: outputs against the analytic wing, and every bad input rejected cleanly."""
import json
from pathlib import Path

import numpy as np
import pytest
from conftest import write_wing_sequence

from fringe3d.cli import main

TIMES = (0.0, 0.01, 0.02)
H = 0.1


@pytest.fixture(scope="module")
def sequence(tmp_path_factory):
    """Three frames of a bending, flapping wing with textures carrying two dark anchor dots."""
    folder = tmp_path_factory.mktemp("seq")
    anchors0, wing = write_wing_sequence(folder, TIMES)
    return folder, anchors0, wing


def test_strain_command_writes_csv_vtk_maps_and_matches_the_analytic_strain(sequence, tmp_path, capsys):
    folder, anchors0, wing = sequence
    out = tmp_path / "out"
    arg = ",".join(f"{x:.3f}" for x in anchors0.ravel())
    assert main(["strain", str(folder), "--anchors", arg, "-o", str(out), "--json", "--thickness", str(H),
                 "--step", "6", "--window", "9"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["frames"] == 3 and summary["tracked_fraction"] > 0.85
    for name in ["strain.csv", "strain.gif", "summary.json", "vtk/frame_00002.vtu", "strain.pvd",
                 "maps/strain_00001.png"]:
        assert (out / name).stat().st_size > 0
    assert not list(out.rglob(".*.part*"))          # no temporary leftovers
    from output_checks import check_folder
    check_folder(out, "strain")                      # summary.json and the marker: units, provenance
    data = np.genfromtxt(out / "strain.csv", delimiter=",", names=True)
    ok = data["ok"] == 1
    peak = abs(wing.bending_strain(TIMES[-1], 0, H))
    err = data["E_dominant"] - np.array([wing.bending_strain(t, 0.0, H) for t in TIMES])[data["frame"].astype(int)]
    assert np.sqrt(np.mean(err[ok] ** 2)) < 0.05 * peak      # goal: ≤ 5 % noise-free
    assert np.abs(err[ok]).max() < 0.10 * peak              # worst points: fit windows at the wing edge
    # tracked xyz of each reference pixel lies on the wing surface at its material point
    assert not list(out.rglob("*.vtk"))  # the legacy ASCII files are gone
    import meshio
    frame2 = meshio.read(out / "vtk" / "frame_00002.vtu")
    assert len(frame2.points) == int((data["frame"] == 2).sum()) and len(frame2.cells_dict["triangle"]) > 0
    np.testing.assert_allclose(frame2.point_data["E_dominant"], data["E_dominant"][data["frame"] == 2], rtol=1e-6)
    header = (out / "strain.csv").read_text().splitlines()[0].split(",")
    assert header[:5] == ["frame", "wing", "x_mm", "y_mm", "z_mm"] and "u_px" in header and "residual_mm" in header
    # the report of a strain folder shows its provenance, summary and strain maps
    assert main(["report", str(out), "-q"]) == 0
    page = (out / "report.html").read_text()
    # the map shown is the frame of largest |dominant strain| among the tracked points (strain.csv's)
    peak = int(data["frame"][ok][np.argmax(np.abs(data["E_dominant"][ok]))])
    assert "fringe3d strain" in page and f"strain_{peak:05d}.png" in page and "tracked_fraction" in page


def test_auto_anchors_find_the_dots(sequence, tmp_path, capsys):
    folder, _, _ = sequence
    assert main(["strain", str(folder), "--anchors", "auto", "-o", str(tmp_path / "o"), "--json", "--no-figures",
                 "--step", "8"]) == 0
    assert json.loads(capsys.readouterr().out)["tracked_fraction"] > 0.85


def _expect_error(args, out, capsys, text):
    assert main(args) == 2
    assert text in " ".join(capsys.readouterr().err.split())
    assert not Path(out).exists()  # nothing half-written


def test_anchor_on_invalid_pixels_is_rejected_and_nothing_written(sequence, tmp_path, capsys):
    folder, _, _ = sequence
    out = tmp_path / "o"
    _expect_error(["strain", str(folder), "--anchors", "3,3,10,3", "-o", str(out)], out, capsys, "invalid")


def test_anchors_not_found_without_dots(tmp_path, sequence, capsys):
    folder, _, _ = sequence
    bad = tmp_path / "nodots"
    bad.mkdir()
    for i in range(2):
        P = np.load(folder / f"points_{i:05d}.npy")
        np.save(bad / f"points_{i:05d}.npy", P)
        np.save(bad / f"texture_{i:05d}.npy", np.where(np.isfinite(P[..., 0]), 200.0, 5.0))
    out = tmp_path / "o"
    _expect_error(["strain", str(bad), "--anchors", "auto", "-o", str(out)], out, capsys, "anchor dot")
    # and no textures at all
    for f in bad.glob("texture_*"):
        f.unlink()
    _expect_error(["strain", str(bad), "--anchors", "auto", "-o", str(out)], out, capsys, "texture")


def test_frames_of_different_sizes_are_rejected(tmp_path, capsys):
    np.save(tmp_path / "points_00000.npy", np.zeros((20, 30, 3), np.float32))
    np.save(tmp_path / "points_00001.npy", np.zeros((20, 31, 3), np.float32))
    out = tmp_path.with_name(tmp_path.name + "-out")  # outside the input folder
    _expect_error(["strain", str(tmp_path), "--anchors", "5,5,10,5", "-o", str(out)], out, capsys, "differ in size")


def test_too_short_or_missing_or_malformed_sequences_are_rejected(tmp_path, capsys):
    np.save(tmp_path / "points_00000.npy", np.zeros((20, 30, 3), np.float32))
    out = tmp_path.with_name(tmp_path.name + "-out")  # outside the input folder
    _expect_error(["strain", str(tmp_path), "--anchors", "5,5,10,5", "-o", str(out)], out, capsys, "at least 2")
    _expect_error(["strain", str(tmp_path / "nope"), "--anchors", "5,5,10,5", "-o", str(out)], out, capsys,
                  "does not exist")
    np.save(tmp_path / "stack.npy", np.zeros((3, 20, 30), np.float32))
    _expect_error(["strain", str(tmp_path / "stack.npy"), "--anchors", "5,5,10,5", "-o", str(out)], out, capsys,
                  "(frames, H, W, 3)")
    _expect_error(["strain", str(tmp_path), "--anchors", "5,5,10", "-o", str(out)], out, capsys, "expected 4")


def test_npz_stack_is_read_like_a_folder(sequence, tmp_path, capsys):
    folder, anchors0, _ = sequence
    pts = np.stack([np.load(folder / f"points_{i:05d}.npy") for i in range(3)])
    tex = np.stack([np.load(folder / f"texture_{i:05d}.npy") for i in range(3)])
    np.savez(tmp_path / "seq.npz", points=pts, texture=tex)
    arg = ",".join(f"{x:.3f}" for x in anchors0.ravel())
    assert main(["strain", str(tmp_path / "seq.npz"), "--anchors", arg, "-o", str(tmp_path / "o"), "--json",
                 "--no-figures", "--step", "8"]) == 0
    assert json.loads(capsys.readouterr().out)["tracked_fraction"] > 0.85


def test_zarr_store_is_read_like_a_folder(sequence, tmp_path, capsys):
    import zarr

    folder, anchors0, _ = sequence
    g = zarr.open_group(str(tmp_path / "seq.zarr"), mode="w")
    pts = np.stack([np.load(folder / f"points_{i:05d}.npy") for i in range(3)])
    tex = np.stack([np.load(folder / f"texture_{i:05d}.npy") for i in range(3)])
    g.create_array("points", shape=pts.shape, dtype="f4")[:] = pts
    g.create_array("texture", shape=tex.shape, dtype="f8")[:] = tex
    assert main(["strain", str(tmp_path / "seq.zarr"), "--anchors", "auto", "-o", str(tmp_path / "o"), "--json",
                 "--no-figures", "--step", "8"]) == 0
    assert json.loads(capsys.readouterr().out)["tracked_fraction"] > 0.85


def test_incomplete_reconstruction_store_is_rejected(tmp_path, capsys):
    import zarr

    g = zarr.open_group(str(tmp_path / "points.zarr"), mode="w")
    g.create_array("points", shape=(3, 20, 30, 3), dtype="f4")[:] = np.ones((3, 20, 30, 3), np.float32)
    g.create_array("done", shape=(3,), dtype="u1")[:] = np.array([1, 0, 1], np.uint8)
    out = tmp_path / "o"
    _expect_error(["strain", str(tmp_path), "--anchors", "5,5,10,5", "-o", str(out)], out, capsys, "incomplete")


def test_gif_frames_are_all_frames_up_to_the_cap_then_evenly_spaced_ends_included():
    from fringe3d.analyze.wing_strain import GIF_FRAMES, gif_frames

    assert gif_frames(5) == [0, 1, 2, 3, 4]
    picks = gif_frames(16667)
    assert len(picks) == GIF_FRAMES and picks[0] == 0 and picks[-1] == 16666
    steps = np.diff(picks)
    assert steps.min() >= 55 and steps.max() <= 57  # 16666 / 299 = 55.7 frames apart


def test_a_long_take_s_gif_holds_the_capped_frames(sequence, tmp_path, monkeypatch, capsys):
    from PIL import Image

    import fringe3d.analyze.wing_strain as ws

    monkeypatch.setattr(ws, "GIF_FRAMES", 2)
    folder, anchors0, _ = sequence
    arg = ",".join(f"{x:.3f}" for x in anchors0.ravel())
    assert main(["strain", str(folder), "--anchors", arg, "-o", str(tmp_path / "out"), "-q", "--step", "6"]) == 0
    with Image.open(tmp_path / "out" / "strain.gif") as gif:
        assert gif.n_frames == 2  # frames 0 and 2 of 3
    assert len(list((tmp_path / "out" / "maps").glob("strain_*.png"))) == 3  # every frame's map still written


def test_pvd_time_steps_are_seconds_from_the_frame_rate(sequence, tmp_path, capsys):
    pv = pytest.importorskip("pyvista")  # VTK's PVD reader
    folder, anchors0, _ = sequence
    arg = ",".join(f"{x:.3f}" for x in anchors0.ravel())
    rate = 1.0 / (TIMES[1] - TIMES[0])  # the sequence's frames are TIMES (s) apart
    out = tmp_path / "o"
    assert main(["strain", str(folder), "--anchors", arg, "-o", str(out), "-q", "--no-figures", "--step", "8",
                 "--frame-rate", str(rate)]) == 0
    np.testing.assert_allclose(pv.get_reader(str(out / "strain.pvd")).time_values, TIMES, atol=1e-12)
    assert json.loads((out / "summary.json").read_text())["pvd_time_unit"] == "s"
    _expect_error(["strain", str(folder), "--anchors", arg, "-o", str(tmp_path / "bad"), "--frame-rate", "0"],
                  tmp_path / "bad", capsys, "--frame-rate must be > 0 Hz")
