"""Import another lab's image sequence as a standard capture folder.

:func:`import_capture` reads frames with any names (natural sort of a folder or glob, or an
explicit list file), PNG, TIFF (single- and multi-page), BMP and JPEG, 8/10/12/16-bit, grey
or colour, converts them with :func:`to_grey`, checks the count against the pattern layout
and writes ``manifest.json``, ``frames/`` and ``capture.json`` (source files, conversion,
bit depth) through :func:`fringe3d.io.capture.write_capture`.

A camera file — Photron MRAW (``.cih``/``.cihx`` + ``.mraw``), Phantom CINE (``.cine``), a
multi-page TIFF stack, a zarr frame store — is not converted: :func:`import_camera_file` writes ``manifest.json`` and a
``capture.json`` whose ``source`` references the file (``copy_frames=True`` writes PNGs).

Colour conversion (the one place; the command line and the API both call it): ITU-R BT.601
luma ``Y = 0.299 R + 0.587 G + 0.114 B`` kept as float32 (not rounded to the source's 8 or 16
bits: rounding an 8-bit luma costs 0.03-0.05 projector px of phase; the capture's frames are
then float32 TIFFs in the source's counts, ``bit_depth`` the source's), or one channel
(``channel="r" | "g" | "b"``, the source dtype unchanged).
"""
from __future__ import annotations

import glob
import os
import re
import warnings
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Sequence

import cv2
import numpy as np
import tifffile

from fringe3d.io.capture import CAPTURE_UNITS, FRAMES_DIR, META_NAME, Capture, write_capture
from fringe3d.io.capture_source import check_header, make_source
from fringe3d.io.frame_sources import FrameRange, FrameSource, guess_kind, open_source
from fringe3d.io.images import write_image
from fringe3d.patterns import sets
from fringe3d.patterns.layouts import (combine_directions, opencv_graycode, opencv_graycode_bits,
                                       opencv_graycode_count, parse_threshold, with_threshold, with_white_black)
from fringe3d.patterns.manifest import MANIFEST_NAME, PatternSet
from fringe3d.utils.jsonfile import write_json
from fringe3d.utils.warning_types import DataQualityWarning

#: Image files the importer reads.
IMPORT_SUFFIXES = (".png", ".tif", ".tiff", ".bmp", ".jpg", ".jpeg")
#: BT.601 luma weights (R, G, B).
BT601 = (0.299, 0.587, 0.114)
#: The same weights in thousandths (exact in floating point: a grey R = G = B keeps its value).
BT601_PERMILLE = (299.0, 587.0, 114.0)
CHANNELS = {"r": 0, "g": 1, "b": 2}
LAYOUTS = ("phase-shift", "gray-code", "opencv-graycode")


def natural_key(path: Path) -> list:
    """Sort key: digit runs compare as numbers (``img_2`` before ``img_10``)."""
    return [int(t) if t.isdigit() else t.lower() for t in re.split(r"(\d+)", path.name)]


def list_sources(src: str | os.PathLike | None, list_file: str | os.PathLike | None = None) -> list[Path]:
    """Frame files in projection order: the lines of ``list_file`` (relative to its folder;
    blank lines and ``#`` comments skipped), else the image files of folder ``src`` or of the
    glob ``src``, naturally sorted. ``FileNotFoundError`` naming what is missing."""
    if list_file is not None:
        lf = Path(list_file)
        if not lf.is_file():
            raise FileNotFoundError(f"list file {lf} does not exist")
        names = [ln.strip() for ln in lf.read_text().splitlines() if ln.strip() and not ln.startswith("#")]
        files = [p if p.is_absolute() else lf.parent / p for p in map(Path, names)]
        missing = [str(p) for p in files if not p.is_file()]
        if missing:
            raise FileNotFoundError(f"{lf} lists {len(missing)} file(s) that do not exist: {missing[:5]}")
    else:
        s = str(src)
        if Path(s).is_dir():
            files = [p for p in Path(s).iterdir() if p.suffix.lower() in IMPORT_SUFFIXES]
        else:
            files = [Path(p) for p in glob.glob(s) if Path(p).suffix.lower() in IMPORT_SUFFIXES]
        files.sort(key=natural_key)
    if not files:
        raise FileNotFoundError(f"no image files ({', '.join(IMPORT_SUFFIXES)}) found at {src}")
    return files


