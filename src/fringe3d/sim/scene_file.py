"""JSON scene files: a list of typed objects, read with errors that name the offending field.

Format (mm, radians, seconds, albedo in [0, 1])::

    {"format": "fringe3d-scene", "version": 1, "name": "demo", "ambient": 0.02,
     "objects": [
       {"type": "plane", "point": [0, 0, 500], "normal": [0, 0, -1], "albedo": 0.8},
       {"type": "sphere", "center": [0, 0, 420], "radius": 40,
        "texture": {"type": "checker", "period": 0.5}},
       {"type": "falling_ball", "center": [0, -40, 430], "radius": 20, "velocity": [0, 1000, 0]},
       {"type": "mesh", "path": "bunny.ply", "center": [0, 0, 450], "scale": 1000},
       {"type": "wing", "root": [-75, 35, 420], "frequency": 25}
     ]}

Types and their fields: see :data:`SCHEMAS` (``fields()`` lists them per type). ``mesh.path`` is
relative to the scene file. ``specular`` (>= 0) and ``roughness`` (0.02..1) make an object glossy
(:mod:`fringe3d.sim.specular`). ``motion`` (box, board, mesh, heightfield, sculpture) is
``{"velocity": [..], "acceleration": [..], "angular_velocity": [..], "t0": 0}``.
"""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from fringe3d.utils.jsonfile import read_json, write_json

from .board import BoardTarget
from .mesh import Mesh
from .motion import GRAVITY_MM_S2, RigidMotion, falling
from .primitives import Box, Plane, Sphere
from .scene import Scene
from .scene_object import SceneObject
from .sculpture import HeightField, sculpture
from .textures import texture_from_dict
from .wing import Wing

SCENE_FORMAT = "fringe3d-scene"
#: The scene-file versions this fringe3d reads.
SCENE_VERSION = 1
#: Inclusive ranges of the whole-number fields (a count of 10^9 would exhaust memory).
INT_RANGES = {"steps": (1, 4096), "cols": (2, 200), "rows": (2, 200), "seed": (0, 2**32 - 1)}

# field kinds: vec3, vec2, number, int, bool, str, rotation (3-vector or 3x3), texture, motion,
# points2 (list of [x, y]), table4 (list of 4-number rows), path
_COMMON = {"albedo": "number", "texture": "texture", "specular": "number", "roughness": "number"}
SCHEMAS: dict[str, dict] = {
    "plane": {"required": {"point": "vec3", "normal": "vec3"},
              "optional": {**_COMMON, "u_axis": "vec3", "size": "vec2", "motion": "motion"}},
    "sphere": {"required": {"center": "vec3", "radius": "number"},
               "optional": {**_COMMON, "velocity": "vec3", "acceleration": "vec3", "spin": "vec3",
                            "t0": "number", "R": "rotation"}},
    "falling_ball": {"required": {"center": "vec3", "radius": "number"},
                     "optional": {**_COMMON, "velocity": "vec3", "spin": "vec3", "gravity": "vec3",
                                  "t0": "number"}},
    "box": {"required": {"center": "vec3", "size": "vec3"},
            "optional": {**_COMMON, "R": "rotation", "motion": "motion"}},
    "board": {"required": {},
              "optional": {"cols": "int", "rows": "int", "spacing": "number", "radius": "number",
                           "R": "rotation", "t": "vec3", "asymmetric": "bool", "margin": "number",
                           "white": "number", "dark": "number", "edge_width": "number", "motion": "motion"}},
    "heightfield": {"required": {"size": "vec2"},
                    "optional": {**_COMMON, "bumps": "table4", "ripples": "table4", "center": "vec3",
                                 "R": "rotation", "steps": "int", "motion": "motion"}},
    "sculpture": {"required": {},
                  "optional": {"center": "vec3", "size": "vec2", "relief": "number", "seed": "int",
                               "R": "rotation", "albedo": "number", "motion": "motion"}},
    "mesh": {"required": {"path": "path"},
             "optional": {**_COMMON, "center": "vec3", "R": "rotation", "scale": "number",
                          "smooth": "bool", "motion": "motion"}},
    "wing": {"required": {},
             "optional": {**_COMMON, "span": "number", "chord": "number", "outline": "str", "root": "vec3",
                          "R0": "rotation", "kappa_mean": "number", "kappa_amp": "number",
                          "frequency": "number", "flap_amplitude": "number", "kappa_phase": "number",
                          "flap_phase": "number", "bend_angle": "number", "bend_offset": "number",
                          "thickness": "number", "anchors": "points2", "markers": "points2",
                          "dot_radius": "number", "anchor_albedo": "number", "marker_albedo": "number"}},
}

