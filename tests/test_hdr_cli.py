"""HDR end to end: simulate --exposures writes a bracket, decode and reconstruct fuse it per pixel."""
from __future__ import annotations

import json

import numpy as np
import tifffile

from fringe3d.cli import main
from fringe3d.decode.edges import SATURATED
from fringe3d.io.capture import read_capture
from fringe3d.phase.exposure_fusion import split_bracket

BRACKET = "0.000625,0.0025,0.01"


def _simulate(tmp_path, *extra, patterns="phase-shift"):
    out = tmp_path / "cap"
    assert main(["simulate", "--scene", "shiny-part", "--patterns", patterns, "--gain", "4", "-o", str(out),
                 "-q", *extra]) == 0
    return out


def test_simulate_exposures_writes_one_cycle_per_exposure(tmp_path):
    cap = read_capture(_simulate(tmp_path, "--exposures", BRACKET))
    assert cap.meta["exposures"] == [0.000625, 0.0025, 0.01]
    stacks = split_bracket(cap.frames, 3, len(cap.patterns))
    means = stacks.reshape(3, -1).astype(float).mean(axis=1)
    assert means[0] < means[1] < means[2]  # longer exposure, brighter frames


def test_decode_fuses_a_bracket_and_saturated_means_every_exposure(tmp_path):
    cap_dir = _simulate(tmp_path, "--exposures", BRACKET)
    single = _simulate(tmp_path / "one", "--exposure", "0.0025")
    out, out1 = tmp_path / "dec", tmp_path / "dec1"
    assert main(["decode", str(cap_dir), "-o", str(out), "-q"]) == 0
    assert main(["decode", str(single), "-o", str(out1), "-q"]) == 0
    index = tifffile.imread(out / "exposure_index.tif")
    cap = read_capture(cap_dir)
    stacks = split_bracket(cap.frames, 3, len(cap.patterns))
    every = (stacks >= 255).any(axis=1).all(axis=0)
    assert set(np.unique(index)) == {0, 1, 2}
    summary = json.loads((out / "decoded.json").read_text())
    d = summary["directions"][0] if isinstance(summary.get("directions"), list) else "v"
    q = tifffile.imread(out / f"quality_{d}.tif")
    flagged = (q & SATURATED) > 0
    # SATURATED only where every exposure saturated (the decoder recovers some of those from the
    # unclipped steps of the 9-step cycle, phase.clipping, so not necessarily all of them)
    assert flagged.any() and not np.any(flagged & ~every)
    valid = tifffile.imread(out / f"mask_{d}.tif").mean()
    valid1 = tifffile.imread(out1 / f"mask_{d}.tif").mean()
    assert valid > valid1 + 0.05


def test_reconstruct_fuses_a_bracket(tmp_path, capsys):
    cap_dir = _simulate(tmp_path, "--exposures", BRACKET, patterns="three-frequency")
    assert main(["reconstruct", str(cap_dir), "--calibration", str(cap_dir / "rig.json"), "-o",
                 str(tmp_path / "rec"), "--json"]) == 0
    out = capsys.readouterr().out
    assert json.loads(out[out.index("{"):])["cycles"] == 1


def test_import_exposures_records_the_bracket_and_checks_its_frame_count(tmp_path):
    cap_dir = _simulate(tmp_path, "--exposures", BRACKET)
    frames = str(cap_dir / "frames")
    manifest = str(cap_dir / "manifest.json")
    assert main(["import", frames, "--manifest", manifest, "--exposures", BRACKET, "-o", str(tmp_path / "imp"),
                 "-q"]) == 0
    assert read_capture(tmp_path / "imp").meta["exposures"] == [0.000625, 0.0025, 0.01]
    assert main(["decode", str(tmp_path / "imp"), "-o", str(tmp_path / "d1"), "-q"]) == 0
    assert main(["decode", str(cap_dir), "-o", str(tmp_path / "d2"), "-q"]) == 0
    assert np.array_equal(tifffile.imread(tmp_path / "d1" / "exposure_index.tif"),
                          tifffile.imread(tmp_path / "d2" / "exposure_index.tif"))
    assert main(["import", frames, "--manifest", manifest, "--exposures", "0.001,0.004",
                 "-o", str(tmp_path / "bad"), "-q"]) == 2
    assert not (tmp_path / "bad" / "capture.json").exists()


def test_capture_exposures_brackets_the_virtual_camera(tmp_path):
    pats, cap_dir = tmp_path / "pats", tmp_path / "cap"
    assert main(["patterns", "--set", "phase-shift", "--width", "256", "--height", "200", "-o", str(pats), "-q"]) == 0
    assert main(["capture", str(pats), "-o", str(cap_dir), "--projector", "virtual:tiny", "--camera",
                 "virtual:tiny?scene=shiny-part", "--exposures", "0.001,0.004", "-q"]) == 0
    cap = read_capture(cap_dir)
    assert cap.meta["exposures"] == [0.001, 0.004]
    assert [r["exposure"] for r in cap.meta["frames"]] == [0.001] * len(cap.patterns) + [0.004] * len(cap.patterns)
    stacks = split_bracket(cap.frames, 2, len(cap.patterns)).astype(float)
    assert stacks[1].mean() > 2 * stacks[0].mean()  # the longer exposure is brighter
    assert main(["decode", str(cap_dir), "-o", str(tmp_path / "dec"), "-q"]) == 0
    assert (tmp_path / "dec" / "exposure_index.tif").is_file()


def test_simulate_read_noise_e_selects_the_emva_camera(tmp_path, capsys):
    cap_dir = _simulate(tmp_path, "--read-noise-e", "15", "--full-well", "5000")
    rs = read_capture(cap_dir).meta["render_settings"]
    assert (rs["noise_model"], rs["read_noise_e"], rs["full_well"]) == ("emva", 15.0, 5000.0)
    code = main(["simulate", "--scene", "shiny-part", "--noise", "0.01", "--read-noise-e", "15",
                 "-o", str(tmp_path / "bad"), "-q"])
    assert code == 2 and "--read-noise-e" in capsys.readouterr().err
    assert not (tmp_path / "bad").exists()