def to_grey(img: np.ndarray, channel: str | None = None) -> np.ndarray:
    """(H, W) grey image from (H, W) or RGB(A) (H, W, C) ``img`` (channels in R, G, B order):
    BT.601 luma ``(299 R + 587 G + 114 B) / 1000`` as float32, not rounded (the weights are
    exact, so a white ``R = G = B = 255`` stays 255.0 and saturation is still seen), or the
    ``channel`` ``"r"``/``"g"``/``"b"`` in the input dtype. Grey input is returned unchanged.

    Examples
    --------
    >>> to_grey(np.array([[[100, 201, 50]]], np.uint8)).tolist()
    [[153.58700561523438]]
    """
    if img.ndim == 2:
        return img
    if img.ndim != 3 or img.shape[2] not in (1, 3, 4):
        raise ValueError(f"an image of shape {img.shape} is neither grey nor RGB(A)")
    if img.shape[2] == 1:
        return img[..., 0]
    if channel is not None:
        if channel not in CHANNELS:
            raise ValueError(f"channel must be one of {sorted(CHANNELS)}, got {channel!r}")
        return np.ascontiguousarray(img[..., CHANNELS[channel]])
    y = img[..., :3].astype(np.float64) @ np.asarray(BT601_PERMILLE, np.float64) / 1000.0
    return y.astype(np.float32)


def read_pages(path: Path) -> list[np.ndarray]:
    """The images in one file, RGB channel order: every page of a TIFF, else one image
    (OpenCV, BGR turned to RGB). ``ValueError`` naming the file when it cannot be read."""
    try:
        if path.suffix.lower() in (".tif", ".tiff"):
            with tifffile.TiffFile(path) as tif:
                pages = [page.asarray() for page in tif.pages]
            # planar RGB pages (3, H, W) -> (H, W, 3)
            return [np.moveaxis(p, 0, -1) if p.ndim == 3 and p.shape[0] in (3, 4) and p.shape[2] > 4 else p
                    for p in pages]
        img = cv2.imdecode(np.fromfile(path, dtype=np.uint8), cv2.IMREAD_UNCHANGED)
    except Exception as e:  # decoders raise many types for corrupt files
        raise ValueError(f"{path} is not a readable image ({type(e).__name__}: {e})") from None
    if img is None:
        raise ValueError(f"{path} is not a readable image (PNG, TIFF, BMP or JPEG expected)")
    if img.ndim == 3 and img.shape[2] >= 3:
        img = cv2.cvtColor(img, cv2.COLOR_BGRA2RGBA if img.shape[2] == 4 else cv2.COLOR_BGR2RGB)
    return [img]


def read_frames(files: Sequence[Path], channel: str | None = None) -> tuple[np.ndarray, list[str], str]:
    """((F, H, W) frames, source names ``file`` or ``file#page``, the source dtype of colour
    input or ``""`` for grey input) of the files in order, converted by :func:`to_grey` (colour
    luma: float32); ``ValueError`` naming the first file whose size or dtype differs from the
    first frame's, or that is not 8- or 16-bit."""
    frames: list[np.ndarray] = []
    names: list[str] = []
    colour = ""
    for f in files:
        pages = read_pages(f)
        for k, img in enumerate(pages):
            name = f"{f}#{k}" if len(pages) > 1 else str(f)
            if img.dtype not in (np.uint8, np.uint16):
                raise ValueError(f"{name} is {img.dtype}; expected 8- or 16-bit integer images")
            if img.ndim == 3 and img.shape[2] >= 3:
                colour = str(img.dtype)
            g = to_grey(img, channel)
            if frames and (g.shape != frames[0].shape or g.dtype != frames[0].dtype):
                raise ValueError(f"{name} is {g.shape[1]}x{g.shape[0]} {g.dtype} "
                                 f"but {names[0]} is {frames[0].shape[1]}x{frames[0].shape[0]} {frames[0].dtype}; "
                                 "all frames must have one size, bit depth and colour type")
            frames.append(g)
            names.append(name)
    return np.stack(frames), names, colour


def check_bit_depth(frames: np.ndarray, bit_depth: int | None, dtype: str | np.dtype | None = None) -> int:
    """The frames' bit depth: ``bit_depth`` (8, 10, 12, 14 or 16; 10-14 stored in 16-bit
    files, checked against the largest value) or the source ``dtype``'s (default the frames')
    8 / 16."""
    native = 8 if np.dtype(dtype or frames.dtype) == np.uint8 else 16
    if bit_depth is None:
        return native
    if bit_depth not in (8, 10, 12, 14, 16) or bit_depth > native:
        raise ValueError(f"bit depth {bit_depth} does not fit {dtype or frames.dtype} frames; expected 8 for 8-bit "
                         "files, 10, 12, 14 or 16 for 16-bit files")
    top = float(frames.max())
    if top >= 2 ** bit_depth:
        raise ValueError(f"frames reach {top:g}, above the {bit_depth}-bit maximum {2 ** bit_depth - 1}; "
                         "is the bit depth right (or are the values left-aligned in 16 bits)?")
    return bit_depth


