"""Write a simulated capture folder: frames + manifest + ``capture.json`` + ``truth/`` + ``rig.json``.

``simulate_capture(folder, preset, scene, patterns, ...)`` renders a pattern set on a scene with
a preset rig and writes exactly what a real capture holds (decoders cannot tell the
difference), plus the ground truth and the true rig. The same is ``fringe3d simulate``.

Scenes are given as a :class:`~fringe3d.sim.scene.Scene`, a name (:data:`SCENE_NAMES`,
built inside the preset's working volume) or a JSON scene file
(:mod:`fringe3d.sim.scene_file`). Before rendering, :func:`fringe3d.sim.validate.check_scene`
rejects objects behind the camera or projector, unseen by the camera or unlit by the projector.
Pattern sets are a :class:`PatternSet`, a manifest file, or a name (:data:`PATTERN_NAMES`,
built for the preset's projector).
"""
from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from fringe3d.calibrate.boards import CircleBoard
from fringe3d.io.capture import FRAMES_DIR, write_capture_frames
from fringe3d.optics import TelecentricCamera
from fringe3d.patterns import sets
from fringe3d.patterns.manifest import PatternSet
from fringe3d.utils.console import progress_bar

from . import catalog
from . import presets as _presets
from .board import board_facing
from .bracket import BRACKET_SEED_STEP, BracketStream, check_exposures
from .presets import Preset
from .primitives import Box, Plane, Sphere
from .radiometry import frame_times
from .render import RenderStream, render_stream
from .scene import Scene
from .scene_file import load_scene
from .scene_object import SceneObject
from .settings import RenderChanges
from .truth import TruthWriter, make_truth, truth_meta
from .validate import check_scene


# ----------------------------------------------------------------------------- pattern sets
def _three_frequency_both(w, h):
    return sets.calibration(w, h, directions=("v", "h"))


def _named_pattern_builders():
    return {
        "three-frequency": lambda w, h: _three_frequency_both(w, h),
        "three-frequency-v": lambda w, h: sets.three_frequency("v", width=w, height=h),
        "three-frequency-h": lambda w, h: sets.three_frequency("h", width=w, height=h),
        "phase-shift": lambda w, h: sets.phase_shift(18, 9, "v", width=w, height=h),
        "two-frequency": lambda w, h: sets.two_frequency(18, 144, "v", width=w, height=h),
        "two-frequency-binary": lambda w, h: sets.two_frequency(18, 144, "v", kind="square", width=w, height=h),
        "hybrid": lambda w, h: sets.hybrid(18, 144, "v", width=w, height=h),
        "hybrid-binary": lambda w, h: sets.hybrid(18, 144, "v", kind="square", width=w, height=h),
        "ftp": lambda w, h: sets.ftp(18, "v", width=w, height=h),
        "modified-ftp": lambda w, h: sets.modified_ftp(18, "v", width=w, height=h),
        "gray-code": lambda w, h: sets.psp_with_gray_code(18, 3, "v", width=w, height=h),
        "calibration": lambda w, h: sets.calibration(w, h),
    }


PATTERN_NAMES = ("three-frequency", "three-frequency-v", "three-frequency-h", "phase-shift", "two-frequency",
                 "two-frequency-binary", "hybrid", "hybrid-binary", "ftp", "modified-ftp", "gray-code",
                 "calibration")


def make_patterns(spec, width: int, height: int) -> PatternSet:
    """A pattern set from a :class:`PatternSet`, a manifest path, or a name in :data:`PATTERN_NAMES`.

    ``three-frequency`` is the dissertation's 18/21/144 heterodyne set in both directions (plus
    a white frame); ``*-binary`` use squared binary frames (binary defocusing).

    Parameters
    ----------
    spec : PatternSet or str or os.PathLike
        A pattern set (returned as is), a manifest (``*.json`` or a folder) or a name.
    width, height : int
        Projector resolution (px) for a named set.

    Returns
    -------
    PatternSet
        The pattern set.
    """
    if isinstance(spec, PatternSet):
        return spec
    spec = str(spec)
    if spec.endswith(".json") or Path(spec).is_dir():
        return PatternSet.load(spec)
    builders = _named_pattern_builders()
    if spec not in builders:
        raise ValueError(f"unknown pattern set {spec!r}; "
                         f"expected a manifest file or one of: {', '.join(PATTERN_NAMES)}")
    return builders[spec](width, height)


