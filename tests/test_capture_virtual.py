"""``fringe3d capture`` on the virtual rig: bit-identity with ``fringe3d simulate``, dropped and
duplicated frames named, interrupted captures never marked complete, bad input with clear messages."""
import json

import numpy as np
import pytest

from fringe3d.cli import main
from fringe3d.io.capture import read_capture


def _meta(folder):
    return json.loads((folder / "capture.json").read_text())


@pytest.mark.parametrize("scene", ["sphere", "wing"])  # static, and moving (re-rendered at each frame's time)
def test_virtual_capture_frames_are_bit_identical_to_simulate(pats, tmp_path, scene):
    cap, sim = tmp_path / "cap", tmp_path / "sim"
    code = main(["capture", str(pats), "-o", str(cap), "--projector", "virtual:tiny",
                 "--camera", f"virtual:tiny?scene={scene}&seed=7&noise=0.02", "-q"])
    assert code == 0
    assert main(["simulate", "--preset", "tiny", "--scene", scene, "--set", str(pats / "manifest.json"),
                 "--seed", "7", "--noise", "0.02", "-o", str(sim), "-q"]) == 0
    a, b = read_capture(cap).frames, read_capture(sim).frames
    assert a.shape == b.shape == (15, 128, 160)
    assert np.array_equal(a, b)
    meta = _meta(cap)
    assert meta["complete"] is True and meta["frames_received"] == 15
    assert [f["frame_id"] for f in meta["frames"]] == list(range(15))
    assert meta["camera_device"]["trigger_mode"] == "software" and meta["sync"]["mode"] == "software"
    assert meta["projector"]["width"] == 256 and meta["camera"] == [160, 128]


def test_hardware_sync_capture_of_two_cycles_equals_simulate_of_two_cycles(pats, tmp_path):
    cap, sim = tmp_path / "cap", tmp_path / "sim"
    assert main(["capture", str(pats), "-o", str(cap), "--projector", "virtual:tiny", "--sync", "hardware",
                 "--cycles", "2", "--camera", "virtual:tiny?scene=plane&noise=0.01", "-q"]) == 0
    assert main(["simulate", "--preset", "tiny", "--scene", "plane", "--set", str(pats / "manifest.json"),
                 "--frames", "30", "--noise", "0.01", "-o", str(sim), "-q"]) == 0
    assert np.array_equal(read_capture(cap).frames, read_capture(sim).frames)
    meta = _meta(cap)
    assert meta["frame_rate"] == pytest.approx(100.0)
    assert np.allclose(np.diff([f["timestamp"] for f in meta["frames"]]), 0.01)


def test_missed_hardware_trigger_is_named_and_the_folder_is_not_complete(pats, tmp_path, capsys):
    cap = tmp_path / "cap"
    code = main(["capture", str(pats), "-o", str(cap), "--projector", "virtual:tiny", "--sync", "hardware",
                 "--timeout", "0.01", "--camera", "virtual:tiny?scene=plane&drop=7"])
    err = capsys.readouterr().err
    assert code == 4
    assert "frame 7 (pattern 7, cycle 0) was not received" in " ".join(err.split())
    meta = _meta(cap)
    assert meta["complete"] is False and meta["missing_frames"] == [7] and meta["frames_received"] == 14
    with pytest.raises(ValueError, match="incomplete"):
        read_capture(cap)
    assert main(["decode", str(cap), "-o", str(tmp_path / "dec")]) == 2


def test_frame_delivered_twice_is_named_as_a_duplicate(pats, tmp_path, capsys):
    cap = tmp_path / "cap"
    code = main(["capture", str(pats), "-o", str(cap), "--projector", "virtual:tiny",
                 "--camera", "virtual:tiny?scene=plane&repeat=3"])
    err = " ".join(capsys.readouterr().err.split())
    assert code == 4
    assert "frame 4 (pattern 4, cycle 0) repeats camera frame id 3 of frame 3 (pattern 3, cycle 0) (duplicated)" in err
    meta = _meta(cap)
    assert meta["complete"] is False and meta["duplicate_frames"] == [4]