@dataclass(frozen=True)
class ImportLayout:
    """What was projected, as a layout instead of a pattern manifest (:func:`layout_patterns`),
    and the code threshold of the plans (also of a manifest's).

    Attributes
    ----------
    name : str | None
        The layout: ``"phase-shift"``, ``"gray-code"`` or ``"opencv-graycode"`` (:data:`LAYOUTS`);
        ``None`` when a pattern manifest says what was projected.
    projector_size : tuple of int | None
        Projector (width, height) in px; a layout needs it (it fixes the code bits and the
        unwrapping range).
    steps : int
        ``"phase-shift"``: phase steps N.
    period : float | None
        Fringe period / stripe width (projector px); a ``"phase-shift"`` or ``"gray-code"``
        layout needs it.
    direction : str
        ``"v"`` (vertical stripes, columns), ``"h"`` (rows), or several, e.g. ``"v,h"``: one set
        each, concatenated (or alternating: ``interleave``).
    shift_order : sequence of int | None
        ``"phase-shift"``: the step held by each captured frame (frame i holds step
        ``shift_order[i]``); ``None``: 0, 1, ..., N-1.
    shift_sign : int
        ``"phase-shift"``: +1 for shifts ``2 pi k / N``, -1 for ``-2 pi k / N``.
    unwrap : str | None
        Unwrapping method of the plans; ``None``: the layout's own (``"none"`` for phase-shift).
    inverse : bool
        ``"gray-code"``: each bit followed by its inverse frame.
    interleave : bool
        Several directions alternate frame by frame (bit by bit, step by step;
        :func:`fringe3d.patterns.layouts.combine_directions`) instead of one after the other.
    white_black : str
        ``"none"``, ``"first"`` or ``"last"``: a white then a black frame before or after the patterns.
    threshold : str | float | None
        The plans' code threshold: ``"inverse"``, ``"white-black"``, ``"average"`` or a level in
        camera counts; ``None``: the decoder's default. Applied to a manifest's plans too.
    """

    name: str | None = None
    projector_size: tuple[int, int] | None = None
    steps: int = 3
    period: float | None = None
    direction: str = "v"
    shift_order: Sequence[int] | None = None
    shift_sign: int = 1
    unwrap: str | None = None
    inverse: bool = True
    interleave: bool = False
    white_black: str = "none"
    threshold: str | float | None = None


@dataclass(frozen=True)
class FrameReading:
    """How imported frames are read (:func:`import_images`, :func:`load_images`).

    Attributes
    ----------
    channel : str | None
        ``"r"``, ``"g"`` or ``"b"``: that colour channel, the source dtype unchanged; ``None``:
        the BT.601 luma of colour frames (float32, the source's counts).
    bit_depth : int | None
        Camera bit depth (bits; e.g. 10/12/14 in 16-bit files); ``None``: the files' 8 / 16, or
        the camera file's.
    first_frame : int
        Camera file: the frame (index) where the first pattern cycle starts.
    frame_count : int | None
        Camera file: frames to use (a multiple of the cycle); ``None``: the whole cycles left.
    """

    channel: str | None = None
    bit_depth: int | None = None
    first_frame: int = 0
    frame_count: int | None = None


def require_size(projector_size: tuple[int, int] | None, layout: str) -> tuple[int, int]:
    """The projector size, or ``ValueError`` saying the layout needs it."""
    if projector_size is None:
        raise ValueError(f"`layout` {layout} needs the projector size (`projector_size` WxH, e.g. 1024x768): "
                         "it fixes the code bits and the unwrapping range and is not guessed")
    return projector_size