# ----------------------------------------------------------------------------- scenes
SCENE_NAMES = ("sphere", "plane", "spheres", "step", "board", "sculpture", "mesh", "falling-balls", "wing",
               "textured-spheres", "shiny-part", "printed-part", "sphere-bar")


def make_scene(spec, preset: Preset) -> Scene:
    """A scene from a Scene, a scene object (a one-object scene), a scene file (``*.json``) or a
    name in :data:`SCENE_NAMES`.

    Named scenes are placed in the preset's working volume (see :func:`named_scene`).

    Parameters
    ----------
    spec : Scene or SceneObject or str or os.PathLike or None
        The scene, one object, a scene file or a name; ``None`` = the preset's default scene.
    preset : Preset
        The rig preset whose working volume (mm) places a named scene.

    Returns
    -------
    Scene
        The scene.
    """
    if spec is None:
        spec = preset.scene
    if isinstance(spec, Scene):
        return spec
    if isinstance(spec, SceneObject):
        return Scene([spec])
    spec = str(spec)
    if spec.endswith(".json") or Path(spec).exists():
        return load_scene(spec)
    return named_scene(spec, preset)


def named_scene(name: str, preset: Preset) -> Scene:
    """Build the named scene inside ``preset.volume`` (mm, world frame).

    * ``sphere``: a sphere (radius 30% of the smaller lateral extent) at the volume centre in
      front of a matte back plane at the far end of the volume.
    * ``plane``: a plane through the volume centre facing the camera.
    * ``spheres``: three isolated spheres at different depths, no background.
    * ``step``: a block on a plane (step height 20% of the depth range).
    * ``board``: a 9x9 circle-grid calibration board facing the camera.
    * ``sculpture``, ``mesh`` (~100k triangles, Embree), ``falling-balls``, ``wing``,
      ``textured-spheres``: from :mod:`fringe3d.sim.catalog`.
    * ``sphere-bar``: a VDI/VDE 2634-3 ball bar, two spheres on a square bar
      (:func:`fringe3d.sim.turntable.sphere_bar_scene`).

    Parameters
    ----------
    name : str
        A name in :data:`SCENE_NAMES`.
    preset : Preset
        The rig preset whose working volume (mm, world frame) places the scene.

    Returns
    -------
    Scene
        The scene.
    """
    c = preset.center
    size = preset.size
    lateral = float(min(size[0], size[1]))
    z0, z1 = preset.volume["z"]
    view = _view_direction(preset)
    if name == "sphere":
        r = 0.3 * lateral
        return Scene([Sphere(c, r), Plane(c + view * (z1 - c[2]), -view, albedo=0.8)], name="sphere")
    if name == "plane":
        return Scene([Plane(c, -view, albedo=0.9)], name="plane")
    if name == "spheres":
        r = 0.15 * lateral
        objs = [Sphere(c + np.array([dx * size[0], dy * size[1], dz * size[2]]), r)
                for dx, dy, dz in ((-0.25, -0.1, -0.2), (0.0, 0.15, 0.0), (0.25, -0.05, 0.2))]
        return Scene(objs, name="spheres")
    if name == "step":
        h = 0.2 * size[2]
        back = c + view * (0.5 * size[2])
        block = Box(back - view * (h / 2), (0.4 * size[0], 0.5 * size[1], h))
        return Scene([block, Plane(back, -view, albedo=0.9)], name="step")
    if name == "board":
        spacing = lateral / 12.0
        cam = preset.rig.camera
        cam_c = c - view * 1000.0 if isinstance(cam, TelecentricCamera) else cam.center  # no centre: 1 m back
        return Scene([board_facing(cam_c, c, board=CircleBoard(cols=9, rows=9, spacing=spacing,
                                                                     radius=0.25 * spacing))], name="board")
    if name in catalog.NAMES:
        return catalog.named_scene(name, preset)
    if name == "sphere-bar":
        return catalog.sphere_bar_scene(preset)[0]
    raise ValueError(f"unknown scene {name!r}; expected a scene file (*.json) or one of: {', '.join(SCENE_NAMES)}")


