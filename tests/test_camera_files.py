"""Camera files as capture sources (issue 16): MRAW, CINE, multi-page TIFF and zarr, referenced and read lazily.

Frames come from the simulator (tiny preset, 3 cycles of a 3-step set); each file is written by
its format's own writer (pyMRAW.save_mraw, tifffile, zarr; CINE, which no library writes, by
``tests/cine_writer.py``, checked against pims in test_camera_file_cine.py), imported with
``fringe3d import`` and decoded; the truth is the decode of the PNG capture of the very same frames.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pyMRAW
import pytest
import tifffile
import zarr
from cine_writer import write_cine

from fringe3d.cli import main
from fringe3d.decode import decode, decode_sequence
from fringe3d.io import frame_sources
from fringe3d.io.capture import open_frames, read_capture, write_capture
from fringe3d.io.frame_sources import FrameRange, MrawSource, TiffSource, ZarrSource
from fringe3d.io.importer import FrameReading, ImportLayout, import_images
from fringe3d.io.store import PointMapStore
from fringe3d.patterns import sets
from fringe3d.sim import presets
from fringe3d.sim import simulate_capture
from fringe3d.sim.render import render
from fringe3d.sim.simulate import make_scene
from fringe3d.utils.warning_types import DataQualityWarning

PERIOD = 16.0
CYCLES = 3
LEAD = 2  # frames before the first pattern cycle in the camera file


def cli(*args) -> int:
    return main([str(a) for a in args])


@pytest.fixture(scope="module")
def sim():
    """(patterns, frames (9, H, W) uint8: 3 cycles with the sphere moving, 12-bit copy) of the tiny rig."""
    p = presets.get("tiny")
    ps = sets.phase_shift(PERIOD, 3, "v", width=p.rig.projector.width, height=p.rig.projector.height)
    cycles = []
    for c in range(CYCLES):
        scene = make_scene("sphere", p)
        f, _ = render(scene, p.rig, ps, p.settings, progress=False)
        cycles.append(np.roll(f, 3 * c, axis=2))  # each cycle differs (a moved image), so order matters
    frames = np.concatenate(cycles)
    assert frames.dtype == np.uint8
    return ps, frames


def size(ps) -> str:
    return f"{ps.width}x{ps.height}"


def import_(src, out, ps, *extra) -> int:
    return cli("import", src, "-o", out, "--set", "phase-shift", "--steps", 3, "--period", PERIOD,
               "--projector-size", size(ps), "--quiet", *extra)


def with_lead(frames: np.ndarray) -> np.ndarray:
    """The camera file: LEAD junk frames, the cycles, one trailing partial-cycle frame."""
    junk = np.full((1,) + frames.shape[1:], 7, frames.dtype)
    return np.concatenate([np.repeat(junk, LEAD, 0), frames, junk])


def write_mraw(path, frames, bits=8, rate=5000):
    mraw, cih = pyMRAW.save_mraw(frames, str(path), bit_depth=bits, info_dict={"Record Rate(fps)": rate})
    return Path(cih)


def write_tiff(path, frames):
    with tifffile.TiffWriter(path, bigtiff=True) as tif:
        for f in frames:
            tif.write(f, photometric="minisblack")
    return path


def write_zarr(path, frames, **attrs):
    z = zarr.open_group(str(path), mode="w")
    arr = z.create_array("frames", shape=frames.shape, dtype=frames.dtype, chunks=(1,) + frames.shape[1:])
    arr[:] = frames
    arr.attrs.update(attrs)
    return path


def png_phase(tmp_path, frames, ps, bit_depth=None):
    """Phase of the PNG capture of ``frames`` (the reference)."""
    meta = {} if bit_depth is None else {"bit_depth": bit_depth}
    write_capture(tmp_path / "png", frames, ps, meta)
    cap = read_capture(tmp_path / "png")
    return [d.phase["v"] for d in decode_sequence(cap.frames, cap.patterns, options=None)]


WRITERS = {
    "mraw": lambda d, f: write_mraw(d / "run.mraw", f),
    "cine": lambda d, f: write_cine(d / "take.cine", f, frame_rate=5000, first_image_no=-LEAD),
    "tiff": lambda d, f: write_tiff(d / "stack.tif", f),
    "zarr": lambda d, f: write_zarr(d / "frames.zarr", f),
}


@pytest.mark.parametrize("kind", ["mraw", "cine", "tiff", "zarr"])
def test_camera_file_imports_as_a_reference_and_decodes_bit_identically_to_png(tmp_path, sim, kind, capsys):
    ps, frames = sim
    src = WRITERS[kind](tmp_path, with_lead(frames))
    assert import_(src, tmp_path / "cap", ps, "--first-frame", LEAD) == 0
    assert "1 trailing frame(s) after the last whole 3-frame cycle are not used" in capsys.readouterr().err
    with pytest.warns(DataQualityWarning, match="1 trailing frame"):  # the library warns (cli shows it)
        import_images(src, tmp_path / "api", layout=ImportLayout("phase-shift", (ps.width, ps.height), steps=3,
                                                                 period=PERIOD), reading=FrameReading(first_frame=LEAD))
    meta = json.loads((tmp_path / "cap" / "capture.json").read_text())
    assert not (tmp_path / "cap" / "frames").exists()  # referenced, not converted
    numbered = {"first_image_no": -LEAD} if kind == "cine" else {}  # the trigger at the first cycle
    assert meta["source"] == {"kind": kind, "path": f"../{src.name}", "first_frame": LEAD,
                              "frame_count": len(frames), "file_frames": len(frames) + LEAD + 1, **numbered}
    assert meta["bit_depth"] == 8 and meta["camera"] == [frames.shape[2], frames.shape[1]]
    cap = read_capture(tmp_path / "cap")
    np.testing.assert_array_equal(cap.frames, frames)
    ref = png_phase(tmp_path, frames, ps)
    assert all(np.isfinite(r).mean() > 0.3 for r in ref) and not np.array_equal(ref[0], ref[1], equal_nan=True)
    got = [d.phase["v"] for d in decode_sequence(cap.frames, cap.patterns)]
    assert len(got) == CYCLES and all(np.array_equal(a, b, equal_nan=True) for a, b in zip(got, ref))
    # lazily, one cycle at a time, and through the CLI
    lazy = [decode(c, cap.patterns).phase["v"] for c in cap.iter_cycles()]
    assert all(np.array_equal(a, b, equal_nan=True) for a, b in zip(lazy, ref))
    assert cli("decode", tmp_path / "cap", "-o", tmp_path / "dec", "--quiet") == 0
    cli_phase = np.load(tmp_path / "dec" / "cycle_00002" / "decoded.npz")["phase_v"]
    assert np.array_equal(cli_phase, ref[2], equal_nan=True)


def test_mraw_header_fields_reach_capture_json_and_max_cycles_reads_only_those(tmp_path, sim):
    ps, frames = sim
    frames12 = frames.astype(np.uint16) * 16
    cih = write_mraw(tmp_path / "run.mraw", frames12, bits=16, rate=20000)  # pyMRAW: 16-bit words, 12 effective bits
    src = MrawSource(cih)
    assert (src.shape, src.dtype, src.bit_depth, src.frame_rate) == (frames.shape, np.uint16, 12, 20000.0)
    assert import_(tmp_path / "run.cih", tmp_path / "cap", ps) == 0
    cap = read_capture(tmp_path / "cap", max_cycles=1)
    assert cap.meta["frame_rate"] == 20000.0 and cap.meta["bit_depth"] == 12
    np.testing.assert_array_equal(cap.frames, frames12[:3])
    assert len(cap.source) == len(frames)
    ref = png_phase(tmp_path, frames12, ps, bit_depth=12)
    assert np.array_equal(decode(cap.frames, cap.patterns).phase["v"], ref[0], equal_nan=True)


def test_packed_12_bit_mraw_is_unpacked_range_by_range(tmp_path):
    rng = np.random.default_rng(1)
    frames = rng.integers(0, 4096, (5, 6, 8)).astype(np.uint16)
    flat = frames.ravel()
    packed = np.empty((flat.size // 2, 3), np.uint8)  # Photron packing: AAAAAAAA AAAABBBB BBBBBBBB
    a, b = flat[0::2], flat[1::2]
    packed[:, 0], packed[:, 1], packed[:, 2] = a >> 4, ((a & 15) << 4) | (b >> 8), b & 255
    packed.tofile(tmp_path / "p.mraw")
    cih = write_mraw(tmp_path / "tmp.mraw", frames.astype(np.uint8), bits=8)
    text = open(cih).read().replace("Color Bit : 8", "Color Bit : 12").replace("EffectiveBit Depth : 8",
                                                                                "EffectiveBit Depth : 12")
    (tmp_path / "p.cih").write_text(text)
    src = MrawSource(tmp_path / "p.cih")
    np.testing.assert_array_equal(src.read(1, 4), frames[1:4])
    np.testing.assert_array_equal(src.read(0, 5), pyMRAW.load_video(str(tmp_path / "p.cih"))[0])


def test_reads_are_bounded_by_the_range_asked_for(tmp_path, sim, monkeypatch):
    ps, frames = sim
    write_tiff(tmp_path / "stack.tif", frames)
    assert import_(tmp_path / "stack.tif", tmp_path / "cap", ps) == 0
    calls: list[tuple[int, int]] = []
    real = TiffSource.read

    def spy(self, start, stop):
        calls.append((start, stop))
        return real(self, start, stop)

    monkeypatch.setattr(TiffSource, "read", spy)
    cap = read_capture(tmp_path / "cap", max_cycles=1)
    assert calls == [(0, 3)]
    calls.clear()
    cycles = list(cap.iter_cycles())
    assert calls == [(0, 3), (3, 6), (6, 9)]
    assert all(np.array_equal(c, frames[3 * i:3 * i + 3]) for i, c in enumerate(cycles))
    calls.clear()
    lazy = open_frames(tmp_path / "cap")
    np.testing.assert_array_equal(lazy[np.array([6, 4, 5])], frames[[6, 4, 5]])  # a sliding window
    assert calls == [(4, 7)]
    calls.clear()
    assert cli("decode", tmp_path / "cap", "-o", tmp_path / "dec", "--quiet") == 0  # one cycle at a time
    assert calls == [(0, 3), (0, 3), (3, 6), (6, 9)]
    # the MRAW reader maps only the bytes of the range: an offset memmap of those frames
    cih = write_mraw(tmp_path / "run.mraw", frames)
    maps = []
    real_memmap = np.memmap

    def memmap_spy(*a, **k):
        maps.append((k.get("offset"), k.get("shape")))
        return real_memmap(*a, **k)

    monkeypatch.setattr(frame_sources.np, "memmap", memmap_spy)
    H, W = frames.shape[1:]
    np.testing.assert_array_equal(MrawSource(cih).read(4, 6), frames[4:6])
    assert maps == [(4 * H * W, (2 * H * W,))]


def test_zarr_store_is_read_chunk_by_chunk(tmp_path, sim):
    ps, frames = sim
    write_zarr(tmp_path / "f.zarr", frames, bit_depth=8, frame_rate=1000.0)
    src = ZarrSource(tmp_path / "f.zarr")
    assert (src.shape, src.bit_depth, src.frame_rate) == (frames.shape, 8, 1000.0)
    view = FrameRange(src, 3, 6)
    np.testing.assert_array_equal(view[2:5], frames[5:8])
    np.testing.assert_array_equal(view[-1], frames[8])


def test_copy_frames_converts_to_png_frames(tmp_path, sim):
    ps, frames = sim
    cih = write_mraw(tmp_path / "run.mraw", frames)
    assert import_(cih, tmp_path / "cap", ps, "--copy-frames", "--frame-count", 6) == 0
    assert sorted(p.name for p in (tmp_path / "cap" / "frames").iterdir())[-1] == "00005.png"
    cap = read_capture(tmp_path / "cap")
    assert "source" not in cap.meta and cap.meta["source_file"]["kind"] == "mraw"
    np.testing.assert_array_equal(cap.frames, frames[:6])


def test_reconstruct_sequence_reads_a_referenced_file(tmp_path):
    """``fringe3d reconstruct`` of a sequence: the referenced MRAW gives the PNG capture's point maps."""
    ps = sets.phase_shift(64, 3, "v", width=256, height=200)
    simulate_capture(tmp_path / "sim", preset="tiny", scene="sphere", patterns=ps, cycles=2, seed=5, progress=False)
    png = read_capture(tmp_path / "sim")
    write_mraw(tmp_path / "run.mraw", png.frames)
    assert cli("import", tmp_path / "run.cih", "-o", tmp_path / "cap", "--manifest", tmp_path / "sim" /
               "manifest.json", "--quiet") == 0
    outs = {}
    for name, folder in (("png", tmp_path / "sim"), ("mraw", tmp_path / "cap")):
        assert cli("reconstruct", folder, "--calibration", tmp_path / "sim" / "rig.json", "-o", tmp_path / name,
                   "--method", "geometric", "--z-min", 340, "--quiet") == 0
        outs[name] = PointMapStore.open_existing(tmp_path / name / "points.zarr")
    assert outs["mraw"].frames == 2
    assert all(np.array_equal(outs["png"].read(k), outs["mraw"].read(k), equal_nan=True) for k in range(2))


