"""The virtual rig's renderer: scene + rig + pattern set -> camera frames and ground truth.

Per frame, at its own timestamp ``k / frame_rate`` (s):

1. cast each camera pixel's ray (pinhole: through the centre; telecentric: parallel rays) and
   take the first surface hit (:mod:`fringe3d.sim.rays`);
2. project the hit into the projector, ``(u_p, v_p) = projector.project(X)`` (Eq. 2.8-2.18),
   and test projector shadows (:mod:`fringe3d.sim.geometry`);
3. look up the pattern value there: analytically (``sinusoid_value``, ``ideal`` mode) or by
   bilinear sampling of the projector image (``render_frame``) blurred by the defocus OTF
   (Eq. 2.22-2.26, optionally growing with distance from the focal plane)
   (:mod:`fringe3d.sim.projector_sampling`);
4. shade: projector gamma, Lambertian cosine toward the projector centre, ambient light,
   albedo / texture, exposure and gain (:mod:`fringe3d.sim.radiometry`);
5. sense: camera blur, shot and read noise, quantisation (:mod:`fringe3d.sim.noise`).

A static scene is cast once and reused for every frame, whose steps 3-5 run on
:data:`SHADE_THREADS` threads (each frame draws its noise from its own generator, so the frames
do not depend on the threads); a moving scene is re-cast per frame (and per motion sub-sample
when ``motion_samples > 1``).
"""
from __future__ import annotations

import os
from collections import deque
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from fringe3d.optics import Rig
from fringe3d.patterns.manifest import PatternSet
from fringe3d.utils.console import progress_bar

from .geometry import Geometry, cast, crop, scene_meta
from .noise import blur_margin, sense
from .projector_sampling import PatternSampler
from .radiometry import frame_times, irradiance, motion_subtimes
from .rays import camera_rays
from .scene import Scene, as_scene
from .scene_object import SceneObject
from .settings import RenderSettings
from .truth import Truth, TruthFrames, directions_of, frame_truth, make_truth


def render(scene: Scene | SceneObject, rig: Rig, patterns: PatternSet, settings: RenderSettings | None = None,
           times=None, progress: bool = True) -> tuple[np.ndarray, Truth]:
    """Render a capture: one camera frame per pattern frame (in projection order).

    Parameters
    ----------
    scene : Scene or SceneObject
        A bare scene object is rendered as a one-object :class:`~fringe3d.sim.scene.Scene`.
    rig : fringe3d.optics.Rig
    patterns : PatternSet
        Its width/height must equal the projector's.
    settings : RenderSettings
    times : array_like (F,), optional
        Capture time of each frame (s). Default ``k / frame_rate``; pass more times than
        pattern frames to render a repeating sequence (frame ``k`` shows pattern ``k % P``).
    progress : bool
        Show a progress bar.

    Returns
    -------
    frames : (F, H, W) uint8 / uint16 / float32
    truth : Truth
        Per pixel; per frame (leading F axis) when the scene moves, taken at the frame's
        timestamp (at the middle motion sub-sample when ``motion_samples > 1``, see
        ``truth.meta["truth_times"]``).

    Examples
    --------
    >>> from fringe3d.patterns import sets
    >>> from fringe3d.sim import Plane, Scene, presets
    >>> p = presets.get("tiny")
    >>> ps = sets.phase_shift(18, 3, "v", width=p.rig.projector.width, height=p.rig.projector.height)
    >>> frames, truth = render(Scene([Plane(p.center, (0, 0, -1))]), p.rig, ps, p.settings, progress=False)
    >>> frames.shape, frames.dtype.name, bool(truth.mask.all())
    ((3, 128, 160), 'uint8', True)
    """
    stream = render_stream(scene, rig, patterns, settings, times)
    frames, per_frame, truth_times = [], TruthFrames(len(stream.times)), []
    first: dict | None = None
    with progress_bar("rendering", len(stream.times), enabled=progress) as advance:
        for k, img, ft, t_truth in stream:
            frames.append(img)
            if stream.moving:
                per_frame.put(k, ft)
                truth_times.append(t_truth)
            elif first is None:
                first = ft
            advance()
    truth = make_truth(per_frame if stream.moving else first, stream.dirs_info, stream.times, not stream.moving,
                       rig)
    truth.meta.update(stream.meta)
    if stream.moving:
        truth.meta["truth_times"] = truth_times  # differs from ``times`` when motion_samples > 1
    return np.stack(frames), truth


