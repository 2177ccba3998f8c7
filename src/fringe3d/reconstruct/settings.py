"""The settings of a sequence reconstruction, grouped by concern and passed whole along the chain
(``fringe3d reconstruct`` -> :func:`fringe3d.cluster.engine.reconstruct_capture_on_dask` ->
:func:`fringe3d.reconstruct.sequence.reconstruct_sequence` -> ``prepare_sequence``).

* :class:`DecodeSettings` - what to decode and how to cut the capture into 3D frames;
* :class:`OutputSettings` - what to write;
* :class:`RunSettings` - where to run (the executor itself is injected separately,
  :mod:`fringe3d.reconstruct.executors`).
"""
from __future__ import annotations

from dataclasses import dataclass, field

from fringe3d.decode.options import DecodeOptions


@dataclass(frozen=True)
class DecodeSettings:
    """What to decode: ``options`` (:class:`~fringe3d.decode.options.DecodeOptions`: ``z_min`` mm,
    ``bit_depth``, thresholds), ``triangulation`` (``"auto"``, ``"fast"``, ``"lsq"``), ``fast``
    (allow the fused 3-step kernel), ``allow_relative`` (triangulate a wrapped or relative phase
    with a warning), and the windows: ``mode`` ``"cycle"`` or ``"window"`` with ``step`` frames
    between windows (:func:`fringe3d.reconstruct.windows.window_starts`)."""

    options: DecodeOptions = field(default_factory=DecodeOptions)
    triangulation: str = "auto"
    fast: bool = True
    allow_relative: bool = False
    mode: str = "cycle"
    step: int | None = None


@dataclass(frozen=True)
class OutputSettings:
    """What to write: ``ply`` (one PLY per 3D frame), ``store`` (the zarr point store) with its
    ``layout`` (``"auto"``, ``"xyz"``, ``"ray_depth"``), ``store_quality`` (the quality map and
    sigma_z per frame), ``codec`` (:data:`fringe3d.io.store.CODECS`; None: lz4) and ``frame_rate``
    (Hz, when known: the store's ``time`` coordinate, each 3D frame's first captured frame / rate in s)."""

    ply: bool = False
    store: bool = True
    layout: str = "auto"
    store_quality: bool = True
    codec: str | None = None
    frame_rate: float | None = None


@dataclass(frozen=True)
class RunSettings:
    """Where to run: ``backend`` ``"cpu"`` or ``"cuda"`` for the per-pixel kernels, ``progress``
    (a progress bar)."""

    backend: str = "cpu"
    progress: bool = True