# ----------------------------------------------------------------------------- bad input
def test_header_that_disagrees_with_capture_json_names_the_file_and_field(tmp_path, sim):
    ps, frames = sim
    cih = write_mraw(tmp_path / "run.mraw", frames)
    assert import_(cih, tmp_path / "cap", ps) == 0
    meta_path = tmp_path / "cap" / "capture.json"
    good = json.loads(meta_path.read_text())
    cases = {
        "bit_depth": ({"bit_depth": 12}, "bit_depth says 12; expected 8"),
        "camera": ({"camera": [10, 20]}, "field camera says 10x20"),
        "frame_rate": ({"frame_rate": 123.0}, "field frame_rate says 123 Hz; expected 5000"),
        "file_frames": ({"source": {**good["source"], "file_frames": 99}}, "source.file_frames says 99; expected 9"),
    }
    for field, (change, msg) in cases.items():
        meta_path.write_text(json.dumps({**good, **change}))
        with pytest.raises(ValueError, match=msg) as e:
            read_capture(tmp_path / "cap")
        assert "run.cih" in str(e.value) and field in str(e.value)
        assert cli("decode", tmp_path / "cap", "-o", tmp_path / "dec") == 2


def test_frame_range_beyond_the_file_is_refused(tmp_path, sim):
    ps, frames = sim
    src = write_tiff(tmp_path / "stack.tif", frames)
    with pytest.raises(ValueError, match="beyond the file's 9 frames"):
        import_images(src, tmp_path / "a", layout=ImportLayout("phase-shift", (ps.width, ps.height), steps=3,
                                                               period=PERIOD),
                      reading=FrameReading(first_frame=3, frame_count=9))
    assert import_(src, tmp_path / "b", ps, "--first-frame", 8) == 2  # fewer than one cycle left
    assert import_(src, tmp_path / "c", ps, "--frame-count", 4) == 2  # not whole cycles
    assert import_(src, tmp_path / "d", ps) == 0
    meta_path = tmp_path / "d" / "capture.json"
    meta = json.loads(meta_path.read_text())
    meta["source"]["first_frame"] = 3
    meta_path.write_text(json.dumps(meta))
    with pytest.raises(ValueError, match=r"stack.tif: frame range first_frame=3, frame_count=9 .* beyond"):
        read_capture(tmp_path / "d")
    assert cli("decode", tmp_path / "d", "-o", tmp_path / "dec") == 2