def layout_patterns(described: ImportLayout) -> PatternSet:
    """The :class:`PatternSet` a layout (:class:`ImportLayout`) describes: ``"phase-shift"``
    (``steps`` frames of ``period`` px along ``direction``; captured step order ``shift_order``
    (frame i holds step ``shift_order[i]``), ``shift_sign=-1`` for shifts ``-2 pi k / N``; plan
    method ``unwrap``, default ``"none"``), ``"gray-code"`` (stripes of ``period`` px, with or
    without inverses) or ``"opencv-graycode"`` (:func:`fringe3d.patterns.layouts.opencv_graycode`).
    The projector size is required.

    ``direction`` may name several directions (``"v,h"``): one set each, concatenated, or with
    ``interleave`` alternating bit by bit (step by step;
    :func:`fringe3d.patterns.layouts.combine_directions`). ``white_black`` (``"first"``,
    ``"last"``) adds a white and a black frame; ``threshold`` (``"inverse"``, ``"white-black"``,
    ``"average"`` or a level in camera counts) is the plans' code threshold. A code without
    inverse frames, white/black frames or phase frames needs a fixed ``threshold``.

    Examples
    --------
    >>> ps = layout_patterns(ImportLayout("phase-shift", (64, 48), steps=3, period=16))
    >>> len(ps), ps.plans[0].method
    (3, 'none')
    """
    layout, projector_size, threshold = described.name, described.projector_size, described.threshold
    period, direction, interleave = described.period, described.direction, described.interleave
    if layout is None or layout not in LAYOUTS:
        raise ValueError(f"unknown layout {layout!r}; expected one of {LAYOUTS} or a manifest (`manifest`)")
    width, height = require_size(projector_size, layout)
    if layout == "opencv-graycode":
        return opencv_graycode(width, height) if threshold is None else with_threshold(opencv_graycode(width, height),
                                                                                      threshold)
    if period is None:
        raise ValueError(f"`layout` {layout} needs the fringe/stripe period in projector pixels (`period` T)")
    directions = [d.strip() for d in direction.split(",")]
    if len(set(directions)) != len(directions) or not all(directions):
        raise ValueError(f"`direction` {direction!r}: expected one direction or distinct ones, e.g. v,h")
    if interleave and len(directions) < 2:
        raise ValueError("`interleave=True` alternates the frames of several directions: give them, "
                         "e.g. `direction` v,h")
    if layout == "gray-code":
        parts = [sets.gray_code(period, d, width=width, height=height, inverse=described.inverse) for d in directions]
    else:
        parts = [phase_shift_layout(sets.phase_shift(period, described.steps, d, width=width, height=height),
                                    described.shift_order, described.shift_sign) for d in directions]
    ps = with_white_black(combine_directions(parts, interleave), described.white_black)
    level = parse_threshold(threshold)
    check_code_threshold(ps, level)
    unwrap = described.unwrap
    plans = tuple(replace(p, method=p.method if unwrap is None else unwrap,
                          options=p.options if level is None else {**p.options, "threshold": level})
                  for p in ps.plans)
    return replace(ps, plans=plans)


def check_code_threshold(ps: PatternSet, threshold: str | float | None) -> None:
    """A code the decoder can threshold: ``ValueError`` saying which option is missing when
    ``ps`` has code frames without inverses, white/black frames or phase frames and no fixed
    ``threshold``, or when ``threshold`` names frames ``ps`` does not have."""
    code = [f for f in ps.frames if f.role == "code"]
    if not code:
        return
    has = {"inverse": any(f.inverse for f in code),
           "white-black": bool(ps.indices(kind="white") and ps.indices(kind="black")),
           "average": any(f.role == "phase" for f in ps.frames)}
    if isinstance(threshold, str) and not has[threshold]:
        raise ValueError(f"`threshold` {threshold}: the layout has no {threshold} frames to threshold the code "
                         "against; add them (`white_black` first|last) or give a level in camera counts")
    if threshold is None and not any(has.values()):
        raise ValueError("a Gray code without inverse frames (`inverse=False`), white/black frames (`white_black`) "
                         "or phase frames cannot be thresholded: give `white_black` first|last or a fixed "
                         "`threshold` LEVEL in camera counts (e.g. half the lit level)")


def phase_shift_layout(ps: PatternSet, shift_order: Sequence[int] | None, shift_sign: int) -> PatternSet:
    """``ps`` with its frames reordered (frame i = step ``shift_order[i]``) and shifts negated
    for ``shift_sign=-1``."""
    n = len(ps.frames)
    order = list(range(n)) if shift_order is None else [int(k) for k in shift_order]
    if sorted(order) != list(range(n)):
        raise ValueError(f"`shift_order` {order} must list the steps 0..{n - 1} once each")
    if shift_sign not in (1, -1):
        raise ValueError(f"`shift_sign` must be +1 or -1, got {shift_sign}")
    frames = tuple(replace(ps.frames[k], shift=shift_sign * ps.frames[k].shift) for k in order)
    return replace(ps, frames=frames)


