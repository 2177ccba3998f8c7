"""Phantom CINE as a capture source (issue 16): header fields, checks and bounded reads.

No library writes CINE files, so ``tests/cine_writer.py`` writes them from simulator frames; the
first test checks that writer against an independent reader (pims) and against offsets the
published layout fixes. The truth for decoding is the PNG capture of the very same frames.
"""
from __future__ import annotations

import json

import numpy as np
import pims
import pytest
from cine_writer import write_cine

from fringe3d.cli import main
from fringe3d.decode import DecodeOptions, decode
from fringe3d.io.capture import read_capture, write_capture
from fringe3d.io.frame_sources import CineSource
from fringe3d.patterns import sets
from fringe3d.sim import presets
from fringe3d.sim.render import render
from fringe3d.sim.simulate import make_scene

PERIOD = 16.0


def cli(*args) -> int:
    return main([str(a) for a in args])


@pytest.fixture(scope="module")
def sim():
    """(patterns, frames (6, H, W) uint8: two cycles of a 3-step set, the second moved) of the tiny rig."""
    p = presets.get("tiny")
    ps = sets.phase_shift(PERIOD, 3, "v", width=p.rig.projector.width, height=p.rig.projector.height)
    f, _ = render(make_scene("sphere", p), p.rig, ps, p.settings, progress=False)
    return ps, np.concatenate([f, np.roll(f, 3, axis=2)])


def import_(src, out, ps, *extra) -> int:
    return cli("import", src, "-o", out, "--set", "phase-shift", "--steps", 3, "--period", PERIOD,
               "--projector-size", f"{ps.width}x{ps.height}", "--quiet", *extra)


@pytest.mark.parametrize("dtype, real_bpp", [(np.uint8, None), (np.uint16, 12)])
def test_pims_reads_back_exactly_the_frames_and_header_the_writer_wrote(tmp_path, sim, dtype, real_bpp):
    _, frames = sim
    frames = frames.astype(dtype) * (16 if real_bpp else 1)
    path = write_cine(tmp_path / "t.cine", frames, frame_rate=20000, real_bpp=real_bpp, first_image_no=-4,
                      annotation=b"image annotation")
    raw = path.read_bytes()
    # offsets the published layout fixes: "CI" and its 0x2c-byte header, the SETUP's "ST" mark at 0xe0
    assert raw[:2] == b"CI" and int.from_bytes(raw[2:4], "little") == 0x2C and raw[0xE0:0xE2] == b"ST"
    c = pims.open(str(path))
    assert isinstance(c, pims.Cine)
    assert (c.shape, c.pixel_type, c.frame_rate) == (frames.shape, np.dtype(dtype), 20000)
    setup = c.setup_fields_dict
    assert (setup["real_bpp"], setup["im_width"], setup["im_height"], setup["cfa"]) == (
        real_bpp or 8, frames.shape[2], frames.shape[1], 0)
    assert (c.header_dict["first_image_no"], c.header_dict["image_count"], c.compression) == (-4, len(frames), 0)
    for k in range(len(frames)):
        np.testing.assert_array_equal(c.get_frame(k), frames[k])
    stamps = [c.get_time_to_trigger(k) for k in range(len(frames))]  # image k at (first_image_no + k) / rate
    np.testing.assert_allclose(stamps, (np.arange(len(frames)) - 4) / 20000, atol=1e-6)
    np.testing.assert_allclose(c.all_exposures, 0.9 / 20000, rtol=0, atol=2.0 ** -32)  # stored in 2**-32 s
    c.close()


def test_12_bit_cine_header_reaches_capture_json_and_decodes_like_the_png_capture(tmp_path, sim):
    ps, frames = sim
    frames12 = frames.astype(np.uint16) * 16
    write_cine(tmp_path / "take.cine", frames12, frame_rate=20000, real_bpp=12, first_image_no=-100)
    src = CineSource(tmp_path / "take.cine")
    assert (src.shape, src.dtype, src.bit_depth, src.frame_rate, src.first_image_no) == (
        frames.shape, np.uint16, 12, 20000.0, -100)
    assert import_(tmp_path / "take.cine", tmp_path / "take", ps, "--first-frame", 3) == 0
    meta = json.loads((tmp_path / "take" / "capture.json").read_text())
    assert not (tmp_path / "take" / "frames").exists()  # referenced, not converted
    assert meta["source"] == {"kind": "cine", "path": "../take.cine", "first_frame": 3, "frame_count": 3,
                              "file_frames": 6, "first_image_no": -100}
    assert (meta["bit_depth"], meta["frame_rate"], meta["camera"]) == (12, 20000.0, [frames.shape[2],
                                                                                      frames.shape[1]])
    cap = read_capture(tmp_path / "take")
    np.testing.assert_array_equal(cap.frames, frames12[3:])
    write_capture(tmp_path / "png", frames12[3:], ps, {"bit_depth": 12})
    png = read_capture(tmp_path / "png")
    opts = DecodeOptions(bit_depth=12)  # the capture's bit depth, as `fringe3d decode` reads it from capture.json
    ref = decode(png.frames, png.patterns, options=opts).phase["v"]
    assert np.isfinite(ref).mean() > 0.3
    assert np.array_equal(decode(cap.frames, cap.patterns, options=opts).phase["v"], ref, equal_nan=True)
    assert cli("decode", tmp_path / "take", "-o", tmp_path / "dec", "--quiet") == 0
    cli_phase = np.load(tmp_path / "dec" / "decoded.npz")["phase_v"]
    assert np.array_equal(cli_phase, ref, equal_nan=True)