def test_bad_source_fields_and_missing_files_are_named(tmp_path, sim):
    ps, frames = sim
    write_zarr(tmp_path / "f.zarr", frames)
    assert import_(tmp_path / "f.zarr", tmp_path / "cap", ps) == 0
    meta_path = tmp_path / "cap" / "capture.json"
    meta = json.loads(meta_path.read_text())
    for change, msg in (({"kind": "avi"}, "source.kind must be one of"), ({"first_frame": -1}, "source.first_frame"),
                        ({"frame_count": 0}, "source.frame_count"), ({"colour": 1}, "unknown source field")):
        meta_path.write_text(json.dumps({**meta, "source": {**meta["source"], **change}}))
        with pytest.raises(ValueError, match=msg):
            read_capture(tmp_path / "cap")
    meta_path.write_text(json.dumps({**meta, "source": {**meta["source"], "path": "gone.zarr"}}))
    with pytest.raises(FileNotFoundError, match="gone.zarr does not exist"):
        read_capture(tmp_path / "cap")
    (tmp_path / "run.mraw").write_bytes(b"\0" * 10)
    write_mraw(tmp_path / "x.mraw", frames)
    (tmp_path / "x.cih").replace(tmp_path / "run.cih")
    with pytest.raises(ValueError, match=r"run.mraw holds 10 bytes but the header run.cih says Total Frame 9"):
        MrawSource(tmp_path / "run.cih")


