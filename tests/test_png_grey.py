"""Greyscale PNG frames decoded without OpenCV (fringe3d.io._png_grey): the image encoded, bit for
bit, whatever the row filters (each of the five forced on every row by an encoder written here
from the PNG specification, and libpng's own choices through OpenCV), equal to OpenCV's
``IMREAD_UNCHANGED``; every file it does not decode (colour, interlace, 1-bit, transparency, a
bad CRC, truncated or extra image data, an unknown filter) left to OpenCV, whose result or error
read_image gives as before; capture stacks decoded in place (CaptureFrames, read_capture) equal
the frames written, a frame that does not fit still named."""
from __future__ import annotations

import struct
import zlib

import cv2
import numpy as np
import pytest

from fringe3d.io import images
from fringe3d.io._png_grey import decode_grey_png, grey_png_header
from fringe3d.io.capture import read_capture, write_capture
from fringe3d.io.capture_frames import CaptureFrames
from fringe3d.io.images import read_image, write_image
from fringe3d.patterns import sets


def _chunk(kind: bytes, data: bytes) -> bytes:
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))


def _paeth(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    p = a + b - c
    pa, pb, pc = np.abs(p - a), np.abs(p - b), np.abs(p - c)
    return np.where((pa <= pb) & (pa <= pc), a, np.where(pb <= pc, b, c))


def encode(img: np.ndarray, filters, extra: tuple = (), **header) -> bytes:
    """A PNG of the grey ``img`` (uint8 or uint16), row ``y`` filtered with ``filters[y % len]``
    (PNG specification, section 9; a filter above 4 written as is, with no prediction), the chunks
    ``extra`` before the image data, the IHDR fields given in ``header`` in place of the image's."""
    rows = img.astype(img.dtype.newbyteorder(">")).view(np.uint8).reshape(img.shape[0], -1).astype(np.int32)
    bpp = img.dtype.itemsize
    out, prev = [], np.zeros(rows.shape[1], np.int32)
    for y, x in enumerate(rows):
        f = filters[y % len(filters)]
        a = np.concatenate([np.zeros(bpp, np.int32), x[:-bpp]])
        c = np.concatenate([np.zeros(bpp, np.int32), prev[:-bpp]])
        pred = [np.zeros_like(x), a, prev, (a + prev) // 2, _paeth(a, prev, c)][f] if f <= 4 else 0
        out.append(bytes([f]) + ((x - pred) % 256).astype(np.uint8).tobytes())
        prev = x
    h = {"width": img.shape[1], "height": img.shape[0], "depth": 8 * bpp, "colour": 0, "interlace": 0, **header}
    head = struct.pack(">IIBBBBB", h["width"], h["height"], h["depth"], h["colour"], 0, 0, h["interlace"])
    data = zlib.compress(b"".join(out), 6)
    return (b"\x89PNG\r\n\x1a\n" + _chunk(b"IHDR", head) + b"".join(extra) + _chunk(b"IDAT", data[:7])
            + _chunk(b"IDAT", data[7:]) + _chunk(b"IEND", b""))


def _image(dtype, shape=(13, 17), seed=0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    smooth = np.add.outer(np.arange(shape[0]) * 31, np.arange(shape[1]) * 7)
    return ((smooth + rng.integers(0, 40, shape)) % (np.iinfo(dtype).max + 1)).astype(dtype)


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16])
@pytest.mark.parametrize("filters", [[0], [1], [2], [3], [4], [4, 3, 2, 1, 0]])
def test_every_row_filter_decodes_to_the_image_encoded_and_to_opencvs_result(dtype, filters):
    img = _image(dtype)
    png = encode(img, filters)
    got = decode_grey_png(png)
    assert got.dtype == dtype and got.shape == img.shape
    np.testing.assert_array_equal(got, img)
    np.testing.assert_array_equal(got, cv2.imdecode(np.frombuffer(png, np.uint8), cv2.IMREAD_UNCHANGED))


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16])
@pytest.mark.parametrize("shape", [(1, 1), (1, 7), (6, 1), (40, 97)])
def test_pngs_written_by_opencv_decode_to_the_image_written(dtype, shape):
    for level in (0, 1, 9):
        ok, buf = cv2.imencode(".png", _image(dtype, shape, seed=level), [cv2.IMWRITE_PNG_COMPRESSION, level])
        np.testing.assert_array_equal(decode_grey_png(buf), _image(dtype, shape, seed=level))


def test_decoding_into_a_frame_of_a_stack_fills_that_frame_alone():
    img = _image(np.uint16)
    stack = np.zeros((3,) + img.shape, np.uint16)
    middle = stack[1]
    assert decode_grey_png(encode(img, [4, 1]), out=middle) is middle
    np.testing.assert_array_equal(stack[1], img)
    assert not stack[0].any() and not stack[2].any()


def _text(key: bytes) -> bytes:
    return _chunk(b"tEXt", key + b"\x00value")


def _flip_a_bit(png: bytes) -> bytes:
    return png[:-20] + bytes([png[-20] ^ 1]) + png[-19:]