def test_cine_frames_are_read_one_window_at_a_time(tmp_path, sim, monkeypatch):
    ps, frames = sim
    write_cine(tmp_path / "take.cine", frames)
    ps.save(tmp_path / "manifest.json")
    assert cli("import", tmp_path / "take.cine", "--manifest", tmp_path / "manifest.json", "-o", tmp_path / "take",
               "--quiet") == 0
    read: list[int] = []
    real = pims.Cine.get_frame

    def spy(self, k):
        read.append(int(k))
        return real(self, k)

    monkeypatch.setattr(pims.Cine, "get_frame", spy)
    cap = read_capture(tmp_path / "take", max_cycles=1)
    assert read == [0, 1, 2]  # the first cycle only
    read.clear()
    cycles = list(cap.iter_cycles())
    assert read == list(range(6)) and all(np.array_equal(c, frames[3 * i:3 * i + 3]) for i, c in enumerate(cycles))


# ----------------------------------------------------------------------------- bad input
def test_cine_header_that_disagrees_with_capture_json_names_the_file_and_field(tmp_path, sim, capsys):
    """The recording replaced after import: each header field that changed is named."""
    ps, frames = sim
    frames12 = frames.astype(np.uint16) * 16
    good = {"frames": frames12, "frame_rate": 5000, "real_bpp": 12, "first_image_no": 0}
    write_cine(tmp_path / "take.cine", **good)
    assert import_(tmp_path / "take.cine", tmp_path / "take", ps) == 0
    W, H = frames.shape[2], frames.shape[1]
    cases = {
        "camera": ({"frames": frames12[:, :-2]}, f"frames are {W}x{H - 2} pixels but .* field camera says {W}x{H}"),
        "bit_depth": ({"real_bpp": 10, "frames": frames12 // 4}, "bit depth 10 but .* field bit_depth says 12"),
        "frame_rate": ({"frame_rate": 4000}, "frame rate 4000 Hz but .* field frame_rate says 5000 Hz"),
        "source.file_frames": ({"frames": np.concatenate([frames12, frames12[:3]])},
                               "holds 9 frames but .* field source.file_frames says 6"),
        "source.first_image_no": ({"first_image_no": -50}, "is -50 but .* field source.first_image_no says 0"),
    }
    for field, (change, msg) in cases.items():
        write_cine(tmp_path / "take.cine", **{**good, **change})
        with pytest.raises(ValueError, match=msg) as e:
            read_capture(tmp_path / "take")
        assert "take.cine: " in str(e.value) and field in str(e.value)
        capsys.readouterr()
        assert cli("decode", tmp_path / "take", "-o", tmp_path / "dec") == 2
        err = capsys.readouterr().err
        assert "take.cine" in err and field in err and "Traceback" not in err


def test_cine_frame_range_beyond_the_file_is_refused_naming_the_file(tmp_path, sim, capsys):
    ps, frames = sim
    write_cine(tmp_path / "take.cine", frames)
    capsys.readouterr()
    assert import_(tmp_path / "take.cine", tmp_path / "a", ps, "--first-frame", 3, "--frame-count", 6) == 2
    err = capsys.readouterr().err
    assert "take.cine" in err and "first_frame=3, frame_count=6" in err and "beyond the file's 6 frames" in err
    assert not (tmp_path / "a" / "capture.json").exists()
    assert import_(tmp_path / "take.cine", tmp_path / "b", ps, "--first-frame", 4) == 2  # under one cycle left
    assert "take.cine: first_frame 4 leaves 2 of the file's 6 frames" in capsys.readouterr().err
    assert import_(tmp_path / "take.cine", tmp_path / "c", ps) == 0
    meta_path = tmp_path / "c" / "capture.json"
    meta = json.loads(meta_path.read_text())
    meta["source"]["first_frame"] = 3
    meta_path.write_text(json.dumps(meta))
    with pytest.raises(ValueError, match=r"take.cine: frame range first_frame=3, frame_count=6 .* beyond"):
        read_capture(tmp_path / "c")
    assert cli("decode", tmp_path / "c", "-o", tmp_path / "dec") == 2
    assert "take.cine: frame range first_frame=3" in capsys.readouterr().err


def test_broken_or_unsupported_cine_files_are_refused_naming_the_file(tmp_path, sim):
    _, frames = sim
    path = write_cine(tmp_path / "take.cine", frames)
    raw = path.read_bytes()
    (tmp_path / "short.cine").write_bytes(raw[:-100])  # the last image cut
    with pytest.raises(ValueError, match=r"short.cine holds \d+ bytes but its header says ImageCount 6"):
        CineSource(tmp_path / "short.cine")
    table = int.from_bytes(raw[32:36], "little")  # CINEFILEHEADER.OffImageOffsets
    (tmp_path / "headers.cine").write_bytes(raw[:table])  # the headers only
    with pytest.raises(ValueError, match=r"headers.cine: the file ends at the image offsets table"):
        CineSource(tmp_path / "headers.cine")
    (tmp_path / "png.cine").write_bytes(b"\x89PNG" + raw[4:])
    with pytest.raises(ValueError, match=r"png.cine is not a Phantom CINE file"):
        CineSource(tmp_path / "png.cine")
    (tmp_path / "stub.cine").write_bytes(raw[:60])  # header only
    with pytest.raises(ValueError, match=r"stub.cine is not a readable Phantom CINE file"):
        CineSource(tmp_path / "stub.cine")
    colour = bytearray(raw)
    colour[84 + 808:84 + 812] = (3).to_bytes(4, "little")  # SETUP.CFA = CFA_BAYER
    (tmp_path / "colour.cine").write_bytes(bytes(colour))
    with pytest.raises(ValueError, match=r"colour.cine: Compression 0, CFA 3; fringe3d reads uncompressed monochrome"):
        CineSource(tmp_path / "colour.cine")
    with pytest.raises(FileNotFoundError, match="gone.cine does not exist"):
        CineSource(tmp_path / "gone.cine")
