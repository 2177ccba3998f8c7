"""Record cycles from a live view into a capture folder the other commands read.

:class:`Recording` collects the raw frames of the next ``cycles`` pattern cycles the live
view receives; :func:`write_recording` writes them as a standard capture folder
(:mod:`fringe3d.io.capture`: ``frames/``, ``manifest.json``, ``capture.json``; ``rig.json``
when the rig is known) through :func:`fringe3d.utils.output_folder.open_output`: a non-empty
folder is refused unless ``overwrite``, nothing is written outside it, and its
``fringe3d.json`` marks it complete last. ``fringe3d decode`` and ``fringe3d reconstruct``
then read it like any capture. A live run that stops before every cycle asked for arrived
writes the cycles it has (``capture.json`` field ``live.cycles`` says how many).
"""
from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from fringe3d.io.capture import write_capture
from fringe3d.optics.rig import Rig
from fringe3d.patterns.manifest import PatternSet
from fringe3d.utils.output_folder import open_output


@dataclass
class Recording:
    """A recording in progress: ``folder`` to write, ``cycles`` to collect, the ``patterns`` they
    show, and the frames collected so far (``frames``, one (n, H, W) array per cycle, with the
    camera frame id of each cycle's first frame in ``first_ids``)."""

    folder: Path
    cycles: int
    patterns: PatternSet
    frames: list = field(default_factory=list)
    first_ids: list = field(default_factory=list)

    def add(self, frames: np.ndarray, first_id: int) -> bool:
        """Keep one cycle's frames.

        Parameters
        ----------
        frames : (n, H, W) ndarray
            The cycle, in manifest order.
        first_id : int
            The camera frame id of its first frame.

        Returns
        -------
        bool
            True once ``cycles`` cycles are held.
        """
        if len(self.frames) < self.cycles:
            self.frames.append(np.array(frames, copy=True))
            self.first_ids.append(int(first_id))
        return self.done

    @property
    def done(self) -> bool:
        """Whether every cycle asked for is held."""
        return len(self.frames) >= self.cycles


def write_recording(rec: Recording, meta: dict, rig: Rig | None = None, overwrite: bool = False) -> dict:
    """Write a finished recording as a capture folder.

    Parameters
    ----------
    rec : Recording
        The cycles collected (at least one).
    meta : dict
        ``capture.json`` fields (camera description, frame rate, bit depth, ...).
    rig : Rig, optional
        Written as ``rig.json`` beside the capture (the virtual rig's, or a calibration's).
    overwrite : bool
        Replace a non-empty folder (refused otherwise).

    Returns
    -------
    dict
        ``folder``, ``frames`` and ``cycles`` written.
    """
    if not rec.frames:
        raise ValueError(f"nothing to record into {rec.folder}: no cycle arrived")
    frames = np.concatenate(rec.frames)
    meta = {**meta, "live": {"cycles": len(rec.frames), "first_frame_ids": rec.first_ids}}
    with open_output(os.fspath(rec.folder), overwrite=overwrite, options={"live": True}) as out:
        write_capture(out.path, frames, rec.patterns, meta=meta)
        if rig is not None:
            rig.save(out.path / "rig.json")
    return {"folder": str(rec.folder), "frames": int(len(frames)), "cycles": len(rec.frames)}