def test_unplugged_camera_leaves_the_capture_marked_incomplete(pats, tmp_path, capsys):
    cap = tmp_path / "cap"
    code = main(["capture", str(pats), "-o", str(cap), "--projector", "virtual:tiny",
                 "--camera", "virtual:tiny?scene=plane&unplug=5"])
    err = " ".join(capsys.readouterr().err.split())
    assert code == 4 and "unplugged" in err and "marked incomplete" in err
    meta = _meta(cap)
    assert meta["complete"] is False and meta["status"] == "interrupted" and meta["frames_received"] == 5
    with pytest.raises(ValueError, match="incomplete"):
        read_capture(cap)


def test_ctrl_c_during_capture_leaves_the_folder_marked_incomplete(pats, tmp_path, capsys):
    cap = tmp_path / "cap"
    code = main(["capture", str(pats), "-o", str(cap), "--projector", "virtual:tiny",
                 "--camera", "virtual:tiny?scene=plane&interrupt=9"])
    assert code == 4 and "capture interrupted" in capsys.readouterr().err
    meta = _meta(cap)
    assert meta["complete"] is False and meta["interrupted"] == "KeyboardInterrupt" and meta["frames_received"] == 9


def test_exposure_longer_than_the_frame_period_is_refused(pats, tmp_path, capsys):
    code = main(["capture", str(pats), "-o", str(tmp_path / "c"), "--projector", "virtual:tiny", "--sync", "hardware",
                 "--camera", "virtual:tiny", "--exposure", "0.02"])
    assert code == 2
    assert "exposure 0.02 s is longer than the frame period 0.01 s" in " ".join(capsys.readouterr().err.split())
    assert not (tmp_path / "c" / "capture.json").exists()


@pytest.mark.parametrize("args, message", [
    (["--projector", "beamer:0", "--camera", "opencv:0"], "unknown projector backend 'beamer'"),
    (["--projector", "virtual:tiny", "--camera", "webcam:0"], "unknown camera backend 'webcam'"),
    (["--projector", "virtual:tiny", "--camera", "genicam:/nowhere/producer.cti"], "pip install 'fringe3d[genicam]'"),
    (["--projector", "virtual:tiny", "--camera", "virtual:tiny?colour=red"], "unknown option(s) ['colour']"),
    (["--projector", "virtual:tiny", "--camera", "virtual:macro"], "must use the same preset"),
    (["--projector", "virtual:tiny", "--camera", "virtual:tiny?scene=falling-balls"], "is not seen by the camera"),
    (["--projector", "virtual:tiny", "--camera", "opencv:7"], "OpenCV cannot open video device 7; devices that open:"),
    (["--projector", "virtual:tiny", "--camera", "virtual:tiny", "--pixel-format", "Mono14"],
     "pixel format 'Mono14' is not supported; expected one of Mono8, Mono10, Mono12"),
])
def test_bad_device_specs_get_clear_messages(pats, tmp_path, capsys, args, message):
    code = main(["capture", str(pats), "-o", str(tmp_path / "c"), *args])
    assert code == 2
    assert message in " ".join(capsys.readouterr().err.split())


def test_patterns_larger_than_the_projector_are_refused(tmp_path, capsys):
    big = tmp_path / "big"
    assert main(["patterns", "--set", "phase-shift", "--width", "300", "--height", "200", "-o", str(big), "-q"]) == 0
    code = main(["capture", str(big), "-o", str(tmp_path / "c"), "--projector", "virtual:tiny",
                 "--camera", "virtual:tiny"])
    assert code == 2
    assert "the patterns are 300x200 but the projector is 256x200" in " ".join(capsys.readouterr().err.split())


def test_latency_helper_on_the_virtual_rig_reports_no_delay(tmp_path, capsys):
    out = tmp_path / "latency.json"
    assert main(["capture", "--latency", "-o", str(out), "--projector", "virtual:tiny",
                 "--camera", "virtual:tiny?scene=plane", "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    assert res["latency"] == 0.0 and res["white_mean"] > res["black_mean"] + 50
    assert json.loads(out.read_text())["latency"] == 0.0


def test_twelve_bit_virtual_capture_is_written_as_16_bit_png_with_bit_depth_12(pats, tmp_path):
    cap = tmp_path / "cap"
    assert main(["capture", str(pats), "-o", str(cap), "--projector", "virtual:tiny", "--camera", "virtual:tiny",
                 "--pixel-format", "Mono12", "-q"]) == 0
    c = read_capture(cap)
    assert c.frames.dtype == np.uint16 and c.bit_depth == 12 and 1000 < c.frames.max() <= 4095