class RenderStream:
    """The frames of a capture rendered one at a time (what :func:`render` collects).

    Iterating yields ``(k, image, truth, truth_time)`` per frame in capture order: ``image`` (H, W)
    as :func:`render` returns it, ``truth`` the instant's :func:`~fringe3d.sim.truth.frame_truth`
    dict (a static scene yields the same dict, cast once, for every frame) and ``truth_time`` (s)
    the instant it describes. Attributes: ``times`` (F,) s, ``moving`` (per-frame truth),
    ``dirs_info`` (:func:`~fringe3d.sim.truth.directions_of`) and ``meta`` (the scene metadata
    :func:`render` adds to ``truth.meta``). Memory holds one frame, whatever F is.
    """

    def __init__(self, scene: Scene, rig: Rig, sampler: PatternSampler, times: np.ndarray):
        self.scene, self.rig, self.sampler, self.times = scene, rig, sampler, times
        #: Frames before ``skip`` are yielded with ``image`` None (not shaded): a resumed capture has
        #: them already; a moving scene still casts them for their truth.
        self.skip = 0
        self.moving = bool(scene.moving)
        self.dirs_info = directions_of(sampler.patterns)
        self.meta = scene_meta(scene, rig, float(times[0]))

    def __len__(self) -> int:
        return len(self.times)

    def __iter__(self):
        return _moving_frames(self) if self.moving else _static_frames(self)


def render_stream(scene: Scene | SceneObject, rig: Rig, patterns: PatternSet,
                  settings: RenderSettings | None = None, times=None) -> RenderStream:
    """The frames :func:`render` makes, as a :class:`RenderStream` (one frame at a time).

    Parameters are those of :func:`render`; the inputs are checked here, before any frame is
    rendered.
    """
    s = settings or RenderSettings()
    scene = as_scene(scene)
    check_inputs(rig, patterns)
    times = frame_times(len(patterns.frames), s) if times is None else np.asarray(times, float).ravel()
    if times.size == 0:
        raise ValueError("nothing to render: no frame times given")
    if not np.all(np.isfinite(times)):
        raise ValueError("frame times must be finite numbers of seconds")
    return RenderStream(scene, rig, PatternSampler(patterns, s), times)


#: Threads shading a static scene's frames at once (at most; one for small images).
SHADE_THREADS = min(4, len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1)
#: Fewest pixels per frame worth a second thread.
SHADE_THREAD_PIXELS = 1 << 17


def _static_frames(st: RenderStream):
    """Frames of a static scene: one cast at ``times[0]``, shaded once per pattern frame (on
    :data:`SHADE_THREADS` threads, yielded in order)."""
    s, patterns, rig, scene = st.sampler.settings, st.sampler.patterns, st.rig, st.scene
    H, W = rig.camera.height, rig.camera.width
    m = blur_margin(s)  # render beyond the sensor what the camera blur brings onto its border
    origins, dirs, off = camera_rays(rig.camera, m)
    pad = cast(scene, rig, origins, dirs, off, float(st.times[0]), s.shadows)
    geo = crop(pad, (H + 2 * m, W + 2 * m), m)
    check_visible(geo)
    ft = frame_truth(geo, (H, W), st.dirs_info)
    t0 = float(st.times[0])

    def shade(k: int) -> np.ndarray:
        spec = patterns.frames[k % len(patterns.frames)]
        img = irradiance(pad, st.sampler.values(spec, pad), s, scene.ambient)
        return sense(img.reshape(H + 2 * m, W + 2 * m), s, k, m)

    for k in range(min(st.skip, len(st.times))):
        yield k, None, ft, t0
    workers = SHADE_THREADS if (H + 2 * m) * (W + 2 * m) >= SHADE_THREAD_PIXELS else 1
    for k, img in _in_order(shade, range(st.skip, len(st.times)), workers):
        yield k, img, ft, t0


