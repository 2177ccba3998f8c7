"""``fringe3d import``: other labs' image sequences become capture folders (issue 13, item 1).

Frames come from the simulator (tiny preset) written by OpenCV / tifffile in the foreign
formats; truth is the simulator's projector coordinates and the BT.601 closed form.
"""
from __future__ import annotations

import json

import cv2
import numpy as np
import pytest
import tifffile

from fringe3d.cli import main
from fringe3d.decode import DecodeOptions, decode, with_method
from fringe3d.io.capture import read_capture
from fringe3d.io.importer import ImportLayout, import_images, list_sources, natural_key, phase_shift_layout, to_grey
from fringe3d.patterns import render_set, sets
from fringe3d.patterns.layouts import opencv_graycode
from fringe3d.patterns.synthetic import frames_from_coordinates
from fringe3d.sim import presets
from fringe3d.sim.render import render
from fringe3d.sim.simulate import make_scene

PERIOD = 16.0


def cli(*args: str) -> int:
    return main([str(a) for a in args])


@pytest.fixture(scope="module")
def sim_frames():
    """A 3-step T=16 set of the tiny rig on a sphere: (patterns, frames (3, H, W) uint8, truth)."""
    p = presets.get("tiny")
    ps = sets.phase_shift(PERIOD, 3, "v", width=p.rig.projector.width, height=p.rig.projector.height)
    frames, truth = render(make_scene("sphere", p), p.rig, ps, p.settings, progress=False)
    return ps, frames, truth


def numbered_pngs(src, frames):
    """``src`` holding ``frames`` as img_1.png, img_2.png, ... and an order.txt listing them."""
    src.mkdir()
    for i, f in enumerate(frames):
        assert cv2.imwrite(str(src / f"img_{i + 1}.png"), f)
    (src / "order.txt").write_text("".join(f"img_{i + 1}.png\n" for i in range(len(frames))))
    return src


def colour(img: np.ndarray) -> np.ndarray:
    """An RGB image whose BT.601 luma is ``img`` within rounding: R = G = B = img, tinted."""
    rgb = np.repeat(img[..., None], 3, axis=2).astype(np.int16)
    rgb[..., 0] += 6
    rgb[..., 2] -= 6
    return np.clip(rgb, 0, 255).astype(np.uint8)


def test_to_grey_is_the_unrounded_bt601_luma_or_one_channel():
    rgb = np.random.default_rng(0).integers(0, 65536, (5, 7, 3)).astype(np.uint16)
    y = 0.299 * rgb[..., 0] + 0.587 * rgb[..., 1] + 0.114 * rgb[..., 2]
    grey = to_grey(rgb)
    assert grey.dtype == np.float32
    np.testing.assert_allclose(grey, y, rtol=1e-7, atol=0)  # float32's precision, not a rounding to counts
    assert np.abs(grey - np.rint(y)).max() > 0.1
    np.testing.assert_array_equal(to_grey(rgb, "g"), rgb[..., 1])
    white = np.full((1, 1, 3), 255, np.uint8)
    assert to_grey(white)[0, 0] == 255.0  # a saturated pixel stays at full scale


