"""Capture folders: what a camera (or the simulator) recorded while the patterns were projected.

Layout::

    CAPTURE/
      manifest.json        the projected PatternSet (a copy of the pattern folder's manifest)
      frames/00000.png     captured frames in projection order, uint8 or uint16 PNG, or TIFF;
      frames/00001.png     a sequence may hold several cycles of the manifest (F = m * len)
      ...
      capture.json         optional: frame_rate (Hz), bit_depth, camera [width, height], free metadata
      truth/               optional: simulator ground truth (not read here)

Instead of ``frames/``, ``capture.json`` may hold a ``source`` object referencing a camera file
(Photron MRAW, Phantom CINE, multi-page TIFF, zarr; :mod:`fringe3d.io.capture_source`), read lazily:
:func:`open_frames` gives an array-like over it and :meth:`Capture.iter_cycles` reads one
cycle at a time.

:func:`read_capture` checks everything a decoder relies on and says exactly what is wrong;
:func:`write_capture` writes each file atomically.
"""
from __future__ import annotations

import os
import re
from collections import deque
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterable, Iterator

import numpy as np

from fringe3d.io.capture_schema import check_frame_values, validate_meta
from fringe3d.io.capture_source import open_source_frames, parse_source
from fringe3d.io.frame_sources import FrameRange
from fringe3d.io.images import IMAGE_SUFFIXES, read_image, write_image
from fringe3d.patterns.manifest import MANIFEST_NAME, PatternSet
from fringe3d.phase.frames import as_frame_stack
from fringe3d.utils.console import progress_bar
from fringe3d.utils.jsonfile import read_json, write_json
from fringe3d.utils.output_folder import check_complete
from fringe3d.utils.write_guard import guard_write

FRAMES_DIR = "frames"
META_NAME = "capture.json"
#: Units of capture.json's fields (its ``provenance``).
CAPTURE_UNITS = {"frame_rate": "Hz", "exposure": "s", "camera": "px (width, height)", "bit_depth": "bits",
                 "volume": "mm", "board_t": "mm", "board_R": "rotation matrix", "intensity": "camera counts"}
TRUTH_DIR = "truth"
_FRAME_NAME = re.compile(r"^(\d+)\.(png|tif|tiff)$", re.IGNORECASE)


@dataclass
class Capture:
    """A capture folder in memory.

    Attributes
    ----------
    frames : (F, H, W) ndarray, uint8 / uint16 (or float32 from TIFF)
        Frames in projection order; F is a multiple of ``len(patterns)``.
    patterns : PatternSet
    meta : dict
        Contents of ``capture.json`` (empty if absent).
    folder : Path or None
    source : FrameRange or None
        For a folder that references a camera file: all its frames (``first_frame`` /
        ``frame_count`` applied), read on demand; ``frames`` holds the cycles read.
    """

    frames: np.ndarray
    patterns: PatternSet
    meta: dict = field(default_factory=dict)
    folder: Path | None = None
    source: FrameRange | None = None

    def iter_cycles(self, max_cycles: int | None = None) -> Iterator[np.ndarray]:
        """Each cycle's frames ``(len(patterns), H, W)`` in turn, read from the camera file on
        demand for a referenced source (memory: one cycle), else sliced from ``frames``."""
        n = len(self.patterns)
        frames = self.source if self.source is not None else self.frames
        total = len(frames) // n
        for c in range(total if max_cycles is None else min(total, max_cycles)):
            yield np.asarray(frames[c * n:(c + 1) * n])

    @property
    def cycles(self) -> int:
        """Number of complete pattern cycles in the sequence."""
        return len(self.frames) // len(self.patterns)

    def cycle(self, i: int) -> np.ndarray:
        """Frames of cycle ``i`` ``(len(patterns), H, W)``."""
        n = len(self.patterns)
        if not 0 <= i < self.cycles:
            raise IndexError(f"cycle {i} out of range; the capture has {self.cycles} cycle(s)")
        return self.frames[i * n:(i + 1) * n]

    @property
    def bit_depth(self) -> int:
        """Camera bit depth: ``meta['bit_depth']`` or 8/16 from the frame dtype."""
        if "bit_depth" in self.meta:
            return int(self.meta["bit_depth"])
        return 8 if self.frames.dtype == np.uint8 else 16

    @property
    def truth_dir(self) -> Path | None:
        if self.folder is None:
            return None
        p = self.folder / TRUTH_DIR
        return p if p.is_dir() else None