def count_message(layout: str, patterns: PatternSet, got: int) -> str:
    """What a layout expects, for a frame count that does not match."""
    if layout == "opencv-graycode":
        bu, bv = opencv_graycode_bits(patterns.width, patterns.height)
        return (f"`layout` opencv-graycode for a {patterns.width}x{patterns.height} projector expects "
                f"2*({bu}+{bv})+2 = {opencv_graycode_count(patterns.width, patterns.height)} frames, got {got}")
    return (f"{layout} ({patterns.name}) expects {len(patterns)} frames (or a multiple, for a sequence), got {got}")


def check_output(out: Path, overwrite: bool) -> None:
    """Refuse an output that is a file, or a non-empty folder unless ``overwrite``."""
    if out.exists() and not out.is_dir():
        raise ValueError(f"output {out} exists and is not a folder")
    if out.is_dir() and any(out.iterdir()) and not overwrite:
        raise ValueError(f"output folder {out} is not empty; choose an empty folder or pass `overwrite=True`")


def read_images(files: Sequence[Path], patterns: PatternSet, layout: str = "manifest",
                channel: str | None = None, bit_depth: int | None = None) -> tuple[np.ndarray, dict]:
    """Read ``files`` (see :func:`list_sources`) and convert them (:func:`to_grey`) for ``patterns``.

    Returns the frames (F, H, W) and the ``capture.json`` summary (``source_files``,
    ``conversion``, ``bit_depth``, ``source_dtype``, ``layout``, ...). Raises ``ValueError`` for
    a frame count that does not fit the layout (saying what was expected), unreadable or
    mismatched frames and a wrong bit depth.
    """
    frames, names, colour = read_frames(files, channel)
    if len(frames) % len(patterns):
        raise ValueError(count_message(layout, patterns, len(frames)))
    if len(frames) > len(patterns) and layout in ("gray-code", "phase-shift") and len(patterns.directions()) == 1:
        n = len(patterns)
        warnings.warn(f"{len(frames)} frames read as {len(frames) // n} cycles of the {n}-frame {patterns.name} "
                      "layout; if they hold columns and rows, describe both: `direction` v,h (`interleave=True` when "
                      "they alternate)", DataQualityWarning, stacklevel=2)
    bits = check_bit_depth(frames, bit_depth, colour or None)
    conversion = ("none (grey input)" if not colour else f"channel {channel}" if channel
                  else "ITU-R BT.601 luma 0.299 R + 0.587 G + 0.114 B, float32 (not rounded)")
    return frames, {"imported": True, "layout": layout, "source_files": names, "conversion": conversion,
                    "source_dtype": colour or str(frames.dtype), "bit_depth": bits, "patterns": patterns.name}


def import_capture(files: Sequence[Path], out: str | os.PathLike, patterns: PatternSet, layout: str = "manifest",
                   channel: str | None = None, bit_depth: int | None = None, overwrite: bool = False,
                   exposures: Sequence[float] | None = None) -> dict:
    """Read ``files`` (:func:`read_images`) and write the capture folder ``out`` for
    ``patterns``. Returns the summary written as ``capture.json`` plus ``folder``, ``frames``
    and ``camera``. ``exposures``: the frames are an exposure bracket, one cycle per exposure
    time (s), exposure-major (``capture.json`` field ``exposures``, fused by ``fringe3d decode``).

    Raises ``ValueError`` as :func:`read_images`, for a bracket whose frame count is not one cycle
    per exposure, and for a non-empty output folder without ``overwrite``.
    """
    out = Path(out)
    check_output(out, overwrite)
    frames, meta = read_images(files, patterns, layout, channel, bit_depth)
    if exposures is not None:
        want = len(exposures) * len(patterns)
        if len(frames) != want:
            raise ValueError(f"exposures: a bracket of {len(exposures)} exposures needs {len(exposures)} x "
                             f"{len(patterns)} = {want} frames (one pattern cycle per exposure), got {len(frames)}")
        meta["exposures"] = [float(e) for e in exposures]
    write_capture(out, frames, patterns, meta, fmt="png" if frames.dtype.kind == "u" else "tif")
    return {**meta, "folder": str(out), "frames": int(len(frames)), "camera": [int(frames.shape[2]),
                                                                                int(frames.shape[1])]}


