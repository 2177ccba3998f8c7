"""The ``source`` object of ``capture.json``: a capture folder that references a camera file.

Fields (checked by :func:`parse_source`)::

    "source": {
      "kind": "mraw" | "cine" | "tiff" | "zarr",   reader (fringe3d.io.frame_sources)
      "path": "../run1.cihx",             relative to the capture folder, or absolute
      "first_frame": 12,                  file frame where the first pattern cycle starts (>= 0)
      "frame_count": 3000,                frames used (a multiple of the manifest), or null: the rest
      "file_frames": 3012,                optional: frames the file held at import (checked)
      "first_image_no": -500              optional (CINE): the camera's number of file frame 0,
                                          counted from the trigger (checked)
    }

:func:`open_source_frames` opens the file and checks its header against ``capture.json``
(``bit_depth``, ``camera`` [width, height], ``frame_rate``, ``source.file_frames``,
``source.first_image_no``) and the frame range against the file; every error names the file,
the field and what was expected.
"""
from __future__ import annotations

import math
import os
from pathlib import Path

from fringe3d.io.frame_sources import SOURCE_KINDS, FrameRange, FrameSource, open_source

SOURCE_FIELDS = ("kind", "path", "first_frame", "frame_count", "file_frames", "first_image_no")


def _is_count(x, minimum: int) -> bool:
    return isinstance(x, int) and not isinstance(x, bool) and x >= minimum


def parse_source(source, where: Path) -> dict:
    """Check the ``source`` object read from ``where`` (``capture.json``); returns it with
    ``first_frame`` (default 0) and ``frame_count`` (default None) filled in."""
    if not isinstance(source, dict):
        raise ValueError(f"{where}: source must be an object with kind and path, got {source!r}")
    unknown = sorted(set(source) - set(SOURCE_FIELDS))
    if unknown:
        raise ValueError(f"{where}: unknown source field(s) {unknown}; expected {list(SOURCE_FIELDS)}")
    if source.get("kind") not in SOURCE_KINDS:
        raise ValueError(f"{where}: source.kind must be one of {list(SOURCE_KINDS)}, got {source.get('kind')!r}")
    if not isinstance(source.get("path"), str) or not source["path"]:
        raise ValueError(f"{where}: source.path must be the camera file's path (a string), "
                         f"got {source.get('path')!r}")
    out = {"first_frame": 0, "frame_count": None, **source}
    if not _is_count(out["first_frame"], 0):
        raise ValueError(f"{where}: source.first_frame must be an integer >= 0, got {out['first_frame']!r}")
    if out["frame_count"] is not None and not _is_count(out["frame_count"], 1):
        raise ValueError(f"{where}: source.frame_count must be an integer >= 1 or null, got {out['frame_count']!r}")
    if "file_frames" in out and not _is_count(out["file_frames"], 1):
        raise ValueError(f"{where}: source.file_frames must be an integer >= 1, got {out['file_frames']!r}")
    number = out.get("first_image_no")
    if "first_image_no" in out and (not isinstance(number, int) or isinstance(number, bool)):
        raise ValueError(f"{where}: source.first_image_no must be an integer (the camera's number of file frame 0), "
                         f"got {number!r}")
    return out


def source_path(folder: Path, source: dict) -> Path:
    """``source.path`` resolved against the capture folder."""
    p = Path(source["path"])
    return p if p.is_absolute() else folder / p


def check_header(src: FrameSource, meta: dict, where: Path) -> None:
    """``ValueError`` naming the file and field when the camera file's header disagrees with
    ``capture.json`` (``where``): ``bit_depth``, ``camera``, ``frame_rate``, ``source.file_frames``,
    ``source.first_image_no`` (a CINE's ``FirstImageNo``)."""
    F, H, W = src.shape
    if "camera" in meta and list(meta["camera"]) != [W, H]:
        raise ValueError(f"{src.path}: the frames are {W}x{H} pixels but {where} field camera says "
                         f"{meta['camera'][0]}x{meta['camera'][1]}; expected the file's frame size")
    bits = meta.get("bit_depth")
    native = 8 * src.dtype.itemsize
    if bits is not None and bits != src.bit_depth and not (src.bit_depth == native and bits < native):
        raise ValueError(f"{src.path}: the header says bit depth {src.bit_depth} but {where} field bit_depth "
                         f"says {bits}; expected {src.bit_depth}")
    rate = meta.get("frame_rate")
    if rate is not None and src.frame_rate is not None and not math.isclose(rate, src.frame_rate, rel_tol=1e-6):
        raise ValueError(f"{src.path}: the header says frame rate {src.frame_rate:g} Hz but {where} field "
                         f"frame_rate says {rate:g} Hz; expected {src.frame_rate:g}")
    expect = meta["source"].get("file_frames")
    if expect is not None and expect != F:
        raise ValueError(f"{src.path}: the file holds {F} frames but {where} field source.file_frames says "
                         f"{expect}; expected {F} (was the recording replaced?)")
    number, have = meta["source"].get("first_image_no"), getattr(src, "first_image_no", None)
    if number is not None and have is not None and number != have:
        raise ValueError(f"{src.path}: the header's first image number is {have} but {where} field "
                         f"source.first_image_no says {number}; expected {have} (was the recording replaced?)")


def open_source_frames(folder: str | os.PathLike, meta: dict, where: Path) -> FrameRange:
    """The frames a capture folder references: its ``source`` opened, checked against the
    header (:func:`check_header`) and cut to ``first_frame`` / ``frame_count``."""
    folder = Path(folder)
    spec = meta["source"]
    src = open_source(spec["kind"], source_path(folder, spec))
    check_header(src, meta, where)
    return FrameRange(src, spec["first_frame"], spec["frame_count"])


def make_source(kind: str, path: str | os.PathLike, folder: str | os.PathLike, first_frame: int = 0,
                frame_count: int | None = None, file_frames: int | None = None,
                first_image_no: int | None = None) -> dict:
    """The ``source`` object for ``capture.json`` in ``folder``; ``path`` is stored relative to
    the folder when both are on one drive (moving them together keeps it valid), else absolute."""
    p = Path(path).resolve()
    try:
        stored = os.path.relpath(p, Path(folder).resolve())
    except ValueError:  # another drive (Windows)
        stored = str(p)
    out: dict = {"kind": kind, "path": Path(stored).as_posix(), "first_frame": int(first_frame),
                 "frame_count": None if frame_count is None else int(frame_count)}
    if file_frames is not None:
        out["file_frames"] = int(file_frames)
    if first_image_no is not None:
        out["first_image_no"] = int(first_image_no)
    return out
