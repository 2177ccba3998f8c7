"""Write a simulated capture folder: frames + manifest + ``capture.json`` + ``truth/`` + ``rig.json``.

``simulate_capture(folder, preset, scene, patterns, ...)`` renders a pattern set on a scene with
a preset rig and writes exactly what a real capture holds (decoders cannot tell the
difference), plus the ground truth and the true rig. The same is ``fringe3d simulate``.

Scenes are given as a :class:`~fringe3d.sim.scenes.Scene`, a name (:data:`SCENE_NAMES`,
built inside the preset's working volume) or a JSON scene file (see :func:`scene_from_dict`).
Pattern sets are a :class:`PatternSet`, a manifest file, or a name (:data:`PATTERN_NAMES`,
built for the preset's projector).
"""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from fringe3d.io.console import info
from fringe3d.patterns.manifest import PatternSet

from . import presets as _presets
from .render import frame_times, render
from .settings import RenderSettings

SCENE_FORMAT = "fringe3d-scene"


# ----------------------------------------------------------------------------- pattern sets
def _three_frequency_both(w, h):
    from fringe3d.patterns import sets
    return sets.calibration(w, h, directions=("v", "h"))


def _named_pattern_builders():
    from fringe3d.patterns import sets
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
    """
    if isinstance(spec, PatternSet):
        return spec
    spec = str(spec)
    if spec.endswith(".json") or Path(spec).is_dir():
        return PatternSet.load(spec)
    builders = _named_pattern_builders()
    if spec not in builders:
        raise ValueError(f"unknown pattern set {spec!r}; expected a manifest file or one of: {', '.join(PATTERN_NAMES)}")
    return builders[spec](width, height)


# ----------------------------------------------------------------------------- scenes
SCENE_NAMES = ("sphere", "plane", "spheres", "step", "board", "sculpture", "mesh", "falling-balls", "wing")


def make_scene(spec, preset):
    """A scene from a Scene object, a scene file (``*.json``) or a name in :data:`SCENE_NAMES`.

    Named scenes are placed in the preset's working volume (see :func:`named_scene`).
    """
    if spec is None:
        spec = preset.scene
    if hasattr(spec, "intersect"):
        return spec
    spec = str(spec)
    if spec.endswith(".json") or Path(spec).exists():
        return load_scene(spec)
    return named_scene(spec, preset)


def named_scene(name: str, preset):
    """Build the named scene inside ``preset.volume`` (mm, world frame).

    * ``sphere``: a sphere (radius 30% of the smaller lateral extent) at the volume centre in
      front of a matte back plane at the far end of the volume.
    * ``plane``: a plane through the volume centre facing the camera.
    * ``spheres``: three isolated spheres at different depths, no background.
    * ``step``: a block on a plane (step height 20% of the depth range).
    * ``board``: a 9x9 circle-grid calibration board facing the camera.
    * ``mesh``: a ~100k-triangle freeform relief (:func:`height_field_mesh`, Embree ray casting).
    * ``sculpture``: the same kind of relief with a blotchy texture.
    * ``falling-balls``: three textured, spinning balls in free fall (moving scene).
    * ``wing``: the flapping isometric membrane (:class:`fringe3d.sim.wing.Wing`) with anchor and
      marker dots (moving scene; truth carries material coordinates, curvature and strain).
    """
    from . import scenes as sc
    c = preset.center
    size = preset.size
    lateral = float(min(size[0], size[1]))
    z0, z1 = preset.volume["z"]
    view = _view_direction(preset)
    if name == "sphere":
        r = 0.3 * lateral
        return sc.Scene([sc.Sphere(c, r), sc.Plane(c + view * (z1 - c[2]), -view, albedo=0.8)], name="sphere")
    if name == "plane":
        return sc.Scene([sc.Plane(c, -view, albedo=0.9)], name="plane")
    if name == "spheres":
        r = 0.15 * lateral
        objs = [sc.Sphere(c + np.array([dx * size[0], dy * size[1], dz * size[2]]), r)
                for dx, dy, dz in ((-0.25, -0.1, -0.2), (0.0, 0.15, 0.0), (0.25, -0.05, 0.2))]
        return sc.Scene(objs, name="spheres")
    if name == "step":
        h = 0.2 * size[2]
        back = c + view * (0.5 * size[2])
        block = sc.Box(back - view * (h / 2), (0.4 * size[0], 0.5 * size[1], h))
        return sc.Scene([block, sc.Plane(back, -view, albedo=0.9)], name="step")
    if name == "board":
        from .board import board_facing
        spacing = lateral / 12.0
        cam_c = getattr(preset.rig.camera, "center", c - view * 1000.0)
        return sc.Scene([board_facing(cam_c, c, cols=9, rows=9, spacing=spacing)], name="board")
    if name in ("mesh", "sculpture"):
        from .mesh import Mesh
        from .textures import Blotches
        mesh = height_field_mesh(0.8 * size[0], 0.8 * size[1], 0.25 * size[2], triangles=100_000,
                                 seed=1 if name == "sculpture" else 0)
        texture = Blotches(scale=0.1 * lateral) if name == "sculpture" else None
        R = _facing_rotation(view)
        return sc.Scene([Mesh(mesh, center=c, R=R, texture=texture, albedo=0.9)], name=name)
    if name == "falling-balls":
        from .motion import falling
        from .textures import Checker
        r = 0.1 * lateral
        fps = preset.settings.frame_rate
        objs = []
        for i, (dx, vy, spin) in enumerate(((-0.3, 0.0, 40.0), (0.0, -0.5, -60.0), (0.3, 0.3, 80.0))):
            start = c + np.array([dx * size[0], -0.2 * size[1], 0.1 * (i - 1) * size[2]])
            # initial speeds ~ a ball's diameter per 50 frames, plus gravity
            v = np.array([0.0, vy * 2 * r * fps / 50.0, 0.0])
            objs.append(sc.Sphere(start, r, texture=Checker(period=np.pi / 6, contrast=0.6),
                                  motion=falling(velocity=v, spin=(0.0, 0.0, spin * np.pi / 180 * fps / 50.0))))
        return sc.Scene(objs, name="falling-balls")
    if name == "wing":
        from .wing import Wing
        span = min(150.0, 0.6 * float(size[0]))
        chord = 70.0 / 150.0 * span
        k = 1.0 / 60.0 * 150.0 / span
        anchors = np.array([[0.2, 0.35], [0.75, 0.2]]) * [span, chord]
        markers = np.array([[0.4, 0.3], [0.55, 0.45], [0.6, 0.2]]) * [span, chord]
        return sc.Scene([Wing(span=span, chord=chord, root=c + np.array([-span / 2, chord / 2, 0.0]),
                              kappa_amp=k, anchors=anchors, markers=markers, dot_radius=span / 75.0)],
                        name="wing")
    raise ValueError(f"unknown scene {name!r}; expected a scene file (*.json) or one of: {', '.join(SCENE_NAMES)}")


def height_field_mesh(width: float, height: float, relief: float, triangles: int = 100_000, seed: int = 0):
    """A smooth freeform relief as a triangle mesh (body frame, mm): a grid over
    ``width x height`` with ``z = -relief * (sum of Gaussian bumps)`` (bumps toward -z, i.e.
    toward a camera looking along +z) and about ``triangles`` faces."""
    import trimesh
    n = max(2, int(round(np.sqrt(triangles / 2.0))) + 1)
    x = np.linspace(-width / 2, width / 2, n)
    y = np.linspace(-height / 2, height / 2, n)
    X, Y = np.meshgrid(x, y)
    rng = np.random.default_rng(seed)
    Z = np.zeros_like(X)
    for _ in range(7):
        cx, cy = rng.uniform(-0.35, 0.35) * width, rng.uniform(-0.35, 0.35) * height
        s = rng.uniform(0.1, 0.25) * min(width, height)
        Z += rng.uniform(0.3, 1.0) * np.exp(-((X - cx) ** 2 + (Y - cy) ** 2) / (2 * s * s))
    Z = -relief * Z / Z.max()
    verts = np.column_stack([X.ravel(), Y.ravel(), Z.ravel()])
    i = np.arange(n - 1)[:, None] * n + np.arange(n - 1)[None, :]
    a, b, c_, d = i.ravel(), i.ravel() + 1, i.ravel() + n, i.ravel() + n + 1
    faces = np.concatenate([np.column_stack([a, c_, b]), np.column_stack([b, c_, d])])
    return trimesh.Trimesh(vertices=verts, faces=faces, process=False)


def _facing_rotation(view) -> np.ndarray:
    """Body -> world rotation taking body +z to the viewing direction ``view`` (so a body
    relief toward -z faces the camera)."""
    z = np.asarray(view, float) / np.linalg.norm(view)
    x = np.cross([0.0, 1.0, 0.0], z)
    x = x / np.linalg.norm(x) if np.linalg.norm(x) > 1e-9 else np.array([1.0, 0.0, 0.0])
    y = np.cross(z, x)
    return np.column_stack([x, y, z])


def _view_direction(preset) -> np.ndarray:
    cam = preset.rig.camera
    if getattr(cam, "kind", "pinhole") == "telecentric":
        return cam.view_direction
    return cam.R[2]


# -- scene files ---------------------------------------------------------------------------------
def _object_types():
    from . import scenes as sc
    from .board import CircleBoard
    return {
        "sphere": (sc.Sphere, {"center", "radius"}, {"albedo", "texture", "velocity", "acceleration", "spin", "t0", "R"}),
        "plane": (sc.Plane, {"point", "normal"}, {"albedo", "texture", "u_axis", "size"}),
        "box": (sc.Box, {"center", "size"}, {"R", "albedo", "texture"}),
        "board": (CircleBoard, set(), {"cols", "rows", "spacing", "radius", "R", "t", "asymmetric", "margin",
                                       "white", "dark", "edge_width"}),
    }


def scene_from_dict(d: dict, where: str = "scene file"):
    """Build a Scene from ``{"objects": [{"type": "sphere", ...}, ...], "ambient": 0.0}``.

    Object types and fields (mm, radians, albedo in [0, 1]):
    ``sphere``: center, radius [albedo, texture, velocity, acceleration, spin, t0, R];
    ``plane``: point, normal [albedo, texture, u_axis, size];
    ``box``: center, size [R, albedo, texture];
    ``board``: [cols, rows, spacing, radius, R, t, asymmetric, margin, white, dark, edge_width].
    ``texture`` is ``{"type": "checker" | "stripes" | "blotches", ...}``.
    Errors name the offending field, e.g. ``scene file: objects[1].radius: ...``.
    """
    from . import scenes as sc
    from .textures import texture_from_dict
    if not isinstance(d, dict):
        raise ValueError(f"{where}: expected a JSON object with an 'objects' list")
    allowed = {"format", "version", "name", "ambient", "objects"}
    unknown = sorted(set(d) - allowed)
    if unknown:
        raise ValueError(f"{where}: unknown field(s) {unknown}; allowed: {sorted(allowed)}")
    if d.get("format", SCENE_FORMAT) != SCENE_FORMAT:
        raise ValueError(f"{where}: 'format' is {d['format']!r}, expected {SCENE_FORMAT!r}")
    objs = d.get("objects")
    if not isinstance(objs, list) or not objs:
        raise ValueError(f"{where}: field 'objects' must be a non-empty list of objects")
    types = _object_types()
    built = []
    for i, od in enumerate(objs):
        at = f"{where}: objects[{i}]"
        if not isinstance(od, dict) or "type" not in od:
            raise ValueError(f"{at}: missing field 'type' (one of {sorted(types)})")
        kind = od["type"]
        if kind not in types:
            raise ValueError(f"{at}.type: unknown object type {kind!r}; expected one of {sorted(types)}")
        cls, required, optional = types[kind]
        fields = {k: v for k, v in od.items() if k != "type"}
        missing = sorted(required - set(fields))
        if missing:
            raise ValueError(f"{at}: missing field {missing[0]!r} for a {kind} (required: {sorted(required)})")
        extra = sorted(set(fields) - required - optional)
        if extra:
            raise ValueError(f"{at}.{extra[0]}: unknown field for a {kind}; allowed: {sorted(required | optional)}")
        if "texture" in fields:
            fields["texture"] = texture_from_dict(fields["texture"], f"{at}.texture")
        for k, v in fields.items():
            if k != "texture" and not _json_number_like(v):
                raise ValueError(f"{at}.{k}: expected a number or a list of numbers, got {v!r}")
        try:
            built.append(cls(**fields))
        except (ValueError, TypeError) as e:
            raise ValueError(f"{at}: {e}") from None
    try:
        ambient = float(d.get("ambient", 0.0))
        return sc.Scene(built, ambient=ambient, name=str(d.get("name", "scene")))
    except (ValueError, TypeError) as e:
        raise ValueError(f"{where}.ambient: {e}") from None


def _json_number_like(v) -> bool:
    if isinstance(v, bool):
        return True
    if isinstance(v, (int, float)):
        return math.isfinite(v)
    if isinstance(v, list):
        return all(_json_number_like(x) for x in v)
    return False


def load_scene(path):
    """Read a JSON scene file (see :func:`scene_from_dict`)."""
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"no scene file at {path}")
    try:
        d = json.loads(path.read_text())
    except json.JSONDecodeError as e:
        raise ValueError(f"scene file {path} is not valid JSON: {e}") from None
    return scene_from_dict(d, where=f"scene file {path.name}")


# ----------------------------------------------------------------------------- capture
def simulate_capture(folder, preset="tiny", scene=None, patterns=None, *, frames: int | None = None,
                     cycles: int = 1, frame_rate: float | None = None, exposure: float | None = None,
                     noise: float | None = None, defocus: float | None = None, bit_depth: int | None = 0,
                     seed: int | None = None, settings: RenderSettings | None = None, progress: bool = True,
                     **overrides) -> dict:
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
    frame_rate, exposure, noise, defocus, bit_depth, seed
        Override the preset's render settings (Hz, s, read-noise sigma in full-scale units,
        defocus size in projector pixels, 8/10/12/16 bits, integer seed). ``bit_depth=None``
        writes float32 TIFF frames; ``0`` keeps the preset's.
    settings : RenderSettings, optional
        Replace the preset's settings entirely (overrides still apply).
    **overrides
        Any other :class:`RenderSettings` field.

    Returns
    -------
    dict
        Summary: folder, preset, scene, patterns, frames, frame_rate, valid fraction, seconds.
    """
    import time

    from fringe3d.io.capture import write_capture

    t0 = time.perf_counter()
    p = _presets.get(preset)
    s = settings or p.settings
    changes = dict(overrides)
    for key, val in (("frame_rate", frame_rate), ("exposure", exposure), ("read_noise", noise),
                     ("defocus_size", defocus), ("seed", seed)):
        if val is not None:
            changes[key] = val
    if defocus is not None and s.defocus == "none" and "defocus" not in changes:
        changes["defocus"] = "gaussian"
    if bit_depth != 0:
        changes["bit_depth"] = bit_depth
    s = s.replace(**changes)
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
    imgs, truth = render(sc, p.rig, ps, s, times=times, progress=progress)
    folder = Path(folder)
    meta = {"frame_rate": s.frame_rate, "simulated": True, "preset": p.name,
            "scene": getattr(sc, "name", str(scene)), "patterns": ps.name, "seed": s.seed,
            "exposure": s.exposure if s.exposure is not None else 1.0 / s.frame_rate,
            "render_settings": s.to_dict(), "volume": p.volume}
    if s.bit_depth is not None:
        meta["bit_depth"] = s.bit_depth
    write_capture(folder, imgs, ps, meta, fmt="png" if s.bit_depth is not None else "tif")
    truth.meta.update({"preset": p.name, "scene": meta["scene"], "seed": s.seed})
    truth.save(folder / "truth")
    p.rig.save(folder / "rig.json")
    valid = float(np.mean(truth.mask))
    summary = {"folder": str(folder), "preset": p.name, "scene": meta["scene"], "patterns": ps.name,
               "frames": int(frames), "frame_rate": s.frame_rate, "camera": [p.rig.camera.width, p.rig.camera.height],
               "valid_fraction": valid, "seed": s.seed, "seconds": round(time.perf_counter() - t0, 2)}
    if progress:
        info(f"wrote {frames} frames + truth to {folder} ({valid:.0%} of pixels valid)")
    return summary
