"""Capture folders: round trip and every bad-input error, each naming what was wrong."""
import json

import numpy as np
import pytest

from fringe3d.io.capture import read_capture, write_capture
from fringe3d.io.images import read_image, write_image
from fringe3d.patterns import render_set, sets


@pytest.fixture
def ps():
    return sets.phase_shift(18, 3, "v", width=40, height=30)


def _frames(n, h=24, w=32, dtype=np.uint8, seed=0):
    rng = np.random.default_rng(seed)
    hi = 255 if dtype == np.uint8 else 4095
    return rng.integers(0, hi + 1, size=(n, h, w)).astype(dtype)


@pytest.mark.parametrize("dtype,fmt", [(np.uint8, "png"), (np.uint16, "png"), (np.uint16, "tif"),
                                       (np.float32, "tif")])
def test_capture_round_trip_is_lossless(tmp_path, ps, dtype, fmt):
    frames = _frames(6, dtype=np.uint16 if dtype == np.float32 else dtype).astype(dtype)
    write_capture(tmp_path / "cap", frames, ps, {"frame_rate": 1000.0, "note": "x"}, fmt=fmt)
    cap = read_capture(tmp_path / "cap")
    assert cap.frames.dtype == dtype
    np.testing.assert_array_equal(cap.frames, frames)
    assert cap.patterns == ps and cap.cycles == 2
    np.testing.assert_array_equal(cap.cycle(1), frames[3:])
    assert cap.meta["frame_rate"] == 1000.0 and cap.meta["camera"] == [32, 24] and cap.meta["note"] == "x"
    assert not list((tmp_path / "cap").rglob("*.part*"))  # no temporary files left


def test_rendered_patterns_survive_a_capture_round_trip(tmp_path):
    ps = sets.three_frequency("h", width=64, height=48)
    frames = render_set(ps)
    write_capture(tmp_path, frames, ps)
    np.testing.assert_array_equal(read_capture(tmp_path).frames, frames)


def test_missing_folder(tmp_path):
    with pytest.raises(FileNotFoundError, match="does not exist"):
        read_capture(tmp_path / "nope")


def test_missing_manifest(tmp_path, ps):
    write_capture(tmp_path, _frames(3), ps)
    (tmp_path / "manifest.json").unlink()
    with pytest.raises(FileNotFoundError, match="no manifest.json"):
        read_capture(tmp_path)


def test_frame_count_not_a_multiple_names_both_numbers(tmp_path, ps):
    write_capture(tmp_path, _frames(6), ps)
    (tmp_path / "frames" / "00005.png").unlink()
    with pytest.raises(ValueError, match=r"5 frames.*manifest's 3 frames"):
        read_capture(tmp_path)


def test_frames_of_different_shapes_name_the_file_and_both_shapes(tmp_path, ps):
    write_capture(tmp_path, _frames(3), ps)
    write_image(tmp_path / "frames" / "00002.png", np.zeros((20, 32), np.uint8))
    with pytest.raises(ValueError, match=r"00002\.png has shape \(20, 32\).*00000\.png has \(24, 32\)"):
        read_capture(tmp_path)


def test_unreadable_frame_names_the_file(tmp_path, ps):
    write_capture(tmp_path, _frames(3), ps)
    (tmp_path / "frames" / "00001.png").write_bytes(b"this is not a png")
    with pytest.raises(ValueError, match=r"00001\.png is not a readable image"):
        read_capture(tmp_path)


def test_empty_frame_file_names_the_file(tmp_path, ps):
    write_capture(tmp_path, _frames(3), ps)
    (tmp_path / "frames" / "00002.png").write_bytes(b"")
    with pytest.raises(ValueError, match=r"00002\.png is not a readable image \(expected PNG or TIFF, empty file\)"):
        read_capture(tmp_path)


def test_non_image_file_in_frames_names_the_file(tmp_path, ps):
    write_capture(tmp_path, _frames(3), ps)
    (tmp_path / "frames" / "notes.txt").write_text("hello")
    with pytest.raises(ValueError, match=r"notes\.txt is not a frame image"):
        read_capture(tmp_path)


def test_gap_in_frame_numbering(tmp_path, ps):
    write_capture(tmp_path, _frames(6), ps)
    (tmp_path / "frames" / "00002.png").rename(tmp_path / "frames" / "00009.png")
    with pytest.raises(ValueError, match="gap or duplicate at 00003.png"):
        read_capture(tmp_path)


