"""Frame rate and end-to-end latency of the frames a live view showed.

The latency of a 3D frame is the time from the arrival of its cycle's last camera frame on the
host to the moment its points were handed to the viewer (both ``time.monotonic()``, s). The
frame rate is the number of 3D frames shown per second between the first and the last shown.
:meth:`LiveStats.summary` gives the figures the page shows and the command's JSON summary
prints, rounded once, in one place, so both show the same numbers.
"""
from __future__ import annotations

import numpy as np

#: Decimals of the figures (frames/s and ms) shown and printed.
DECIMALS = 1


class LiveStats:
    """Counts and times of a live run (module docstring)."""

    def __init__(self) -> None:
        self.latencies: list[float] = []
        self.sent: list[float] = []
        self.points: list[int] = []
        self.arrived = 0
        self.skipped = 0
        self.empty = 0
        self.warm_up = 0

    def shown(self, arrival: float, sent: float, points: int) -> None:
        """Record one 3D frame handed to the viewer.

        Parameters
        ----------
        arrival : float
            Host time its cycle's last frame arrived (s).
        sent : float
            Host time its points were handed to the viewer (s).
        points : int
            Points sent.
        """
        self.latencies.append(sent - arrival)
        self.sent.append(sent)
        self.points.append(int(points))

    @property
    def frames_shown(self) -> int:
        """3D frames handed to the viewer so far."""
        return len(self.sent)

    def fps(self) -> float:
        """3D frames shown per second (0 before the second frame).

        Returns
        -------
        float
            ``(shown - 1) / (last - first)`` over the shown frames' send times.
        """
        if len(self.sent) < 2 or self.sent[-1] <= self.sent[0]:
            return 0.0
        return (len(self.sent) - 1) / (self.sent[-1] - self.sent[0])

    def summary(self) -> dict:
        """The run's figures, rounded as shown.

        Returns
        -------
        dict
            ``frames_shown``, ``fps``, ``latency_ms`` (``median``, ``p95``, ``max``),
            ``cycles_arrived``, ``cycles_skipped`` (arrived while an older one was being
            reconstructed, while the page was still drawing, or while paused), ``warm_up_cycles``
            (the first, reconstructed while the kernels load, and those that arrived meanwhile:
            not shown), ``empty_cycles`` and ``points_median``.
        """
        lat = np.asarray(self.latencies, float) * 1e3
        r = DECIMALS
        return {"frames_shown": self.frames_shown, "fps": round(self.fps(), r),
                "latency_ms": {"median": round(float(np.median(lat)), r) if lat.size else None,
                               "p95": round(float(np.percentile(lat, 95)), r) if lat.size else None,
                               "max": round(float(lat.max()), r) if lat.size else None},
                "cycles_arrived": self.arrived, "cycles_skipped": self.skipped, "warm_up_cycles": self.warm_up,
                "empty_cycles": self.empty,
                "points_median": int(np.median(self.points)) if self.points else 0}


def shown_text(value: float | None) -> str:
    """A figure as the page shows it (``-`` before there is one).

    Parameters
    ----------
    value : float or None
        The figure, already rounded by :meth:`LiveStats.summary`.

    Returns
    -------
    str
        ``f"{value:.1f}"`` or ``"-"``.
    """
    return "-" if value is None else f"{value:.{DECIMALS}f}"
