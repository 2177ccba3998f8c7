"""Ready-made scenes placed inside a rig preset's working volume.

``named_scene(name, preset)`` for ``sculpture``, ``mesh``, ``falling-balls``, ``wing`` and
``textured-spheres`` (the renderer's :mod:`fringe3d.sim.simulate` builds the simpler ones). Every
builder takes the volume centre ``c``, its size and the camera's viewing direction from the
preset, so the same name works for the macro, high-speed and tiny rigs.
"""
from __future__ import annotations

import time as _time
from collections.abc import Callable

import numpy as np

from fringe3d.optics import TelecentricCamera

from . import presets
from .mesh import Mesh
from .motion import GRAVITY_MM_S2, falling
from .presets import Preset
from .primitives import Box, Plane, Sphere
from .scene import Scene
from .scene_object import PosedObject
from .sculpture import sculpture
from .textures import Checker, Ramp
from .wing import Wing, WingBeat, WingDots, WingShape

NAMES = ("sculpture", "mesh", "falling-balls", "wing", "textured-spheres", "shiny-part", "printed-part")


def preset_frame(preset: Preset) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(centre (3,), size (3,), view (3,), down (3,)) from a preset: unit viewing direction and
    the world direction of image-down (the camera's +y axis)."""
    cam = preset.rig.camera
    if isinstance(cam, TelecentricCamera):
        view = cam.view_direction
        down = cam.M[1, :3] - (cam.M[1, :3] @ view) * view
    else:
        view, down = cam.R[2], cam.R[1]
    down = down / np.linalg.norm(down)
    return np.asarray(preset.center, float), np.asarray(preset.size, float), view, down


def facing_rotation(view, down) -> np.ndarray:
    """Body → world rotation whose body ``+z`` points back at the camera (``−view``), body
    ``+x`` along image-right and body ``+y`` along image-up."""
    z = -np.asarray(view, float)
    y = -np.asarray(down, float)
    x = np.cross(y, z)
    return np.column_stack([x, y, z])


def sculpture_scene(preset, seed: int = 0) -> Scene:
    """The textured freeform relief, 60% of the lateral volume, relief 15% of the depth range."""
    c, size, view, down = preset_frame(preset)
    R = facing_rotation(view, down)
    relief = 0.15 * size[2]
    base = c + view * (0.5 * relief)
    s = sculpture(center=base, size=(0.6 * size[0], 0.6 * size[1]), relief=relief, seed=seed, R=R)
    return Scene([s], name="sculpture")


def mesh_scene(preset, triangles: int = 100_000, seed: int = 0) -> Scene:
    """The sculpture tessellated into a ~``triangles`` triangle mesh, ray-cast with Embree."""
    c, size, view, down = preset_frame(preset)
    R = facing_rotation(view, down)
    relief = 0.15 * size[2]
    w, h = 0.6 * size[0], 0.6 * size[1]
    s = sculpture(center=c + view * (0.5 * relief), size=(w, h), relief=relief, seed=seed, R=R)
    step = float(np.sqrt(2 * w * h / triangles))
    return Scene([Mesh(s.to_mesh(step), center=s.center, R=s.R, albedo=s.albedo)], name="mesh")


def falling_balls_scene(preset, n: int = 3, seed: int = 0) -> Scene:
    """``n`` isolated ping-pong-like balls (radius ≤ 20 mm) falling under gravity (image-down)
    with different initial velocities (0.5–1.5 m/s, scaled down in volumes under 150 mm) and
    spins, each printed with a checker texture so their motion is visible. Their centres follow
    ``c0 + v0 t + g t²/2`` exactly (ch. 5). In the microscope volume they leave the view within
    a few tens of milliseconds (:func:`fringe3d.sim.validate.scene_problems` says so)."""
    c, size, view, down = preset_frame(preset)
    rng = np.random.default_rng(seed)
    r = float(min(20.0, 0.15 * min(size[0], size[1])))
    right = np.cross(down, view)
    balls = []
    for k in range(n):
        fx = (k + 0.5) / n - 0.5
        c0 = c + right * (0.75 * fx * size[0]) - down * (0.15 * size[1]) + view * (rng.uniform(-0.2, 0.2) * size[2])
        speed = min(1.0, min(size[0], size[1]) / 150.0)  # slower in small volumes
        v0 = speed * (down * rng.uniform(500.0, 1500.0) + right * rng.uniform(-150.0, 150.0))  # mm/s
        spin = rng.normal(size=3)
        spin *= rng.uniform(10.0, 30.0) / np.linalg.norm(spin)  # rad/s
        balls.append(Sphere(c0, r, albedo=0.9, texture=Checker(period=np.pi / 6, contrast=0.5),
                            motion=falling(velocity=v0, spin=spin, gravity=down * GRAVITY_MM_S2)))
    return Scene(balls, name="falling-balls")


def wing_scene(preset, frequency: float = 25.0, markers: bool = True) -> Scene:
    """The flapping 150 × 70 mm membrane (scaled down to 60% of the lateral volume if needed)
    with two dark anchor dots at the root corners and optional white marker dots (ch. 6)."""
    c, size, view, down = preset_frame(preset)
    scale = min(1.0, 0.6 * size[0] / 150.0, 0.6 * size[1] / 70.0)
    span, chord = 150.0 * scale, 70.0 * scale
    R0 = facing_rotation(view, down)  # material x → image right, y → image up, normal → camera
    right, up = R0[:, 0], R0[:, 1]
    root = c - right * (0.5 * span) - up * (0.5 * chord)
    anchors = [(0.04 * span, 0.1 * chord), (0.04 * span, 0.85 * chord)]
    mk = [(0.3 * span, 0.5 * chord), (0.5 * span, 0.3 * chord), (0.5 * span, 0.65 * chord),
          (0.7 * span, 0.45 * chord), (0.85 * span, 0.2 * chord)] if markers else []
    wing = Wing(WingShape(span=span, chord=chord),
                WingBeat(kappa_mean=0.0, kappa_amp=1.0 / (0.9 * chord), frequency=frequency,
                         flap_amplitude=np.radians(15), kappa_phase=0.5),
                root=root, R0=R0, dots=WingDots(anchors=anchors, markers=mk, dot_radius=0.03 * chord))
    return Scene([wing], name="wing")


def textured_spheres_scene(preset) -> Scene:
    """Three isolated checker-printed spheres at different depths in front of a matte plane."""
    c, size, view, down = preset_frame(preset)
    right = np.cross(down, view)
    r = 0.12 * min(size[0], size[1])
    objs: list[PosedObject] = [
        Sphere(c + right * (dx * size[0]) + down * (dy * size[1]) + view * (dz * size[2]), r,
               albedo=0.9, texture=Checker(period=np.pi / 8, contrast=0.4))
        for dx, dy, dz in ((-0.28, 0.1, -0.2), (0.0, -0.12, 0.0), (0.28, 0.08, 0.2))]
    objs.append(Plane(c + view * (0.5 * size[2]), -view, albedo=0.7))
    return Scene(objs, name="textured-spheres")


def shiny_part_scene(preset) -> Scene:
    """A machined metal part: a polished dome (sphere, radius 30% of the lateral volume, specular
    weight 1, roughness 0.12) on a brushed plate (specular 0.6, roughness 0.25), both grey
    (albedo 0.35) — specular highlights tens of times brighter than the diffuse part, which
    saturate wherever the camera sees the projector's mirror image (:mod:`fringe3d.sim.specular`)."""
    c, size, view, down = preset_frame(preset)
    r = 0.3 * min(size[0], size[1])
    dome = Sphere(c, r, albedo=0.35).set_gloss(1.0, 0.12)
    plate = Plane(c + view * (0.5 * size[2]), -view, albedo=0.35).set_gloss(0.6, 0.25)
    return Scene([dome, plate], name="shiny-part")


def printed_part_scene(preset) -> Scene:
    """A black-and-white printed part: a matte plate whose albedo ramps from black (0.05) to white
    (1) across 80% of the view (left to right), carrying a dome printed with a black/white checker
    (albedo 0.9 and 0.02). Dark areas drown in noise at an exposure that keeps the white ones
    below saturation."""
    c, size, view, down = preset_frame(preset)
    right = np.cross(down, view)
    R = facing_rotation(view, down)
    plate = Plane(c + view * (0.4 * size[2]), -view, albedo=1.0, u_axis=right,
                  texture=Ramp(start=-0.4 * size[0], length=0.8 * size[0], contrast=0.95))
    dome = Sphere(c - right * (0.15 * size[0]), 0.2 * min(size[0], size[1]), albedo=0.9,
                  texture=Checker(period=np.pi / 6, contrast=0.98), R=R)
    return Scene([plate, dome], name="printed-part")


_BUILDERS: dict[str, Callable[[Preset], Scene]] = {
    "sculpture": sculpture_scene, "mesh": mesh_scene, "falling-balls": falling_balls_scene,
    "wing": wing_scene, "textured-spheres": textured_spheres_scene,
    "shiny-part": shiny_part_scene, "printed-part": printed_part_scene}


def named_scene(name: str, preset) -> Scene:
    """Build scene ``name`` (one of :data:`NAMES`) inside ``preset``'s working volume."""
    if name not in _BUILDERS:
        raise ValueError(f"unknown scene {name!r}; expected one of: {', '.join(NAMES)}")
    return _BUILDERS[name](preset)


def bench_cast(preset: str = "macro", repeats: int = 5, time: float = 0.003) -> dict:
    """Seconds per full camera frame of ray casting (best and median of ``repeats``) for the
    ~100k-triangle ``mesh`` scene (Embree), an analytic sphere, the analytic sculpture and the
    wing, with the preset's camera (1280×1024 for ``macro``). Geometry only: no shading.
    ``best_cpu_s`` is process CPU time, less sensitive to other jobs on a shared machine."""
    p = presets.get(preset)
    cam = p.rig.camera
    o, d = cam.rays(cam.pixel_grid().reshape(-1, 2))
    mesh = named_scene("mesh", p)
    assert isinstance(mesh[0], Mesh)
    scenes = {f"mesh ({mesh[0].n_faces} triangles)": mesh,
              "analytic sphere": Scene([Sphere(p.center, 0.25 * min(p.size[0], p.size[1]))]),
              "analytic sculpture": named_scene("sculpture", p), "wing": named_scene("wing", p)}
    out = {"camera": [cam.width, cam.height], "rays": len(d)}
    for name, scene in scenes.items():
        scene.intersect(o, d, time)  # warm-up (numba compile / cache load)
        ts, cpu = [], []
        for _ in range(repeats):
            t0, c0 = _time.perf_counter(), _time.process_time()
            h = scene.intersect(o, d, time)
            ts.append(_time.perf_counter() - t0)
            cpu.append(_time.process_time() - c0)
        out[name] = {"best_s": round(min(ts), 4), "median_s": round(float(np.median(ts)), 4),
                     "best_cpu_s": round(min(cpu), 4), "hit_fraction": round(float(h.mask.mean()), 3)}
    return out


BAR_KINDS = ("box", "none")


def sphere_bar_scene(preset: Preset, spacing: float | None = None, radius: float | None = None,
                     knob: bool = False, bar: str = "box"):
    """A ball bar for VDI/VDE 2634-3.

    Two spheres ``spacing`` mm apart (default 45 % of the volume width), joined by a square bar
    (``bar="box"``) or by nothing visible (``bar="none"``: a dumbbell whose roll about the line
    of centres no view can observe), with an optional smaller knob sphere on the bar (``knob``:
    it breaks the bar's symmetries so free-hand registration has a unique answer; a real ball bar
    has none, and its two equal spheres and square bar make the free-hand answer ambiguous).

    Parameters
    ----------
    preset : Preset
        The rig preset whose working volume (mm) places the bar.
    spacing, radius : float, optional
        Centre distance and sphere radius (mm); default 45 % and 8 % of the volume width.
    knob : bool
        Add the asymmetric knob sphere.
    bar : str
        ``"box"`` or ``"none"`` (:data:`BAR_KINDS`).

    Returns
    -------
    tuple
        ``(scene, centres (2, 3) mm, radius mm)``, in the camera frame at table angle 0.
    """
    if bar not in BAR_KINDS:
        raise ValueError(f"bar must be one of {', '.join(BAR_KINDS)}, got {bar!r}")
    c, size, view, down = preset_frame(preset)
    L = 0.45 * size[0] if spacing is None else float(spacing)
    r = 0.08 * size[0] if radius is None else float(radius)
    right = np.cross(down, view)
    right /= np.linalg.norm(right)
    ca, cb = c - 0.5 * L * right, c + 0.5 * L * right
    R = np.column_stack([right, -down, -view])
    objects: list = [Sphere(ca, r), Sphere(cb, r)]
    if bar == "box":
        objects.append(Box(c, (L - r, 0.5 * r, 0.5 * r), R=R))
    if knob:
        objects.append(Sphere(c + 0.2 * L * right - 0.6 * r * down, 0.5 * r))
    return Scene(objects, name="sphere-bar"), np.stack([ca, cb]), r
