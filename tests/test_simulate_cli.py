"""``fringe3d simulate`` and ``simulate_capture``: what they write, and the errors they give."""
import dataclasses
import json

import numpy as np
import pytest

from fringe3d.cli import main
from fringe3d.io.capture import read_capture
from fringe3d.optics import Rig
from fringe3d.sim import RenderChanges, Truth, presets, simulate_capture


def wrapped(frames):
    """N-step least-squares phase, Eq. (2.4), closed form."""
    I = np.asarray(frames, float)
    d = 2 * np.pi * np.arange(len(I))[:, None, None] / len(I)
    return np.arctan2(-(I * np.sin(d)).sum(0), (I * np.cos(d)).sum(0))


def test_simulate_cli_writes_a_capture_with_truth_and_rig(tmp_path, capsys):
    out = tmp_path / "cap"
    code = main(["simulate", "--preset", "tiny", "--scene", "sphere", "--set", "three-frequency-v",
                 "-o", str(out), "--bit-depth", "16", "--ideal", "--json"])
    assert code == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["frames"] == 15 and summary["preset"] == "tiny"
    cap = read_capture(out)
    assert cap.frames.shape == (15, 128, 160) and cap.frames.dtype == np.uint16
    truth = Truth.load(out)
    rig = Rig.load(out / "rig.json")
    assert np.allclose(rig.projector.P, presets.get("tiny").rig.projector.P)
    # the 9-step T=18 group decodes to the truth phase (wrapped), Eq. (2.4)
    idx = cap.patterns.indices(group=cap.patterns.groups("v")[0])
    phi = wrapped(cap.frames[idx])
    err = np.angle(np.exp(1j * (phi - truth.phase["v"])))[truth.mask]
    assert truth.mask.mean() > 0.8
    assert np.sqrt(np.mean(err**2)) < 2e-3  # 16-bit quantisation, 8% ambient


def test_simulate_capture_repeats_the_sequence_with_frame_times(tmp_path):
    summary = simulate_capture(tmp_path / "c", "tiny", "plane", "two-frequency", frames=12, progress=False,
                               render=RenderChanges(frame_rate=500.0))
    assert summary["frames"] == 12
    cap = read_capture(tmp_path / "c")
    assert len(cap.frames) == 12 and cap.meta["frame_rate"] == 500.0
    assert Truth.load(tmp_path / "c").meta["times"][-1] == pytest.approx(11 / 500.0)


def test_scene_file_round_trip(tmp_path):
    f = tmp_path / "scene.json"
    f.write_text(json.dumps({"objects": [
        {"type": "sphere", "center": [0, 0, 400], "radius": 50, "texture": {"type": "checker", "period": 0.3}},
        {"type": "plane", "point": [0, 0, 470], "normal": [0, 0, -1], "albedo": 0.7}]}))
    simulate_capture(tmp_path / "c", "tiny", str(f), "phase-shift", progress=False)
    truth = Truth.load(tmp_path / "c")
    assert set(np.unique(truth.object_id)) == {0, 1}


@pytest.mark.parametrize("args,message", [
    (["--preset", "mega"], "unknown preset 'mega'"),
    (["--frame-rate", "0"], "--frame-rate must be positive"),
    (["--frame-rate", "100", "--exposure", "0.5"], "longer than the frame period"),
    (["--scene", "teapot"], "unknown scene 'teapot'"),
    (["--set", "zigzag"], "unknown pattern set 'zigzag'"),
    (["--set", "phase-shift", "--frames", "10"], "multiple of the pattern set's 9 frames"),
])
def test_bad_simulate_arguments_exit_2_with_a_clear_message(tmp_path, capsys, args, message):
    code = main(["simulate", "-o", str(tmp_path / "x"), "--quiet", *args])
    assert code == 2
    assert message in " ".join(capsys.readouterr().err.split())
    assert not (tmp_path / "x" / "manifest.json").exists()