def source_range(src: FrameSource, patterns: PatternSet, layout: str, first_frame: int,
                 frame_count: int | None) -> FrameRange:
    """The frames of ``src`` to use: ``frame_count`` from ``first_frame`` (a multiple of the
    manifest), or, when None, the whole cycles after ``first_frame`` (trailing frames dropped
    with a :class:`DataQualityWarning`). ``ValueError`` for a range beyond the file."""
    n = len(patterns)
    if frame_count is None:
        rest = len(src) - first_frame
        if first_frame < 0 or rest < n:
            raise ValueError(f"{src.path}: first_frame {first_frame} leaves {max(rest, 0)} of the file's {len(src)} "
                             f"frames, fewer than one {n}-frame cycle; expected first_frame <= {len(src) - n}")
        frame_count = rest // n * n
        if frame_count < rest:
            warnings.warn(f"{src.path}: {rest - frame_count} trailing frame(s) after the last whole {n}-frame "
                          f"cycle are not used", DataQualityWarning, stacklevel=3)
    elif frame_count % n:
        raise ValueError(f"{src.path}: {count_message(layout, patterns, frame_count)} (frame_count)")
    return FrameRange(src, first_frame, frame_count)


def range_max(frames: FrameRange, chunk: int = 64) -> int:
    """Largest value of ``frames``, read ``chunk`` frames at a time (memory: one chunk)."""
    top = 0
    for a in range(0, len(frames), chunk):
        top = max(top, int(frames.read(a, min(a + chunk, len(frames))).max()))
    return top


def source_bit_depth(frames: FrameRange, bit_depth: int | None) -> int:
    """The capture's bit depth: the header's, or ``bit_depth`` (10-14 in 16-bit files, checked
    against the largest value, read in chunks); ``ValueError`` if the header disagrees."""
    src = frames.source
    if bit_depth is None or bit_depth == src.bit_depth:
        return src.bit_depth
    native = 8 * src.dtype.itemsize
    if src.bit_depth != native:
        raise ValueError(f"{src.path}: the header says bit depth {src.bit_depth} but `bit_depth` is {bit_depth}; "
                         f"expected {src.bit_depth} (or leave `bit_depth` out)")
    check_bit_depth(np.array([range_max(frames)], src.dtype), bit_depth)
    return bit_depth


def copy_to_png(frames: FrameRange, out: Path, chunk: int = 64) -> None:
    """Write ``frames`` as ``out/frames/00000.png ...``, ``chunk`` frames at a time (memory: one
    chunk), removing numbered frames an older capture left beyond them."""
    fdir = out / FRAMES_DIR
    fdir.mkdir(parents=True, exist_ok=True)
    for stale in fdir.iterdir():
        if stale.stem.isdigit() and int(stale.stem) >= len(frames):
            stale.unlink()
    for a in range(0, len(frames), chunk):
        for k, img in enumerate(frames.read(a, min(a + chunk, len(frames))), start=a):
            write_image(fdir / f"{k:05d}.png", img)


def camera_file_range(kind: str, path: str | os.PathLike, patterns: PatternSet, layout: str, first_frame: int,
                      frame_count: int | None, bit_depth: int | None) -> tuple[FrameSource, FrameRange, dict]:
    """The camera file ``path`` of ``kind`` opened, the frames used (:func:`source_range`) and
    the capture metadata they give (layout, dtype, bit depth, camera size, frame rate where the
    file has one); what :func:`import_camera_file` writes and :func:`load_images` holds."""
    src = open_source(kind, path)
    frames = source_range(src, patterns, layout, first_frame, frame_count)
    bits = source_bit_depth(frames, bit_depth)
    H, W = src.shape[1:]
    meta: dict = {"imported": True, "layout": layout, "conversion": "none (camera file referenced)",
                  "source_dtype": str(src.dtype), "bit_depth": bits, "camera": [W, H], "patterns": patterns.name}
    if src.frame_rate is not None:
        meta["frame_rate"] = src.frame_rate
    return src, frames, meta


def camera_file_kind(src: str | os.PathLike | None, list_file, channel: str | None,
                     convert_tiff: bool = False) -> str | None:
    """The camera-file kind of ``src`` (:func:`guess_kind`; None for image files, a list file,
    or a TIFF stack to be converted page by page with ``convert_tiff``). ``channel`` on a
    camera file is an error: its frames are read as grey."""
    kind = guess_kind(src) if list_file is None and src is not None else None
    if kind == "tiff" and convert_tiff:
        return None
    if kind is not None and channel is not None:
        raise ValueError(f"{src}: `channel` converts colour frames; a camera file is read as grey frames"
                         + (" (add `copy_frames=True` to convert a TIFF stack page by page)" if kind == "tiff" else ""))
    return kind