def frame_count_error(n_frames: int, n_manifest: int) -> str | None:
    """Message if ``n_frames`` is not a positive multiple of ``n_manifest``, else None."""
    if n_manifest <= 0:
        return "the manifest lists no frames"
    if n_frames == 0:
        return f"the capture holds no frames; expected {n_manifest} (or a multiple) for the manifest"
    if n_frames % n_manifest:
        return (f"the capture holds {n_frames} frames, which is not a multiple of the manifest's "
                f"{n_manifest} frames (expected {n_manifest}, {2 * n_manifest}, ...)")
    return None


def list_frame_files(folder: str | os.PathLike) -> list[Path]:
    """Frame files of a capture in projection order, rejecting anything else in ``frames/``."""
    fdir = Path(folder) / FRAMES_DIR
    if not fdir.is_dir():
        raise FileNotFoundError(f"capture folder {folder} has no {FRAMES_DIR}/ folder with the captured frames")
    numbered = []
    for p in sorted(fdir.iterdir()):
        if p.name.startswith("."):
            continue
        m = _FRAME_NAME.match(p.name)
        if m is None:
            what = "an image in an unsupported format" if p.suffix.lower() in IMAGE_SUFFIXES else "not a frame image"
            raise ValueError(f"{p} is {what}; {FRAMES_DIR}/ may only hold numbered .png or .tif frames "
                             f"(00000.png, 00001.png, ...)")
        numbered.append((int(m.group(1)), p))
    numbered.sort()
    for expect, (num, p) in enumerate(numbered):
        if num != expect:
            raise ValueError(f"frame numbering has a gap or duplicate at {p.name}: expected frame {expect:05d}")
    return [p for _, p in numbered]


def read_meta(folder: str | os.PathLike) -> dict:
    """``capture.json`` as a dict ({} if absent); checks the known fields' types."""
    path = Path(folder) / META_NAME
    if not path.exists():
        return {}
    meta = validate_meta(read_json(path, "capture metadata"), f"capture metadata {path}")
    if meta.get("complete") is False:  # written by fringe3d capture until the last frame is in
        why = "; ".join(meta.get("problems") or []) or meta.get("interrupted") or meta.get("status", "not finished")
        raise ValueError(f"{path}: the capture is incomplete ({why}); it is not used, capture it again")
    if "source" in meta:
        meta["source"] = parse_source(meta["source"], path)
    return meta


def _read_or_error(path: Path, out: np.ndarray):
    """read_image into ``out`` (None when copied there; else the image read, whose shape or dtype
    does not fit, for the caller to name), returning the exception instead of raising (so errors
    surface in file order)."""
    try:
        img = read_image(path, out=out)
    except (ValueError, FileNotFoundError) as e:
        return e
    return None if img is out else img