def _view_direction(preset: Preset) -> np.ndarray:
    cam = preset.rig.camera
    if isinstance(cam, TelecentricCamera):
        return cam.view_direction
    return cam.R[2]


# ----------------------------------------------------------------------------- capture
def _frames_done(folder: Path, count: int, fmt: str) -> int:
    """How many frames ``0, 1, ...`` an interrupted run already wrote (atomically, so each is whole);
    at most ``count - 1`` (the last is rendered again: the capture's metadata comes from it)."""
    n = 0
    while n < count - 1 and (folder / FRAMES_DIR / f"{n:05d}.{fmt}").is_file():
        n += 1
    return n


def _write_streamed(folder: Path, stream: RenderStream | BracketStream, p: Preset, ps: PatternSet, meta: dict, fmt: str,
                    progress: bool) -> float:
    """Render ``stream`` frame by frame into ``folder``: each frame file written as it is rendered,
    a moving scene's per-frame truth appended to ``truth/`` (:class:`~fringe3d.sim.truth.TruthWriter`),
    then the manifest, ``capture.json``, the truth and ``rig.json``. Memory holds a few frames
    whatever the take's length. Returns the valid (lit) fraction of the truth's pixels."""
    tdir = folder / "truth"
    first: dict = {}
    truth_times: list[float] = []
    with progress_bar("rendering", len(stream), enabled=progress) as advance, \
            TruthWriter(tdir, len(stream) if stream.moving else 0) as tw:
        def frames():
            for k, img, ft, t_truth in stream:
                if stream.moving:
                    tw.put(k, ft)
                    truth_times.append(t_truth)
                elif not first:
                    first.update(ft)
                if img is not None:  # None: written by the run this one resumes
                    yield img
                advance()

        write_capture_frames(folder, frames(), len(stream), ps, meta, fmt=fmt, progress=False, start=stream.skip)
        tmeta = {**truth_meta(stream.dirs_info, stream.times, not stream.moving, p.rig), **stream.meta}
        if stream.moving:
            tmeta["truth_times"] = truth_times  # differs from ``times`` when motion_samples > 1
        tmeta.update({"preset": p.name, "scene": meta["scene"], "seed": meta["seed"]})
        if stream.moving:
            tw.finish(tmeta)
            valid = tw.mask_sum / (len(stream) * p.rig.camera.width * p.rig.camera.height)
        else:
            truth = make_truth(first, stream.dirs_info, stream.times, True, p.rig)
            truth.meta = tmeta
            truth.save(tdir)
            valid = float(np.mean(truth.mask))
    p.rig.save(folder / "rig.json")
    return float(valid)