def check_no_range(src: str | os.PathLike | None, first_frame: int, frame_count: int | None) -> None:
    """``first_frame`` / ``frame_count`` name frames of a camera file: an error for image files."""
    if (first_frame, frame_count) != (0, None):
        raise ValueError("`first_frame` / `frame_count` apply to a camera file (.cih/.cihx/.mraw, .cine, .tif, zarr); "
                         f"{src} is a folder or glob of images")


def import_camera_file(path: str | os.PathLike, out: str | os.PathLike, patterns: PatternSet,
                       layout: str = "manifest", kind: str | None = None, bit_depth: int | None = None,
                       first_frame: int = 0, frame_count: int | None = None, copy_frames: bool = False,
                       overwrite: bool = False) -> dict:
    """Capture folder ``out`` referencing the camera file ``path`` (no conversion).

    Parameters
    ----------
    path : .cih / .cihx / .mraw, .cine, multi-page .tif, or zarr store folder (array ``frames``)
    kind : ``"mraw"``, ``"cine"``, ``"tiff"`` or ``"zarr"``; default from the name (:func:`guess_kind`)
    first_frame, frame_count : file frame of the first pattern cycle; frames used (a multiple
        of ``len(patterns)``; None: the whole cycles that follow)
    copy_frames : write the frames as PNGs into ``frames/`` instead of referencing the file

    Returns the summary (``capture.json`` plus ``folder``, ``frames``, ``camera``).
    """
    out = Path(out)
    check_output(out, overwrite)
    kind = kind or guess_kind(path)
    if kind is None:
        raise ValueError(f"{path} is not a camera file fringe3d reads (.cih/.cihx/.mraw, .cine, .tif, zarr store)")
    src, frames, meta = camera_file_range(kind, path, patterns, layout, first_frame, frame_count, bit_depth)
    F = src.shape[0]
    spec = make_source(kind, src.path, out, frames.first, frames.count, file_frames=F,
                       first_image_no=getattr(src, "first_image_no", None))
    out.mkdir(parents=True, exist_ok=True)
    if copy_frames:
        meta.update(conversion="none (frames copied to PNG)", source_file={**spec, "path": str(src.path.resolve())})
        copy_to_png(frames, out)
    else:
        meta["source"] = spec
        check_header(src, meta, out / META_NAME)
    patterns.save(out / MANIFEST_NAME)
    write_json(out / META_NAME, meta, units=CAPTURE_UNITS)
    return {**meta, "folder": str(out), "frames": int(len(frames))}


def parse_size(text: str | None) -> tuple[int, int] | None:
    """``"1024x768"`` -> (1024, 768); None stays None; ``ValueError`` for anything else."""
    if text is None:
        return None
    m = re.fullmatch(r"\s*(\d+)\s*[xX]\s*(\d+)\s*", text)
    if m is None or int(m.group(1)) <= 0 or int(m.group(2)) <= 0:
        raise ValueError(f"projector size {text!r} must be WIDTHxHEIGHT in pixels, e.g. 1024x768")
    return int(m.group(1)), int(m.group(2))


def check_source(src: str | os.PathLike | None, list_file: str | os.PathLike | None) -> None:
    """Exactly one frame source: ``src`` (a folder, glob or camera file) or ``list_file``;
    ``ValueError`` saying which to drop (a source beside ``list_file`` would be ignored)."""
    if src is not None and list_file is not None:
        raise ValueError(f"give the frames either as SRC ({src}) or as `list_file` {list_file}, not both: the list "
                         "names every frame, so SRC would be ignored")
    if src is None and list_file is None:
        raise ValueError("no frames given: pass SRC (a folder, glob or camera file) or `list_file` FILE")


def described_patterns(manifest: str | os.PathLike | None, layout: ImportLayout | None = None
                       ) -> tuple[PatternSet, str]:
    """(patterns, name) of what was projected: the pattern ``manifest`` file or the layout
    ``layout.name`` (:func:`layout_patterns`); exactly one must be given. ``layout.threshold``
    sets every plan's code threshold, also of a manifest or of ``opencv-graycode``
    (:func:`fringe3d.patterns.layouts.with_threshold`)."""
    layout = layout or ImportLayout()
    if (manifest is None) == (layout.name is None):
        raise ValueError("describe what was projected with exactly one of `manifest` FILE or `layout` "
                         f"({', '.join(LAYOUTS)})")
    if manifest is None:
        assert layout.name is not None
        return layout_patterns(layout), layout.name
    ps, threshold = PatternSet.load(manifest), layout.threshold
    if threshold is not None:
        ps = with_threshold(ps, threshold)
        check_code_threshold(ps, parse_threshold(threshold))
    return ps, f"manifest {manifest}"