def read_capture(folder: str | os.PathLike, max_cycles: int | None = None) -> Capture:
    """Read and check a capture folder.

    Parameters
    ----------
    folder : path
    max_cycles : int, optional
        Read only the first ``max_cycles`` pattern cycles.

    Returns
    -------
    Capture with ``frames`` (F, H, W) in the files' dtype. For a folder whose ``capture.json``
    references a camera file (``source``), ``frames`` holds the cycles read and ``source`` the
    whole range, read on demand (:meth:`Capture.iter_cycles`).

    Raises
    ------
    FileNotFoundError
        Missing folder, ``manifest.json``, ``frames/`` or referenced camera file.
    ValueError
        A camera file whose header disagrees with ``capture.json`` or a frame range beyond it
        (naming the file and field);
        unknown manifest fields, a frame count that is not a multiple of the manifest's length,
        frames of different shapes or dtypes, unreadable or non-image files, bad capture.json.

    Examples
    --------
    >>> import tempfile
    >>> from fringe3d.patterns import sets, render_set
    >>> ps = sets.phase_shift(16, 3, "v", width=32, height=8)
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     _ = write_capture(folder, render_set(ps), ps)
    ...     cap = read_capture(folder)
    >>> cap.frames.shape, cap.cycles, cap.meta["bit_depth"]
    ((3, 8, 32), 1, 8)
    """
    folder = Path(folder)
    if not folder.is_dir():
        raise FileNotFoundError(f"capture folder {folder} does not exist")
    check_complete(folder, "capture folder")  # first: an unfinished capture has no manifest yet
    if not (folder / MANIFEST_NAME).is_file():
        raise FileNotFoundError(f"capture folder {folder} has no {MANIFEST_NAME}; copy the pattern "
                                f"manifest there (fringe3d patterns writes it next to the PNGs)")
    patterns = PatternSet.load(folder / MANIFEST_NAME)
    meta = read_meta(folder)
    if "source" in meta:
        return _read_source_capture(folder, patterns, meta, max_cycles)
    files = list_frame_files(folder)
    msg = frame_count_error(len(files), len(patterns))
    if msg:
        raise ValueError(f"{folder}: {msg}")
    if max_cycles is not None:
        files = files[:max(1, max_cycles) * len(patterns)]
    first = read_image(files[0])
    frames = np.empty((len(files),) + first.shape, dtype=first.dtype)
    frames[0] = first
    # decoders (ours for grey PNG, OpenCV, tifffile) release the GIL: read in a few threads (a
    # grey PNG straight into its place), check in file order
    with progress_bar(f"reading {len(files)} frames", len(files), enabled=len(files) > 60) as advance, \
            ThreadPoolExecutor(max_workers=min(4, os.cpu_count() or 1)) as pool:
        advance()
        for i, (p, img) in enumerate(zip(files[1:], pool.map(_read_or_error, files[1:], frames[1:])), start=1):
            if img is None:
                advance()
                continue
            if isinstance(img, Exception):
                raise img
            if img.shape != first.shape:
                raise ValueError(f"{p} has shape {img.shape} (H, W) but {files[0].name} has {first.shape}; "
                                 f"all frames of a capture must have the same size")
            if img.dtype != first.dtype:
                raise ValueError(f"{p} is {img.dtype} but {files[0].name} is {first.dtype}; "
                                 f"all frames of a capture must have the same bit depth")
            frames[i] = img
            advance()
    if "camera" in meta and list(meta["camera"]) != [first.shape[1], first.shape[0]]:
        raise ValueError(f"{folder / META_NAME} says the camera is {meta['camera'][0]}x{meta['camera'][1]} "
                         f"but the frames are {first.shape[1]}x{first.shape[0]}")
    check_frame_values(frames, meta.get("bit_depth"), str(folder / FRAMES_DIR))
    return Capture(frames=frames, patterns=patterns, meta=meta, folder=folder)


def _read_source_capture(folder: Path, patterns: PatternSet, meta: dict, max_cycles: int | None) -> Capture:
    """:func:`read_capture` for a folder whose ``capture.json`` references a camera file."""
    source = open_source_frames(folder, meta, folder / META_NAME)
    msg = frame_count_error(len(source), len(patterns))
    if msg:
        raise ValueError(f"{folder / META_NAME}: source {source.source.path} frames {source.first}.."
                         f"{source.first + source.count - 1}: {msg}")
    n = len(source) if max_cycles is None else min(len(source), max(1, max_cycles) * len(patterns))
    return Capture(frames=source.read(0, n), patterns=patterns, meta=meta, folder=folder, source=source)


def open_frames(folder: str | os.PathLike, limit: int | None = None):
    """The frames of a capture folder as an array-like, read on demand: a :class:`FrameRange`
    over the referenced camera file, or None for a folder with ``frames/`` (read those with
    the file-based readers). ``limit`` keeps only the first frames."""
    folder = Path(folder)
    meta = read_meta(folder)
    if "source" not in meta:
        return None
    frames = open_source_frames(folder, meta, folder / META_NAME)
    if limit is not None and limit < len(frames):
        frames = FrameRange(frames.source, frames.first, limit)
    return frames


def write_capture(folder: str | os.PathLike, frames: np.ndarray, patterns: PatternSet, meta: dict | None = None,
                  fmt: str = "png") -> Path:
    """Write a capture folder (each file atomically): frames, manifest copy, capture.json.

    Parameters
    ----------
    folder : str or os.PathLike
        The capture folder (created; an older capture's frames and metadata there are replaced).
    frames : (F, H, W) uint8 or uint16 (PNG) or any dtype (``fmt="tif"``)
        F must be a multiple of ``len(patterns)``.
    patterns : PatternSet
        The projected patterns, in frame order; its manifest is copied into the folder.
    meta : dict, optional
        Extra metadata; ``camera`` and ``bit_depth`` are filled in when missing.
    fmt : ``"png"`` or ``"tif"``
        Frame file format.

    Returns
    -------
    Path
        The capture folder.
    """
    frames = as_frame_stack(frames)
    if fmt == "png" and frames.dtype not in (np.uint8, np.uint16):   # refused before any file is touched
        raise ValueError(f"PNG frames must be uint8 or uint16, got {frames.dtype}; use fmt='tif'")
    return write_capture_frames(folder, iter(frames), len(frames), patterns, meta, fmt)


