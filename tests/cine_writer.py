"""Write small Phantom CINE files for the tests (no library writes them).

The layout follows Vision Research's "The CINE File Format" (software release 640 and the SETUP
fields added up to release 702); all values little-endian, structures packed to 1 byte::

    offset 0      CINEFILEHEADER   44 bytes: "CI", header size, compression, version, first movie
                                   image, total image count, first image number, image count,
                                   offsets of the BITMAPINFOHEADER, the SETUP and the image
                                   offsets table, trigger time (TIME64)
    offset 44     BITMAPINFOHEADER 40 bytes: width, height (> 0: rows stored bottom-up), planes,
                                   bits per pixel (8 or 16), compression 0, image size ...
    offset 84     SETUP            7240 bytes (release 702): "ST" mark at +140, its length at +142,
                                   FrameRate, SoftwareVersion, CFA, RealBPP, ShutterNs, ...
    ...           tagged blocks    TimeOnly (type 1002: a TIME64 per image) and ExposureOnly
                                   (type 1003: a uint32 per image, seconds x 2**32)
    ...           image offsets    one int64 per image: where its annotation block starts
    ...           per image        AnnotationSize (uint32, 8 + annotation bytes), the annotation,
                                   ImageSize (uint32), then the pixels, rows bottom-up

Only what the tests need: uncompressed monochrome 8- or 16-bit images (CFA 0), 16-bit values in
the low ``real_bpp`` bits.
"""
from __future__ import annotations

import struct
from pathlib import Path

import numpy as np

HEADER = struct.Struct("<2sHHHiIiIIIIII")  # CINEFILEHEADER; TriggerTime = (fractions, seconds)
BITMAPINFO = struct.Struct("<IiiHHIIiiII")  # BITMAPINFOHEADER
TAG = struct.Struct("<IHH")  # tagged block: BlockSize, Type, Reserved
ANNOTATION_SIZE = struct.Struct("<I")
SOFTWARE_VERSION = 702  # the release whose SETUP ends with CineName

#: SETUP (``#pragma pack(1)``) as (field, struct format); runs of fields these files leave 0
#: are one ``"Nx"`` span named after their first and last field.
SETUP_LAYOUT = (
    ("FrameRate16", "H"), ("Shutter16..Res12", "17x"), ("DescriptionOld", "121s"),
    ("Mark", "2s"), ("Length", "H"), ("Res13..Res3", "593x"),
    ("ImWidth", "H"), ("ImHeight", "H"), ("EDRShutter16..Grid", "27x"),
    ("FrameRate", "I"), ("Shutter..FrameDelay", "16x"), ("bEnableColor", "i"),
    ("CameraVersion", "I"), ("FirmwareVersion", "I"), ("SoftwareVersion", "I"), ("RecordingTimeZone", "i"),
    ("CFA", "I"), ("Bright..WBView", "84x"), ("RealBPP", "I"), ("Conv8Min..Sensor", "668x"),
    ("ShutterNs", "I"), ("EDRShutterNs..ImHeightAcq", "24x"), ("Description", "4096s"),
    ("RisingEdge..fGain16_8", "1212x"), ("FRPShape..fTcRate", "80x"), ("CineName", "256s"),
)
SETUP = struct.Struct("<" + "".join(fmt for _, fmt in SETUP_LAYOUT))
SETUP_FIELDS = tuple(name for name, fmt in SETUP_LAYOUT if not fmt.endswith("x"))
assert SETUP.size == 7240, SETUP.size  # the documented size of the release-702 SETUP


def time64(t: float) -> int:
    """TIME64 ``(fractions, seconds)`` of ``t`` seconds since 1970 as one little-endian uint64:
    ``seconds * 2**32 + round(fraction * 2**32)``."""
    seconds = int(np.floor(t))
    return (seconds << 32) | min(int(round((t - seconds) * 2 ** 32)), 2 ** 32 - 1)