def load_images(src: str | os.PathLike | None, *, list_file: str | os.PathLike | None = None,
                manifest: str | os.PathLike | None = None, layout: ImportLayout | None = None,
                reading: FrameReading | None = None) -> Capture:
    """What :func:`import_images` would write, in memory and writing nothing: a
    :class:`fringe3d.io.capture.Capture` of the frames of ``src`` (a folder or glob of images,
    or ``list_file``; a camera file is read on demand as its ``source``) described by
    ``manifest`` or ``layout`` (:class:`ImportLayout`), read as ``reading`` says
    (:class:`FrameReading`). Same arguments and errors as :func:`import_images`."""
    reading = reading or FrameReading()
    channel, bit_depth, first_frame, frame_count = (reading.channel, reading.bit_depth, reading.first_frame,
                                                    reading.frame_count)
    check_source(src, list_file)
    patterns, name = described_patterns(manifest, layout)
    kind = camera_file_kind(src, list_file, channel)
    if kind is not None and src is not None:
        _, used, meta = camera_file_range(kind, src, patterns, name, first_frame, frame_count, bit_depth)
        meta["conversion"] = "none (camera file read)"
        return Capture(np.asarray(used[:len(patterns)]), patterns, meta, source=used)
    check_no_range(src, first_frame, frame_count)
    frames, meta = read_images(list_sources(src, list_file), patterns, name, channel, bit_depth)
    return Capture(frames, patterns, meta)


def import_images(src: str | os.PathLike | None, out: str | os.PathLike, *, list_file: str | os.PathLike | None = None,
                  manifest: str | os.PathLike | None = None, layout: ImportLayout | None = None,
                  reading: FrameReading | None = None, overwrite: bool = False, copy_frames: bool = False,
                  exposures: Sequence[float] | None = None) -> dict:
    """``fringe3d import``: frames of ``src`` (folder or glob) or of ``list_file`` (exactly one) described by
    a pattern ``manifest`` file or a ``layout`` (:class:`ImportLayout`, :func:`layout_patterns`)
    -> capture folder ``out`` (:func:`import_capture`), read as ``reading`` says
    (:class:`FrameReading`: colour channel, bit depth, camera-file range). A camera file ``src``
    (:func:`guess_kind`) is referenced, not converted (:func:`import_camera_file` with
    ``reading.first_frame``, ``reading.frame_count``, ``copy_frames``).

    Examples
    --------
    >>> import tempfile
    >>> from fringe3d.patterns import render_set
    >>> described = ImportLayout("phase-shift", (64, 48), steps=3, period=16)
    >>> ps = layout_patterns(described)
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     for i, img in enumerate(render_set(ps)):
    ...         ok = cv2.imwrite(f"{tmp}/shot_{i + 1}.bmp", img)
    ...     s = import_images(tmp, f"{tmp}/capture", layout=described)
    >>> s["frames"], s["bit_depth"], s["source_files"][0].endswith("shot_1.bmp")
    (3, 8, True)
    """
    reading = reading or FrameReading()
    channel, bit_depth, first_frame, frame_count = (reading.channel, reading.bit_depth, reading.first_frame,
                                                    reading.frame_count)
    check_source(src, list_file)
    patterns, name = described_patterns(manifest, layout)
    ranged = (first_frame, frame_count) != (0, None)
    kind = camera_file_kind(src, list_file, channel, convert_tiff=copy_frames and not ranged)
    if kind is not None and src is not None:
        if exposures is not None:
            raise ValueError(f"{src}: exposures: an exposure bracket is imported from image files, not from a "
                             "camera file")
        return import_camera_file(src, out, patterns, name, bit_depth=bit_depth, first_frame=first_frame,
                                  frame_count=frame_count, copy_frames=copy_frames, overwrite=overwrite)
    check_no_range(src, first_frame, frame_count)
    files = list_sources(src, list_file)
    return import_capture(files, out, patterns, name, channel=channel, bit_depth=bit_depth, overwrite=overwrite,
                          exposures=exposures)