@pytest.mark.parametrize("scene,message", [
    ({"objects": [{"type": "sphere", "center": [0, 0, 400]}]}, "objects[0]: missing field 'radius'"),
    ({"objects": [{"type": "sphere", "center": [0, 0, 400], "radius": 5, "colour": 1}]}, "objects[0].colour"),
    ({"objects": [{"type": "cube", "center": [0, 0, 400]}]}, "objects[0].type: unknown object type 'cube'"),
    ({"objects": [{"type": "plane", "point": [0, 0, 400], "normal": "up"}]}, "objects[0].normal"),
    ({"objects": [{"type": "sphere", "center": [0, 0, 400], "radius": -1}]}, "objects[0]: sphere radius"),
    ({"things": []}, "scene.json.things: unknown field"),
    ({"objects": []}, "scene.json.objects: expected a non-empty list"),
])
def test_invalid_scene_file_names_the_field(tmp_path, capsys, scene, message):
    f = tmp_path / "scene.json"
    f.write_text(json.dumps(scene))
    code = main(["simulate", "-o", str(tmp_path / "x"), "--quiet", "--scene", str(f)])
    assert code == 2
    assert message in " ".join(capsys.readouterr().err.split())


def test_object_behind_the_camera_is_a_clear_error(tmp_path):
    f = tmp_path / "behind.json"
    f.write_text(json.dumps({"objects": [{"type": "sphere", "center": [0, 0, -400], "radius": 50}]}))
    with pytest.raises(ValueError, match="behind the camera"):
        simulate_capture(tmp_path / "x", "tiny", str(f), "phase-shift", progress=False)


def test_object_outside_the_projector_view_is_a_clear_error(tmp_path):
    # the tiny rig with its projector turned 60 degrees away from the camera's view
    p = presets.get("tiny")
    R, t = presets.look_at((100.0, 0.0, 0.0), (100.0 + 400 * np.sin(1.05), 0.0, 400 * np.cos(1.05)))
    turned = dataclasses.replace(p, rig=Rig(p.rig.camera, p.rig.projector.with_pose(R, t)))
    with pytest.raises(ValueError, match="outside the projector"):
        simulate_capture(tmp_path / "x", turned, "sphere", "phase-shift", progress=False)
    assert not (tmp_path / "x" / "manifest.json").exists()


def test_missing_scene_file_is_file_not_found(tmp_path):
    with pytest.raises(FileNotFoundError, match="no scene file"):
        simulate_capture(tmp_path / "x", "tiny", str(tmp_path / "nope.json"), "phase-shift", progress=False)


def test_simulated_three_frequency_capture_decodes_to_the_truth_absolute_phase(tmp_path):
    """The decoder (heterodyne unwrapping) on a noise-free 16-bit capture returns the truth
    absolute phase Phi = 2 pi w / T (narrowest period) within 1e-3 rad in both directions."""
    from fringe3d.decode import decode
    simulate_capture(tmp_path / "c", "tiny", "sphere", "three-frequency", progress=False,
                     render=RenderChanges(bit_depth=16, others={"ideal": True}))
    cap = read_capture(tmp_path / "c")
    truth = Truth.load(tmp_path / "c")
    dec = decode(cap.frames, cap.patterns)
    for d in ("v", "h"):
        m = truth.mask & dec.mask[d]
        assert m.sum() > 0.95 * truth.mask.sum()
        assert np.abs(dec.phase[d][m] - truth.phase[d][m]).max() < 1e-3


def test_moving_scene_capture_has_per_frame_truth_on_the_falling_balls(tmp_path):
    from fringe3d.sim.catalog import named_scene
    scene = named_scene("falling-balls", presets.get("tiny"))
    simulate_capture(tmp_path / "c", "tiny", scene, "two-frequency", progress=False,
                     render=RenderChanges(frame_rate=500.0))
    truth = Truth.load(tmp_path / "c")
    assert truth.per_frame and truth.xyz.shape[0] == 6
    for k in (0, 5):
        tk = truth.frame(k)
        for i, ball in enumerate(scene.objects):
            m = tk.object_id == i
            assert m.sum() > 10
            r = np.linalg.norm(tk.xyz[m] - ball.center_at(k / 500.0), axis=1)
            assert np.abs(r - ball.radius).max() < 1e-6  # on the ball at its closed-form position


def test_twelve_bit_capture_is_written_as_uint16_with_its_bit_depth(tmp_path):
    simulate_capture(tmp_path / "c", "tiny", "plane", "phase-shift", progress=False,
                     render=RenderChanges(bit_depth=12))
    cap = read_capture(tmp_path / "c")
    assert cap.frames.dtype == np.uint16 and cap.frames.max() <= 4095 and cap.frames.max() > 255
    assert json.loads((tmp_path / "c" / "capture.json").read_text())["bit_depth"] == 12