def _in_order(fn: Callable[[int], np.ndarray], ks: Iterable[int], workers: int) -> Iterator[tuple[int, np.ndarray]]:
    """``(k, fn(k))`` for every ``k`` of ``ks`` in order, computed on ``workers`` threads with at most
    ``2 * workers`` results ahead of the one yielded (bounded memory)."""
    if workers <= 1:
        for k in ks:
            yield k, fn(k)
        return
    with ThreadPoolExecutor(max_workers=workers, thread_name_prefix="fringe3d-shade") as pool:
        pending: deque = deque()
        try:
            for k in ks:
                pending.append((k, pool.submit(fn, k)))
                if len(pending) >= 2 * workers:
                    k0, fut = pending.popleft()
                    yield k0, fut.result()
            while pending:
                k0, fut = pending.popleft()
                yield k0, fut.result()
        finally:
            for _, fut in pending:
                fut.cancel()


def _moving_frames(st: RenderStream):
    """Frames of a moving scene: re-cast at every frame's motion sub-samples (averaged over
    the exposure); per-frame truth at the middle sub-sample."""
    s, patterns, rig, scene = st.sampler.settings, st.sampler.patterns, st.rig, st.scene
    H, W = rig.camera.height, rig.camera.width
    m = blur_margin(s)
    Hp, Wp = H + 2 * m, W + 2 * m
    origins, dirs, off = camera_rays(rig.camera, m)
    work: list[dict] = [{} for _ in range(max(1, s.motion_samples))]  # cast buffers per sub-sample index
    for k, tk in enumerate(st.times):
        spec = patterns.frames[k % len(patterns.frames)]
        sub = motion_subtimes(float(tk), s)
        img = np.zeros(Hp * Wp)
        for j, ts in enumerate(sub):  # buffers reused per sub-sample index across frames
            g = cast(scene, rig, origins, dirs, off, ts, s.shadows, work=work[j])
            if j == len(sub) // 2:  # truth at the middle sub-sample of the exposure
                geo, t_truth = crop(g, (Hp, Wp), m), ts
            if k >= st.skip:
                img += irradiance(g, st.sampler.values(spec, g), s, scene.ambient) / len(sub)
        if k == 0:
            check_visible(geo)
        shot = sense(img.reshape(Hp, Wp), s, k, m) if k >= st.skip else None
        yield k, shot, frame_truth(geo, (H, W), st.dirs_info), float(t_truth)


def check_inputs(rig: Rig, patterns: PatternSet) -> None:
    """Reject a pattern set that does not fit the projector or holds no frames."""
    proj = rig.projector
    if (patterns.width, patterns.height) != (proj.width, proj.height):
        raise ValueError(f"pattern set is {patterns.width}x{patterns.height} but the projector is "
                         f"{proj.width}x{proj.height}; build the patterns for the projector's size")
    if len(patterns.frames) == 0:
        raise ValueError("pattern set has no frames")


def check_visible(geo: Geometry) -> None:
    """Reject scenes the camera cannot see or the projector cannot light."""
    if not geo.hit.any():
        raise ValueError("no scene object is in the camera's view (is it behind the camera or outside "
                         "its field of view?); place objects in front of the camera within the preset's "
                         "working volume")
    if not geo.lit.any():
        raise ValueError("the scene is outside the projector's view: no visible surface point is lit by "
                         "the projector; move the objects into the projector's field")
