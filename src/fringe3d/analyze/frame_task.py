"""The per-frame work of a strain run as one picklable object, for any frame scheduler.

Given the reference frame's :class:`~fringe3d.analyze.strain.WingReference` of every wing and
every frame's anchors, the 3D frames of a sequence are independent (Eq. 6.9–6.21 use nothing but
the reference and the frame itself). :class:`StrainFrameTask` is that work: called with a frame
index it reads the frame from the sequence's PATH and returns its
:class:`~fringe3d.analyze.strain.WingFrame` per wing. It holds no open file, so it can be sent to
other processes (dask.distributed workers, :mod:`fringe3d.cluster.strain_frames`): each opens the
sequence itself, lazily and once, from a path it shares with the client.
"""
from __future__ import annotations

import threading
from dataclasses import dataclass, field

import numpy as np

from fringe3d.io.point_sequence import PointSequence, read_point_sequence

from .strain import WingFrame, WingReference, wing_frame


@dataclass(eq=False)
class StrainFrameTask:
    """``task(f)`` → the ``list[WingFrame]`` (one per wing) of 3D frame ``f``.

    Parameters
    ----------
    sequence : str
        The point sequence's path (:func:`~fringe3d.io.point_sequence.read_point_sequence`),
        absolute so that other processes find it.
    reference : int
        Index of the reference frame (its results come from ``refs`` alone; it is not read).
    refs : tuple of WingReference
        The W wings' references (reference point map (H, W, 3) mm, distance maps, local shapes).
    anchors : ndarray, shape (F, W, 2, 2)
        Every frame's anchors per wing, px.

    Only these four fields are pickled; the opened sequence is not (a process that unpickles
    the task opens it on its first call and keeps it for the task's life).
    """

    sequence: str
    reference: int
    refs: tuple[WingReference, ...]
    anchors: np.ndarray
    _seq: PointSequence | None = field(default=None, repr=False)
    _lock: threading.Lock = field(default_factory=threading.Lock, repr=False)

    def __getstate__(self) -> dict:
        return {"sequence": self.sequence, "reference": self.reference, "refs": self.refs, "anchors": self.anchors}

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state, _seq=None, _lock=threading.Lock())

    def frames(self) -> PointSequence:
        """The sequence, opened on first use (once per process, thread-safe)."""
        with self._lock:
            if self._seq is None:
                self._seq = read_point_sequence(self.sequence)
            return self._seq

    def __call__(self, f: int) -> list[WingFrame]:
        raw = None if f == self.reference else self.frames()[f]  # read (checked, float64) when processed
        return [wing_frame(r, raw, self.anchors[f, w], f) for w, r in enumerate(self.refs)]
