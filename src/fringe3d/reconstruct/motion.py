"""Motion-robust absolute 3D from a fast capture (ch. 5): hybrid FTP + PSP vs two-frequency PSP.

The dissertation's sequence (ch. 5.3) repeats six binary patterns at 1,500 Hz: three
phase-shifted squared-binary fringes of period ``T = 18`` (``I_h1..I_h3``) then three
phase-shifted dithered fringes of period ``T_l = 228`` (``I_l1..I_l3``), made sinusoidal by
projector defocus. Two ways to measure one cycle:

* enhanced two-frequency PSP (Hyun & Zhang, the ``"two_frequency_geometric"`` unwrapper):
  all six frames; objects that move between frames corrupt it (motion-induced error);
* the hybrid framework (Eq. 5.13–5.15, the ``"hybrid"`` unwrapper): the last four frames,
  ``I_h3`` by FTP + spatial unwrapping, ``I_l1..I_l3`` only to pick each object's fringe order.

:func:`dissertation_sequence` builds the six-frame pattern set, :func:`hybrid_view` the
four-frame view the hybrid method reads, and :func:`measure` runs the plan's decoding method
(:data:`fringe3d.decode.METHODS`) on one cycle and triangulates it.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from fringe3d.decode.context import DecodeContext
from fringe3d.decode.methods import run_method
from fringe3d.decode.options import DecodeOptions
from fringe3d.optics.rig import Rig
from fringe3d.patterns.manifest import DirectionPlan, PatternSet
from fringe3d.patterns.sets import phase_shift
from fringe3d.phase.quality import default_min_modulation
from fringe3d.reconstruct.triangulate import Triangulator

#: Ch. 5.3: squared binary T = 18 (high), Bayer-dithered T = 228 (low), 1,500 Hz.
HIGH_PERIOD = 18.0
LOW_PERIOD = 228.0
FRAME_RATE_HZ = 1500.0


def dissertation_sequence(width: int, height: int, high_period: float = HIGH_PERIOD,
                          low_period: float = LOW_PERIOD, direction: str = "v",
                          high_kind: str = "square", low_kind: str = "bayer") -> PatternSet:
    """The six-frame cycle of ch. 5.3: 3-step high frequency, then 3-step low frequency.

    Built from :func:`fringe3d.patterns.sets.phase_shift`; the plan is
    ``"two_frequency_geometric"`` with periods ``(T, T_l)``. 1-bit patterns by default.

    Parameters
    ----------
    width, height : int
        Projector resolution (px).
    high_period, low_period : float
        Fringe periods ``T`` and ``T_l`` (projector px), default 18 and 228.
    direction : str
        Fringe direction (``"v"``: vertical stripes).
    high_kind, low_kind : str
        Pattern kinds of the high- and low-frequency frames (default squared binary and
        Bayer-dithered), as in :func:`fringe3d.patterns.sets.phase_shift`.

    Returns
    -------
    PatternSet
        Six frames, one direction plan.
    """
    hi = phase_shift(high_period, 3, direction, kind=high_kind, width=width, height=height)
    lo = phase_shift(low_period, 3, direction, kind=low_kind, width=width, height=height)
    ps = hi.concat(lo, name=f"ch5-two-frequency-{high_period:g}-{low_period:g}-{direction}")
    plan = DirectionPlan(direction, hi.plans[0].angle, "two_frequency_geometric",
                         (float(high_period), float(low_period)), {"phase": "psp"})
    return replace(ps, plans=(plan,))


def hybrid_view(ps: PatternSet) -> tuple[PatternSet, list[int]]:
    """The hybrid method's four frames of a six-frame cycle: the LAST high-frequency frame
    (a one-frame FTP group keeping its phase shift) and the three low-frequency frames.

    Parameters
    ----------
    ps : PatternSet
        A one-direction, two-period (high, low) six-frame cycle, e.g. from
        :func:`dissertation_sequence`.

    Returns
    -------
    view : PatternSet
        The four frames with a ``"hybrid"`` plan.
    indices : list of int
        Their frame indices into the cycle.
    """
    if len(ps.plans) != 1 or len(ps.plans[0].periods) != 2:
        raise ValueError("hybrid_view needs a one-direction, two-period (high, low) pattern set, "
                         f"got plans {[(p.direction, p.periods) for p in ps.plans]}")
    plan = ps.plans[0]
    high, low = sorted(plan.periods)
    hi_idx = [i for i, f in enumerate(ps.frames) if f.role == "phase" and f.period == high]
    lo_idx = [i for i, f in enumerate(ps.frames) if f.role == "phase" and f.period == low]
    if not hi_idx or len(lo_idx) < 3:
        raise ValueError(f"pattern set {ps.name!r} lacks a high-frequency frame or 3 low-frequency frames")
    last = hi_idx[-1]
    f = ps.frames[last]
    single = replace(f, step=0, steps=1)
    frames = (single,) + tuple(ps.frames[i] for i in lo_idx)
    new_plan = DirectionPlan(plan.direction, plan.angle, "hybrid", (high, low), {"phase": "ftp+psp"})
    return (PatternSet(ps.width, ps.height, frames, (new_plan,), ps.bit_depth, ps.name + "-hybrid-view"),
            [last] + lo_idx)


@dataclass
class Measurement:
    """One 3D frame: absolute phase (H, W) float32 rad of period ``period``, validity mask,
    points (H, W, 3) float32 mm (NaN invalid), and, for object-wise methods (hybrid), the
    object ``labels`` (H, W) int and each object's fringe-order shift ``object_orders``
    (label -> k_s, Eq. 5.14)."""

    phase: np.ndarray
    mask: np.ndarray
    points: np.ndarray
    period: float
    labels: np.ndarray | None = None
    object_orders: dict[int, int] | None = None


def measure(frames: np.ndarray, ps: PatternSet, rig: Rig, options: DecodeOptions) -> Measurement:
    """Decode one cycle with the plan's decoding method and triangulate it.

    Parameters
    ----------
    frames : (F, H, W) uint8/uint16/float
        The cycle's frames in the order of ``ps``.
    ps : PatternSet
        One direction; its plan's ``method`` selects the decoding method (``"hybrid"``,
        ``"two_frequency_geometric"``, ``"histogram"``...).
    rig : fringe3d.optics.Rig
    options : DecodeOptions
        ``z_min`` (nearest depth of the measurement volume, mm, for the geometric constraint)
        and the method's options (e.g. ``erode``, ``min_modulation``; the latter defaults to
        2 % of the frames' full scale).

    Returns
    -------
    Measurement
        Absolute phase (rad), mask, points (mm) and period (px); labels and object orders for
        object-wise methods.
    """
    frames = np.asarray(frames)
    if frames.ndim != 3 or frames.shape[0] != len(ps):
        raise ValueError(f"expected {len(ps)} frames of shape (H, W) for pattern set {ps.name!r}, "
                         f"got an array of shape {frames.shape}")
    if len(ps.plans) != 1:
        raise ValueError(f"measure() takes a one-direction pattern set, got {len(ps.plans)} plans")
    plan = ps.plans[0]
    min_mod = options.min_modulation
    if min_mod is None:
        min_mod = default_min_modulation(frames, options.bit_depth)
    ctx = DecodeContext(frames=frames, patterns=ps, direction=plan.direction, plan=plan, rig=rig, options=options,
                        min_modulation=min_mod)
    out = run_method(ctx)
    period = float(min(plan.periods) if out.period is None else out.period)
    tri = Triangulator(rig, angle=plan.angle, warn_distortion=False)
    points = tri.points_from_phase(np.where(out.mask, out.phase, np.nan), period, out.mask)
    return Measurement(np.asarray(out.phase, np.float32), np.asarray(out.mask, bool), points, period,
                       labels=out.labels, object_orders=out.object_orders)


__all__ = ["HIGH_PERIOD", "LOW_PERIOD", "FRAME_RATE_HZ", "dissertation_sequence", "hybrid_view",
           "measure", "Measurement"]
