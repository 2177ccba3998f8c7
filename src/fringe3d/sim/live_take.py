"""The virtual rig's live take: a moving scene rendered once, for a camera to replay in a loop.

``fringe3d live`` with the virtual camera shows a rendered moving scene frame by frame as a
camera would deliver it (:class:`fringe3d.live.replay.ReplayCamera`). :func:`render_take`
renders it: ``cycles`` pattern cycles of :func:`bouncing_ball` (or any scene) at the camera's
frame rate, with the per-frame ground truth. The ball's motion closes on itself over the take
(it leaves its start, turns back and arrives where it began, spinning one full turn), so the
replayed loop has no jump.

:data:`LIVE_PATTERNS` are the pattern sets a live view offers: ``3-step`` (one direction of
three phase-shifted fringes, unwrapped by the geometric constraint from the scene's nearest
depth: the fused 3-step kernel, the fastest path), and the named sets of
:func:`fringe3d.sim.simulate.make_patterns` (the decode path).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fringe3d.patterns import sets
from fringe3d.patterns.manifest import PatternSet

from . import presets as _presets
from .motion import RigidMotion
from .presets import Preset
from .primitives import Plane, Sphere
from .render import render
from .scene import Scene
from .simulate import PATTERN_NAMES, make_patterns
from .textures import Checker
from .truth import Truth

#: The fast live pattern set: three phase-shifted frames, geometric unwrapping.
THREE_STEP = "3-step"
#: Pattern sets a live view offers (:func:`live_patterns`).
LIVE_PATTERNS = (THREE_STEP,) + PATTERN_NAMES
#: Depth (mm) left in front of the scene's nearest point for the geometric constraint's z_min.
Z_MIN_MARGIN = 5.0


def live_patterns(name: str, preset: Preset) -> tuple[PatternSet, str | None]:
    """A live pattern set for ``preset``'s projector, and the unwrapping method it needs.

    Parameters
    ----------
    name : str
        One of :data:`LIVE_PATTERNS`.
    preset : Preset
        The rig whose projector shows it.

    Returns
    -------
    patterns : PatternSet
        The set.
    method : str or None
        ``"geometric"`` for ``3-step`` (one fringe period per eighth of the projector width),
        None (the manifest's own) otherwise.
    """
    proj = preset.rig.projector
    if name == THREE_STEP:
        return sets.phase_shift(round(proj.width / 8), 3, "v", width=proj.width, height=proj.height), "geometric"
    if name not in LIVE_PATTERNS:
        raise ValueError(f"unknown live pattern set {name!r}; expected one of: {', '.join(LIVE_PATTERNS)}")
    return make_patterns(name, proj.width, proj.height), None


def bouncing_ball(preset: Preset, duration: float, cycles: int) -> Scene:
    """A checker-printed ball swinging sideways and back in ``duration`` s, before a wall.

    Parameters
    ----------
    preset : Preset
        The rig: the ball (radius a quarter of the smaller lateral extent of the working volume)
        sits at the volume's centre, the wall 20 mm behind it.
    duration : float
        Seconds the loop lasts: the ball is back at its start, turned once, after it.
    cycles : int
        Pattern cycles in the loop: the ball travels 2 mm per cycle on average (at most 15% of
        the volume's width either way), so one cycle blurs little.

    Returns
    -------
    Scene
        The moving ball and the static wall.
    """
    c, size = preset.center, preset.size
    view = preset.rig.camera.R[2]
    right = preset.rig.camera.R[0]
    r = 0.25 * float(min(size[0], size[1]))
    amp = min(0.15 * float(size[0]), 0.5 * cycles)  # path 4 * amp = 2 mm per cycle
    d = float(duration)
    # x(t) = -amp + v t - a t^2 / 2 along `right`: back at -amp at t = d, +amp at d / 2
    motion = RigidMotion(velocity=right * (8 * amp / d), acceleration=-right * (16 * amp / d ** 2),
                         angular_velocity=-np.asarray(preset.rig.camera.R[1]) * (2 * np.pi / d))
    ball = Sphere(c - right * amp, r, albedo=0.9, texture=Checker(period=np.pi / 6, contrast=0.4), motion=motion)
    return Scene([ball, Plane(c + view * (r + 20.0), -view, albedo=0.8)], name="bouncing-ball")


@dataclass(frozen=True)
class Take:
    """A rendered live take: ``frames`` (F, H, W) camera counts, ``truth`` per frame, the
    ``patterns`` shown (F is a multiple of their length), the unwrapping ``method`` they need
    (or None), ``z_min`` (mm, the scene's nearest depth less :data:`Z_MIN_MARGIN`), the
    ``preset`` and the ``frame_rate`` (Hz) it was rendered at."""

    frames: np.ndarray
    truth: Truth
    patterns: PatternSet
    method: str | None
    z_min: float
    preset: Preset
    frame_rate: float


def render_take(preset: str | Preset, patterns: str, cycles: int, frame_rate: float, seed: int = 0,
                scene: Scene | None = None) -> Take:
    """Render ``cycles`` cycles of a live pattern set on a moving scene.

    Parameters
    ----------
    preset : str or Preset
        The rig (:mod:`fringe3d.sim.presets`).
    patterns : str
        A name in :data:`LIVE_PATTERNS`.
    cycles : int
        Pattern cycles to render (the loop's length).
    frame_rate : float
        The camera's frame rate (Hz): frame ``k`` is exposed at ``k / frame_rate``.
    seed : int
        Noise seed.
    scene : Scene, optional
        The scene; :func:`bouncing_ball` over the take's duration by default.

    Returns
    -------
    Take
        Frames, truth and what reconstructing them needs.
    """
    p = _presets.get(preset)
    if int(cycles) < 1:
        raise ValueError(f"cycles must be at least 1, got {cycles}")
    ps, method = live_patterns(patterns, p)
    n_frames = int(cycles) * len(ps)
    s = p.settings.replace(frame_rate=float(frame_rate), seed=int(seed))
    if scene is None:
        scene = bouncing_ball(p, n_frames / float(frame_rate), int(cycles))
    frames, truth = render(scene, p.rig, ps, s, times=np.arange(n_frames) / float(frame_rate), progress=False)
    z_min = float(np.nanmin(np.where(truth.mask, truth.depth, np.nan))) - Z_MIN_MARGIN
    return Take(frames, truth, ps, method, z_min, p, float(frame_rate))