CIHX = """<?xml version="1.0" encoding="UTF-8" ?>
<cih>
<fileInfo><date>2026/12/01</date></fileInfo>
<basicInfo><comment>written by the test</comment></basicInfo>
<deviceInfo><deviceName>none (hand-written header)</deviceName></deviceInfo>
<recordInfo><recordRate>{rate}</recordRate><shutterSpeed>0.0001</shutterSpeed></recordInfo>
<frameInfo><totalFrame>{F}</totalFrame><recordedFrame>{F}</recordedFrame></frameInfo>
<imageDataInfo><resolution><width>{W}</width><height>{H}</height></resolution>
<effectiveBit><depth>{bits}</depth><side>Higher</side></effectiveBit><colorInfo><bit>16</bit></colorInfo>
</imageDataInfo>
<imageFileInfo><fileFormat>MRaw</fileFormat></imageFileInfo>
</cih>
"""


def test_cihx_header_and_high_side_values_read_like_the_lower_side_file(tmp_path, sim):
    """A .cihx (XML) header, the .mraw path given, 12-bit values stored in the high bits."""
    ps, frames = sim
    frames12 = frames.astype(np.uint16) * 16
    (frames12 << 4).tofile(tmp_path / "run.mraw")  # EffectiveBit Side: Higher -> left-aligned in 16 bits
    F, H, W = frames.shape
    (tmp_path / "run.cihx").write_text(CIHX.format(rate=50000, F=F, W=W, H=H, bits=12))
    src = MrawSource(tmp_path / "run.mraw")
    assert src.path.name == "run.cihx" and (src.shape, src.bit_depth, src.frame_rate) == (frames.shape, 12, 50000.0)
    np.testing.assert_array_equal(src.read(2, 5), frames12[2:5])
    assert import_(tmp_path / "run.mraw", tmp_path / "cap", ps) == 0
    cap = read_capture(tmp_path / "cap")
    assert cap.meta["source"]["path"] == "../run.cihx" and cap.meta["bit_depth"] == 12
    np.testing.assert_array_equal(cap.frames, frames12)


def test_load_images_holds_what_import_writes_and_channel_on_a_camera_file_is_refused(tmp_path, sim, capsys):
    from fringe3d.io.importer import load_images

    ps, frames = sim
    write_mraw(tmp_path / "run.mraw", frames, rate=12000)
    assert import_(tmp_path / "run.cih", tmp_path / "cap", ps) == 0
    written = json.loads((tmp_path / "cap" / "capture.json").read_text())
    held = load_images(tmp_path / "run.cih", layout=ImportLayout("phase-shift", (ps.width, ps.height), steps=3,
                                                                 period=PERIOD))
    for field in ("frame_rate", "bit_depth", "camera", "source_dtype", "layout"):
        assert held.meta[field] == written[field], field
    np.testing.assert_array_equal(held.frames, frames[:3])
    capsys.readouterr()
    assert import_(tmp_path / "run.cih", tmp_path / "cap2", ps, "--channel", "g") == 2
    err = capsys.readouterr().err
    assert "run.cih" in err and "--channel" in err and "Traceback" not in err
    assert not (tmp_path / "cap2" / "capture.json").exists()
