"""Exposure bracketing on the virtual rig: one full pattern cycle per exposure time.

A bracket of ``E`` exposure times renders the capture ``E`` times with ``RenderSettings.exposure``
set to each (the signal scales with ``exposure * frame_rate``, :mod:`fringe3d.sim.radiometry`);
exposure ``e`` draws its noise with seed ``settings.seed + BRACKET_SEED_STEP * e`` so the
exposures' noise is independent. The frames are stacked exposure-major, the layout of a
bracketed capture folder (``capture.json`` field ``exposures``) that
:func:`fringe3d.phase.exposure_fusion.fuse_exposures` fuses.
"""
from __future__ import annotations

import math

import numpy as np

from fringe3d.optics import Rig
from fringe3d.patterns.manifest import PatternSet

from .render import render
from .scene import Scene
from .settings import RenderSettings
from .truth import Truth

BRACKET_SEED_STEP = 7919


def check_exposures(exposures, frame_rate: float, where: str = "exposures") -> tuple[float, ...]:
    """The bracket as a tuple of exposure times (s): each finite, > 0 and at most the frame period
    ``1 / frame_rate``, no repeats; ``ValueError`` naming ``where`` otherwise."""
    ex = tuple(float(e) for e in exposures)
    if not ex:
        raise ValueError(f"{where}: give at least one exposure time (s)")
    period = 1.0 / frame_rate
    bad = [e for e in ex if not (math.isfinite(e) and 0 < e <= period * (1 + 1e-9))]
    if bad:
        raise ValueError(f"{where}: exposure times must be in (0, {period:g}] s (the frame period at "
                         f"{frame_rate:g} Hz), got {bad}")
    if len(set(ex)) != len(ex):
        raise ValueError(f"{where}: repeated exposure time in {list(ex)}")
    return ex


def render_bracket(scene: Scene, rig: Rig, patterns: PatternSet, settings: RenderSettings, exposures,
                   progress: bool = False) -> tuple[np.ndarray, Truth]:
    """Render one cycle of ``patterns`` per exposure time.

    Returns
    -------
    stacks : (E, F, H, W) the frames' dtype
    truth : Truth
        Of the (static) scene, the same for every exposure.
    """
    ex = check_exposures(exposures, settings.frame_rate)
    stacks, truth = [], None
    for e, t in enumerate(ex):
        s = settings.replace(exposure=t, seed=settings.seed + BRACKET_SEED_STEP * e)
        frames, tr = render(scene, rig, patterns, s, progress=progress)
        stacks.append(frames)
        truth = truth or tr
    assert truth is not None
    return np.stack(stacks), truth


class BracketStream:
    """The frames of a bracketed capture, one :class:`~fringe3d.sim.render.RenderStream` per exposure
    chained exposure-major (frame ``e * F + k`` is pattern frame ``k`` at exposure ``e``), with the
    interface :func:`fringe3d.sim.simulate.simulate_capture` writes from (static scenes only)."""

    def __init__(self, streams: list):
        if any(st.moving for st in streams):
            raise ValueError("exposures: an exposure bracket needs a static scene (a moving scene changes "
                             "between the exposures, so no pixel's cycles describe the same point)")
        self.streams, self.moving = streams, False
        first = streams[0]
        self.times, self.dirs_info, self.meta = first.times, first.dirs_info, first.meta
        self.skip = 0

    def __len__(self) -> int:
        return sum(len(st) for st in self.streams)

    def __iter__(self):
        base = 0
        for st in self.streams:
            st.skip = min(max(self.skip - base, 0), len(st))
            for k, img, ft, t in st:
                yield base + k, img, ft, t
            base += len(st)