def test_rgb_jpeg_sequence_imports_and_decodes_identically_from_cli_and_api(tmp_path, sim_frames):
    ps, frames, truth = sim_frames
    src = tmp_path / "jpg"
    src.mkdir()
    for i, f in enumerate(frames):  # cv2 writes BGR: flip the RGB image
        assert cv2.imwrite(str(src / f"img_{i + 1:04d}.jpg"), cv2.cvtColor(colour(f), cv2.COLOR_RGB2BGR),
                           [cv2.IMWRITE_JPEG_QUALITY, 95])
    size = f"{ps.width}x{ps.height}"
    assert cli("import", src, "-o", tmp_path / "cap", "--set", "phase-shift", "--steps", 3, "--period", PERIOD,
               "--projector-size", size, "--unwrap", "spatial", "--quiet") == 0
    assert cli("decode", tmp_path / "cap", "-o", tmp_path / "dec", "--quiet") == 0
    meta = json.loads((tmp_path / "cap" / "capture.json").read_text())
    assert meta["conversion"].startswith("ITU-R BT.601") and meta["bit_depth"] == 8
    assert meta["source_dtype"] == "uint8"
    assert [p.split("/")[-1] for p in meta["source_files"]] == ["img_0001.jpg", "img_0002.jpg", "img_0003.jpg"]
    s = import_images(src, tmp_path / "api", layout=ImportLayout("phase-shift", (ps.width, ps.height), steps=3,
                                                                 period=PERIOD, unwrap="spatial"))
    api_cap = read_capture(s["folder"])  # float luma: the capture's bit depth sets the saturation level
    api = decode(api_cap.frames, with_method(ps, "spatial"), options=DecodeOptions(bit_depth=api_cap.bit_depth))
    cli_phase = np.load(tmp_path / "dec" / "decoded.npz")["phase_v"]
    np.testing.assert_array_equal(cli_phase, api.phase["v"])
    # the wrapped phase from the JPEG frames is the simulator's (mod 2 pi) on the object
    m = api.mask["v"] & truth.mask
    dphi = np.angle(np.exp(1j * (api.wrapped["v"] - truth.phase["v"])))
    assert m.mean() > 0.5 and np.median(np.abs(dphi[m])) < 0.05


def test_multipage_tiff_with_12_bit_frames_imports_and_decodes(tmp_path, sim_frames):
    ps, frames, truth = sim_frames
    frames12 = (frames.astype(np.uint16) * 16)  # 12-bit values in 16-bit pages
    with tifffile.TiffWriter(tmp_path / "stack.tif") as tif:
        for f in frames12:
            tif.write(f, photometric="minisblack")
    assert cli("import", tmp_path / "stack.tif", "-o", tmp_path / "cap", "--set", "phase-shift", "--period", PERIOD,
               "--projector-size", f"{ps.width}x{ps.height}", "--bit-depth", 12, "--copy-frames", "--quiet") == 0
    cap = read_capture(tmp_path / "cap")
    np.testing.assert_array_equal(cap.frames, frames12)
    assert cap.meta["bit_depth"] == 12 and cap.meta["source_files"][2].endswith("stack.tif#2")
    d = decode(cap.frames, cap.patterns)
    m = d.mask["v"] & truth.mask
    assert np.median(np.abs(np.angle(np.exp(1j * (d.phase["v"] - truth.phase["v"]))))[m]) < 0.05
    # decoded straight from the stack (read on demand), as from the imported capture
    assert cli("decode", tmp_path / "stack.tif", "-o", tmp_path / "dec", "--set", "phase-shift", "--period", PERIOD,
               "--projector-size", f"{ps.width}x{ps.height}", "--bit-depth", 12, "--quiet") == 0
    assert cli("decode", tmp_path / "cap", "-o", tmp_path / "dec-cap", "--quiet") == 0
    np.testing.assert_array_equal(np.load(tmp_path / "dec" / "decoded.npz")["phase_v"],
                                  np.load(tmp_path / "dec-cap" / "decoded.npz")["phase_v"])


def test_names_sort_naturally_and_a_list_file_sets_the_order(tmp_path):
    names = ["f10.png", "f2.png", "f1.png"]
    for k, n in enumerate(names):
        cv2.imwrite(str(tmp_path / n), np.full((4, 4), k, np.uint8))
    assert [p.name for p in list_sources(tmp_path)] == ["f1.png", "f2.png", "f10.png"]
    assert sorted(names, key=lambda n: natural_key(tmp_path / n)) == ["f1.png", "f2.png", "f10.png"]
    (tmp_path / "order.txt").write_text("# projection order\nf10.png\nf1.png\n\nf2.png\n")
    assert [p.name for p in list_sources(tmp_path, tmp_path / "order.txt")] == ["f10.png", "f1.png", "f2.png"]


