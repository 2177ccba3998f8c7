"""The ``pylon`` backend against Basler's camera emulation (a real pylon device, PYLON_CAMEMU):
image-file mode fed with simulator frames, software trigger, projected by the window projector
under Xvfb."""
import json
import os

os.environ.setdefault("PYLON_CAMEMU", "1")  # before pylon's transport layer is created

import numpy as np
import pytest
from devices_xvfb import SCREEN

from fringe3d.cli import main
from fringe3d.decode import decode
from fringe3d.io.capture import read_capture

EMU_SERIAL = "0815-0000"


@pytest.fixture(scope="module")
def fed(tmp_path_factory):
    """Pattern folder (the tiny projector's size) and the simulator's capture of it."""
    root = tmp_path_factory.mktemp("pylon")
    pats, sim = root / "pats", root / "sim"
    assert main(["patterns", "--set", "three-frequency", "--width", str(SCREEN[0]), "--height", str(SCREEN[1]),
                 "-o", str(pats), "-q"]) == 0
    assert main(["simulate", "--preset", "tiny", "--scene", "sphere", "--set", str(pats / "manifest.json"),
                 "--noise", "0.01", "-o", str(sim), "-q"]) == 0
    return pats, sim


def _emulator_features(frames_dir):
    return ["--camera-feature", f"ImageFilename={frames_dir}", "--camera-feature", "ImageFileMode=On",
            "--camera-feature", "TestImageSelector=Off"]


def test_fifteen_frame_capture_arrives_complete_in_order_and_decodes_to_the_fed_phase(fed, tmp_path, xvfb):
    pats, sim = fed
    cap = tmp_path / "cap"
    code = main(["capture", str(pats), "-o", str(cap), "--projector", "window:0", "--camera", f"pylon:{EMU_SERIAL}",
                 "--roi", "0,0,160,128", "--exposure", "0.001", *_emulator_features(sim / "frames"), "-q"])
    assert code == 0
    meta = json.loads((cap / "capture.json").read_text())
    assert meta["complete"] is True and meta["frames_received"] == 15
    assert [f["frame_id"] for f in meta["frames"]] == list(range(15))  # pylon's BlockID, in order
    assert meta["camera_device"]["model"] == "Emulation" and meta["camera_device"]["serial"] == EMU_SERIAL
    assert meta["camera_device"]["exposure"] == pytest.approx(0.001)
    assert meta["camera_device"]["trigger_mode"] == "software" and meta["projector"]["backend"] == "window"
    got, want = read_capture(cap), read_capture(sim)
    assert np.array_equal(got.frames, want.frames)
    a, b = decode(got.frames, got.patterns), decode(want.frames, want.patterns)
    both = a.mask["v"] & b.mask["v"]
    err = float(np.max(np.abs(a.phase["v"][both] - b.phase["v"][both])))
    print(f"pylon emulation: 15 frames in order, max phase error vs fed frames {err:.3g} rad")
    assert both.mean() > 0.5 and err < 1e-6


def test_skipped_trigger_is_reported_by_frame_number_and_not_marked_complete(fed, tmp_path, xvfb):
    from fringe3d.io.pattern_folder import read_pattern_folder
    from fringe3d.devices import open_projector
    from fringe3d.devices.acquire import CaptureIncompleteError, CaptureTiming, capture_sequence
    from fringe3d.devices.pylon import PylonCamera

    class SkipsTriggerSeven(PylonCamera):
        """The real emulated camera; the capture loop's 8th software trigger is not sent."""
        sent = 0

        def trigger(self):
            self.sent += 1
            if self.sent - 1 != 7:
                super().trigger()

    pats, sim = fed
    ps, images, _ = read_pattern_folder(pats)
    cam = SkipsTriggerSeven(EMU_SERIAL, features=[("ImageFilename", str(sim / "frames")), ("ImageFileMode", "On"),
                                                 ("TestImageSelector", "Off")])
    cam.roi = (0, 0, 160, 128)
    with pytest.warns(Warning):
        proj = open_projector("window:0")
    try:
        with pytest.raises(CaptureIncompleteError) as info:
            capture_sequence(proj, cam, ps, images, tmp_path / "cap", timing=CaptureTiming(timeout=0.3))
    finally:
        cam.close()
        proj.close()
    msg = str(info.value)
    print(f"pylon emulation, one trigger skipped: {msg}")
    assert "frame 7 (pattern 7, cycle 0) was not received" in msg and "14 of 15 frames" in msg
    meta = json.loads((tmp_path / "cap" / "capture.json").read_text())
    assert meta["complete"] is False and meta["missing_frames"] == [7]
    with pytest.raises(ValueError, match="incomplete"):
        read_capture(tmp_path / "cap")


def test_unknown_serial_lists_the_cameras_pylon_found(fed, tmp_path, capsys):
    pats, _ = fed
    code = main(["capture", str(pats), "-o", str(tmp_path / "c"), "--projector", "virtual:tiny",
                 "--camera", "pylon:40012345"])
    err = " ".join(capsys.readouterr().err.split())
    assert code == 2
    assert "no Basler camera with serial or name '40012345' found; pylon found: Emulation serial 0815-0000" in err