_KIND_TEXT = {"vec3": "a list of 3 numbers", "vec2": "a list of 2 numbers", "number": "a number",
              "int": "an integer", "bool": "true or false", "str": "a string",
              "rotation": "a rotation vector (3 numbers, rad) or a 3x3 matrix",
              "texture": 'an object like {"type": "checker", "period": 10}',
              "motion": 'an object like {"velocity": [0, 0, 0], "acceleration": [0, 9806.65, 0]}',
              "points2": "a list of [x, y] pairs", "table4": "a list of rows of 4 numbers",
              "path": "a file path string"}


def fields(kind: str) -> dict:
    """``{field: kind}`` (required and optional) for object type ``kind``."""
    s = SCHEMAS[kind]
    return {**s["required"], **s["optional"]}


def _finite(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def _shape_ok(v, shape) -> bool:
    try:
        a = np.asarray(v, dtype=float)
    except (TypeError, ValueError):
        return False
    return a.shape == shape and bool(np.all(np.isfinite(a)))


def _check(value, kind, at, base: Path | None):
    """Validate one field and convert it; raises ValueError naming ``at``."""
    ok = True
    if kind == "vec3":
        ok = _shape_ok(value, (3,))
    elif kind == "vec2":
        ok = _shape_ok(value, (2,))
    elif kind == "number":
        ok = _finite(value)
    elif kind == "int":
        lo, hi = INT_RANGES.get(at.rsplit(".", 1)[-1], (0, 2**31 - 1))
        ok = isinstance(value, int) and not isinstance(value, bool) and lo <= value <= hi
    elif kind == "bool":
        ok = isinstance(value, bool)
    elif kind in ("str", "path"):
        ok = isinstance(value, str) and value != ""
    elif kind == "rotation":
        ok = _shape_ok(value, (3,)) or _shape_ok(value, (3, 3))
    elif kind == "points2":
        ok = isinstance(value, list) and (len(value) == 0 or _shape_ok(value, (len(value), 2)))
    elif kind == "table4":
        ok = isinstance(value, list) and (len(value) == 0 or _shape_ok(value, (len(value), 4)))
    elif kind == "texture":
        return texture_from_dict(value, at)
    elif kind == "motion":
        return _motion(value, at)
    if not ok:
        what = _KIND_TEXT[kind]
        if kind == "int":
            what += " in [{}, {}]".format(*INT_RANGES.get(at.rsplit(".", 1)[-1], (0, 2**31 - 1)))
        raise ValueError(f"{at}: expected {what}, got {json.dumps(value)}")
    if kind == "path":
        p = Path(value)
        return p if p.is_absolute() or base is None else base / p
    if kind in ("vec3", "vec2", "rotation", "points2", "table4"):
        return np.asarray(value, dtype=float)
    return value


def _motion(d, at):
    if not isinstance(d, dict):
        raise ValueError(f"{at}: expected {_KIND_TEXT['motion']}, got {json.dumps(d)}")
    allowed = {"velocity": "vec3", "acceleration": "vec3", "angular_velocity": "vec3", "t0": "number"}
    extra = sorted(set(d) - set(allowed))
    if extra:
        raise ValueError(f"{at}.{extra[0]}: unknown motion field; allowed: {sorted(allowed)}")
    return RigidMotion(**{k: _check(v, allowed[k], f"{at}.{k}", None) for k, v in d.items()})


def _build(kind: str, kw: dict) -> SceneObject:
    if kind == "plane":
        return Plane(**kw)
    if kind == "sphere":
        return Sphere(**kw)
    if kind == "falling_ball":
        motion = falling(velocity=kw.pop("velocity", (0, 0, 0)), spin=kw.pop("spin", (0, 0, 0)),
                         gravity=kw.pop("gravity", (0, GRAVITY_MM_S2, 0)), t0=kw.pop("t0", 0.0))
        return Sphere(motion=motion, **kw)
    if kind == "box":
        return Box(**kw)
    if kind == "board":
        return BoardTarget.from_fields(kw)
    if kind == "heightfield":
        return HeightField(**kw)
    if kind == "sculpture":
        return sculpture(**kw)
    if kind == "mesh":
        return Mesh(kw.pop("path"), **kw)
    if kind == "wing":
        return Wing.from_fields(kw)
    raise AssertionError(kind)


def object_from_dict(d, at: str = "object", base: Path | None = None) -> SceneObject:
    """Build one scene object from ``{"type": ..., fields...}``."""
    if not isinstance(d, dict):
        raise ValueError(f"{at}: expected an object with a 'type' field, got {json.dumps(d)[:60]}")
    if "type" not in d:
        raise ValueError(f"{at}: missing field 'type' (one of {sorted(SCHEMAS)})")
    kind = d["type"]
    if not isinstance(kind, str) or kind not in SCHEMAS:
        raise ValueError(f"{at}.type: unknown object type {kind!r}; expected one of {sorted(SCHEMAS)}")
    schema = SCHEMAS[kind]
    given = {k: v for k, v in d.items() if k != "type"}
    for name in schema["required"]:
        if name not in given:
            raise ValueError(f"{at}: missing field {name!r} for a {kind} "
                             f"(required: {sorted(schema['required']) or 'none'})")
    allowed = fields(kind)
    for name in given:
        if name not in allowed:
            raise ValueError(f"{at}.{name}: unknown field for a {kind}; allowed: {sorted(allowed)}")
    kw = {name: _check(v, allowed[name], f"{at}.{name}", base) for name, v in given.items()}
    gloss = {k: kw.pop(k) for k in ("specular", "roughness") if k in kw}
    try:
        ob = _build(kind, kw)
        if gloss:  # a glossy lobe (fringe3d.sim.specular): weight and roughness
            ob.set_gloss(gloss.get("specular", 0.0), gloss.get("roughness", 1.0))  # type: ignore[attr-defined]
        return ob
    except FileNotFoundError as e:
        raise FileNotFoundError(f"{at}.path: {e}") from None
    except (ValueError, TypeError) as e:
        raise ValueError(f"{at}: {e}") from None


def scene_from_dict(d, where: str = "scene", base: Path | None = None) -> Scene:
    """Build a :class:`~fringe3d.sim.scene.Scene` from a parsed scene file."""
    if not isinstance(d, dict):
        raise ValueError(f"{where}: expected a JSON object with an 'objects' list")
    allowed = {"format", "version", "name", "ambient", "objects"}
    unknown = sorted(set(d) - allowed)
    if unknown:
        raise ValueError(f"{where}.{unknown[0]}: unknown field; allowed: {sorted(allowed)}")
    if d.get("format", SCENE_FORMAT) != SCENE_FORMAT:
        raise ValueError(f"{where}.format: {d['format']!r} is not {SCENE_FORMAT!r}")
    version = d.get("version", SCENE_VERSION)
    if isinstance(version, bool) or version != SCENE_VERSION:
        raise ValueError(f"{where}.version: {json.dumps(version)} is not supported (this fringe3d reads scene "
                         f"files of version {SCENE_VERSION})")
    objs = d.get("objects")
    if not isinstance(objs, list) or not objs:
        raise ValueError(f"{where}.objects: expected a non-empty list of objects")
    built = [object_from_dict(o, f"{where}.objects[{i}]", base) for i, o in enumerate(objs)]
    ambient = d.get("ambient", 0.0)
    if not _finite(ambient) or not 0 <= ambient <= 1:
        raise ValueError(f"{where}.ambient: expected a number in [0, 1], got {json.dumps(ambient)}")
    name = d.get("name", "scene")
    if not isinstance(name, str):
        raise ValueError(f"{where}.name: expected a string, got {json.dumps(name)}")
    return Scene(built, ambient=float(ambient), name=name)


def save_scene(scene: Scene, path) -> Path:
    """Write ``scene`` as a JSON scene file (atomic). Every object must support ``to_dict()``;
    meshes must come from a file (their path is stored as given).

    Parameters
    ----------
    scene : Scene
        The scene to write.
    path : str or os.PathLike
        The JSON file to write.

    Returns
    -------
    pathlib.Path
        ``path``.
    """
    path = Path(path)
    write_json(path, scene.to_dict())
    return path


def load_scene(path) -> Scene:
    """Read a JSON scene file; relative mesh paths are resolved next to it (errors name the field).

    Parameters
    ----------
    path : str or os.PathLike
        The JSON scene file.

    Returns
    -------
    Scene
        The scene it describes.
    """
    path = Path(path)
    d = read_json(path, "scene file", require_object=False)
    return scene_from_dict(d, where=f"{path.name}", base=path.parent)
