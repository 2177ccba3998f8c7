"""A pattern folder: the frames of a :class:`~fringe3d.patterns.manifest.PatternSet` as 8-bit PNGs
``00000.png ...`` (Eq. 2.1-2.2 rendered on the projector grid) plus ``manifest.json``, ready
for a projector (``fringe3d patterns``)."""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from fringe3d.patterns.gamma import precompensate
from fringe3d.patterns.manifest import PatternSet
from fringe3d.patterns.render import render_frame
from fringe3d.radiometry import ResponseLUT, predistort
from fringe3d.utils.console import progress_bar
from fringe3d.utils.write_guard import guard_write

from .images import read_image, write_image
from .packed_patterns import read_packed


def write_pattern_folder(ps: PatternSet, out: Path, gamma: float | None = None, response: ResponseLUT | None = None,
                         **render_options) -> list[Path]:
    """Render ``ps`` and write ``out/00000.png ...`` plus ``out/manifest.json`` (atomically).

    ``gamma``: pre-compensate the 8-bit frames for a projector of that gamma
    (:func:`fringe3d.patterns.gamma.precompensate`); ``response``: for a projector of that
    measured response table (:func:`fringe3d.radiometry.predistort`).
    """
    out.mkdir(parents=True, exist_ok=True)
    for stale in out.glob("*.png"):  # a longer, older set must not leave frames behind
        if re.fullmatch(r"\d{5}\.png", stale.name) and int(stale.stem) >= len(ps):
            guard_write(stale).unlink()
    paths = []
    with progress_bar(f"writing {len(ps)} patterns", len(ps), enabled=len(ps) > 4) as advance:
        for i, spec in enumerate(ps.frames):
            img = render_frame(spec, ps.width, ps.height, **render_options)
            img8 = ((img >= 0.5) * 255 if ps.bit_depth == 1 else (img * 255.0).round()).astype("uint8")
            if gamma is not None:
                img8 = precompensate(img, gamma)
            elif response is not None:
                img8 = predistort(img, response)
            paths.append(write_image(out / f"{i:05d}.png", img8))
            advance()
    ps.save(out / "manifest.json")
    return paths


def read_pattern_folder(folder: Path) -> tuple[PatternSet, list[np.ndarray], tuple[list[np.ndarray], list[int]] | None]:
    """Read a pattern folder written by :func:`write_pattern_folder`, checking every frame.

    Parameters
    ----------
    folder : Path
        The pattern folder: ``manifest.json`` plus ``00000.png ...``.

    Returns
    -------
    patterns : PatternSet
        The manifest.
    images : list of ndarray
        One uint8 ``(height, width)`` image per frame of the manifest, in manifest order.
    packed : tuple or None
        The packed bit-plane frames ``(images, planes)``
        (:func:`fringe3d.io.packed_patterns.read_packed`), or None when the folder has none.

    Raises
    ------
    FileNotFoundError
        The folder or one of the frames the manifest lists is missing.
    ValueError
        A frame is not an 8-bit image of the manifest's size.
    """
    folder = Path(folder)
    if not folder.is_dir():
        raise FileNotFoundError(f"pattern folder {folder} does not exist; write one with fringe3d patterns -o {folder}")
    ps = PatternSet.load(folder)
    images = []
    for i in range(len(ps)):
        p = folder / f"{i:05d}.png"
        if not p.is_file():
            raise FileNotFoundError(f"pattern folder {folder} lacks {p.name}: the manifest lists {len(ps)} frames")
        img = read_image(p)
        if img.dtype != np.uint8 or img.shape != (ps.height, ps.width):
            raise ValueError(f"{p} is {img.shape[1]}x{img.shape[0]} {img.dtype}; the manifest says "
                             f"{ps.width}x{ps.height} 8-bit")
        images.append(img)
    return ps, images, read_packed(folder)