def test_opencv_graycode_session_imports_and_decodes_to_projector_pixels(tmp_path):
    ps = opencv_graycode(64, 32)
    for i, f in enumerate(render_set(ps)):  # a camera seeing the projector 1:1, as BMP files
        cv2.imwrite(str(tmp_path / f"pattern_{i}.bmp"), f[:, 8:40] // 2 + 40)
    assert cli("import", tmp_path / "pattern_*.bmp", "-o", tmp_path / "cap", "--set", "opencv-graycode",
               "--projector-size", "64x32", "--quiet") == 0
    assert cli("decode", tmp_path / "cap", "-o", tmp_path / "dec", "--quiet") == 0
    cap = read_capture(tmp_path / "cap")
    d = decode(cap.frames, cap.patterns)
    assert d.mask["v"].all()
    np.testing.assert_allclose(d.projector_coordinate("v"), np.broadcast_to(np.arange(8, 40), (32, 32)), atol=1e-4)
    np.testing.assert_allclose(d.projector_coordinate("h"), np.broadcast_to(np.arange(32)[:, None], (32, 32)),
                               atol=1e-4)


def test_bad_input_says_what_was_expected(tmp_path, capsys):
    src = tmp_path / "src"
    src.mkdir()
    for i in range(41):
        cv2.imwrite(str(src / f"{i}.png"), np.zeros((4, 4), np.uint8))
    assert cli("import", src, "-o", tmp_path / "a", "--set", "opencv-graycode",
               "--projector-size", "1024x768") == 2
    assert ("--set opencv-graycode for a 1024x768 projector expects 2*(10+10)+2 = 42 frames, got 41"
            in " ".join(capsys.readouterr().err.split()))
    assert cli("import", src, "-o", tmp_path / "b", "--set", "opencv-graycode") == 2
    assert "--projector-size" in capsys.readouterr().err
    (tmp_path / "full").mkdir()
    (tmp_path / "full" / "keep.txt").write_text("mine")
    assert cli("import", src, "-o", tmp_path / "full", "--set", "phase-shift", "--period", 16,
               "--projector-size", "64x48") == 2
    assert "not empty" in capsys.readouterr().err
    assert (tmp_path / "full" / "keep.txt").read_text() == "mine"
    assert cli("import", src, "-o", tmp_path / "c", "--set", "phase-shift", "--period", 16) == 2
    assert "--projector-size" in capsys.readouterr().err


def test_shift_order_and_sign_describe_frames_stored_in_another_step_order(tmp_path):
    ps = sets.phase_shift(PERIOD, 4, "v", width=64, height=48)
    negative = phase_shift_layout(ps, None, -1)  # what the other lab projected: shifts -2 pi k / 4
    v_p, u_p = np.mgrid[0:24, 4:60].astype(float) + 0.3
    frames = frames_from_coordinates(negative, u_p, v_p, dtype=np.uint8)
    order = [2, 0, 3, 1]  # file i holds step order[i]
    for i, k in enumerate(order):
        cv2.imwrite(str(tmp_path / f"step{i}.png"), frames[k])
    assert cli("import", tmp_path / "step*.png", "-o", tmp_path / "cap", "--set", "phase-shift", "--steps", 4,
               "--period", PERIOD,
               "--projector-size", "64x48", "--shift-order", "2,0,3,1", "--shift-sign", -1, "--quiet") == 0
    cap = read_capture(tmp_path / "cap")
    d = decode(cap.frames, cap.patterns)
    dphi = np.angle(np.exp(1j * (d.phase["v"] - 2 * np.pi * u_p / PERIOD)))
    assert np.abs(dphi).max() < 0.02


def test_decode_reads_a_folder_of_frames_with_the_import_options_and_writes_only_its_output(tmp_path, sim_frames,
                                                                                            capsys):
    ps, frames, _ = sim_frames
    src = tmp_path / "png"
    src.mkdir()
    for i, f in enumerate(frames):
        assert cv2.imwrite(str(src / f"shot_{i + 1}.png"), colour(f))
    opts = ["--set", "phase-shift", "--steps", 3, "--period", PERIOD, "--projector-size", f"{ps.width}x{ps.height}",
            "--unwrap", "spatial", "--channel", "g"]
    before = sorted(p.name for p in src.iterdir())
    assert cli("decode", src, "-o", tmp_path / "direct", *opts, "--quiet") == 0
    assert sorted(p.name for p in src.iterdir()) == before  # nothing written beside the frames
    assert cli("import", src, "-o", tmp_path / "cap", *opts, "--quiet") == 0
    assert cli("decode", tmp_path / "cap", "-o", tmp_path / "via-import", "--quiet") == 0
    for name in ("phase_v", "mask_v", "modulation_v"):
        np.testing.assert_array_equal(np.load(tmp_path / "direct" / "decoded.npz")[name],
                                      np.load(tmp_path / "via-import" / "decoded.npz")[name])
    # the same folder without a description says what is missing
    capsys.readouterr()
    assert cli("decode", src, "-o", tmp_path / "bare") == 2
    err = " ".join(capsys.readouterr().err.split())
    assert "no manifest.json" in err and "--set" in err and not (tmp_path / "bare").exists()


def test_import_and_decode_share_one_definition_of_the_import_options():
    from fringe3d.commands.lazy import load_command
    params = {name: {p.name: p for p in load_command(name).params} for name in ("import", "decode")}
    shared = ("list_file", "manifest", "layout", "projector_size", "steps", "period", "direction", "shift_order",
              "shift_sign", "unwrap", "no_inverse", "interleave", "white_black", "threshold", "channel", "bit_depth",
              "first_frame", "frame_count")
    for name in shared:
        a, b = params["import"][name], params["decode"][name]
        assert (a.opts, a.help, a.default) == (b.opts, b.help, b.default), name


def test_a_glob_or_list_source_is_an_input_the_output_may_not_replace(tmp_path, sim_frames, capsys):
    ps, frames, _ = sim_frames
    src = numbered_pngs(tmp_path / "scan", frames)
    opts = ["--set", "phase-shift", "--steps", 3, "--period", PERIOD, "--projector-size", f"{ps.width}x{ps.height}",
            "--unwrap", "spatial", "--quiet"]
    before = {p.name: p.read_bytes() for p in src.iterdir()}
    for command in ("decode", "import"):
        for source in ([str(src / "img_*.png")], ["--list", src / "order.txt"]):
            capsys.readouterr()
            assert cli(command, *source, "-o", src, "--overwrite", *opts) == 2, (command, source)
            assert "inside the output" in " ".join(capsys.readouterr().err.split())
            assert {p.name: p.read_bytes() for p in src.iterdir()} == before  # the source frames are untouched


def test_colour_frames_import_as_float_luma_and_decode_without_8_bit_rounding(tmp_path, sim_frames):
    ps, frames, truth = sim_frames
    rgb = np.stack([np.clip(frames.astype(np.int16) + d, 0, 255).astype(np.uint8) for d in (7, -3, 5)], -1)
    src = tmp_path / "png"
    src.mkdir()
    for i, f in enumerate(rgb):
        assert cv2.imwrite(str(src / f"c{i}.png"), cv2.cvtColor(f, cv2.COLOR_RGB2BGR))
    assert cli("import", src, "-o", tmp_path / "cap", "--set", "phase-shift", "--period", PERIOD,
               "--projector-size", f"{ps.width}x{ps.height}", "--quiet") == 0
    cap = read_capture(tmp_path / "cap")
    exact = rgb.astype(np.float64) @ np.array([0.299, 0.587, 0.114])
    assert cap.frames.dtype == np.float32 and cap.meta["bit_depth"] == 8
    np.testing.assert_allclose(cap.frames, exact, atol=1e-4)  # rounding would leave up to 0.5 counts
    assert cli("decode", tmp_path / "cap", "-o", tmp_path / "dec", "--quiet") == 0
    dec = np.load(tmp_path / "dec" / "decoded.npz")
    api = decode(exact, ps, options=DecodeOptions(bit_depth=8))
    np.testing.assert_array_equal(dec["mask_v"], api.mask["v"])
    m = api.mask["v"]
    assert m.mean() > 0.3
    np.testing.assert_allclose(dec["phase_v"][m], api.phase["v"][m], atol=1e-4)


def gray_bits(n: int, bits: int) -> np.ndarray:
    """(bits, n) 0/1: bit k (0 = most significant) of the reflected Gray code of 0..n-1."""
    g = np.arange(n) ^ (np.arange(n) >> 1)
    return (g[None] >> (bits - 1 - np.arange(bits))[:, None]) & 1


def write_interleaved_gray_code(folder, white_black: bool) -> None:
    """Another lab's 64x32 projector code seen 1:1: column bit 0, row bit 0, column bit 1, ...
    (6 column bits, 5 row bits, no inverses), lit 200 / dark 30 counts, then white and black."""
    cols, rows = gray_bits(64, 6), gray_bits(32, 5)
    images = []
    for k in range(6):
        images.append(np.broadcast_to(cols[k][None, :], (32, 64)))
        if k < 5:
            images.append(np.broadcast_to(rows[k][:, None], (32, 64)))
    if white_black:
        images += [np.ones((32, 64)), np.zeros((32, 64))]
    folder.mkdir()
    for i, img in enumerate(images):
        assert cv2.imwrite(str(folder / f"code_{i}.png"), (30 + 170 * img).astype(np.uint8))


@pytest.mark.parametrize("reference", [["--threshold", "115"], ["--white-black", "last"]],
                         ids=["fixed-level", "white-black"])
def test_interleaved_row_column_gray_code_without_inverses_imports_and_decodes(tmp_path, reference, capsys):
    write_interleaved_gray_code(tmp_path / "src", white_black=reference[0] == "--white-black")
    layout = ["--set", "gray-code", "--period", 1, "--projector-size", "64x32", "--no-inverse",
              "--direction", "v,h", "--interleave"]
    assert cli("import", tmp_path / "src", "-o", tmp_path / "cap", *layout, *reference, "--quiet") == 0
    assert cli("decode", tmp_path / "cap", "-o", tmp_path / "dec", "--quiet") == 0
    dec = np.load(tmp_path / "dec" / "decoded.npz")
    u, v = (dec[f"phase_{d}"] / (2 * np.pi) for d in ("v", "h"))  # period 1: w = Phi / 2 pi
    assert dec["mask_v"].all() and dec["mask_h"].all()
    np.testing.assert_allclose(u, np.broadcast_to(np.arange(64), (32, 64)), atol=1e-4)
    np.testing.assert_allclose(v, np.broadcast_to(np.arange(32)[:, None], (32, 64)), atol=1e-4)
    # without a reference to threshold against, the import says what to add and writes nothing
    capsys.readouterr()
    assert cli("import", tmp_path / "src", "-o", tmp_path / "bare", *layout) == 2
    err = " ".join(capsys.readouterr().err.split())
    assert "--threshold" in err and "--white-black" in err and not (tmp_path / "bare").exists()


def test_decode_threshold_overrides_a_capture_folders_code_reference(tmp_path):
    write_interleaved_gray_code(tmp_path / "src", white_black=True)
    layout = ["--set", "gray-code", "--period", 1, "--projector-size", "64x32", "--no-inverse",
              "--direction", "v,h", "--interleave", "--white-black", "last", "--quiet"]
    assert cli("import", tmp_path / "src", "-o", tmp_path / "cap", *layout) == 0
    # a level above the lit 200 counts turns every bit off: every pixel decodes to stripe 0
    assert cli("decode", tmp_path / "cap", "-o", tmp_path / "dec", "--threshold", "250", "--black-thr", "0",
               "--quiet") == 0
    dec = np.load(tmp_path / "dec" / "decoded.npz")
    assert np.nanmax(np.abs(dec["phase_v"])) < 1e-3


def test_list_file_alone_names_the_frames_and_a_source_beside_it_is_refused(tmp_path, sim_frames, capsys):
    ps, frames, _ = sim_frames
    src = numbered_pngs(tmp_path / "scan", frames)
    opts = ["--set", "phase-shift", "--period", PERIOD, "--projector-size", f"{ps.width}x{ps.height}", "--quiet"]
    assert cli("import", "--list", src / "order.txt", "-o", tmp_path / "cap", *opts) == 0
    np.testing.assert_array_equal(read_capture(tmp_path / "cap").frames, frames)
    capsys.readouterr()
    assert cli("import", tmp_path / "elsewhere", "--list", src / "order.txt", "-o", tmp_path / "both", *opts) == 2
    err = " ".join(capsys.readouterr().err.split())
    assert "--list" in err and "not both" in err and not (tmp_path / "both").exists()
    assert cli("decode", "--list", src / "order.txt", "-o", tmp_path / "dec", *opts) == 0


def test_interleaved_two_direction_phase_shift_imports_and_decodes(tmp_path):
    v_p, u_p = np.mgrid[0:24, 0:40].astype(float) + np.array([[0.25]])
    src = tmp_path / "src"
    src.mkdir()
    for k in range(3):  # column step k, then row step k: I = 1/2 (1 + cos(2 pi w / T + 2 pi k / 3))
        for d, w in (("v", u_p), ("h", v_p)):
            img = 40 + 160 * 0.5 * (1 + np.cos(2 * np.pi * w / PERIOD + 2 * np.pi * k / 3))
            assert cv2.imwrite(str(src / f"f{2 * k + (d == 'h')}.png"), np.rint(img).astype(np.uint8))
    assert cli("import", src, "-o", tmp_path / "cap", "--set", "phase-shift", "--period", PERIOD, "--steps", 3,
               "--projector-size", "40x24", "--direction", "v,h", "--interleave", "--quiet") == 0
    assert cli("decode", tmp_path / "cap", "-o", tmp_path / "dec", "--quiet") == 0
    dec = np.load(tmp_path / "dec" / "decoded.npz")
    for d, w in (("v", u_p), ("h", v_p)):
        m = dec[f"mask_{d}"]
        err = np.angle(np.exp(1j * (dec[f"wrapped_{d}"] - 2 * np.pi * w / PERIOD)))
        assert m.mean() > 0.5 and np.abs(err[m]).max() < 0.03, d


def test_frames_read_as_several_one_direction_cycles_warn_about_two_directions(tmp_path):
    from fringe3d.utils.warning_types import DataQualityWarning

    write_interleaved_gray_code(tmp_path / "src", white_black=True)  # 13 frames: 6 column + 5 row bits + 2
    for f in sorted((tmp_path / "src").glob("*.png"))[:1]:
        f.unlink()  # 12 frames: two 6-frame cycles of a one-direction, inverse-free 64-px code
    with pytest.warns(DataQualityWarning, match=r"2 cycles.*`direction` v,h"):
        import_images(tmp_path / "src", tmp_path / "cap",
                      layout=ImportLayout("gray-code", (64, 32), period=1, inverse=False, threshold=115))


def test_threshold_applies_to_the_opencv_layout_and_to_a_manifest(tmp_path):
    ps = opencv_graycode(64, 32)
    for i, f in enumerate(render_set(ps)):
        cv2.imwrite(str(tmp_path / f"pattern_{i}.bmp"), f[:, 8:40] // 2 + 40)
    ps.save(tmp_path / "m.json")
    for k, described in enumerate((["--set", "opencv-graycode", "--projector-size", "64x32"],
                                   ["--manifest", tmp_path / "m.json"])):
        out = tmp_path / f"cap{k}"
        assert cli("import", tmp_path / "pattern_*.bmp", "-o", out, *described, "--threshold", "white-black",
                   "--quiet") == 0
        cap = read_capture(out)
        assert [p.options["threshold"] for p in cap.patterns.plans] == ["white-black", "white-black"]
        d = decode(cap.frames, cap.patterns)  # the bits against (W + B) / 2 instead of their inverses
        assert d.mask["v"].all()
        np.testing.assert_allclose(d.projector_coordinate("v"), np.broadcast_to(np.arange(8, 40), (32, 32)),
                                   atol=0.02)
    # the layout options of --set gray-code/phase-shift are refused, not ignored, for a fixed layout
    assert cli("import", tmp_path / "pattern_*.bmp", "-o", tmp_path / "x", "--manifest", tmp_path / "m.json",
               "--interleave") == 2
    assert not (tmp_path / "x").exists()