def simulate_capture(folder, preset="tiny", scene=None, patterns=None, *, frames: int | None = None,
                     cycles: int = 1, seed: int | None = None, render: RenderChanges = RenderChanges(),
                     progress: bool = True, resume: bool = False) -> dict:
    """Render and write a capture folder with ``truth/`` and ``rig.json``.

    Parameters
    ----------
    folder : path
        Output folder (created; every file written atomically).
    preset : str | Preset
        Rig preset (:func:`fringe3d.sim.presets.get`).
    scene : Scene | str | None
        Scene object, scene name, or JSON scene file; ``None`` = the preset's default scene.
    patterns : PatternSet | str | None
        Pattern set, manifest file, or name; ``None`` = the preset's default set.
    frames : int, optional
        Total frames to capture (a multiple of the pattern count; the sequence repeats).
    cycles : int
        Pattern cycles to capture when ``frames`` is not given.
    seed : int, optional
        Seed of the sensor noise (overrides the render settings' ``seed``).
    render : RenderChanges
        Changes to the preset's render settings: frame rate (Hz), exposure (s), read noise
        (full-scale units), defocus (projector px), bit depth, other :class:`RenderSettings`
        fields, or other settings entirely; and an exposure bracket (s), written exposure-major
        (frame ``e * len + k`` is pattern frame ``k`` at ``exposures[e]``), ``capture.json`` field
        ``exposures``; ``fringe3d decode`` fuses them per pixel.
    progress : bool
        Show a progress bar while rendering (default ``True``).
    resume : bool
        ``folder`` holds the frames ``0, 1, ...`` of an interrupted run with the same arguments: they
        are kept and not shaded again (every frame's noise is seeded by its index, so the result is
        bit-identical to an uninterrupted run).

    Returns
    -------
    dict
        Summary: folder, preset, scene, patterns, frames, frame_rate, valid fraction, seconds.

    Examples
    --------
    >>> import tempfile
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     summary = simulate_capture(tmp, "tiny", "plane", "phase-shift", progress=False)
    >>> summary["frames"], summary["camera"], summary["valid_fraction"]
    (9, [160, 128], 1.0)
    """
    t0 = time.perf_counter()
    p = _presets.get(preset)
    s = render.applied_to(p.settings)
    if seed is not None:
        s = s.replace(seed=seed)
    exposures = render.exposures
    proj = p.rig.projector
    ps = make_patterns(patterns if patterns is not None else p.patterns, proj.width, proj.height)
    if (ps.width, ps.height) != (proj.width, proj.height):
        raise ValueError(f"pattern set {ps.name!r} is {ps.width}x{ps.height} but the {p.name} projector is "
                         f"{proj.width}x{proj.height}")
    if frames is None:
        if cycles < 1:
            raise ValueError(f"cycles must be >= 1, got {cycles}")
        frames = cycles * len(ps)
    if frames < 1 or frames % len(ps):
        raise ValueError(f"frames must be a positive multiple of the pattern set's {len(ps)} frames, got {frames}")
    sc = make_scene(scene, p)
    times = frame_times(frames, s)
    check_scene(sc, p.rig, times=sorted({float(times[0]), float(times[-1])}))
    folder = Path(folder)
    meta = {"frame_rate": s.frame_rate, "simulated": True, "preset": p.name,
            "scene": sc.name, "patterns": ps.name, "seed": s.seed,
            "exposure": s.exposure if s.exposure is not None else 1.0 / s.frame_rate,
            "render_settings": s.to_dict(), "volume": p.volume}
    if s.bit_depth is not None:
        meta["bit_depth"] = s.bit_depth
    fmt = "png" if s.bit_depth is not None else "tif"
    stream: RenderStream | BracketStream
    if exposures is not None:
        ex = check_exposures(exposures, s.frame_rate)
        if frames != len(ps):
            raise ValueError(f"exposures: a bracket records one pattern cycle per exposure; got {frames} frames "
                             f"for the {len(ps)}-frame pattern set")
        stream = BracketStream([render_stream(sc, p.rig, ps, s.replace(exposure=t, seed=s.seed + BRACKET_SEED_STEP * e),
                                              times=times) for e, t in enumerate(ex)])
        meta["exposures"], frames = list(ex), frames * len(ex)
        meta.pop("exposure")
    else:
        stream = render_stream(sc, p.rig, ps, s, times=times)
    stream.skip = _frames_done(folder, len(stream), fmt) if resume else 0
    valid = _write_streamed(folder, stream, p, ps, meta, fmt, progress)
    summary = {"folder": str(folder), "preset": p.name, "scene": meta["scene"], "patterns": ps.name,
               "frames": int(frames), "frame_rate": s.frame_rate, "camera": [p.rig.camera.width, p.rig.camera.height],
               "valid_fraction": valid, "seed": s.seed, "seconds": round(time.perf_counter() - t0, 2)}
    return summary
