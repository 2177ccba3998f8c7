"""Bit-plane packing of 1-bit patterns into RGB video frames, and a packed 24-pattern set captured
through the virtual rig (a DLP in video pattern mode) decoding like the unpacked set."""
import json

import numpy as np
import pytest

from fringe3d.cli import main
from fringe3d.decode import decode
from fringe3d.io.capture import read_capture
from fringe3d.io.packed_patterns import read_packed
from fringe3d.patterns.bitplanes import PLANE_ORDER, pack_bitplanes, unpack_bitplanes


def test_pack_then_unpack_round_trips_exactly_for_any_count():
    rng = np.random.default_rng(0)
    for count in (1, 7, 24, 25, 48):
        frames = rng.integers(0, 2, (count, 9, 13)).astype(np.uint8) * 255
        packed = pack_bitplanes(frames)
        assert packed.shape == (-(-count // 24), 9, 13, 3) and packed.dtype == np.uint8
        assert np.array_equal(unpack_bitplanes(packed, count), frames > 0)


def test_plane_k_is_bit_of_the_dlpc350_channel():
    frames = np.zeros((24, 1, 1), np.uint8)
    frames[9] = 255  # plane 9 = R1
    assert PLANE_ORDER[9] == (0, 1)
    assert pack_bitplanes(frames)[0, 0, 0].tolist() == [2, 0, 0]


def test_grey_patterns_cannot_be_packed():
    with pytest.raises(ValueError, match="only 1-bit patterns can be packed"):
        pack_bitplanes(np.full((2, 3, 3), 128, np.uint8))


@pytest.fixture(scope="module")
def packed_set(tmp_path_factory):
    out = tmp_path_factory.mktemp("bin") / "pats"
    # 14-step squared-binary T=18 + a 10-frame Gray code: 24 patterns, one packed video frame
    assert main(["patterns", "--set", "psp-gray", "--kind", "square", "--steps", "14", "--width", "256",
                 "--height", "200", "--pack-bitplanes", "-o", str(out), "-q"]) == 0
    return out


def test_pattern_folder_records_which_plane_is_which_pattern_and_round_trips(packed_set):
    from fringe3d.io.images import read_image
    d = json.loads((packed_set / "manifest.json").read_text())
    n = len(d["frames"])
    assert d["packing"]["frames"][0]["file"] == "bitplanes/00000.png"
    planes = [p for f in d["packing"]["frames"] for p in f["planes"]]
    assert [p["pattern"] for p in planes] == list(range(n))
    assert planes[0] == {"plane": 0, "channel": "G", "bit": 0, "pattern": 0}
    images, counts = read_packed(packed_set)
    unpacked = np.stack([read_image(packed_set / f"{i:05d}.png") for i in range(n)])
    assert np.array_equal(unpack_bitplanes(np.stack(images), n), unpacked > 0)
    assert sum(counts) == n


def test_packed_capture_through_the_virtual_dlp_decodes_like_the_unpacked_set(packed_set, tmp_path):
    packed_cap, plain_cap = tmp_path / "packed", tmp_path / "plain"
    cam = "virtual:tiny?scene=sphere&noise=0.01"
    assert main(["capture", str(packed_set), "-o", str(packed_cap), "--sync", "hardware",
                 "--projector", "virtual:tiny?bitplanes=1&defocus=2", "--camera", cam, "-q"]) == 0
    assert main(["capture", str(packed_set), "-o", str(plain_cap), "--sync", "software",
                 "--projector", "virtual:tiny?defocus=2", "--camera", cam, "-q"]) == 0
    a, b = read_capture(packed_cap), read_capture(plain_cap)
    n = len(a.patterns)
    assert n == 24 and (json.loads((packed_cap / "capture.json").read_text())["bitplanes"]["planes_per_video_frame"]
                        == [n])
    assert np.array_equal(a.frames, b.frames)
    da, db = decode(a.frames, a.patterns), decode(b.frames, b.patterns)
    assert np.array_equal(da.mask["v"], db.mask["v"]) and da.mask["v"].mean() > 0.5
    assert np.array_equal(da.phase["v"], db.phase["v"], equal_nan=True)
    print(f"packed {n}-pattern set: frames and decoded phase identical to the unpacked capture "
          f"(valid {da.mask['v'].mean():.1%})")


def test_missed_plane_in_a_packed_burst_is_placed_by_its_timestamp(packed_set, tmp_path, capsys):
    cap = tmp_path / "cap"
    code = main(["capture", str(packed_set), "-o", str(cap), "--sync", "hardware", "--timeout", "0.01",
                 "--projector", "virtual:tiny?bitplanes=1", "--camera", "virtual:tiny?scene=plane&drop=5"])
    assert code == 4
    assert "frame 5 (pattern 5, cycle 0) was not received" in " ".join(capsys.readouterr().err.split())
    meta = json.loads((cap / "capture.json").read_text())
    assert meta["missing_frames"] == [5] and meta["frames_received"] == 23 and meta["complete"] is False
    assert [f["index"] for f in meta["frames"]] == [i for i in range(24) if i != 5]


def test_packed_set_needs_hardware_sync_on_a_bitplane_projector(packed_set, tmp_path, capsys):
    code = main(["capture", str(packed_set), "-o", str(tmp_path / "c"), "--sync", "hardware",
                 "--projector", "virtual:tiny", "--camera", "virtual:tiny"])
    assert code == 2
    assert ("for packed RGB bit-plane frames open it as virtual:PRESET?bitplanes=1"
            in " ".join(capsys.readouterr().err.split()))
