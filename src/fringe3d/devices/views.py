"""Multi-view capture: move the stage, capture one pattern sequence per view.

:func:`capture_views` turns (or moves) a :class:`fringe3d.devices.stage.Stage` to each position in
turn and captures the pattern sequence into ``folder/view-NN`` (a standard capture folder,
:func:`fringe3d.devices.acquire.capture_sequence`); it returns what the stage reported at each
view (its position and transform), from which the command writes ``poses.json``. A view that
loses frames stops the sequence (:class:`~fringe3d.devices.acquire.CaptureIncompleteError`): the
views after it would be captured but could not be merged without it.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .acquire import CaptureResult, capture_sequence
from .stage import Stage


def view_name(k: int) -> str:
    """``view-NN``: the folder (and poses-file) name of view ``k``."""
    return f"view-{k:02d}"


@dataclass
class ViewCapture:
    """One captured view: its ``name``, the stage ``position`` (deg or mm) and ``transform``
    (4, 4) it reported there, and the capture's :class:`~fringe3d.devices.acquire.CaptureResult`."""

    name: str
    position: float
    transform: np.ndarray
    result: CaptureResult


def stage_positions(views: int, step: float, start: float = 0.0) -> np.ndarray:
    """``start + k × step`` for ``k < views`` (degrees or mm); ValueError for fewer than 2 views or
    a step that is zero or not finite."""
    if views < 2:
        raise ValueError(f"`views` must be at least 2, got {views}")
    if not np.isfinite(step) or step == 0:
        raise ValueError(f"the stage step must be a finite non-zero number, got {step}")
    return start + step * np.arange(views)


def capture_views(projector, camera, stage: Stage, positions, sequence: dict, folder,
                  progress=None) -> list[ViewCapture]:
    """Capture one pattern sequence per stage position into ``folder/view-NN``.

    Parameters
    ----------
    projector, camera
        The open, configured devices.
    stage : Stage
        The stage (moved to each position and waited for).
    positions : sequence of float
        Stage positions in view order (degrees for a turntable).
    sequence : dict
        Keywords of :func:`fringe3d.devices.acquire.capture_sequence`: ``patterns``, ``images``
        and any of its options (``timing``, ``cycles``, ``planes``, ``extra_meta``).
    folder : path
        The multi-view output folder.
    progress : callable, optional
        Called with ``(view index, frames received in that view)``.

    Returns
    -------
    list of ViewCapture
        One per view, in order.

    Raises
    ------
    CaptureIncompleteError
        A view lost frames (the views before it are kept, complete).
    """
    folder = Path(folder)
    out = []
    for k, pos in enumerate(positions):
        name = view_name(k)
        stage.move_to(float(pos))
        meta = {**sequence.get("extra_meta", {}), "stage": {**stage.describe(), "position": float(stage.position)}}
        kw = {**sequence, "extra_meta": meta}
        res = capture_sequence(projector, camera, kw.pop("patterns"), kw.pop("images"), folder / name,
                               progress=(lambda n, k=k: progress(k, n)) if progress else None, **kw)
        out.append(ViewCapture(name, float(stage.position), np.asarray(stage.transform(), float), res))
    return out