def test_mixed_bit_depths_are_rejected(tmp_path, ps):
    write_capture(tmp_path, _frames(3), ps)
    write_image(tmp_path / "frames" / "00001.png", np.zeros((24, 32), np.uint16))
    with pytest.raises(ValueError, match="uint16 but 00000.png is uint8"):
        read_capture(tmp_path)


def test_manifest_with_unknown_fields_is_rejected(tmp_path, ps):
    write_capture(tmp_path, _frames(3), ps)
    d = json.loads((tmp_path / "manifest.json").read_text())
    d["frames"][1]["colour"] = "red"
    (tmp_path / "manifest.json").write_text(json.dumps(d))
    with pytest.raises(ValueError, match=r"manifest .*manifest.json: field frames\[1\]\.colour: unknown field"):
        read_capture(tmp_path)
    d = json.loads((tmp_path / "manifest.json").read_text())
    del d["frames"][1]["colour"]
    d["projector_model"] = "x"
    (tmp_path / "manifest.json").write_text(json.dumps(d))
    with pytest.raises(ValueError, match=r"field projector_model: unknown field"):
        read_capture(tmp_path)


def test_missing_frames_folder(tmp_path, ps):
    ps.save(tmp_path)
    with pytest.raises(FileNotFoundError, match="no frames/ folder"):
        read_capture(tmp_path)


def test_bad_capture_json_fields(tmp_path, ps):
    write_capture(tmp_path, _frames(3), ps)
    (tmp_path / "capture.json").write_text(json.dumps({"frame_rate": -5}))
    with pytest.raises(ValueError, match=r"capture.json: field frame_rate: Input should be greater than 0 \(got -5\)"):
        read_capture(tmp_path)
    (tmp_path / "capture.json").write_text(json.dumps({"camera": [10, 10]}))
    with pytest.raises(ValueError, match="camera is 10x10 but the frames are 32x24"):
        read_capture(tmp_path)


def test_write_capture_rejects_wrong_count_and_float_png(tmp_path, ps):
    with pytest.raises(ValueError, match="4 frames"):
        write_capture(tmp_path, _frames(4), ps)
    with pytest.raises(ValueError, match="uint8 or uint16"):
        write_capture(tmp_path, _frames(3).astype(np.float32), ps)


def test_rewriting_a_shorter_capture_removes_stale_frames(tmp_path, ps):
    write_capture(tmp_path, _frames(6), ps)
    write_capture(tmp_path, _frames(3, seed=1), ps)
    cap = read_capture(tmp_path)
    np.testing.assert_array_equal(cap.frames, _frames(3, seed=1))


def test_read_image_converts_colour_to_grey(tmp_path):
    import cv2
    bgr = np.zeros((5, 6, 3), np.uint8)
    bgr[..., 2] = 200  # red in OpenCV's BGR order
    cv2.imwrite(str(tmp_path / "c.png"), bgr)
    grey = read_image(tmp_path / "c.png")
    assert grey.shape == (5, 6) and abs(int(grey[0, 0]) - round(0.299 * 200)) <= 1


def test_failed_image_write_leaves_no_file(tmp_path):
    with pytest.raises(ValueError, match="PNG holds uint8 or uint16"):
        write_image(tmp_path / "x.png", np.zeros((4, 4), np.float64))
    with pytest.raises(ValueError, match="unsupported image suffix"):
        write_image(tmp_path / "x.jpg2", np.zeros((4, 4), np.uint8))
    assert list(tmp_path.iterdir()) == []


def test_missing_image_file(tmp_path):
    with pytest.raises(FileNotFoundError, match="does not exist"):
        read_image(tmp_path / "nope.png")


def test_a_rewrite_that_fails_part_way_leaves_no_readable_capture(tmp_path, ps):
    from fringe3d.io.capture import write_capture_frames

    write_capture(tmp_path / "cap", _frames(6), ps)
    new = _frames(6, seed=1)

    def failing():
        yield from new[:4]
        raise OSError("camera disconnected")

    with pytest.raises(OSError, match="disconnected"):
        write_capture_frames(tmp_path / "cap", failing(), 6, ps)
    # new frames 0-3 beside old 4-5: never read as a capture, whatever frames survived
    assert not (tmp_path / "cap" / "capture.json").exists()
    with pytest.raises(FileNotFoundError, match="manifest"):
        read_capture(tmp_path / "cap")
    write_capture_frames(tmp_path / "cap", iter(new), 6, ps)  # the same call again completes it
    np.testing.assert_array_equal(read_capture(tmp_path / "cap").frames, new)