#: Frame files being written at once by :func:`write_capture_frames` (and frames held for them).
WRITE_THREADS = 4


def write_capture_frames(folder: str | os.PathLike, frames: Iterable[np.ndarray], count: int, patterns: PatternSet,
                         meta: dict | None = None, fmt: str = "png", progress: bool | None = None,
                         start: int = 0) -> Path:
    """:func:`write_capture` from an iterable of ``count`` frames (H, W), each written as it comes.

    ``start`` (resuming): frames ``0 .. start - 1`` are already in ``frames/`` (written by an
    interrupted run of the same command) and ``frames`` yields ``start .. count - 1`` only.

    At most :data:`WRITE_THREADS` frames are held (being written) at any time, so a take of any
    length is written in bounded memory. The manifest and ``capture.json`` are written after the
    last frame (an older capture's are removed first), so a write that fails part way leaves a
    folder no step reads as a capture. ``progress``: a progress bar (default: when ``count > 60``).
    """
    folder = Path(folder)
    msg = frame_count_error(count, len(patterns))
    if msg:
        raise ValueError(msg)
    if fmt not in ("png", "tif"):
        raise ValueError(f"capture frame format must be 'png' or 'tif', got {fmt!r}")
    fdir = folder / FRAMES_DIR
    fdir.mkdir(parents=True, exist_ok=True)
    for done in (folder / META_NAME, folder / MANIFEST_NAME):  # written last: the capture's "complete" mark,
        if done.exists():  # so an interrupted write never leaves new frames under an older manifest
            guard_write(done).unlink()
    for stale in fdir.iterdir():  # an older capture must not leave frames behind
        m = _FRAME_NAME.match(stale.name)
        if m and (int(m.group(1)) >= count or stale.suffix.lower() != f".{fmt}"):
            guard_write(stale).unlink()
    if not 0 <= start < count:
        raise ValueError(f"start must be in [0, {count}), got {start}")
    first: np.ndarray | None = None
    n = start
    pending: deque = deque()
    with progress_bar(f"writing {count - start} frames", count - start,
                      enabled=count > 60 if progress is None else progress) as advance, \
            ThreadPoolExecutor(max_workers=min(WRITE_THREADS, os.cpu_count() or 1)) as pool:
        for img in frames:
            img = np.asarray(img)
            if first is None:
                first = img
            if img.ndim != 2 or img.shape != first.shape or img.dtype != first.dtype:
                raise ValueError(f"frame {n} is {img.dtype} {img.shape}; expected every frame a 2D "
                                 f"{first.dtype} image of shape {first.shape} like frame {start}")
            if fmt == "png" and img.dtype not in (np.uint8, np.uint16):
                raise ValueError(f"PNG frames must be uint8 or uint16, got {img.dtype}; use fmt='tif'")
            if n >= count:
                raise ValueError(f"more than the {count} frames announced")
            if len(pending) >= WRITE_THREADS:
                pending.popleft().result()
                advance()
            unit = "camera counts" if img.dtype.kind in "ui" else "camera intensity (float, as given)"
            pending.append(pool.submit(write_image, fdir / f"{n:05d}.{fmt}", img, f"camera frame {n}", unit))
            n += 1
        while pending:
            pending.popleft().result()
            advance()
    if n != count:
        raise ValueError(f"{n} frames written; expected {count}")
    assert first is not None
    patterns.save(folder / MANIFEST_NAME)
    meta = dict(meta or {})
    meta.setdefault("camera", [int(first.shape[1]), int(first.shape[0])])
    if first.dtype in (np.uint8, np.uint16):
        meta.setdefault("bit_depth", 8 if first.dtype == np.uint8 else 16)
    write_json(folder / META_NAME, meta, units=CAPTURE_UNITS)
    return folder