def setup_block(width: int, height: int, frame_rate: int, real_bpp: int, exposure_ns: int,
                description: str) -> bytes:
    """The SETUP of a monochrome camera recording at ``frame_rate`` Hz."""
    values = {"FrameRate16": min(frame_rate, 0xFFFF), "DescriptionOld": description.encode()[:120],
              "Mark": b"ST", "Length": SETUP.size, "ImWidth": width, "ImHeight": height,
              "FrameRate": frame_rate, "bEnableColor": 0, "CameraVersion": 0, "FirmwareVersion": 0,
              "SoftwareVersion": SOFTWARE_VERSION, "RecordingTimeZone": 0, "CFA": 0, "RealBPP": real_bpp,
              "ShutterNs": exposure_ns, "Description": description.encode()[:4095], "CineName": b"test"}
    return SETUP.pack(*(values[name] for name in SETUP_FIELDS))


def tagged_blocks(times: list[int], exposure: float) -> bytes:
    """TimeOnly (1002) and ExposureOnly (1003) blocks; Reserved is 1 on a block that another
    follows (pims reads that word as "more blocks follow") and 0 on the last."""
    t = np.asarray(times, "<u8").tobytes()
    e = np.full(len(times), min(int(round(exposure * 2 ** 32)), 2 ** 32 - 1), "<u4").tobytes()
    return TAG.pack(TAG.size + len(t), 1002, 1) + t + TAG.pack(TAG.size + len(e), 1003, 0) + e


def write_cine(path: str | Path, frames: np.ndarray, *, frame_rate: int = 1000, real_bpp: int | None = None,
               first_image_no: int = 0, trigger_time: float = 1.7e9, annotation: bytes = b"",
               description: str = "written by tests/cine_writer.py") -> Path:
    """Write ``frames`` ((F, H, W) uint8 or uint16) as an uncompressed monochrome CINE file.

    Parameters
    ----------
    frame_rate : int, Hz (SETUP ``FrameRate``; the format stores an integer)
    real_bpp : bits used of each 16-bit pixel (SETUP ``RealBPP``); default the dtype's 8 / 16
    first_image_no : the camera's number of the first image, counted from the trigger
        (``FirstImageNo``; image ``k`` is taken at ``trigger_time + (first_image_no + k) / frame_rate``)
    trigger_time : seconds since 1970 (``TriggerTime``)
    annotation : the bytes of every image's annotation block (``AnnotationSize = 8 + len``)
    """
    frames = np.asarray(frames)
    if frames.ndim != 3 or frames.dtype not in (np.uint8, np.uint16):
        raise ValueError(f"frames must be (F, H, W) uint8 or uint16, got {frames.dtype} {frames.shape}")
    F, H, W = frames.shape
    bits = 8 * frames.dtype.itemsize
    real = bits if real_bpp is None else int(real_bpp)
    image_bytes = H * W * frames.dtype.itemsize
    times = [time64(trigger_time + (first_image_no + k) / frame_rate) for k in range(F)]
    setup = setup_block(W, H, frame_rate, real, int(0.9e9 / frame_rate), description)
    tags = tagged_blocks(times, 0.9 / frame_rate)
    off_bitmap = HEADER.size
    off_setup = off_bitmap + BITMAPINFO.size
    off_offsets = off_setup + len(setup) + len(tags)
    first_image = off_offsets + 8 * F
    step = ANNOTATION_SIZE.size * 2 + len(annotation) + image_bytes
    offsets = first_image + step * np.arange(F, dtype="<i8")
    trigger = time64(trigger_time)
    header = HEADER.pack(b"CI", HEADER.size, 0, 1, first_image_no, F, first_image_no, F, off_bitmap, off_setup,
                         off_offsets, trigger & 0xFFFFFFFF, trigger >> 32)
    bitmap = BITMAPINFO.pack(BITMAPINFO.size, W, H, 1, bits, 0, image_bytes, 0, 0, 0, 0)
    path = Path(path)
    with open(path, "wb") as f:
        f.write(header + bitmap + setup + tags + offsets.tobytes())
        for img in frames:
            f.write(ANNOTATION_SIZE.pack(8 + len(annotation)) + annotation + ANNOTATION_SIZE.pack(image_bytes))
            f.write(np.ascontiguousarray(img[::-1]).astype(frames.dtype.newbyteorder("<")).tobytes())
    return path