IMG = _image(np.uint8)
NOT_DECODED = {
    "colour": lambda: encode(IMG, [0], colour=2),
    "grey_and_alpha": lambda: encode(IMG, [0], colour=4),
    "interlaced": lambda: encode(IMG, [0], interlace=1),
    "one_bit": lambda: encode(IMG, [0], depth=1),
    "transparency": lambda: encode(IMG, [0], extra=(_chunk(b"tRNS", b"\x00\x05"),)),
    "gamma": lambda: encode(IMG, [0], extra=(_chunk(b"gAMA", struct.pack(">I", 45455)),)),
    "bad_crc": lambda: _flip_a_bit(encode(IMG, [0])),
    "short_data": lambda: encode(IMG[:-1], [0], height=13),
    "long_data": lambda: encode(np.vstack([IMG, IMG[:1]]), [0], height=13),
    "bad_filter": lambda: encode(IMG, [0, 0, 0, 0, 0, 7]),
    "not_png": lambda: b"GIF89a" + bytes(40),
}


@pytest.mark.parametrize("case", sorted(NOT_DECODED))
def test_files_it_does_not_decode_are_left_to_opencv(case):
    assert decode_grey_png(NOT_DECODED[case]()) is None


def test_an_out_array_that_does_not_fit_is_declined():
    png = encode(IMG, [0])
    assert decode_grey_png(png, out=np.empty((13, 16), np.uint8)) is None
    assert decode_grey_png(png, out=np.empty((13, 17), np.uint16)) is None
    assert decode_grey_png(png, out=np.empty((17, 13), np.uint8).T) is None


def test_text_chunks_do_not_stop_the_decoder_and_the_header_gives_shape_and_dtype():
    img = _image(np.uint16)
    png = encode(img, [2], extra=(_text(b"Software"),))
    assert grey_png_header(png) == (13, 17, np.dtype(np.uint16))
    np.testing.assert_array_equal(decode_grey_png(png), img)


@pytest.fixture
def kernel_for_small_files(monkeypatch):
    """read_image sends even these small test files to the numba decoder."""
    monkeypatch.setattr(images, "PNG_KERNEL_FROM", 1)


def test_read_image_gives_opencvs_result_for_a_file_left_to_it(tmp_path, kernel_for_small_files):
    img = _image(np.uint8)
    (tmp_path / "t.png").write_bytes(encode(img, [1], extra=(_chunk(b"tRNS", b"\x00\x05"),)))
    by_opencv = cv2.imread(str(tmp_path / "t.png"), cv2.IMREAD_UNCHANGED)
    np.testing.assert_array_equal(read_image(tmp_path / "t.png"), by_opencv)
    np.testing.assert_array_equal(read_image(tmp_path / "t.png"), img)


def test_a_corrupt_frame_file_is_named_by_read_image(tmp_path, kernel_for_small_files):
    good = encode(_image(np.uint8), [0])
    (tmp_path / "bad.png").write_bytes(good[:60])
    with pytest.raises(ValueError, match="bad.png"):
        read_image(tmp_path / "bad.png")


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16])
@pytest.mark.parametrize("small_files_to", ["kernel", "opencv"])
def test_capture_stacks_decoded_in_place_equal_the_frames_written(tmp_path, dtype, small_files_to, monkeypatch):
    if small_files_to == "kernel":
        monkeypatch.setattr(images, "PNG_KERNEL_FROM", 1)
    frames = np.stack([_image(dtype, (9, 11), seed=s) for s in range(5)])
    (tmp_path / "frames").mkdir()
    for i, f in enumerate(frames):
        write_image(tmp_path / "frames" / f"{i:05d}.png", f)
    lazy = CaptureFrames(tmp_path)
    for idx in ([2, 0, 1], [4], [3, 4], []):
        got = lazy[np.array(idx)]
        assert got.dtype == dtype and got.flags.c_contiguous
        np.testing.assert_array_equal(got, frames[idx])
    np.testing.assert_array_equal(lazy[3], frames[3])


def test_frame_files_from_the_size_limit_on_are_decoded_by_the_kernel_into_the_stack(tmp_path, monkeypatch):
    frames = np.random.default_rng(5).integers(0, 256, (2, 300, 300), dtype=np.uint8)  # ~90 kB files
    (tmp_path / "frames").mkdir()
    for i, f in enumerate(frames):
        write_image(tmp_path / "frames" / f"{i:05d}.png", f)
    assert (tmp_path / "frames" / "00000.png").stat().st_size >= images.PNG_KERNEL_FROM
    calls = []

    def spy(data, out=None):
        got = decode_grey_png(data, out)
        calls.append(got is not None and (out is None or got is out))
        return got
    monkeypatch.setattr(images, "decode_grey_png", spy)
    got = CaptureFrames(tmp_path)[np.array([1, 0])]
    np.testing.assert_array_equal(got, frames[[1, 0]])
    assert calls == [True, True, True]  # the opening's first frame, then each into its place


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16])
def test_a_capture_read_whole_with_the_kernel_equals_the_frames_written_and_names_a_misfit(
        tmp_path, dtype, kernel_for_small_files):
    ps = sets.phase_shift(18, 3, "v", width=40, height=30)
    frames = np.stack([_image(dtype, (12, 20), seed=s) for s in range(6)])
    write_capture(tmp_path, frames, ps, meta={"bit_depth": 8 * np.dtype(dtype).itemsize})
    got = read_capture(tmp_path).frames
    assert got.dtype == dtype
    np.testing.assert_array_equal(got, frames)
    write_image(tmp_path / "frames" / "00004.png", _image(dtype, (11, 20)))
    with pytest.raises(ValueError, match=r"00004\.png has shape \(11, 20\).*00000\.png has \(12, 20\)"):
        read_capture(tmp_path)
